//! Machine inputs from the drives' 0x60FD (issue 17) against simulated drives: a limit switch
//! stops the machine naming the axis and node, but not while that axis homes on it; the
//! E-stop input is read before start and stops a run when it opens.

mod master_common;

use cia402::HomingMethod;
use cnc402_config::{DriveHoming, Homing, MachineConfig};
use cnc402_drives::master::StopReason;
use cnc402_drives::sim::FaultKind;
use master_common::Rig;

const X: usize = 0;
const Z: usize = 2;
/// The E-stop chain on Z's drive, bit 16 (manufacturer-specific inputs start there).
const ESTOP_BIT: u8 = 16;

/// The shipped machine with X's limit switches at ±5 mm and watched.
fn watched_limits() -> MachineConfig {
    let mut c = MachineConfig::default_machine();
    c.axes[X].sim.machine.limit_switches = Some((-5.0, 5.0));
    c.axes[X].limit_switch_inputs = true;
    // What config load decides from the keys (the test builds the config in code).
    c.axes[X].inputs_pdo = true;
    c
}

/// Runs X towards `to` (1 mm/s steps of 0.01 mm a cycle) until a stop or 2000 cycles.
fn move_x(rig: &mut Rig, to: f64) -> Option<cnc402_drives::master::SafetyStop> {
    let mut cmd = rig.master.positions();
    let step = 0.01 * (to - cmd[X]).signum();
    for _ in 0..2000 {
        if (to - cmd[X]).abs() > 0.01 {
            cmd[X] += step;
        }
        if let Err(s) = rig.cycle(&cmd[..rig.axes()]) {
            return Some(s);
        }
    }
    None
}

#[test]
fn a_limit_switch_stops_the_machine_naming_axis_and_node() {
    let mut rig = Rig::booted_for(watched_limits());
    let stop = move_x(&mut rig, 8.0).expect("the positive limit switch at 5 mm stops X");
    assert_eq!(stop.reason, StopReason::LimitSwitch { positive: true });
    assert_eq!((stop.axis, stop.node), (Some('X'), Some(1)));
    let x = rig.master.positions()[X];
    // Event TPDO: within its 10 ms inhibit time of the switch (0.1 mm at 10 mm/s).
    assert!((5.0..5.2).contains(&x), "{x}");
    assert!(
        stop.to_string()
            .contains("positive limit switch (0x60FD bit 1)"),
        "{stop}"
    );
    // Unwatched, the same machine runs through (the switch is only reported).
    let mut c = watched_limits();
    c.axes[X].limit_switch_inputs = false;
    let mut rig = Rig::booted_for(c);
    assert_eq!(move_x(&mut rig, 8.0), None);
}

#[test]
fn homing_on_a_limit_switch_is_not_stopped_by_it() {
    let mut c = watched_limits();
    c.axes[X].homing = Some(Homing::Drive(DriveHoming {
        method: HomingMethod::new(17).unwrap(),
        speed_switch: 20.0,
        speed_zero: 2.0,
        acceleration: 200.0,
        offset: -5.0,
        timeout_s: 10.0,
    }));
    let mut rig = Rig::booted_for(c);
    let r = rig
        .master
        .home(&mut rig.bus, &[X])
        .unwrap_or_else(|e| panic!("{e}"));
    rig.next = r.last_cycle + rig.master.period();
    assert!((rig.master.positions()[X] + 5.0).abs() < 1e-9);
    // Off the switch, X moves; back onto it, it stops.
    assert_eq!(move_x(&mut rig, -4.0), None);
    let stop = move_x(&mut rig, -6.0).expect("the negative limit switch");
    assert_eq!(stop.reason, StopReason::LimitSwitch { positive: false });
}

fn with_estop(closed: bool) -> MachineConfig {
    let mut c = MachineConfig::default_machine();
    c.machine.estop_input = Some((Z, ESTOP_BIT));
    c.axes[Z].inputs_pdo = true;
    if closed {
        c.axes[Z].sim.machine.inputs = 1 << ESTOP_BIT;
    }
    c
}

#[test]
fn an_open_estop_is_found_before_start_and_stops_a_run_when_it_opens() {
    let mut rig = Rig::booted_for(with_estop(false));
    let why = rig.master.estop_open(&mut rig.bus).expect("open");
    assert!(why.contains("axis Z (node 3)"), "{why}");
    assert!(why.contains("bit 16 is 0"), "{why}");

    let mut rig = Rig::booted_for(with_estop(true));
    assert_eq!(rig.master.estop_open(&mut rig.bus), None);
    let hold = rig.master.positions();
    for _ in 0..50 {
        rig.cycle(&hold[..rig.axes()]).unwrap();
    }
    rig.inject(Z, FaultKind::Inputs(0));
    let stop = (0..50)
        .find_map(|_| rig.cycle(&hold[..rig.axes()]).err())
        .expect("the opened chain stops the machine");
    assert_eq!(stop.reason, StopReason::EstopOpen { bit: ESTOP_BIT });
    assert_eq!((stop.axis, stop.node), (Some('Z'), Some(3)));
}
