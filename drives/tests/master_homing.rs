//! The master's homing (issue 17) against simulated drives on the in-process bus: each
//! method ends with the home point at the configured offset whatever the power-on position,
//! the axis then follows CSP setpoints from there; a switch that is never found is an error
//! naming the axis, node and state; polarity and an absolute encoder's offset are applied
//! consistently.

mod master_common;

use cia402::HomingMethod;
use cnc402_config::{DriveHoming, Homing, MachineConfig};
use cnc402_drives::master::HomingError;
use master_common::Rig;

const X: usize = 0;
/// The shipped X axis: 10000 counts per mm.
const CPU: f64 = 10_000.0;

fn homing(method: i8, offset: f64) -> Homing {
    Homing::Drive(DriveHoming {
        method: HomingMethod::new(method).unwrap(),
        speed_switch: 20.0,
        speed_zero: 2.0,
        acceleration: 200.0,
        offset,
        timeout_s: 30.0,
    })
}

/// The shipped machine with X homed by `h`, its simulated machine set by `machine`.
fn machine(h: Homing, machine: impl FnOnce(&mut cnc402_config::SimMachine)) -> MachineConfig {
    let mut c = MachineConfig::default_machine();
    c.axes[X].homing = Some(h);
    // A bare machine (the shipped X has a home switch and limit switches) that each test
    // furnishes.
    c.axes[X].sim.machine = cnc402_config::SimDynamics::default().machine;
    machine(&mut c.axes[X].sim.machine);
    c
}

/// Boots, homes X, and checks the result: the machine position and the drive's 0x6064 at
/// the offset, the motor at `motor_home` counts.
fn homes_to(c: MachineConfig, offset: f64, motor_home: i32) -> Rig {
    let mut rig = Rig::booted_for(c);
    assert!(!rig.master.is_homed(X));
    let report = rig
        .master
        .home(&mut rig.bus, &[X])
        .unwrap_or_else(|e| panic!("{e}"));
    rig.next = report.last_cycle + rig.master.period();
    assert_eq!(report.axes.len(), 1);
    assert_eq!(report.axes[0].axis, 'X');
    assert!(rig.master.is_homed(X));
    assert!(
        (rig.master.positions()[X] - offset).abs() < 1e-9,
        "{:?}",
        rig.master.positions()
    );
    assert_eq!(
        rig.drive(X).position_actual(),
        (offset * CPU).round() as i32
    );
    assert_eq!(rig.drive(X).motor_position(), motor_home);
    rig
}

/// After homing the axis follows CSP setpoints from where it is, without a following error.
fn moves_after_homing(rig: &mut Rig) {
    let mut cmd = rig.master.positions();
    let start = cmd[X];
    for k in 0..400 {
        cmd[X] = start + 0.5 * (k as f64 / 400.0);
        rig.cycle(&cmd[..rig.axes()])
            .unwrap_or_else(|s| panic!("cycle {k}: {s}"));
    }
    cmd[X] = start + 0.5;
    for _ in 0..100 {
        rig.cycle(&cmd[..rig.axes()]).unwrap();
    }
    let actual = rig.master.positions()[X];
    assert!((actual - (start + 0.5)).abs() < 1e-4, "{actual} vs {start}");
}

#[test]
fn home_switch_method_ends_at_the_offset_from_any_power_on_position() {
    for power_on in [0.0, 30.0, -40.0, 12.3449] {
        let c = machine(homing(19, 5.0), |m| {
            m.home_switch = Some(12.345);
            m.limit_switches = Some((-290.0, 290.0));
            m.power_on_position = power_on;
        });
        let mut rig = homes_to(c, 5.0, 123_450);
        moves_after_homing(&mut rig);
    }
}

#[test]
fn index_pulse_and_limit_switch_methods() {
    // Method 34: the first index pulse above the power-on position (every 4096 counts).
    let c = machine(homing(34, -2.0), |m| {
        m.index_pulse_counts = Some(4096);
        m.power_on_position = 1.0;
    });
    let mut rig = homes_to(c, -2.0, 3 * 4096);
    moves_after_homing(&mut rig);
    // Method 1: the negative limit switch, then the first index pulse above it.
    let c = machine(homing(1, 0.0), |m| {
        m.index_pulse_counts = Some(4096);
        m.limit_switches = Some((-10.0, 10.0));
        m.power_on_position = 3.0;
    });
    homes_to(c, 0.0, -24 * 4096);
    // Method 37: the current position.
    let c = machine(homing(37, 7.5), |m| m.power_on_position = -3.0);
    homes_to(c, 7.5, -30_000);
}

#[test]
fn inverted_polarity_homes_in_the_drives_direction_and_moves_the_right_way() {
    // 0x607E inverts the drive: its negative limit switch is the motor's positive one.
    let mut c = machine(homing(17, -250.0), |m| {
        m.limit_switches = Some((-5.0, 5.0));
    });
    c.axes[X].polarity_inverted = true;
    let mut rig = homes_to(c, -250.0, 50_000);
    let motor_before = rig.drive(X).motor_position();
    moves_after_homing(&mut rig);
    // +0.5 mm in machine coordinates is −5000 motor counts.
    assert_eq!(rig.drive(X).motor_position() - motor_before, -5000);
}

#[test]
fn a_home_switch_never_found_is_a_homing_error_naming_axis_and_node() {
    // No home switch: the search runs into the positive limit switch.
    let c = machine(homing(19, 0.0), |m| {
        m.home_switch = None;
        m.limit_switches = Some((-3.0, 3.0));
    });
    let mut rig = Rig::booted_for(c);
    let e = rig.master.home(&mut rig.bus, &[X]).unwrap_err();
    assert!(
        matches!(
            e,
            HomingError::Failed {
                axis: 'X',
                node: 1,
                ..
            }
        ),
        "{e}"
    );
    let text = e.to_string();
    assert!(
        text.contains("axis X (node 1, method 19 (positive home switch)) failed"),
        "{text}"
    );
    assert!(text.contains("homing error"), "{text}");
    assert!(!rig.master.is_homed(X));
}

#[test]
fn a_search_that_outlasts_the_timeout_names_the_state() {
    let mut h = homing(34, 0.0);
    if let Homing::Drive(d) = &mut h {
        d.timeout_s = 0.5;
    }
    // No index pulse anywhere and no switch: the drive searches on.
    let c = machine(h, |m| m.index_pulse_counts = None);
    let mut rig = Rig::booted_for(c);
    let e = rig.master.home(&mut rig.bus, &[X]).unwrap_err();
    let HomingError::Timeout {
        axis, node, waited, ..
    } = &e
    else {
        panic!("{e}")
    };
    assert_eq!((*axis, *node), ('X', 1));
    assert!(waited.as_secs_f64() >= 0.5, "{waited:?}");
    let text = e.to_string();
    assert!(
        text.contains("did not complete within 0.5 s: homing in progress"),
        "{text}"
    );
}

#[test]
fn an_absolute_encoder_takes_its_stored_offset_at_boot() {
    let c = machine(Homing::Absolute { offset: 100.0 }, |m| {
        m.power_on_position = 2.0;
    });
    let mut rig = Rig::booted_for(c);
    assert!(rig.master.is_homed(X));
    assert!((rig.master.positions()[X] - 102.0).abs() < 1e-9);
    let report = rig.master.home(&mut rig.bus, &[X]).unwrap();
    assert_eq!(report.axes[0].method, None);
    let mut cmd = rig.master.positions();
    cmd[X] = 102.25;
    for _ in 0..200 {
        rig.cycle(&cmd[..rig.axes()]).unwrap();
    }
    // The drive counts without the offset.
    assert_eq!(rig.drive(X).position_actual(), 22_500);
    assert!((rig.master.positions()[X] - 102.25).abs() < 1e-9);
}

#[test]
fn an_axis_without_homing_is_refused() {
    let mut rig = Rig::booted();
    // The spindle (C) has no `homing` key in the shipped config.
    let e = rig.master.home(&mut rig.bus, &[3]).unwrap_err();
    assert_eq!(e, HomingError::NotConfigured { axis: 'C' });
}

/// With the compact layout the controlword (bit 4) goes in the event RPDO2 and the
/// statusword (bits 10, 12, 13) comes in the event TPDO2: homing works the same.
#[test]
fn homing_works_with_the_compact_pdo_layout() {
    let mut c = machine(homing(19, 5.0), |m| {
        m.home_switch = Some(12.345);
        m.power_on_position = 30.0;
    });
    c.bus.pdo_layout = cnc402_config::busload::PdoLayout::Compact;
    let mut rig = homes_to(c, 5.0, 123_450);
    moves_after_homing(&mut rig);
}

/// Boot writes 0x607E, 0x6091 and 0x6092 when the axis gives them, and leaves them at the
/// drive's values otherwise; the master's own scaling does not change with them.
#[test]
fn boot_writes_polarity_gear_ratio_and_feed_constant_when_given() {
    let mut c = MachineConfig::default_machine();
    c.axes[X].polarity_inverted = true;
    c.axes[X].gear_ratio = Some((3, 1));
    c.axes[X].feed_constant = Some((5000, 2));
    let rig = Rig::booted_for(c);
    let od = |axis: usize, index: u16, sub: u8| rig.drive(axis).od().get_u64(index, sub);
    assert_eq!(od(X, 0x607E, 0), Some(0xC0));
    assert_eq!((od(X, 0x6091, 1), od(X, 0x6091, 2)), (Some(3), Some(1)));
    assert_eq!((od(X, 0x6092, 1), od(X, 0x6092, 2)), (Some(5000), Some(2)));
    // Y gives none: the drive's defaults stay (polarity normal, ratios 1:1).
    assert_eq!(od(1, 0x607E, 0), Some(0));
    assert_eq!((od(1, 0x6091, 1), od(1, 0x6092, 1)), (Some(1), Some(1)));
    // Boot writes no homing object: those go to the drive when homing starts.
    assert_eq!(od(X, 0x6098, 0), Some(0));
}
