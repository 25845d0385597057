//! `bus.pdo_layout = "compact"` on the simulated drives: the master maps targets and positions
//! alone in the synchronous PDOs and the control/status words event-driven; 4 axes at 1 ms on
//! 1 Mbit/s then load the bus ≤ 85 % (measured on the simulated bus's bit counters and from
//! the load plan), motion follows, and a drive fault still stops naming node and EMCY.

mod master_common;

use cnc402_config::MachineConfig;
use cnc402_config::busload::{BusLoad, PdoLayout, frame_bits};
use cnc402_drives::bus::CanBus;
use cnc402_drives::master::{Feedback, Phase, SafetyStop, StopReason};
use cnc402_drives::sim::FaultKind;
use cnc402_drives::wire::Function;
use master_common::{Rig, smoothstep};

fn compact_machine() -> MachineConfig {
    let mut config = MachineConfig::default_machine();
    config.bus.pdo_layout = PdoLayout::Compact;
    config
}

/// A smooth move of every axis (X +20, Y −10, Z −5 mm, C 90°) over 0.5 s.
fn command(start: &[f64], k: u64) -> [f64; 4] {
    let s = smoothstep(k as f64 / 500.0);
    [
        start[0] + 20.0 * s,
        start[1] - 10.0 * s,
        start[2] - 5.0 * s,
        start[3] + 90.0 * s,
    ]
}

fn run(
    rig: &mut Rig,
    start: &[f64],
    from: u64,
    cycles: u64,
) -> Result<Feedback, (u64, SafetyStop)> {
    let mut last = None;
    for k in from..from + cycles {
        last = Some(rig.cycle(&command(start, k)).map_err(|s| (k, s))?);
    }
    Ok(last.unwrap())
}

#[test]
fn compact_layout_is_mapped_as_cia_301_says() {
    let rig = Rig::booted_for(compact_machine());
    for i in 0..4 {
        let od = rig.drive(i).od();
        let node = rig.config.axes[i].node.unwrap() as u64;
        // RPDO1 target, RPDO2 controlword (event), TPDO1 position, TPDO2 statusword (event).
        assert_eq!(od.get_u64(0x1600, 0), Some(1));
        assert_eq!(od.get_u64(0x1600, 1), Some(0x607A_0020));
        assert_eq!(od.get_u64(0x1400, 2), Some(1));
        assert_eq!(od.get_u64(0x1601, 0), Some(1));
        assert_eq!(od.get_u64(0x1601, 1), Some(0x6040_0010));
        assert_eq!(
            od.get_u64(0x1401, 1).map(|c| c & 0x8000_07FF),
            Some(0x300 + node)
        );
        assert_eq!(od.get_u64(0x1401, 2), Some(255));
        assert_eq!(od.get_u64(0x1A00, 1), Some(0x6064_0020));
        assert_eq!(od.get_u64(0x1A00, 0), Some(1));
        assert_eq!(od.get_u64(0x1A01, 1), Some(0x6041_0010));
        assert_eq!(
            od.get_u64(0x1801, 1).map(|c| c & 0x8000_07FF),
            Some(0x280 + node)
        );
        assert_eq!(od.get_u64(0x1801, 2), Some(255));
        assert_eq!(od.get_u64(0x1801, 3), Some(100), "inhibit 10 ms");
        assert_eq!(
            od.get_u64(0x1801, 5),
            Some(50),
            "event timer = heartbeat period"
        );
        assert_eq!(rig.drive(i).state(), cia402::State::OperationEnabled);
    }
}

#[test]
fn four_axes_at_1ms_load_the_bus_at_most_85_percent_and_follow() {
    let mut rig = Rig::booted_for(compact_machine());
    let start = rig.master.positions();
    run(&mut rig, &start, 0, 100).unwrap();
    let (bits0, t0) = (rig.bus.counters().bus_bits, rig.next);
    let fb = run(&mut rig, &start, 100, 1000).unwrap();
    let elapsed = rig.next - t0;
    let measured = cnc402_drives::bus::BusCounters {
        bus_bits: rig.bus.counters().bus_bits - bits0,
        ..rig.bus.counters()
    }
    .load_percent(rig.config.bus.bitrate, elapsed);
    let plan = BusLoad::of_machine(&rig.config);
    // In steady state the event PDOs go at their refresh period (50 ms), not at the inhibit
    // rate the plan's worst case counts: SYNC 55 + 8 × 95 + 8 × 75 / 50 + 5 × 65 / 50.
    let steady = (frame_bits(0) as f64
        + 8.0 * frame_bits(4) as f64
        + 8.0 * frame_bits(2) as f64 / 50.0
        + 5.0 * frame_bits(1) as f64 / 50.0)
        / 10.0;
    let standard = BusLoad::of_config(&rig.config.bus, &rig.config.axes, PdoLayout::Standard);
    println!(
        "4 axes, 1 ms, 1 Mbit/s, compact: measured {measured:.2} %, steady-state arithmetic \
         {steady:.2} %, planned worst case {:.2} % ({}); standard layout planned {:.2} %",
        plan.percent(),
        plan.breakdown(),
        standard.percent()
    );
    assert!(measured <= 85.0, "{measured}");
    assert!((measured - steady).abs() < 0.3, "{measured} vs {steady}");
    assert!(measured <= plan.traffic_percent(), "the plan is a bound");
    assert!((plan.percent() - 88.69).abs() < 1e-9);
    // Motion followed: at the end every axis is at its target within its window, and no
    // feedback PDO went missing.
    assert_eq!(rig.master.phase(), Phase::Running);
    let end = command(&start, 1099);
    for (i, &target) in end.iter().enumerate() {
        assert!(
            (fb.actual[i] - target).abs() < rig.config.axes[i].following_error_window,
            "{i}"
        );
        assert_eq!(
            fb.statusword[i].and_then(|s| s.state()),
            Some(cia402::State::OperationEnabled)
        );
    }
    let syncs = rig.master.syncs_sent();
    for i in 0..4 {
        let got = rig.master.tpdos_received(i);
        assert!(
            got + 1 >= syncs && got <= syncs,
            "axis {i}: {got} of {syncs}"
        );
    }
}

#[test]
fn compact_drive_fault_stops_naming_node_and_emcy() {
    let mut rig = Rig::booted_for(compact_machine());
    let start = rig.master.positions();
    run(&mut rig, &start, 0, 300).unwrap();
    rig.inject(2, FaultKind::Fault(0x8611));
    let (k, stop) = run(&mut rig, &start, 300, 20).unwrap_err();
    // EMCY at once; the statusword TPDO2 within its 10 ms inhibit time.
    assert!(k <= 302, "noticed at cycle {k}");
    assert!(
        matches!(stop.reason, StopReason::DriveFault | StopReason::Emergency),
        "{stop}"
    );
    assert_eq!((stop.axis, stop.node), (Some('Z'), Some(3)));
    assert_eq!(stop.emcy.map(|e| e.code), Some(0x8611));
    // The fault shows in the statusword from TPDO2 within the inhibit time.
    let hold = rig.master.positions();
    for _ in 0..12 {
        let _ = rig.cycle(&hold[..4]);
    }
    assert!(
        rig.master
            .last_feedback()
            .state(2)
            .is_some_and(cia402::State::is_fault),
        "{:?}",
        rig.master.last_feedback().statusword[2]
    );
}

/// An unchanged controlword goes out again every refresh period (the heartbeat period, 50
/// cycles here), so a lost RPDO2 heals; a changed one at once.
#[test]
fn the_controlword_is_refreshed_every_heartbeat_period() {
    let mut rig = Rig::booted_for(compact_machine());
    let start = rig.master.positions();
    run(&mut rig, &start, 0, 10).unwrap();
    rig.bus.start_trace();
    run(&mut rig, &start, 10, 100).unwrap();
    let rpdo2 = rig
        .bus
        .take_trace()
        .iter()
        .filter(|t| matches!(t.frame.function(), Function::Rpdo(2, _)))
        .count();
    assert_eq!(rpdo2, 8, "RPDO2 in 100 cycles of 4 drives");
    rig.bus.start_trace();
    rig.master.quick_stop();
    let hold = rig.master.positions();
    rig.cycle(&hold[..4]).unwrap();
    rig.bus.advance(rig.next);
    let quick_stops = rig
        .bus
        .take_trace()
        .iter()
        .filter(|t| {
            matches!(t.frame.function(), Function::Rpdo(2, _)) && t.frame.data() == [0x02, 0x00]
        })
        .count();
    assert_eq!(quick_stops, 4);
}
