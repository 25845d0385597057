//! The compact layout's statusword comes event-driven (TPDO2, with an event timer): the
//! master stops when it goes stale, naming the drive, and not while it comes on its timer at
//! standstill.

mod master_common;

use cnc402_config::MachineConfig;
use cnc402_config::busload::PdoLayout;
use cnc402_drives::bus::{Action, Direction, FaultRule, FrameFilter};
use cnc402_drives::master::StopReason;
use cnc402_drives::wire::{Function, NodeId};
use master_common::FaultRig;

fn compact() -> MachineConfig {
    let mut c = MachineConfig::default_machine();
    c.bus.pdo_layout = PdoLayout::Compact;
    c
}

#[test]
fn a_statusword_on_its_event_timer_keeps_a_standstill_running() {
    let config = compact();
    let mut rig = FaultRig::booted(&config, &[]);
    let hold = rig.master.positions();
    for k in 0..2000 {
        rig.cycle(&hold[..4])
            .unwrap_or_else(|s| panic!("cycle {k}: {s}"));
    }
}

#[test]
fn a_stale_statusword_stops_naming_the_drive() {
    let config = compact();
    let mut rig = FaultRig::booted(&config, &[]);
    let node2 = NodeId::new(2).unwrap();
    rig.bus.add_rule(FaultRule::new(
        FrameFilter::function(Function::Tpdo(2, node2)),
        Direction::Both,
        Action::Drop,
    ));
    let hold = rig.master.positions();
    let mut stop = None;
    let mut cycles = 0;
    for k in 0..2000 {
        if let Err(s) = rig.cycle(&hold[..4]) {
            stop = Some(s);
            cycles = k;
            break;
        }
    }
    let stop = stop.expect("the stale statusword must stop the machine");
    assert_eq!((stop.axis, stop.node), (Some('Y'), Some(2)), "{stop}");
    let StopReason::StatuswordStale { silent_ms } = stop.reason else {
        panic!("{stop}");
    };
    let refresh = cnc402_config::busload::event_refresh_ms(&config.bus) as u64;
    // Within three event-timer periods and one more for the last one's phase.
    assert!(
        silent_ms > 3 * refresh && silent_ms <= 4 * refresh + 1,
        "{silent_ms} ms"
    );
    assert!((cycles as u64) <= 4 * refresh + 1, "{cycles} cycles");
    assert!(stop.to_string().contains("statusword stale"), "{stop}");
}
