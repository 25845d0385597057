//! The cycle controller on the embedded simulated machine (master + SimBus + SimDrives):
//! enabling never moves a drive, an operator stop mid-tap keeps Z and C coupled and quick-stops
//! every drive, a drive fault names node/EMCY/line, coupling windows are measured (and would
//! catch a decoupling), and the real-time driver runs with its latency figures.

mod common;

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use cnc402_config::{MAX_AXES, MachineConfig};
use cnc402_drives::Instant;
use cnc402_lang::SourceFile;
use cnc402_runtime::controller::{CycleController, Step};
use cnc402_runtime::link::{DriveLink, FaultPlan, Startup, StopCause};
use cnc402_runtime::recorder::Recorder;
use cnc402_runtime::ring::{Consumer, move_ring, status_ring};
use cnc402_runtime::status::TapCoupling;
use cnc402_runtime::testing::ModelLink;
use cnc402_runtime::{Outcome, Phase, RunOptions, SimLink, Status, Timing, run_program};

const TAP: &str = "%\nG21 G90 G17 G94 G54\nG0 X10. Y10. Z10.\nM29 S500\nG98 G84 X10. Y10. Z-16. R3. F750.\nG80\nG0 Z20.\nM30\n%\n";

/// Runs `text` on `link` tick by tick; `hook` sees every status and may raise the stop flag.
fn drive<L: DriveLink>(
    cfg: &MachineConfig,
    mut link: L,
    text: &str,
    mut hook: impl FnMut(&Status, &AtomicBool),
) -> (Outcome, Vec<Status>, [f64; MAX_AXES], L) {
    let period = Duration::from_micros(cfg.bus.period_us as u64);
    let mut now = Instant::ZERO;
    let start = loop {
        match link.startup(now) {
            Startup::Ready(p) => break p,
            Startup::Pending if now < Instant::from_millis(100) => now += period,
            other => panic!("startup: {other:?}"),
        }
    };
    let mut feeder = common::feeder(cfg, "t.nc", text, &start);
    let (mut mp, mc) = move_ring(64);
    let (sp, mut sc) = status_ring(1024);
    let stop = Arc::new(AtomicBool::new(false));
    let mut ctrl = CycleController::new(cfg, start, link, mc, sp, stop.clone());
    let mut out = Vec::new();
    let outcome = loop {
        feeder.fill(&mut mp).expect("program");
        now += period;
        let step = ctrl.step(now);
        while let Some(s) = sc.try_pop() {
            hook(&s, &stop);
            out.push(s);
        }
        if let Step::Done(o) = step {
            break o;
        }
        assert!(out.len() < 200_000, "runaway");
    };
    // The link is moved into the controller; hand it back through a swap-free path.
    let link = into_link(ctrl);
    (outcome, out, start, link)
}

fn into_link<L: DriveLink>(ctrl: CycleController<L>) -> L {
    ctrl.into_link()
}

#[test]
fn enabling_never_moves_a_drive() {
    let cfg = MachineConfig::default_machine();
    // Drives power on away from zero (C a quarter turn on).
    let initial = [123_456, -50_000, 70_000, 32_768, 0, 0, 0, 0];
    let mut link = SimLink::simulated(&cfg, Some(initial)).unwrap();
    let pos = match link.startup(Instant::ZERO) {
        Startup::Ready(p) => p,
        other => panic!("{other:?}"),
    };
    for i in 0..4 {
        let dev = link.sim_bus().device(i).unwrap();
        assert_eq!(
            dev.position_actual(),
            initial[i],
            "drive {i} moved while enabling"
        );
        let cpu = cfg.axes[i].counts_per_unit;
        assert_eq!((pos[i] * cpu).round() as i32, initial[i]);
    }
    let (outcome, st, start, _) = drive(&cfg, link, "G91 G0 X1.\nM30\n", |_, _| {});
    assert_eq!(outcome, Outcome::Finished);
    assert_eq!(start, pos);
    // The first setpoint is where each drive stood.
    assert_eq!(&st[0].cmd_counts[..4], &initial[..4]);
    assert_eq!(&st[0].act_counts[..4], &initial[..4]);
    // And the incremental move went from there.
    let last = st.last().unwrap();
    assert!(
        (last.act[0] - (12.3456 + 1.0)).abs() < 1e-4,
        "{}",
        last.act[0]
    );
}

#[test]
fn operator_stop_mid_tap_keeps_z_and_c_coupled_and_quick_stops_every_drive() {
    let cfg = MachineConfig::default_machine();
    let link = SimLink::simulated(&cfg, None).unwrap();
    let mut raised_at = None;
    let (outcome, st, _, link) = drive(&cfg, link, TAP, |s, stop| {
        if s.tap.is_some() && s.cmd[2] < -6.0 && raised_at.is_none() {
            stop.store(true, Ordering::SeqCst);
            raised_at = Some(s.tick);
        }
    });
    let raised_at = raised_at.expect("the tap ran");
    match outcome {
        Outcome::Stopped { stop, line, .. } => {
            assert_eq!(stop.cause, StopCause::Operator);
            assert_eq!(line, 5, "the G84 block");
        }
        other => panic!("{other:?}"),
    }
    // Decelerated along the tap: Z never reached the bottom, and every setpoint tick of the
    // stop is coupled within one count.
    let z_min = st.iter().map(|s| s.cmd[2]).fold(f64::INFINITY, f64::min);
    assert!(z_min > -16.0 + 1e-3, "stopped before the bottom: {z_min}");
    let mut rec = Recorder::new(&cfg, st.len() as u64);
    for s in &st {
        rec.record(s);
    }
    rec.finish().unwrap();
    assert_eq!(rec.taps.len(), 1);
    assert!(
        rec.taps[0].max_coupling_error_um_cmd <= 0.1,
        "{:?}",
        rec.taps[0]
    );
    assert!(
        rec.taps[0].ticks.1 > raised_at,
        "the window covers the stop"
    );
    assert!(st.iter().any(|s| s.phase == Phase::Stopping));
    assert!(st.iter().any(|s| s.phase == Phase::QuickStop));
    // Every drive out of OPERATION ENABLED, at rest.
    for d in link.sim_bus().devices() {
        assert_ne!(
            d.state(),
            cia402::State::OperationEnabled,
            "node {}",
            d.node().get()
        );
    }
    let last = st.last().unwrap();
    let prev = &st[st.len() - 2];
    for i in 0..4 {
        assert!(
            (last.act[i] - prev.act[i]).abs() < 1e-4,
            "axis {i} still moving"
        );
    }
}

#[test]
fn drive_fault_names_node_emcy_and_line_and_stops_all_axes() {
    let cfg = MachineConfig::default_machine();
    let link = common::faulty_sim(&cfg, common::fault(4, 2300, 0x8611));
    let (outcome, st, _, link) = drive(&cfg, link, TAP, |_, _| {});
    let Outcome::Stopped { stop, line, .. } = outcome else {
        panic!("{outcome:?}")
    };
    assert_eq!(stop.node, 4);
    assert_eq!(stop.emcy, Some(0x8611));
    assert!(
        matches!(stop.cause, StopCause::DriveFault | StopCause::Emergency),
        "{stop:?}"
    );
    // The EMCY may arrive before the TPDO that shows the FAULT bit: the statusword named is
    // the last one received.
    assert_ne!(stop.statusword, 0);
    assert_eq!(line, 5);
    let t_fault = st.iter().find(|s| s.stop.is_some()).unwrap().tick;
    assert!(st.len() as u64 - t_fault < 1000, "stopped within a second");
    for d in link.sim_bus().devices() {
        assert_ne!(
            d.state(),
            cia402::State::OperationEnabled,
            "node {}",
            d.node().get()
        );
    }
}

#[test]
fn model_link_fault_and_motion_are_reported_the_same_way() {
    let cfg = MachineConfig::default_machine();
    let link = ModelLink::new(&cfg, [0.0; MAX_AXES], 1).with_fault(common::fault(3, 500, 0x2310));
    let (outcome, _, _, _) = drive(&cfg, link, TAP, |_, _| {});
    let Outcome::Stopped { stop, .. } = outcome else {
        panic!("{outcome:?}")
    };
    assert_eq!(
        (stop.node, stop.emcy, stop.cause),
        (3, Some(0x2310), StopCause::DriveFault)
    );
}

fn status(tick: u64, z: f64, c: f64, tap: Option<TapCoupling>) -> Status {
    let mut s = Status {
        tick,
        line: 7,
        statusword: [0x0237; MAX_AXES],
        tap,
        moves_started: tick,
        ..Status::default()
    };
    s.cmd[2] = z;
    s.cmd[3] = c;
    s.cmd_counts[2] = (z * 10000.0).round() as i32;
    s.cmd_counts[3] = (c * 131072.0 / 360.0).round() as i32;
    s.act[2] = z;
    s.act[3] = c;
    s
}

#[test]
fn recorder_measures_a_decoupled_tap() {
    let cfg = MachineConfig::default_machine();
    let coupling = TapCoupling {
        tool: 2,
        spindle: 3,
        ratio: -1.5 / 360.0,
    };
    let mut rec = Recorder::new(&cfg, 100);
    rec.record(&status(0, 3.0, 0.0, None));
    for k in 1..=10 {
        let c = 36.0 * k as f64;
        // Z lags by 2 µm at tick 5.
        let z = 3.0 - c * 1.5 / 360.0 + if k == 5 { 0.002 } else { 0.0 };
        rec.record(&status(k, z, c, Some(coupling)));
    }
    rec.record(&status(11, 3.0 - 0.15 * 10.0 / 10.0 * 1.0, 360.0, None));
    rec.finish().unwrap();
    assert_eq!(rec.taps.len(), 1);
    let w = &rec.taps[0];
    assert_eq!(w.line, 7);
    assert!((w.pitch_mm - 1.5).abs() < 1e-12);
    // Z still moves down monotonically through the 2 µm bump: the travel ratio (observed
    // pitch) is 1.5, the deviation is measured tick by tick.
    assert!((w.pitch_observed_mm - 1.5).abs() < 1e-9, "{w:?}");
    assert!((w.max_coupling_error_um_cmd - 2.0).abs() < 0.06, "{w:?}");
    assert!((w.max_coupling_error_um_act - 2.0).abs() < 1e-6, "{w:?}");
    assert_eq!(w.ticks, (1, 10));
}

#[test]
fn realtime_run_reports_wakeup_latency() {
    // This test is about the latency figures: a loaded test machine can stall the loop for
    // longer than the shipped 200 ms heartbeat or 10-cycle TPDO time-outs, which would then
    // (rightly) stop the run. Those monitors have tests of their own.
    let mut cfg = MachineConfig::default_machine();
    cfg.bus.heartbeat_timeout_ms = 5000;
    cfg.bus.tpdo_timeout_cycles = 5000;
    let src = SourceFile::new("rt.nc", "G21 G90\nG0 X5. Y2.\nG1 X6. F600.\nM30\n");
    let ast = cnc402_lang::parse(&src).unwrap();
    let opts = RunOptions {
        timing: Timing::RealTime,
        ..RunOptions::default()
    };
    let wall = std::time::Instant::now();
    let r = run_program(&cfg, src, ast, opts, &mut |_| {}).unwrap_or_else(|e| panic!("{e:?}"));
    assert!(r.ok, "{:?}", r.error);
    let lat = r.wakeup_latency.expect("latency figures");
    assert!(lat.samples >= r.ticks - 1 && lat.samples > 100, "{lat:?}");
    assert!(lat.p50_us <= lat.p99_us && lat.p99_us <= lat.max_us.max(lat.p99_us));
    assert!(r.realtime_grant.as_deref().unwrap().contains("mlockall"));
    // Against the clock: the run takes about its program time.
    let program = r.ticks as f64 * 1e-3;
    assert!(
        wall.elapsed().as_secs_f64() >= program * 0.9,
        "{program} s program"
    );
    assert!((r.axes[0].final_position - 6.0).abs() < 1e-4);
}

#[test]
fn spindle_runs_across_the_int32_wrap_without_a_jump_or_fault() {
    // 6000 rpm = 100 rev/s; 2^31 counts at 131072 counts/rev = 16384 rev ≈ 164 s.
    let cfg = MachineConfig::default_machine();
    let mut max_step = 0i64;
    let mut prev: Option<Status> = None;
    let mut wrapped = false;
    let mut rec_steps = |s: &Status| {
        if let Some(p) = prev {
            let d = s.cmd_counts[3].wrapping_sub(p.cmd_counts[3]) as i64;
            max_step = max_step.max(d.abs());
            wrapped |= s.cmd_counts[3] < p.cmd_counts[3] && d > 0;
        }
        prev = Some(*s);
    };
    // Drive the loop directly so that every status is seen.
    let (outcome, st, _, _) = drive(
        &cfg,
        SimLink::simulated(&cfg, None).unwrap(),
        "G21 G90\nM3 S6000\nG4 X170.\nM5\nM30\n",
        |s, _| rec_steps(s),
    );
    assert_eq!(outcome, Outcome::Finished);
    assert!(wrapped, "the setpoint crossed i32::MAX");
    // 36°/tick at 6000 rpm = 13107.2 counts: no jump anywhere.
    assert!(max_step <= 13108, "{max_step}");
    let last = st.last().unwrap();
    let revs = last.act[3] / 360.0;
    assert!(revs > 16384.0, "{revs} revolutions");
    assert!(
        (last.act[3] - last.cmd[3]).abs() < 0.01,
        "actual unwrapped like the command"
    );
}

fn run_text(cfg: &MachineConfig, text: &str) -> cnc402_runtime::RunReport {
    let src = SourceFile::new("sync.nc", text);
    let ast = cnc402_lang::parse(&src).unwrap();
    run_program(cfg, src, ast, RunOptions::default(), &mut |_| {})
        .unwrap_or_else(|e| panic!("{e:?}"))
}

#[test]
fn a_position_read_waits_for_the_machine_to_settle() {
    // A sluggish X drive (5 Hz tracking): after a slow feed move it needs a while to come
    // within a count of its setpoint. Reading #5021 (actual X) is a sync point: the next move
    // starts only once the drive has settled (or after SETTLE_LIMIT_TICKS idle ticks), so the
    // run takes that much longer than the same program with a constant.
    let mut cfg = MachineConfig::default_machine();
    cfg.axes[0].sim.bandwidth_hz = 5.0;
    let synced = run_text(
        &cfg,
        "G21 G90\nG1 X2. F60.\n#1 = #5021\nG0 X[#1 + 1.]\nM30\n",
    );
    let plain = run_text(&cfg, "G21 G90\nG1 X2. F60.\n#1 = 2.\nG0 X[#1 + 1.]\nM30\n");
    assert!(
        synced.ok && plain.ok,
        "{:?} {:?}",
        synced.error,
        plain.error
    );
    // (The sluggish drive is still settling on X3 when the run ends.)
    assert!(
        (synced.axes[0].final_position - 3.0).abs() <= 0.1,
        "{}",
        synced.axes[0].final_position
    );
    assert!(
        synced.ticks >= plain.ticks + 90,
        "waited for the drive to settle: {} vs {} ticks",
        synced.ticks,
        plain.ticks
    );
    assert!(synced.starved_ticks >= 90, "{}", synced.starved_ticks);
    assert_eq!(plain.starved_ticks, 0);
}

#[test]
fn a_fault_under_a_waiting_position_read_is_a_fault_not_a_program_error() {
    let cfg = MachineConfig::default_machine();
    let src = SourceFile::new(
        "f.nc",
        "G21 G90\nG1 X20. F600.\n#1 = #5021\nG0 X[#1 + 1.]\nM30\n",
    );
    let ast = cnc402_lang::parse(&src).unwrap();
    let opts = RunOptions {
        fault: Some(FaultPlan {
            node: 1,
            at: Duration::from_millis(500),
            emcy: 0x2310,
        }),
        ..RunOptions::default()
    };
    let r = run_program(&cfg, src, ast, opts, &mut |_| {}).unwrap_or_else(|e| panic!("{e:?}"));
    assert!(!r.ok);
    let stop = r.stop.expect("a stop report");
    assert_eq!((stop.stop.node, stop.stop.emcy), (1, Some(0x2310)));
    assert_eq!(stop.location, "f.nc:2");
}

#[test]
fn recorder_compares_actual_positions_at_equal_age() {
    let cfg = MachineConfig::default_machine();
    let coupling = TapCoupling {
        tool: 2,
        spindle: 3,
        ratio: -1.5 / 360.0,
    };
    // C's feedback is one cycle older than Z's throughout: compared naively the thread looks
    // off by one tick of motion (36° · 1.5/360 = 150 µm); at equal age it is exact.
    let pos = |k: u64| {
        let c = 36.0 * k as f64;
        (3.0 - c * 1.5 / 360.0, c)
    };
    let mut rec = Recorder::new(&cfg, 100);
    rec.record(&status(0, 3.0, 0.0, None));
    for k in 1..=20u64 {
        let (z, c) = pos(k);
        let mut s = status(k, z, c, Some(coupling));
        s.act[2] = z;
        s.act[3] = pos(k - 1).1;
        s.age[3] = 1;
        rec.record(&s);
    }
    rec.finish().unwrap();
    let w = &rec.taps[0];
    assert!(w.max_coupling_error_um_act < 1e-6, "{w:?}");
}

#[test]
fn a_spindle_fault_mid_tap_slaves_the_tool_axis_to_the_spindle() {
    // The spindle drive faults and brakes on its own: its setpoints no longer move it, so a
    // path-coupled stop alone would drive Z 0.6 mm past the thread. Z follows C's actual
    // position instead.
    let cfg = MachineConfig::default_machine();
    let link = common::faulty_sim(&cfg, common::fault(4, 1800, 0x8611));
    let (outcome, st, _, _) = drive(&cfg, link, TAP, |_, _| {});
    let Outcome::Stopped { stop, line, .. } = outcome else {
        panic!("{outcome:?}")
    };
    assert_eq!((stop.node, line), (4, 5));
    assert!(st.iter().any(|s| s.spindle_follow));
    let mut rec = Recorder::new(&cfg, st.len() as u64);
    for s in &st {
        rec.record(s);
    }
    rec.finish().unwrap();
    let w = &rec.taps[0];
    assert!(w.max_coupling_error_um_act < 50.0, "{w:?}");
    assert!(
        w.max_coupling_error_um_cmd <= 0.1,
        "before the fault: {w:?}"
    );
    // At rest, Z sits on the thread the spindle's final angle defines (R3, pitch 1.5).
    let last = st.last().unwrap();
    let want_z = 3.0 - last.act[3] * 1.5 / 360.0;
    assert!(
        (last.act[2] - want_z).abs() < 0.005,
        "Z {} vs thread {}",
        last.act[2],
        want_z
    );
}

/// Regression (found on vcan0 with simdrive --boot-delay 2:3): a drive that boots seconds
/// after the others made the master call the first ones silent at the first cycle, because
/// their heartbeat clock ran from their boot-up, not from when their heartbeat was set up.
#[test]
fn a_drive_booting_late_does_not_make_the_others_look_silent() {
    use cnc402_drives::sim::SimDriveOptions;
    use cnc402_runtime::{MasterLink, SimMachine};
    let cfg = MachineConfig::default_machine();
    // Node 2 boots 3 s late: 15× the 200 ms heartbeat timeout.
    let machine = SimMachine::with_drive_options(&cfg, |_, node| SimDriveOptions {
        boot_delay: if node == 2 {
            Duration::from_secs(3)
        } else {
            Duration::ZERO
        },
        ..SimDriveOptions::default()
    })
    .unwrap();
    assert!(cfg.bus.heartbeat_timeout_ms < 3000);
    let link: SimLink = MasterLink::new(&cfg, machine).unwrap();
    let (outcome, st, _, link) = drive(&cfg, link, "G21 G90\nG1 X2. Y1. F600.\nM30\n", |_, _| {});
    assert_eq!(outcome, Outcome::Finished, "{outcome:?}");
    assert!(link.sim_bus().now() > Instant::from_millis(3000));
    assert!((st.last().unwrap().cmd[0] - 2.0).abs() < 1e-9);
}

#[test]
fn a_full_status_ring_still_gives_ok_true() {
    // A ring far smaller than the driver's drain threshold loses records (a slow reporter).
    let cfg = MachineConfig::default_machine();
    let run = |text: &str, ring: Option<usize>| {
        let src = SourceFile::new("ring.nc", text);
        let ast = cnc402_lang::parse(&src).unwrap();
        let opts = RunOptions {
            status_ring: ring,
            ..RunOptions::default()
        };
        run_program(&cfg, src, ast, opts, &mut |_| {}).unwrap_or_else(|e| panic!("{e:?}"))
    };
    let full = run(TAP, None);
    let tiny = run(TAP, Some(16));
    assert!(full.ok && full.coupling_complete, "{:?}", full.error);
    assert_eq!(full.dropped_status, 0);
    assert!(!full.tapping.is_empty());
    // Records were lost: the coupling figures of the tap are incomplete, so the run is not ok.
    assert!(tiny.dropped_status > 1000, "{}", tiny.dropped_status);
    assert!(!tiny.coupling_complete);
    assert!(!tiny.ok);
    let err = tiny.error.as_deref().unwrap_or("");
    assert!(
        err.contains(&format!("{} status records were lost", tiny.dropped_status))
            && err.contains("coupling figures are incomplete"),
        "{err}"
    );
    assert_eq!(tiny.to_json()["coupling_complete"], false);
    // The following-error maxima come from the loop: exact whatever was dropped.
    assert_eq!(tiny.ticks, full.ticks);
    for (t, f) in tiny.axes.iter().zip(&full.axes) {
        assert!(f.max_following_error > 0.0, "{}", f.name);
        assert_eq!(t.max_following_error, f.max_following_error, "{}", t.name);
    }
    // Without tap windows the lost records cost only the trace: ok, but marked incomplete.
    let plain = run("G21 G90\nG1 X20. Y5. F600.\nM30\n", Some(16));
    assert!(plain.dropped_status > 0 && !plain.coupling_complete);
    assert!(plain.ok, "{:?}", plain.error);
}

/// The coupling comes from the segment kind, never from geometry: a rapid and a plain feed
/// that move Z and C together are no taps (no coupling in the status, no tap window), while a
/// programmed `G1 Z.. C..` and the G84 moves are, with the pitch they were programmed with.
#[test]
fn only_tap_segments_couple_z_and_c() {
    let cfg = MachineConfig::default_machine();
    let text = "G0 Z5.\nG0 Z-1. C90.\nG1 Z-5. C1050. F300.\nG0 Z5. C0\nM30\n";
    let link = ModelLink::new(&cfg, [0.0; MAX_AXES], 1);
    let (outcome, st, _, _) = drive(&cfg, link, text, |_, _| {});
    assert_eq!(outcome, Outcome::Finished);
    let coupled_lines: Vec<u32> = st
        .iter()
        .filter(|s| s.tap.is_some())
        .map(|s| s.line)
        .collect();
    assert!(!coupled_lines.is_empty());
    assert!(coupled_lines.iter().all(|&l| l == 3), "{coupled_lines:?}");
    let c = st.iter().find_map(|s| s.tap).unwrap();
    assert_eq!((c.tool, c.spindle), (2, 3));
    // ΔZ −4 mm over ΔC 960°: 1.5 mm per turn, Z down while C counts up.
    assert_eq!(c.ratio, -4.0 / 960.0 * 360.0 / 360.0);
    let mut rec = Recorder::new(&cfg, st.len() as u64);
    for s in &st {
        rec.record(s);
    }
    rec.finish().unwrap();
    assert_eq!(rec.taps.len(), 1, "{:?}", rec.taps);
    assert!((rec.taps[0].pitch_mm - 1.5).abs() < 1e-12);
    assert_eq!(rec.taps[0].line, 3);
}

/// The report carries the planned worst-case bus load (config load's plan) next to the
/// measured one; the measurement stays below the plan (the plan counts worst-case stuffing
/// and the SDO reserve, the simulated bus counts the same worst-case bits without SDOs).
#[test]
fn report_gives_planned_bus_load_next_to_the_measured_one() {
    let cfg = MachineConfig::default_machine();
    let r = run_text(&cfg, "G21 G90\nG0 X5. Y2.\nG1 X6. F600.\nM30\n");
    assert!(r.ok, "{:?}", r.error);
    // 55 + 8 × 115 + 5 × 65 / 50 + 270 / 50 = 986.9 bits of 1000.
    assert!(
        (r.bus_planned_percent - 98.69).abs() < 1e-9,
        "{}",
        r.bus_planned_percent
    );
    assert!(
        r.bus_load_percent > 90.0 && r.bus_load_percent <= r.bus_planned_percent,
        "measured {} planned {}",
        r.bus_load_percent,
        r.bus_planned_percent
    );
    assert_eq!(r.to_json()["bus"]["planned_percent"], r.bus_planned_percent);
    assert!(
        r.summary().contains("(planned worst case 98.7 %)"),
        "{}",
        r.summary()
    );
}
