//! Proves the loop allocates nothing: a counting global allocator is armed around many ticks
//! of the full per-tick path — interpolator, CANopen master cycle, SimBus with four simulated
//! drives, status ring — through a rigid tap, an injected drive fault, the path-coupled stop
//! and quick stop.

mod common;

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use cnc402_config::MachineConfig;
use cnc402_drives::Instant;
use cnc402_runtime::controller::{CycleController, Step};
use cnc402_runtime::link::FaultPlan;
use cnc402_runtime::ring::{Consumer, status_ring};
use cnc402_runtime::{Outcome, SimLink};

use cnc402_testkit::{CountingAlloc, allocs, arm};

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

const TAP: &str = "G21 G90 G17 G94 G54\nG0 X10. Y10. Z10.\nM29 S500\nG98 G84 X10. Y10. Z-16. R3. F750.\nX30.\nG80\nG2 X50. Y10. I10. J0 F1200.\nG0 Z20.\nM30\n";

fn machine() -> MachineConfig {
    MachineConfig::default_machine()
}

/// A G64 program: fine blocks blended at the feed (several moves a tick), an arc, a corner.
fn blended() -> String {
    let mut p = String::from("G21 G90 G17 G94 G54 G64 P0.01\nG0 X0 Y0 Z0\nG1 F3000\n");
    for i in 1..=2000 {
        let a = f64::from(i) * 0.001;
        p += &format!("X{:.4} Y{:.4}\n", 10.0 * a.sin(), 10.0 - 10.0 * a.cos());
    }
    p + "G3 I-2 J0\nG1 X-10\nY0\nM30\n"
}

/// Runs TAP with the counter armed over every tick; returns (allocations, outcome, ticks).
fn run_armed(fault: Option<FaultPlan>) -> (u64, Outcome, u64) {
    run_program_armed(TAP, fault, None)
}

/// Runs `program` with the counter armed over every tick, raising the operator's stop at
/// tick `stop_at` if given.
fn run_program_armed(
    program: &str,
    fault: Option<FaultPlan>,
    stop_at: Option<u32>,
) -> (u64, Outcome, u64) {
    run_armed_on(&machine(), program, fault, stop_at)
}

/// [`run_program_armed`] on `cfg`.
fn run_armed_on(
    cfg: &MachineConfig,
    program: &str,
    fault: Option<FaultPlan>,
    stop_at: Option<u32>,
) -> (u64, Outcome, u64) {
    let cfg = cfg.clone();
    let mut link = SimLink::simulated(&cfg, None).expect("sim link");
    if let Some(f) = fault {
        link = link.with_fault(f);
    }
    let start = common::started(&mut link);
    // Plan the whole program before arming: the feeder runs outside the loop.
    let (_mp, mc) = common::planned(&cfg, "tap.nc", program, &start, 8192);
    let (sp, mut sc) = status_ring(1 << 16);
    let stop = Arc::new(AtomicBool::new(false));
    let mut ctrl = CycleController::new(&cfg, start, link, mc, sp, stop.clone());

    // A few ticks unarmed so that lazily sized buffers reach their working size.
    let period = Duration::from_micros(cfg.bus.period_us as u64);
    let mut now = Instant::ZERO;
    for _ in 0..20 {
        now += period;
        assert_eq!(ctrl.step(now), Step::Continue);
    }
    let before = allocs();
    arm(true);
    let mut outcome = None;
    for k in 0..60_000 {
        if Some(k) == stop_at {
            stop.store(true, std::sync::atomic::Ordering::SeqCst);
        }
        now += period;
        if let Step::Done(o) = ctrl.step(now) {
            outcome = Some(o);
            break;
        }
        // Drain as the reporting side would, still armed (popping must not allocate either).
        if sc.occupied_len() > 30_000 {
            while sc.try_pop().is_some() {}
        }
    }
    arm(false);
    let n = allocs() - before;
    (n, outcome.expect("the run ended"), ctrl.ticks())
}

use cnc402_runtime::ring::Observer;

#[test]
fn full_tick_path_allocates_nothing_through_a_tap() {
    let (n, outcome, ticks) = run_armed(None);
    assert_eq!(outcome, Outcome::Finished);
    assert!(ticks > 3000, "{ticks}");
    assert_eq!(n, 0, "allocations in {ticks} ticks");
}

#[test]
fn full_tick_path_allocates_nothing_through_a_fault_and_stop() {
    let plan = common::fault(3, 1500, 0x8611);
    let (n, outcome, ticks) = run_armed(Some(plan));
    assert!(matches!(outcome, Outcome::Stopped { .. }), "{outcome:?}");
    assert_eq!(n, 0, "allocations in {ticks} ticks");
}

#[test]
fn full_tick_path_allocates_nothing_through_blended_moves() {
    let (n, outcome, ticks) = run_program_armed(&blended(), None, None);
    assert_eq!(outcome, Outcome::Finished);
    assert!(ticks > 500, "{ticks}");
    assert_eq!(n, 0, "allocations in {ticks} ticks");
}

#[test]
fn full_tick_path_allocates_nothing_stopping_along_blended_moves() {
    let (n, outcome, ticks) = run_program_armed(&blended(), None, Some(200));
    assert!(matches!(outcome, Outcome::Stopped { .. }), "{outcome:?}");
    assert_eq!(n, 0, "allocations in {ticks} ticks");
}

/// X slow (simulated and modelled) with X, Y, Z matched: the contouring set is shaped every
/// tick, and the tap's pair on top of it.
#[test]
fn full_tick_path_allocates_nothing_with_matched_contouring_axes() {
    let mut cfg = machine();
    let slow = cnc402_config::DriveModel {
        delay_cycles: 2,
        bandwidth_hz: 40.0,
    };
    cfg.axes[0].dynamics = Some(slow);
    cfg.axes[0].sim = cnc402_config::SimDynamics {
        delay_cycles: 2,
        bandwidth_hz: 40.0,
        ..cnc402_config::SimDynamics::default()
    };
    cfg.axes[0].following_error_window = 5.0;
    cfg.planner.match_axes = vec![0, 1, 2];
    for (program, stop_at) in [
        (TAP.to_string(), None),
        (blended(), None),
        (blended(), Some(200)),
    ] {
        let (n, outcome, ticks) = run_armed_on(&cfg, &program, None, stop_at);
        let stopped = matches!(outcome, Outcome::Stopped { .. });
        assert_eq!(stopped, stop_at.is_some(), "{outcome:?}");
        assert_eq!(n, 0, "allocations in {ticks} ticks");
    }
}

/// Feed hold, resume, feed override 50 % and 0 %, spindle override, from the panel's
/// atomics (as the terminal sets them) and from triggered commands (a command file), over a
/// blended run and the tap: the loop still allocates nothing.
#[test]
fn full_tick_path_allocates_nothing_with_feed_hold_and_overrides() {
    use cnc402_runtime::operator::{
        Panel, PanelAction, PanelCommand, Schedule, Scheduled, Trigger,
    };
    let cfg = machine();
    for program in [blended(), TAP.to_string()] {
        let mut link = SimLink::simulated(&cfg, None).expect("sim link");
        let start = common::started(&mut link);
        let (_mp, mc) = common::planned(&cfg, "p.nc", &program, &start, 8192);
        let (sp, mut sc) = status_ring(1 << 16);
        let panel = Arc::new(Panel::default());
        let mut schedule = Schedule::default();
        let at = |ms: u64, action, line| Scheduled {
            command: PanelCommand {
                action,
                at: Some(Trigger::Time { micros: ms * 1000 }),
            },
            input_line: line,
        };
        for s in [
            at(300, PanelAction::Feed(50), 1),
            at(600, PanelAction::Spindle(120), 2),
            at(900, PanelAction::Feed(0), 3),
            at(1300, PanelAction::Feed(100), 4),
            at(1900, PanelAction::Resume, 5),
        ] {
            schedule.push(s).unwrap();
        }
        let stop = Arc::new(AtomicBool::new(false));
        let mut ctrl = CycleController::new(&cfg, start, link, mc, sp, stop)
            .with_panel(panel.clone(), schedule);
        let period = Duration::from_micros(cfg.bus.period_us as u64);
        let mut now = Instant::ZERO;
        for _ in 0..20 {
            now += period;
            assert_eq!(ctrl.step(now), Step::Continue);
        }
        let before = allocs();
        arm(true);
        let mut outcome = None;
        for k in 0..120_000 {
            if k == 1500 {
                // The terminal's hold (the listener thread stores it).
                panel.apply(PanelAction::Hold, 7);
            }
            now += period;
            if let Step::Done(o) = ctrl.step(now) {
                outcome = Some(o);
                break;
            }
            if sc.occupied_len() > 30_000 {
                while sc.try_pop().is_some() {}
            }
        }
        arm(false);
        let n = allocs() - before;
        assert_eq!(outcome, Some(Outcome::Finished));
        assert_eq!(ctrl.panel_log().events().count(), 6);
        assert_eq!(n, 0, "allocations in {} ticks", ctrl.ticks());
    }
}

#[test]
fn the_counter_counts() {
    arm(true);
    let before = allocs();
    let v: Vec<u8> = Vec::with_capacity(10);
    drop(std::hint::black_box(v));
    arm(false);
    assert!(allocs() - before >= 2);
}

#[test]
fn full_tick_path_allocates_nothing_when_the_spindle_faults_mid_tap() {
    // The tool axis then follows the spindle's actual position (another code path).
    let plan = common::fault(4, 1500, 0x8611);
    let (n, outcome, ticks) = run_armed(Some(plan));
    assert!(matches!(outcome, Outcome::Stopped { .. }), "{outcome:?}");
    assert_eq!(n, 0, "allocations in {ticks} ticks");
}

#[test]
fn latency_histogram_records_without_allocating() {
    let mut h = cnc402_runtime::rt::LatencyHistogram::new(5000, 500_000);
    arm(true);
    let before = allocs();
    // Fine, coarse and overflow buckets, as the loop records them.
    for i in 0..10_000u64 {
        h.record(std::hint::black_box(i * 997));
    }
    h.record(std::hint::black_box(5_000_000_000));
    let n = allocs() - before;
    arm(false);
    assert_eq!(n, 0);
    assert_eq!(h.summary().samples, 10_001);
    assert_eq!(h.histogram().overflow(), 1);
}

/// A program stop held for 500 ticks, then resumed: the hold allocates nothing, the setpoints
/// hold at the M0 position, and no move starts until the gate is released.
#[test]
fn holding_at_m0_allocates_nothing_and_holds_position() {
    use cnc402_runtime::{AtStop, StopGate};
    let cfg = machine();
    let mut link = SimLink::simulated(&cfg, None).expect("sim link");
    let start = common::started(&mut link);
    let program = "G21 G90\nG1 X5 F1200\nM0\nG1 X9 F1200\nM30\n";
    let (_mp, mc) = common::planned(&cfg, "m0.nc", program, &start, 64);
    let (sp, mut sc) = status_ring(1 << 16);
    let gate = Arc::new(StopGate::new(AtStop::Wait, false));
    let mut ctrl =
        CycleController::new(&cfg, start, link, mc, sp, Arc::new(AtomicBool::new(false)))
            .with_stop_gate(gate.clone());
    let period = Duration::from_micros(cfg.bus.period_us as u64);
    let mut now = Instant::ZERO;
    let mut n = 0;
    while !ctrl.is_held() {
        now += period;
        assert_eq!(ctrl.step(now), Step::Continue);
        n += 1;
        assert!(n < 20_000, "never reached the M0");
    }
    while sc.try_pop().is_some() {}
    let before = allocs();
    arm(true);
    for _ in 0..500 {
        now += period;
        assert_eq!(ctrl.step(now), Step::Continue);
    }
    arm(false);
    assert_eq!(allocs() - before, 0, "allocations while held");
    assert!(ctrl.is_held());
    let mut held = 0;
    while let Some(s) = sc.try_pop() {
        assert!(
            (s.cmd[0] - 5.0).abs() < 1e-9,
            "X setpoint {} while held",
            s.cmd[0]
        );
        held += 1;
    }
    assert_eq!(held, 500);
    gate.resume(0.5);
    let mut end = None;
    for _ in 0..20_000 {
        now += period;
        if let Step::Done(o) = ctrl.step(now) {
            end = Some(o);
            break;
        }
    }
    assert_eq!(end, Some(Outcome::Finished));
    let last = std::iter::from_fn(|| sc.try_pop()).last().expect("status");
    assert!((last.cmd[0] - 9.0).abs() < 1e-9, "X {}", last.cmd[0]);
}

/// Two channels (X Y Z C and U W) in one loop on the simulated bus: each channel's moves with
/// a wait mark after its first, planned before arming; every tick of the set is armed.
fn run_two_channels_armed(fault: Option<FaultPlan>) -> (u64, Vec<Option<Outcome>>, u64) {
    use cnc402_motion::{MoveKind, PlannedMove, SegmentEnd, StopKind};
    use cnc402_runtime::channel_set::{ChannelPort, ChannelSet, Member};
    use cnc402_runtime::ring::{LoopInput, Producer, move_ring};

    let cfg = MachineConfig::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../examples/axioma/two-channel.toml"
    ))
    .expect("config");
    let mut link = SimLink::simulated(&cfg, None).expect("sim link");
    if let Some(f) = fault {
        link = link.with_fault(f);
    }
    let start = common::started(&mut link);
    let stop = Arc::new(AtomicBool::new(false));
    let programs = [TAP, "G90 G1 U20 W-5 F3000\nG0 U0 W0\nM30\n"];
    let mut members = Vec::new();
    let mut rings = Vec::new();
    let mut producers = Vec::new();
    for (k, text) in programs.iter().enumerate() {
        let view = cfg.channel(k).expect("channel");
        let mut local = [0.0; cnc402_config::MAX_AXES];
        for (i, &a) in view.axes.iter().enumerate() {
            local[i] = start[a];
        }
        let mut feeder = common::feeder(&view.config, "t.nc", text, &local);
        let (mut mp, mc) = move_ring(8192);
        let mut first = true;
        while let Some(mv) = feeder.next_move().expect("plan") {
            assert!(mp.try_push(LoopInput::Move(mv)).is_ok());
            if std::mem::take(&mut first) {
                let mark = PlannedMove {
                    line: 1,
                    n: None,
                    kind: MoveKind::ProgramStop {
                        kind: StopKind::WaitMark {
                            mark: 1,
                            channels: 0,
                        },
                    },
                    ends: SegmentEnd::ExactStop,
                };
                assert!(mp.try_push(LoopInput::Move(mark)).is_ok());
            }
        }
        assert!(mp.try_push(LoopInput::End).is_ok());
        let (sp, sc) = status_ring(1 << 16);
        let ctrl = CycleController::new(
            &view.config,
            local,
            ChannelPort::default(),
            mc,
            sp,
            stop.clone(),
        );
        members.push(Member::new(ctrl, &view));
        rings.push(sc);
        producers.push(mp);
    }
    let mut set = ChannelSet::new(link, members, start);
    let period = Duration::from_micros(cfg.bus.period_us as u64);
    let mut now = Instant::ZERO;
    for _ in 0..20 {
        now += period;
        assert!(!set.step(now));
    }
    let before = allocs();
    arm(true);
    let mut ticks = 0;
    for _ in 0..60_000 {
        now += period;
        ticks += 1;
        if set.step(now) {
            break;
        }
        for sc in rings.iter_mut() {
            if sc.occupied_len() > 30_000 {
                while sc.try_pop().is_some() {}
            }
        }
    }
    arm(false);
    let n = allocs() - before;
    let outcomes = set.members().iter().map(|m| m.outcome.clone()).collect();
    (n, outcomes, ticks)
}

#[test]
fn two_channels_in_one_loop_allocate_nothing_through_a_wait_mark_and_a_tap() {
    let (n, outcomes, ticks) = run_two_channels_armed(None);
    assert_eq!(outcomes, vec![Some(Outcome::Finished); 2]);
    assert!(ticks > 1000, "{ticks}");
    assert_eq!(n, 0, "allocations in {ticks} ticks");
}

#[test]
fn two_channels_in_one_loop_allocate_nothing_through_a_fault_and_stop() {
    let plan = common::fault(5, 600, 0x8611);
    let (n, outcomes, ticks) = run_two_channels_armed(Some(plan));
    assert!(
        outcomes
            .iter()
            .all(|o| matches!(o, Some(Outcome::Stopped { .. }))),
        "{outcomes:?}"
    );
    assert_eq!(n, 0, "allocations in {ticks} ticks");
}
