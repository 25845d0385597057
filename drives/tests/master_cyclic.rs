//! The master in cyclic operation against four simulated drives (virtual time): following a
//! ramp, each safety reaction with the stop value it produces, the INT32 wrap of a spindle,
//! SDO during cyclic operation without losing PDOs, virtual axes, quick stop and disable.

// Several per-axis arrays are indexed together.
#![allow(clippy::needless_range_loop)]

mod master_common;

use cia402::State;
use cnc402_config::{AxisKind, MachineConfig};
use cnc402_drives::bus::{CanBus, Origin};
use cnc402_drives::master::{
    BlockingSdo, Feedback, MasterOptions, Phase, SafetyStop, SdoError, StopMode, StopReason,
};
use cnc402_drives::sim::{FaultKind, SimDriveOptions};
use cnc402_drives::wire::{Function, NodeId};
use master_common::{Rig, smoothstep};
use std::time::Duration;

/// Commands at cycle `k` of a move from `start`: X +40 mm, Y −30 mm, Z −20 mm in 1 s
/// (S-shaped), C accelerating to 600 rpm in 0.5 s and then turning at that speed.
fn ramp(start: &[f64], k: u64) -> [f64; 4] {
    let t = k as f64 * 1e-3;
    let u = t / 1.0;
    let c = if t < 0.5 {
        // ∫ of a smoothstep velocity ramp to 3600 °/s over 0.5 s.
        let x = t / 0.5;
        3600.0 * 0.5 * (x * x * x - 0.5 * x * x * x * x)
    } else {
        3600.0 * 0.5 * 0.5 + 3600.0 * (t - 0.5)
    };
    [
        start[0] + 40.0 * smoothstep(u),
        start[1] - 30.0 * smoothstep(u),
        start[2] - 20.0 * smoothstep(u),
        start[3] + c,
    ]
}

/// Runs `cycles` cycles of `ramp` from cycle `from`; stops at the first safety stop.
fn run(
    rig: &mut Rig,
    start: &[f64],
    from: u64,
    cycles: u64,
) -> Result<Vec<Feedback>, (u64, SafetyStop)> {
    let mut out = Vec::new();
    for k in from..from + cycles {
        match rig.cycle(&ramp(start, k)) {
            Ok(fb) => out.push(fb),
            Err(s) => return Err((k, s)),
        }
    }
    Ok(out)
}

/// The machine at a 2 ms period (half the bus free for SDO), booted, after `cycles` cycles
/// of `ramp`: the rig, the start positions and the next cycle.
fn ramped_at_2ms(cycles: u64) -> (Rig, [f64; cnc402_config::MAX_AXES], u64) {
    let mut rig = Rig::booted_for(master_common::machine_at_period_us(2000));
    let start = rig.master.positions();
    run(&mut rig, &start, 0, cycles).unwrap();
    (rig, start, cycles)
}

/// Starts an in-cycle SDO upload of `index:0` on `axis` and waits for its outcome (see
/// `sdo_outcome`).
fn upload(
    rig: &mut Rig,
    start: &[f64],
    k: &mut u64,
    axis: usize,
    index: u16,
    limit: u64,
) -> Result<(), SdoError> {
    let now = rig.next;
    rig.master.start_sdo_upload(axis, index, 0, now).unwrap();
    sdo_outcome(rig, start, k, axis, limit)
}

/// Runs `ramp` from cycle `*k` until the in-cycle SDO transfer on `axis` ends and returns
/// its outcome; the cycle count `*k` must stay below `limit` until then.
fn sdo_outcome(
    rig: &mut Rig,
    start: &[f64],
    k: &mut u64,
    axis: usize,
    limit: u64,
) -> Result<(), SdoError> {
    loop {
        rig.cycle(&ramp(start, *k))
            .unwrap_or_else(|s| panic!("cycle {k}: {s}"));
        *k += 1;
        if let Some(o) = rig.master.take_sdo_outcome(axis) {
            return o;
        }
        assert!(*k < limit, "SDO on axis {axis} never finished");
    }
}

#[test]
fn all_four_drives_follow_a_ramp() {
    let mut rig = Rig::booted();
    let start = rig.master.positions();
    let fbs = run(&mut rig, &start, 0, 1500).unwrap_or_else(|(k, s)| panic!("cycle {k}: {s}"));
    let mut late = 0;
    let mut run_len = [0u32; 4];
    let mut longest = 0;
    for fb in &fbs {
        for i in 0..4 {
            assert_eq!(fb.state(i), Some(State::OperationEnabled));
            if !fb.fresh[i] {
                late += 1;
                run_len[i] += 1;
                longest = longest.max(run_len[i]);
            } else {
                run_len[i] = 0;
            }
        }
    }
    // 4 axes at 1 ms fill ~98 % of 1 Mbit/s: heartbeats push a TPDO past the cycle edge now
    // and then, never for long (the TPDO monitor allows 5 cycles).
    assert!(longest <= 2, "{longest} cycles without a TPDO");
    let max = rig.master.max_following_errors();
    for i in 0..4 {
        let a = &rig.config.axes[i];
        assert!(
            max[i] < a.following_error_window / 2.0,
            "{}: {}",
            a.name,
            max[i]
        );
        assert!(max[i] > 0.0, "{} moved, so it lagged", a.name);
    }
    // Hold the end point: every actual settles on its command (within a count).
    let end = ramp(&start, 1500);
    let mut fb = fbs[fbs.len() - 1];
    for _ in 0..100 {
        fb = rig.cycle(&end).unwrap();
    }
    for i in 0..4 {
        let cpu = rig.config.axes[i].counts_per_unit;
        assert!(
            (fb.actual[i] - end[i]).abs() * cpu <= 1.0,
            "{i}: {} vs {}",
            fb.actual[i],
            end[i]
        );
        assert!((rig.drive(i).position_actual() as f64 - end[i] * cpu).abs() <= 1.0);
    }
    eprintln!(
        "ramp: max following error X {:.4} Y {:.4} Z {:.4} mm, C {:.3} deg; late TPDO samples {late} of {}, longest gap {longest} cycle(s)",
        max[0],
        max[1],
        max[2],
        max[3],
        fbs.len() * 4
    );
}

#[test]
fn drive_fault_with_emcy_stops_all_axes_naming_node_state_and_code() {
    let mut rig = Rig::booted();
    let start = rig.master.positions();
    run(&mut rig, &start, 0, 300).unwrap();
    rig.bus.start_trace();
    rig.inject(2, FaultKind::Fault(0x8611));
    let (k, stop) = run(&mut rig, &start, 300, 10).unwrap_err();
    assert!(k <= 302, "noticed at cycle {k}");
    assert!(
        matches!(stop.reason, StopReason::DriveFault | StopReason::Emergency),
        "{stop}"
    );
    assert_eq!(
        (stop.axis, stop.node, stop.axis_index),
        (Some('Z'), Some(3), Some(2))
    );
    assert_eq!(stop.emcy.map(|e| e.code), Some(0x8611));
    assert!(stop.statusword.is_some());
    // The tripping cycle's feedback is still available.
    assert_eq!(rig.master.last_feedback().statusword[2], stop.statusword);
    assert!(rig.master.last_feedback().stopping);
    let text = stop.at_line(17).to_string();
    for part in [
        "axis Z (node 3)",
        "0x8611",
        "following error",
        "statusword",
        "line 17",
    ] {
        assert!(text.contains(part), "{text} lacks {part}");
    }
    // Later cycles report the stop reaction; every drive got quick stop (0x02).
    assert_eq!(rig.master.phase(), Phase::Stopping);
    let hold = rig.master.positions();
    for _ in 0..300 {
        let fb = rig.cycle(&hold[..4]).unwrap();
        assert!(fb.stopping);
    }
    for i in 0..4 {
        let s = rig.drive(i).state();
        assert!(
            matches!(
                s,
                State::QuickStopActive | State::SwitchOnDisabled | State::Fault
            ),
            "axis {i} in {s}"
        );
    }
    let quick_stops: Vec<u16> = rig
        .bus
        .take_trace()
        .iter()
        .filter(|t| t.origin == Origin::Master)
        .filter(|t| matches!(t.frame.function(), Function::Rpdo(1, _)))
        .filter(|t| t.frame.data()[0] == 0x02)
        .map(|t| t.frame.id())
        .collect();
    for id in [0x201, 0x202, 0x203, 0x204] {
        assert!(quick_stops.contains(&id), "{id:#x}");
    }
    assert_eq!(rig.master.stop_reason().map(|s| s.node), Some(Some(3)));
}

#[test]
fn silent_heartbeat_stops_naming_the_drive() {
    let mut rig = Rig::booted();
    let start = rig.master.positions();
    run(&mut rig, &start, 0, 100).unwrap();
    rig.inject(1, FaultKind::HeartbeatSilence);
    let (k, stop) = run(&mut rig, &start, 100, 400).unwrap_err();
    let StopReason::HeartbeatLost { silent_ms } = stop.reason else {
        panic!("{stop}")
    };
    assert_eq!((stop.axis, stop.node), (Some('Y'), Some(2)));
    // Heartbeat every 50 ms, timeout 200 ms: noticed 200..=251 ms after the last one.
    assert!((201..=202).contains(&silent_ms), "{silent_ms}");
    assert!((250..=360).contains(&k), "{k}");
    assert_eq!(
        stop.statusword.and_then(|s| s.state()),
        Some(State::OperationEnabled)
    );
}

#[test]
fn missing_tpdos_stop_after_the_configured_cycles() {
    let mut rig = Rig::booted();
    let start = rig.master.positions();
    run(&mut rig, &start, 0, 100).unwrap();
    rig.inject(3, FaultKind::DropTpdos);
    let (k, stop) = run(&mut rig, &start, 100, 20).unwrap_err();
    assert_eq!(stop.reason, StopReason::TpdoMissing { cycles: 5 });
    assert_eq!((stop.axis, stop.node), (Some('C'), Some(4)));
    assert!((104..=106).contains(&k), "{k}");
}

#[test]
fn following_error_beyond_the_window_stops_before_the_drive_faults() {
    // The master's X time-out is 0 ms: it trips on the first sample beyond the window (with
    // the shipped 10 ms it needs 11 in a row, see master_following_error.rs). The drive keeps
    // its own 10 ms (0x6066, written after boot, which set it to the config's 0).
    let mut config = MachineConfig::default_machine();
    config.axes[0].following_error_timeout_ms = 0;
    // Without a drive model the command is expected at once (with one, the model's loop
    // would follow the jump too: see master_following_error.rs).
    for a in config.axes.iter_mut() {
        a.dynamics = None;
    }
    let mut rig = Rig::booted_for(config);
    {
        let mut ignore = |_: &cnc402_drives::wire::CanFrame| {};
        let mut sdo = BlockingSdo::new(&mut rig.bus, Duration::from_millis(100), &mut ignore);
        sdo.write_u16(NodeId::new(1).unwrap(), 0x6066, 0, 10)
            .unwrap();
    }
    rig.next = rig.next.max(rig.bus.now() + rig.master.period());
    let start = rig.master.positions();
    run(&mut rig, &start, 0, 50).unwrap();
    // A 3 mm jump of X: the drive closes most of it in one cycle, so its own 10 ms time-out
    // never fires — the master's window check does.
    let mut cmd = ramp(&start, 50);
    cmd[0] += 3.0;
    let mut stop = None;
    for _ in 0..5 {
        if let Err(s) = rig.cycle(&cmd) {
            stop = Some(s);
            break;
        }
    }
    let stop = stop.expect("following error stop");
    let StopReason::FollowingError { error, window } = stop.reason else {
        panic!("{stop}")
    };
    assert_eq!((stop.axis, stop.node), (Some('X'), Some(1)));
    assert_eq!(window, 0.5);
    assert!(error > 0.5 && error < 3.0, "{error}");
    assert_eq!(rig.drive(0).fault_code(), None);
}

#[test]
fn spindle_across_the_int32_wrap_keeps_counting() {
    let start_counts = [0, 0, 0, i32::MAX - 300_000];
    let mut rig = Rig::new(|i| SimDriveOptions {
        initial_position: start_counts[i],
        ..SimDriveOptions::default()
    });
    rig.boot();
    let cpu = rig.config.axes[3].counts_per_unit;
    let start = rig.master.positions();
    assert!((start[3] * cpu - start_counts[3] as f64).abs() < 1e-6);
    let mut prev = start[3];
    let mut crossed = false;
    for k in 0..800u64 {
        let fb = rig
            .cycle(&ramp(&start, k))
            .unwrap_or_else(|s| panic!("cycle {k}: {s}"));
        let a = fb.actual[3];
        // Continuous: at most 3600 °/s · 1 ms plus tracking transients per cycle, never back.
        assert!(
            a - prev >= -1e-9 && a - prev < 10.0,
            "cycle {k}: {prev} → {a}"
        );
        prev = a;
        if a * cpu > i32::MAX as f64 + 1000.0 {
            crossed = true;
        }
    }
    assert!(crossed, "actual {prev} deg = {} counts", prev * cpu);
    // The drive's own counter wrapped; the master's did not.
    assert!(rig.drive(3).position_actual() < 0);
    assert!(rig.master.max_following_errors()[3] < 5.0);
}

#[test]
fn pdos_keep_flowing_while_an_sdo_transfer_runs() {
    // At 1 ms the four drives' PDOs fill 97.5 % of 1 Mbit/s (see the next test); at 2 ms
    // half the bus is free for SDO.
    let (mut rig, start, mut k) = ramped_at_2ms(20);
    let outcome = upload(&mut rig, &start, &mut k, 3, 0x1008, 200);
    outcome.unwrap();
    assert_eq!(rig.master.sdo_data(3), b"cnc402 simdrive C");
    // A write during cyclic operation too, then the read-back.
    let now = rig.next;
    rig.master
        .start_sdo_download(0, 0x6065, 0, &6000u32.to_le_bytes(), now)
        .unwrap();
    let limit = k + 200;
    sdo_outcome(&mut rig, &start, &mut k, 0, limit).unwrap();
    assert_eq!(rig.drive(0).od().get_u64(0x6065, 0), Some(6000));
    run(&mut rig, &start, k, 5).unwrap();
    // Not one TPDO lost: all but the one answering the last SYNC (still in flight) arrived.
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
fn sdo_during_cyclic_operation_is_refused_when_the_bus_is_full() {
    let mut rig = Rig::booted();
    // SYNC, 4 RPDO1, 4 TPDO1 per ms, and 5 heartbeats (4 drives, the master) per 50 ms.
    assert!(
        (rig.master.cyclic_load_percent() - 98.15).abs() < 0.01,
        "{}",
        rig.master.cyclic_load_percent()
    );
    let now = rig.next;
    let e = rig.master.start_sdo_upload(3, 0x1008, 0, now).unwrap_err();
    assert!(
        matches!(
            e.kind,
            cnc402_drives::master::SdoErrorKind::NoBusCapacity { .. }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("98.2 %"), "{e}");
    // Nothing was sent; cyclic operation goes on.
    let start = rig.master.positions();
    run(&mut rig, &start, 0, 100).unwrap();
}

#[test]
fn sdo_error_during_cyclic_operation_is_reported_not_a_stop() {
    let (mut rig, start, mut k) = ramped_at_2ms(10);
    let outcome = upload(&mut rig, &start, &mut k, 1, 0x2345, 200);
    let e = outcome.unwrap_err();
    assert_eq!(
        e.abort_code(),
        Some(cnc402_drives::wire::AbortCode::NoObject)
    );
    assert_eq!(e.node, 2);
    // Silence: the in-cycle client times out after 100 ms and aborts.
    rig.inject(1, FaultKind::SdoSilence);
    let t0 = k;
    let outcome = upload(&mut rig, &start, &mut k, 1, 0x1000, t0 + 200);
    assert!(matches!(
        outcome.unwrap_err().kind,
        cnc402_drives::master::SdoErrorKind::Timeout { .. }
    ));
    assert!((50..=52).contains(&(k - t0)), "100 ms at 2 ms: {}", k - t0);
}

#[test]
fn virtual_axes_echo_their_command() {
    let mut config = MachineConfig::default_machine();
    let mut a = config.axes[3].clone();
    a.name = 'A';
    a.kind = AxisKind::Rotary;
    a.node = None;
    config.axes.push(a);
    let mut rig = Rig::booted_for(config);
    assert_eq!(rig.master.axis_count(), 5);
    let start = rig.master.positions();
    for k in 0..100u64 {
        let r = ramp(&start, k);
        let cmd = [r[0], r[1], r[2], r[3], k as f64 * 0.5];
        let fb = rig.cycle(&cmd).unwrap();
        assert_eq!(fb.actual[4], k as f64 * 0.5);
        assert_eq!(fb.statusword[4], None);
    }
}

#[test]
fn quick_stop_then_disable() {
    let mut rig = Rig::booted();
    let start = rig.master.positions();
    run(&mut rig, &start, 0, 400).unwrap();
    rig.master.quick_stop();
    let hold = ramp(&start, 400);
    for _ in 0..200 {
        assert!(rig.cycle(&hold).unwrap().stopping);
    }
    for i in 0..4 {
        let s = rig.drive(i).state();
        assert!(
            matches!(s, State::QuickStopActive | State::SwitchOnDisabled),
            "{i}: {s}"
        );
    }
    rig.bus.advance(rig.next);
    rig.master.disable(&mut rig.bus).unwrap();
    for i in 0..4 {
        assert_eq!(rig.drive(i).state(), State::SwitchOnDisabled, "axis {i}");
    }
}

#[test]
fn follow_path_stop_mode_keeps_healthy_drives_enabled() {
    let mut rig = Rig::with_config(
        MachineConfig::default_machine(),
        |_| SimDriveOptions::default(),
        MasterOptions {
            stop_mode: StopMode::FollowPath,
            ..MasterOptions::default()
        },
    );
    rig.boot();
    let start = rig.master.positions();
    run(&mut rig, &start, 0, 200).unwrap();
    rig.inject(0, FaultKind::Fault(0x2310));
    let (k, stop) = run(&mut rig, &start, 200, 10).unwrap_err();
    assert_eq!(stop.node, Some(1));
    assert_eq!(stop.emcy.map(|e| e.text()), Some("current"));
    // Z and C keep following the (caller's decelerating) path.
    let fbs = run(&mut rig, &start, k + 1, 100).unwrap();
    for fb in &fbs {
        assert!(fb.stopping);
        assert_eq!(fb.state(2), Some(State::OperationEnabled));
        assert_eq!(fb.state(3), Some(State::OperationEnabled));
    }
    rig.master.quick_stop();
    let hold = rig.master.positions();
    for _ in 0..300 {
        rig.cycle(&hold[..4]).unwrap();
    }
    for i in 1..4 {
        let s = rig.drive(i).state();
        assert!(
            matches!(s, State::QuickStopActive | State::SwitchOnDisabled),
            "{i}: {s}"
        );
    }
}

#[test]
fn reenable_after_a_fault_stop_resumes_where_the_axes_stopped() {
    let mut rig = Rig::booted();
    let start = rig.master.positions();
    run(&mut rig, &start, 0, 300).unwrap();
    rig.inject(0, FaultKind::Fault(0x2310));
    let (_, stop) = run(&mut rig, &start, 300, 10).unwrap_err();
    assert_eq!(stop.node, Some(1));
    let hold = rig.master.positions();
    for _ in 0..300 {
        rig.cycle(&hold[..4]).unwrap();
    }
    rig.bus.advance(rig.next);
    let t = rig.master.reenable(&mut rig.bus).unwrap();
    rig.next = t + rig.master.period();
    assert_eq!(rig.master.phase(), Phase::Running);
    assert!(rig.master.stop_reason().is_none());
    let pos = rig.master.positions();
    let before: Vec<i32> = (0..4).map(|i| rig.drive(i).position_actual()).collect();
    for i in 0..4 {
        let cpu = rig.config.axes[i].counts_per_unit;
        assert!((pos[i] * cpu - before[i] as f64).abs() < 0.5, "axis {i}");
    }
    for _ in 0..100 {
        let fb = rig.cycle(&pos[..4]).unwrap();
        for i in 0..4 {
            assert_eq!(fb.state(i), Some(State::OperationEnabled));
        }
    }
    for i in 0..4 {
        assert_eq!(rig.drive(i).position_actual(), before[i], "axis {i} moved");
    }
}

#[test]
fn a_failed_boot_can_be_retried() {
    let mut rig = Rig::with_config(
        MachineConfig::default_machine(),
        |i| SimDriveOptions {
            boot_delay: if i == 3 {
                std::time::Duration::from_millis(2500)
            } else {
                std::time::Duration::from_millis(1)
            },
            ..SimDriveOptions::default()
        },
        MasterOptions {
            boot_timeout: std::time::Duration::from_secs(1),
            ..MasterOptions::default()
        },
    );
    let mut failures = 0;
    loop {
        match rig.master.boot(&mut rig.bus) {
            Ok(_) => break,
            Err(cnc402_drives::master::BootError::NoBootUp { node: 4, .. }) => failures += 1,
            Err(e) => panic!("{e}"),
        }
        assert_eq!(rig.master.phase(), Phase::Idle);
        assert!(failures < 5);
    }
    assert!(failures >= 2, "{failures}");
    assert_eq!(rig.master.phase(), Phase::Running);
    assert_eq!(rig.drive(3).state(), State::OperationEnabled);
}

#[test]
fn a_machine_without_drives_boots_and_echoes() {
    let mut config = MachineConfig::default_machine();
    for a in &mut config.axes {
        a.node = None;
    }
    let mut rig = Rig::for_machine(config);
    let r = rig.boot();
    assert!(r.drives.is_empty());
    let start = rig.master.positions();
    for k in 0..10 {
        let fb = rig.cycle(&ramp(&start, k)).unwrap();
        assert_eq!(fb.actual, {
            let mut a = [0.0; cnc402_config::MAX_AXES];
            a[..4].copy_from_slice(&ramp(&start, k));
            a
        });
    }
}

#[test]
fn after_dropped_tpdos_a_reenabled_master_follows_without_false_errors() {
    let mut rig = Rig::booted();
    let start = rig.master.positions();
    run(&mut rig, &start, 0, 100).unwrap();
    rig.inject(3, FaultKind::DropTpdos);
    let (_, stop) = run(&mut rig, &start, 100, 20).unwrap_err();
    assert_eq!(stop.reason, StopReason::TpdoMissing { cycles: 5 });
    let hold = rig.master.positions();
    for _ in 0..200 {
        rig.cycle(&hold[..4]).unwrap();
    }
    rig.clear_injected(3);
    rig.bus.advance(rig.next);
    let t = rig.master.reenable(&mut rig.bus).unwrap();
    rig.next = t + rig.master.period();
    // The same ramp again from where the axes are: the following error stays at its
    // tracking-lag size (C 2.3° at 600 rpm), no stale-sample error on top.
    let start = rig.master.positions();
    let fbs = run(&mut rig, &start, 0, 1000).unwrap_or_else(|(k, s)| panic!("cycle {k}: {s}"));
    assert!(fbs.iter().all(|f| f.age[3] <= 1));
    let max = rig.master.max_following_errors();
    assert!(max[3] < 2.5, "{}", max[3]);
}

#[test]
fn spindle_backwards_across_the_int32_wrap_keeps_counting() {
    let start_counts = [0, 0, 0, i32::MIN + 300_000];
    let mut rig = Rig::new(|i| SimDriveOptions {
        initial_position: start_counts[i],
        ..SimDriveOptions::default()
    });
    rig.boot();
    let cpu = rig.config.axes[3].counts_per_unit;
    let start = rig.master.positions();
    let mut prev = start[3];
    for k in 0..800u64 {
        // M4: the same ramp mirrored.
        let r = ramp(&start, k);
        let cmd = [start[0], start[1], start[2], 2.0 * start[3] - r[3]];
        let fb = rig.cycle(&cmd).unwrap_or_else(|s| panic!("cycle {k}: {s}"));
        let a = fb.actual[3];
        assert!(
            a - prev <= 1e-9 && a - prev > -10.0,
            "cycle {k}: {prev} → {a}"
        );
        prev = a;
    }
    assert!(prev * cpu < i32::MIN as f64 - 1000.0, "{}", prev * cpu);
    assert!(
        rig.drive(3).position_actual() > 0,
        "the drive's counter wrapped"
    );
}

#[test]
fn the_master_produces_its_heartbeat_every_heartbeat_period() {
    let mut rig = Rig::booted();
    let id = 0x700 + rig.config.bus.master_node_id as u16;
    assert_eq!(id, 0x77F);
    rig.bus.start_trace();
    let start = rig.master.positions();
    let sent = rig.master.heartbeats_sent();
    run(&mut rig, &start, 0, 500).unwrap();
    let beats: Vec<_> = rig
        .bus
        .take_trace()
        .into_iter()
        .filter(|t| t.frame.id() == id)
        .collect();
    // 500 ms at 50 ms: 10 heartbeats, "operational", all from the master, 50 ms apart.
    assert_eq!(beats.len(), 10);
    assert_eq!(rig.master.heartbeats_sent() - sent, 10);
    for w in beats.windows(2) {
        let gap = w[1].at.saturating_since(w[0].at);
        assert!(
            gap >= std::time::Duration::from_micros(49_500)
                && gap <= std::time::Duration::from_micros(50_500),
            "{gap:?}"
        );
    }
    for b in &beats {
        assert_eq!(b.origin, Origin::Master);
        assert_eq!(b.frame.data(), &[0x05]);
    }
}

#[test]
fn no_master_heartbeat_when_heartbeats_are_off() {
    let mut config = MachineConfig::default_machine();
    config.bus.heartbeat_ms = 0;
    let mut rig = Rig::for_machine(config);
    let report = rig.boot();
    assert!(report.drives.iter().all(|d| !d.supervises_master));
    rig.bus.start_trace();
    let start = rig.master.positions();
    run(&mut rig, &start, 0, 200).unwrap();
    assert!(rig.bus.take_trace().iter().all(|t| t.frame.id() != 0x77F));
    assert_eq!(rig.master.heartbeats_sent(), 0);
}

#[test]
fn the_following_error_allows_the_configured_feedback_delay_not_the_sims() {
    // Same simulated drives, X told it has no dead time: every X error is then larger by one
    // cycle's command travel (the reference is one cycle newer).
    let run_with = |delay: u32| {
        let mut config = MachineConfig::default_machine();
        config.axes[0].feedback_delay_cycles = delay;
        // feedback_delay_cycles counts only without a drive model.
        for a in config.axes.iter_mut() {
            a.dynamics = None;
        }
        let mut rig = Rig::booted_for(config);
        let start = rig.master.positions();
        run(&mut rig, &start, 0, 400).unwrap()
    };
    let (one, zero) = (run_with(1), run_with(0));
    let mut compared = 0;
    for k in 3..400 {
        if !(one[k].fresh[0] && zero[k].fresh[0] && one[k].age[0] == 0 && zero[k].age[0] == 0) {
            continue;
        }
        let travel = one[k - 1].command[0] - one[k - 2].command[0];
        let d = zero[k].following_error[0] - one[k].following_error[0];
        assert!((d - travel).abs() < 1e-9, "cycle {k}: {d} vs {travel}");
        compared += 1;
    }
    assert!(compared > 350, "{compared}");
}

#[test]
fn drives_quick_stop_when_the_master_stops_cycling() {
    let mut rig = Rig::booted();
    let start = rig.master.positions();
    run(&mut rig, &start, 0, 300).unwrap();
    let t_dead = rig.next;
    // The master dies: no more cycles, no SYNC, no RPDO, no heartbeat. Its last heartbeat
    // went out at most 50 ms ago; the drives wait 200 ms (bus.heartbeat_timeout_ms).
    let mut emcys = Vec::new();
    let mut at = t_dead;
    let mut stopped_at = None;
    while at < t_dead + std::time::Duration::from_millis(400) {
        at += rig.master.period();
        rig.bus.advance(at);
        while let Some(f) = rig.bus.recv().unwrap() {
            if let Function::Emcy(n) = f.function() {
                emcys.push((at, n.get(), u16::from_le_bytes([f.data()[0], f.data()[1]])));
            }
        }
        if stopped_at.is_none() && (0..4).all(|i| rig.drive(i).state() != State::OperationEnabled) {
            stopped_at = Some(at);
        }
        if at < t_dead + std::time::Duration::from_millis(150) {
            for i in 0..4 {
                assert_eq!(rig.drive(i).state(), State::OperationEnabled, "{at:?}");
            }
        }
    }
    let stopped = stopped_at.expect("the drives stayed enabled without a master");
    let silent = stopped.saturating_since(t_dead);
    assert!(
        silent >= std::time::Duration::from_millis(150)
            && silent <= std::time::Duration::from_millis(252),
        "{silent:?}"
    );
    // Each drive reports the lost heartbeat (0x8130) once and took its quick stop: the
    // quick stop ramp (0x605A = 2) ends in SWITCH ON DISABLED.
    for n in 1..=4u8 {
        assert_eq!(
            emcys.iter().filter(|e| e.1 == n && e.2 == 0x8130).count(),
            1,
            "{emcys:?}"
        );
    }
    for i in 0..4 {
        assert!(
            matches!(
                rig.drive(i).state(),
                State::QuickStopActive | State::SwitchOnDisabled
            ),
            "{:?}",
            rig.drive(i).state()
        );
        assert!(rig.drive(i).fault_code().is_none());
    }
}
