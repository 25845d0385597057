//! Faults on the embedded simulated machine, end to end: each row of docs/faults.md is a
//! test here (the run's report through `run_program`, and the physical coupling of Z and C at
//! rest read from the simulated drives after the same run tick by tick) or in
//! drives/tests/master_faults.rs (bus-off recovery and the boot refusals at master level).
//! The faults strike at 1.5 s, in the middle of the G84's descent (line 5).

mod common;

use std::time::Duration;

use cnc402_config::MachineConfig;
use cnc402_drives::bus::{Action, Direction, FaultRule, FrameFilter};
use cnc402_drives::sim::FaultKind;
use cnc402_lang::SourceFile;
use cnc402_runtime::link::StopCause;
use cnc402_runtime::{
    Outcome, RunOptions, RunReport, SimFault, SimFaultPlan, SimLink, run_program,
};

/// The G84 is line 5 (R3, Z-16, pitch 1.5 mm at S500: F750).
const TAP: &str = "%\nG21 G90 G17 G94 G54\nG0 X10. Y10. Z10.\nM29 S500\nG98 G84 X10. Y10. Z-16. R3. F750.\nG80\nG0 Z20.\nM30\n%\n";
/// Milliseconds after the first cyclic SYNC: Z is half-way down the thread at full feed.
const MID_TAP_MS: u64 = 1500;
/// Z's travel in one 1 ms cycle at F750 (mm).
const TAP_TRAVEL_PER_CYCLE_MM: f64 = 750.0 / 60_000.0;
/// When one axis of the pair stops dead (a drive that reboots or stops acting on SYNC halts
/// at once in the simulator), the other follows its actual position with its own dynamics:
/// the thread error at rest stays within this many cycles of tap travel.
const DEAD_STOP_BOUND_CYCLES: f64 = 5.0;
/// A stop both axes take along the path keeps the thread within 1 µm.
const PATH_STOP_BOUND_UM: f64 = 1.0;

fn mid_tap(fault: SimFault) -> SimFaultPlan {
    SimFaultPlan {
        at: Some(Duration::from_millis(MID_TAP_MS)),
        fault,
    }
}

fn drive_mid_tap(node: u8, kind: FaultKind) -> SimFaultPlan {
    mid_tap(SimFault::Drive { node, kind })
}

fn at_power_on(fault: SimFault) -> SimFaultPlan {
    SimFaultPlan { at: None, fault }
}

/// The run's report with `faults` armed.
fn report(faults: &[SimFaultPlan]) -> RunReport {
    report_for(&MachineConfig::default_machine(), faults)
}

/// The run's report on machine `cfg` with `faults` armed.
fn report_for(cfg: &MachineConfig, faults: &[SimFaultPlan]) -> RunReport {
    let src = SourceFile::new("t.nc", TAP);
    let ast = cnc402_lang::parse(&src).unwrap();
    let opts = RunOptions {
        sim_faults: faults.to_vec(),
        ..RunOptions::default()
    };
    run_program(cfg, src, ast, opts, &mut |_| {}).unwrap_or_else(|e| panic!("{e:?}"))
}

/// Asserts the report of a stopped run: cause, node, program line, and the message naming
/// them.
fn assert_stopped(r: &RunReport, cause: StopCause, node: u8) {
    assert!(!r.ok);
    let stop = r.stop.as_ref().unwrap_or_else(|| panic!("{:?}", r.error));
    assert_eq!((stop.stop.cause, stop.stop.node), (cause, node), "{stop:?}");
    assert_eq!(stop.location, "t.nc:5");
    let msg = r.error.as_deref().unwrap_or("");
    assert!(msg.starts_with(cause.describe()), "{msg}");
    assert!(msg.contains("while executing t.nc:5: G98 G84"), "{msg}");
    if node != 0 {
        assert!(msg.contains(&format!("on node {node}")), "{msg}");
    }
}

/// The same run tick by tick: its outcome, whether a follow took over, the link (master
/// counters), and the thread error at rest (µm): Z's actual against the Z that C's actual
/// angle puts on the thread, read from the simulated drives.
fn at_rest(faults: &[SimFaultPlan]) -> (Outcome, bool, SimLink, f64) {
    let cfg = MachineConfig::default_machine();
    let mut link = SimLink::simulated(&cfg, None).unwrap();
    for &p in faults {
        link = link.with_plan(p);
    }
    let (outcome, st, link) = common::run_on(&cfg, link, TAP);
    let followed = st.iter().any(|s| s.spindle_follow);
    let d = link.sim_bus().devices();
    let z = d[2].position_actual() as f64 / cfg.axes[2].counts_per_unit;
    let c = d[3].position_actual() as f64 / cfg.axes[3].counts_per_unit;
    // The tap starts at R3 with C at 0; 1.5 mm per turn.
    let thread_z = 3.0 - c * 1.5 / 360.0;
    (outcome, followed, link, (z - thread_z).abs() * 1000.0)
}

fn dead_stop_bound_um() -> f64 {
    DEAD_STOP_BOUND_CYCLES * TAP_TRAVEL_PER_CYCLE_MM * 1000.0
}

#[test]
fn a_drive_rebooting_mid_tap_is_a_stop_naming_node_and_line() {
    let faults = [drive_mid_tap(3, FaultKind::Reboot)];
    let r = report(&faults);
    assert_stopped(&r, StopCause::DriveRebooted, 3);
    let (outcome, followed, _, err_um) = at_rest(&faults);
    assert!(
        matches!(outcome, Outcome::Stopped { line: 5, .. }),
        "{outcome:?}"
    );
    assert!(followed, "C follows the stopped Z");
    assert!(err_um <= dead_stop_bound_um(), "{err_um} µm");
}

#[test]
fn an_emcy_storm_stops_once_with_the_first_code_and_stays_coupled() {
    let faults = [drive_mid_tap(4, FaultKind::EmcyStorm(0x5530))];
    let r = report(&faults);
    assert_stopped(&r, StopCause::Emergency, 4);
    assert_eq!(r.stop.as_ref().unwrap().stop.emcy, Some(0x5530));
    assert!(r.error.as_deref().unwrap().contains("EMCY 0x5530"));
    let (_, followed, link, err_um) = at_rest(&faults);
    // The drive stays enabled: it takes the path's deceleration like Z, no follow needed.
    assert!(!followed);
    assert!(err_um <= PATH_STOP_BOUND_UM, "{err_um} µm");
    // One EMCY per cycle until the end of the run: counted, one stop, nothing stored per
    // message (the master keeps the first; its state is fixed-size).
    let c = link.master().axis_of_node(4).unwrap();
    assert!(link.master().emcys_received(c) > 100);
    assert_eq!(link.master().last_emcy(c).map(|e| e.code), Some(0x5530));
}

#[test]
fn a_drive_that_stops_acting_on_sync_is_a_missing_feedback_stop() {
    let faults = [drive_mid_tap(3, FaultKind::StopSync)];
    let r = report(&faults);
    assert_stopped(&r, StopCause::TpdoMissing, 3);
    let (_, followed, _, err_um) = at_rest(&faults);
    assert!(followed, "C follows the stopped Z");
    assert!(err_um <= dead_stop_bound_um(), "{err_um} µm");
}

#[test]
fn a_spindle_drive_rebooting_mid_tap_slaves_z_without_extrapolating_stale_feedback() {
    // Regression: the tool axis followed the spindle's last velocity for as long as its
    // feedback stayed stale (a rebooted spindle sends none), driving Z 0.1 mm off the thread.
    let faults = [drive_mid_tap(4, FaultKind::Reboot)];
    let r = report(&faults);
    assert_stopped(&r, StopCause::DriveRebooted, 4);
    let (_, followed, _, err_um) = at_rest(&faults);
    assert!(followed);
    assert!(err_um <= dead_stop_bound_um(), "{err_um} µm");
}

#[test]
fn bus_off_mid_tap_is_a_bus_stop_at_the_line_and_stays_coupled() {
    let faults = [mid_tap(SimFault::BusOff(Duration::from_millis(5)))];
    let r = report(&faults);
    assert_stopped(&r, StopCause::Bus, 0);
    // The kind of bus error is named, in the message and in the report's cause.
    let msg = r.error.as_deref().unwrap_or("");
    assert!(
        msg.starts_with("CAN bus error (bus-off), while executing t.nc:5"),
        "{msg}"
    );
    assert_eq!(r.to_json()["stop"]["cause"], "CAN bus error (bus-off)");
    let (_, _, _, err_um) = at_rest(&faults);
    assert!(err_um <= PATH_STOP_BOUND_UM, "{err_um} µm");
}

#[test]
fn corrupted_feedback_frames_are_counted_and_do_not_stop_a_run() {
    // Every 7th TPDO of any drive cut short, 20 of them: malformed, ignored, counted.
    let rule = FaultRule::new(
        FrameFilter::class(0x180),
        Direction::Rx,
        Action::Truncate { len: 3 },
    )
    .every(7)
    .limit(20);
    let faults = [mid_tap(SimFault::Frames(rule))];
    let r = report(&faults);
    assert!(r.ok, "{:?}", r.error);
    let (outcome, _, link, _) = at_rest(&faults);
    assert_eq!(outcome, Outcome::Finished);
    assert_eq!(link.master().unexpected_frames(), 20);
}

#[test]
fn corrupted_feedback_past_the_limit_is_a_missing_feedback_stop_naming_the_node() {
    // Every TPDO of Y (node 2) cut short from mid-tap on: Y is not in the tap, Z and C stop
    // along the path.
    let rule = FaultRule::new(
        FrameFilter::id(0x182),
        Direction::Rx,
        Action::Truncate { len: 3 },
    );
    let faults = [mid_tap(SimFault::Frames(rule))];
    let r = report(&faults);
    assert_stopped(&r, StopCause::TpdoMissing, 2);
    let (_, followed, link, err_um) = at_rest(&faults);
    assert!(!followed);
    assert!(err_um <= PATH_STOP_BOUND_UM, "{err_um} µm");
    assert!(link.master().unexpected_frames() > 0);
}

/// A start-up refusal: not run, the message names the node and the cause.
fn assert_refused(r: &RunReport, parts: &[&str]) {
    assert!(!r.ok);
    assert!(r.stop.is_none());
    let msg = r.error.as_deref().unwrap_or("");
    assert!(msg.starts_with("start-up failed: "), "{msg}");
    for p in parts {
        assert!(msg.contains(p), "{msg} lacks {p}");
    }
}

#[test]
fn a_wrong_device_type_refuses_start_up_naming_node_and_object() {
    let r = report(&[at_power_on(SimFault::Drive {
        node: 2,
        kind: FaultKind::DeviceType(0x0002_0191),
    })]);
    assert_refused(
        &r,
        &["node 2", "0x1000", "0x00020191", "not a CiA 402 drive"],
    );
}

#[test]
fn a_wrong_identity_refuses_start_up_naming_node_object_and_both_values() {
    let mut cfg = MachineConfig::default_machine();
    cfg.axes[1].identity = Some(cnc402_config::ExpectedIdentity {
        vendor: cnc402_drives::sim::VENDOR_ID,
        product: Some(cnc402_drives::sim::PRODUCT_CODE),
        revision_min: None,
    });
    let fault = at_power_on(SimFault::Drive {
        node: 2,
        kind: FaultKind::Identity {
            vendor: cnc402_drives::sim::VENDOR_ID,
            product: 0x0003_0924,
            revision: None,
        },
    });
    assert_refused(
        &report_for(&cfg, &[fault]),
        &[
            "axis Y (node 2)",
            "0x1018:2 product code 0x00030924",
            "expects 0x00000001",
        ],
    );
    // The same config runs against the drive it expects.
    assert!(report_for(&cfg, &[]).ok);
}

#[test]
fn a_duplicate_node_id_refuses_start_up_naming_the_node() {
    let r = report(&[at_power_on(SimFault::SecondDevice(2))]);
    assert_refused(
        &r,
        &["node 2", "2 boot-up messages", "two devices on node id 2"],
    );
}

#[test]
fn a_drive_silent_to_sdo_at_boot_refuses_start_up_naming_node_and_object() {
    let r = report(&[at_power_on(SimFault::Drive {
        node: 2,
        kind: FaultKind::SdoSilence,
    })]);
    assert_refused(
        &r,
        &["node 2", "SDO read of 0x1000:00", "no response within"],
    );
}
