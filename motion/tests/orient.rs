//! Spindle orientation (G76/G87): `SpindleOrient { angle }` must put the PHYSICAL spindle
//! (program C + the offset an M3/M4 run leaves) on the angle, whatever angle the run stopped
//! at, and a later tap must still turn exactly its programmed C difference, coupled to Z.

mod common;

use cnc402_config::MachineConfig;
use cnc402_motion::*;
use common::*;

/// Counts per degree of the shipped spindle.
fn cpd(c: &MachineConfig) -> f64 {
    c.axes[3].counts_per_unit
}

/// |physical C − angle| modulo one turn, in counts (0 ≤ result ≤ half a turn).
fn counts_off_angle(c: &MachineConfig, pos: f64, angle: f64) -> f64 {
    let per_rev = (360.0 * cpd(c)).round() as i64;
    let d = ((pos * cpd(c)).round() as i64 - (angle * cpd(c)).round() as i64).rem_euclid(per_rev);
    d.min(per_rev - d) as f64
}

fn orient(angle: f64, line: u32) -> Segment {
    seg(
        SegmentKind::SpindleOrient {
            angle,
            program: None,
            spindle: 1,
        },
        line,
    )
}

fn spindle(rpm: f64, dir: SpindleDir, line: u32) -> Segment {
    seg(
        SegmentKind::Spindle {
            rpm,
            dir,
            spindle: 1,
        },
        line,
    )
}

/// The segments an interpreted G76 makes at the bottom of a bore after an M3 run, followed by
/// a rigid tap (as in a later G84) from program C = `c0`.
fn bore_then_tap(rpm: f64, run_x: f64, angle: f64, c0: f64, pitch: f64) -> Vec<Segment> {
    let depth = 12.0;
    vec![
        spindle(rpm, SpindleDir::Cw, 1),
        // The boring feed: the spindle turns through it and stops wherever the ramp ends.
        lin(xyzc(run_x, 0.0, -10.0, c0), 300.0, 2),
        spindle(0.0, SpindleDir::Stop, 3),
        orient(angle, 4),
        // The Q shift, retract, shift back: C holds the oriented angle.
        rapid(xyzc(run_x + 0.3, 0.0, -10.0, c0), 5),
        rapid(xyzc(run_x + 0.3, 0.0, 2.0, c0), 6),
        rapid(xyzc(run_x, 0.0, 2.0, c0), 7),
        // The tap: Z down by `depth`, C by depth/pitch turns, and back.
        lin(
            xyzc(run_x, 0.0, 2.0 - depth, c0 + depth / pitch * 360.0),
            800.0 * pitch,
            8,
        ),
        lin(xyzc(run_x, 0.0, 2.0, c0), 800.0 * pitch, 9),
    ]
}

#[test]
fn g76_orient_after_m3_lands_on_the_physical_angle_and_a_later_tap_couples() {
    let c = MachineConfig::default_machine();
    let pitch = 1.5;
    let mut landed = Vec::new();
    // Different spindle speeds and feed lengths stop the M3 run at unrelated angles.
    for (rpm, run_x, angle, c0) in [
        (1234.0, 17.0, 0.0, 0.0),
        (2777.0, 23.5, 90.0, 200.0),
        (913.0, 41.25, 271.5, -45.0),
        (4321.0, 8.0, 359.9, 720.0),
    ] {
        let start = xyzc(0.0, 0.0, -10.0, c0);
        let ticks = run(&c, start, &bore_then_tap(rpm, run_x, angle, c0, pitch));
        check_limits(&c, &ticks);
        let cc = |t: &Tick| t.pos.0[3];

        // Where the M3 run left the spindle: not already on the angle (else the test proves
        // nothing).
        let stopped = ticks.iter().rposition(|t| t.line == 3).unwrap();
        let c_stop = cc(&ticks[stopped]);
        assert!(
            counts_off_angle(&c, c_stop, angle) > 10.0 * cpd(&c),
            "rpm {rpm}: the run stopped within 10° of the angle ({c_stop})"
        );

        // The orientation: at rest at its end, physical C on the angle within one count, and
        // it took the shorter way (at most half a turn, never reversing).
        let oriented = ticks.iter().rposition(|t| t.line == 4).expect("orient ran");
        let t_or = &ticks[oriented];
        assert!(t_or.finished);
        assert_eq!(t_or.state, TickState::Moving);
        let c_or = cc(t_or);
        assert!(
            counts_off_angle(&c, c_or, angle) <= 1.0,
            "rpm {rpm}: oriented to {c_or}, want {angle} mod 360"
        );
        assert!((c_or - c_stop).abs() <= 180.0 + 1e-9, "{c_stop} -> {c_or}");
        let sign = (c_or - c_stop).signum();
        let or_ticks: Vec<&Tick> = ticks.iter().filter(|t| t.line == 4).collect();
        for w in or_ticks.windows(2) {
            assert!((w[1].pos.0[3] - w[0].pos.0[3]) * sign >= -1e-9, "reversal");
        }
        // Nothing else moves during the orientation.
        for t in &or_ticks {
            assert_eq!(&t.pos.0[..3], &ticks[stopped].pos.0[..3]);
        }

        // Shift, retract, shift back: C stays exactly where the orientation put it.
        for t in ticks.iter().filter(|t| (5..=7).contains(&t.line)) {
            assert_eq!(cc(t), c_or, "line {} moved C", t.line);
        }

        // The tap turns exactly depth/pitch turns from the oriented angle, coupled to Z
        // within one count, and comes back to the oriented angle.
        let (zc, cpd_) = (c.axes[2].counts_per_unit, cpd(&c));
        let mut worst = (0.0f64, 0.0f64);
        for t in ticks.iter().filter(|t| t.line == 8 || t.line == 9) {
            let (z, cpos) = (t.pos.0[2], cc(t));
            let c_ideal = c_or + (2.0 - z) * 360.0 / pitch;
            let z_ideal = 2.0 - (cpos - c_or) * pitch / 360.0;
            worst.0 = worst
                .0
                .max(((z * zc).round() - (z_ideal * zc).round()).abs());
            worst.1 = worst
                .1
                .max(((cpos * cpd_).round() - (c_ideal * cpd_).round()).abs());
        }
        assert!(worst.0 <= 1.0 && worst.1 <= 1.0, "rpm {rpm}: {worst:?}");
        let bottom = ticks.iter().rposition(|t| t.line == 8).unwrap();
        assert!(((cc(&ticks[bottom]) - c_or) - 12.0 / pitch * 360.0).abs() < 1e-6);
        let last = ticks.last().unwrap();
        assert!(
            (cc(last) - c_or).abs() * cpd(&c) <= 1.0,
            "tap did not return"
        );
        assert_eq!(last.pos.0[2], 2.0);
        landed.push(c_or);
    }
    // The runs stopped at different places, so the oriented machine C differ by whole turns
    // plus the different angles — not a fixed program value.
    assert!(landed.windows(2).all(|w| w[0] != w[1]), "{landed:?}");
}

/// The planner and interpolator alone: program C stays, the offset takes the turn, the
/// shorter way is taken across 0°, and a second orientation does not move.
#[test]
fn orientation_takes_the_shorter_way_and_keeps_program_c() {
    let c = MachineConfig::default_machine();
    for (offset, prog_c, angle, want) in [
        (350.0, 0.0, 10.0, 370.0),
        (10.0, 0.0, 350.0, -10.0),
        (-725.0, 100.0, 0.0, -720.0),
        (1.3e9 + 123.456, 0.0, 45.0, 1.3e9 + 5.0),
        (-181.0, 1.0, 0.0, 0.0),
        (179.0, 1.0, 0.0, 360.0),
    ] {
        let mut planner = Planner::new(&c);
        let start = xyzc(1.0, 2.0, 3.0, prog_c);
        planner.set_position(start);
        let mut ip = Interpolator::new(&c, start);
        assert!(ip.set_spindle_offset(offset));
        let from = prog_c + offset;
        for pass in 0..2 {
            let mv = planner.plan(&orient(angle, 1)).unwrap();
            ip.start(mv).unwrap();
            let mut n = 0;
            let last = loop {
                let t = ip.tick();
                n += 1;
                assert!(n < 100_000, "runaway");
                if t.finished {
                    break t;
                }
            };
            let cpos = last.pos.0[3];
            assert_eq!(cpos.rem_euclid(360.0), angle, "{from} -> {cpos}");
            assert!((cpos - want).abs() < 1e-6, "{from}: {cpos} want {want}");
            if pass == 1 {
                assert_eq!(n, 1, "already oriented: a one-tick move");
            }
            assert_eq!(ip.program_position(), start);
            assert_eq!(planner.position(), start);
            assert_eq!(ip.spindle_offset(), cpos - prog_c);
            assert_eq!(ip.position().0[3], cpos);
        }
    }
}

#[test]
fn orientation_with_the_spindle_running_or_a_bad_angle_is_refused() {
    let c = MachineConfig::default_machine();
    let mut planner = Planner::new(&c);
    let mut ip = Interpolator::new(&c, AxisPos::default());
    for bad in [360.0, -0.5, f64::NAN, f64::INFINITY] {
        let e = planner.plan(&orient(bad, 3)).unwrap_err();
        assert!(
            matches!(e.kind, MotionErrorKind::BadOrientAngle(_)),
            "{bad}: {e:?}"
        );
        assert_eq!(e.line, 3);
    }
    let planned_orient = planner.plan(&orient(0.0, 4)).unwrap();
    ip.start(planner.plan(&spindle(500.0, SpindleDir::Cw, 5)).unwrap())
        .unwrap();
    while !ip.tick().finished {}
    let e = planner.plan(&orient(0.0, 6)).unwrap_err();
    assert_eq!(e.kind, MotionErrorKind::SpindleRunning);
    // The interpolator checks too (a move planned while at rest, started while turning).
    let e = ip.start(planned_orient).unwrap_err();
    assert_eq!(e.kind, MotionErrorKind::SpindleRunning);
    // No spindle axis.
    let mut c3 = c.clone();
    c3.axes.truncate(3);
    let e = Planner::new(&c3).plan(&orient(0.0, 7)).unwrap_err();
    assert_eq!(e.kind, MotionErrorKind::NoSpindle { number: 1 });
}

/// A stop mid-orientation decelerates along it (within the axis limits, never turning back
/// or past the target) and holds; the offset then holds the angle reached.
#[test]
fn stop_during_orientation_brakes_along_it() {
    let c = MachineConfig::default_machine();
    let start = xyzc(0.0, 0.0, 0.0, 0.0);
    let mut planner = Planner::new(&c);
    let mut ip = Interpolator::new(&c, start);
    assert!(ip.set_spindle_offset(10.0)); // 10° → 190° is the full half turn
    ip.start(planner.plan(&orient(190.0, 1)).unwrap()).unwrap();
    let mut ticks = vec![idle_tick(&ip, 1)];
    let mut n = 0;
    while !ip.is_held() {
        n += 1;
        assert!(n < 100_000, "runaway");
        if n == 40 {
            ip.request_stop();
        }
        let t = ip.tick();
        assert!(!t.finished, "a stopped orientation does not finish");
        ticks.push(t);
    }
    check_limits(&c, &ticks);
    for w in ticks.windows(2) {
        assert!(w[1].pos.0[3] >= w[0].pos.0[3] - 1e-12, "turned back");
    }
    let held = ip.position().0[3];
    assert!(held > 10.0 && held < 190.0, "{held}");
    assert_eq!(ip.spindle_offset(), held);
    assert_eq!(ip.program_position(), start);
    assert!(ip.clear_stop());
    // Orienting again from where it stopped finishes the job.
    ip.start(planner.plan(&orient(190.0, 2)).unwrap()).unwrap();
    let last = loop {
        let t = ip.tick();
        if t.finished {
            break t;
        }
    };
    assert_eq!(last.pos.0[3], 190.0);
}

fn orient_to(angle: f64, program: f64, line: u32) -> Segment {
    seg(
        SegmentKind::SpindleOrient {
            angle,
            program: Some(program),
            spindle: 1,
        },
        line,
    )
}

/// G28/G30 C (`program: Some`): after an M3 run the orientation lands on the angle and program
/// C becomes the reference, so the offset is whole turns and a later absolute C move ends on
/// its physical angle (review: `G28 C30.` then `G0 C45.` ended at the physical 15°). The
/// setpoints stay within the axis limits (no jump when program C is re-based), and a tap
/// from the reference turns exactly its programmed difference.
#[test]
fn orientation_that_sets_program_c_makes_the_physical_angle_follow_it() {
    let c = MachineConfig::default_machine();
    for (rpm, reference, left_at) in [
        (1234.0, 0.0f64, 0.0),
        (2777.0, -90.0, 200.7),
        (913.0, 725.5, -1234.5),
    ] {
        let angle = reference.rem_euclid(360.0);
        let start = xyzc(0.0, 0.0, 0.0, 30.0);
        let segs = [
            spindle(rpm, SpindleDir::Cw, 1),
            rapid(xyzc(10.0, 0.0, 0.0, 30.0), 2),
            spindle(0.0, SpindleDir::Stop, 3),
            orient_to(angle, reference, 4),
            rapid(xyzc(10.0, 0.0, 0.0, reference + 45.0), 5),
            // A tap: Z down 6 at pitch 1.5 (4 turns), and back.
            lin(xyzc(10.0, 0.0, -6.0, reference + 45.0 + 1440.0), 900.0, 6),
            lin(xyzc(10.0, 0.0, 0.0, reference + 45.0), 900.0, 7),
            spindle(500.0, SpindleDir::Cw, 8),
        ];
        let mut planner = Planner::new(&c);
        planner.set_position(start);
        let mut ip = Interpolator::new(&c, start);
        assert!(ip.set_spindle_offset(left_at));
        let mut ticks = vec![idle_tick(&ip, 0)];
        for s in &segs {
            ip.start(planner.plan(s).expect("plans")).expect("starts");
            loop {
                let t = ip.tick();
                ticks.push(t);
                if t.finished {
                    break;
                }
            }
            if s.source.line == 4 {
                assert_eq!(ip.program_position().0[3], reference);
                assert_eq!(planner.position().0[3], reference);
                let off = ip.spindle_offset() / 360.0;
                assert!((off - off.round()).abs() < 1e-9, "offset {off} turns");
            }
        }
        check_limits(&c, &ticks);
        let at = |line: u32| ticks.iter().rposition(|t| t.line == line).unwrap();
        let c_or = ticks[at(4)].pos.0[3];
        assert!(
            counts_off_angle(&c, c_or, angle) <= 1.0,
            "oriented to {c_or}"
        );
        let c45 = ticks[at(5)].pos.0[3];
        assert!(
            counts_off_angle(&c, c45, (angle + 45.0).rem_euclid(360.0)) <= 1.0,
            "G0 C(ref+45) ended at {c45}"
        );
        assert!((c45 - c_or - 45.0).abs() < 1e-6);
        let bottom = ticks[at(6)].pos.0[3];
        assert!((bottom - c45 - 1440.0).abs() < 1e-6);
        assert!((ticks[at(7)].pos.0[3] - c45).abs() < 1e-6);
    }
}

/// Program C not ≡ the angle (mod 360), or not finite, is refused by the planner and the
/// interpolator: the physical angle would not follow program C.
#[test]
fn orientation_to_a_program_c_off_its_angle_is_refused() {
    let c = MachineConfig::default_machine();
    let mut planner = Planner::new(&c);
    for (angle, program) in [
        (0.0, 30.0),
        (90.0, 91.0),
        (0.0, f64::NAN),
        (0.0, f64::INFINITY),
    ] {
        let e = planner.plan(&orient_to(angle, program, 3)).unwrap_err();
        assert!(
            matches!(e.kind, MotionErrorKind::BadOrientProgram { .. }),
            "{angle} {program}: {e:?}"
        );
    }
    assert_eq!(
        planner.position(),
        AxisPos::default(),
        "nothing changes on error"
    );
    // Whole turns, and a rounding below a reference of one turn less, are accepted.
    for (angle, program) in [(0.0, -720.0), (270.0, -90.0), (0.0, -1e-13)] {
        planner.plan(&orient_to(angle, program, 4)).unwrap();
        assert_eq!(planner.position().0[3], program);
    }
    let mut ip = Interpolator::new(&c, AxisPos::default());
    let e = ip
        .start(PlannedMove {
            line: 5,
            n: None,
            kind: MoveKind::SpindleOrient {
                angle: 0.0,
                limits: Limits {
                    velocity: 100.0,
                    acceleration: 100.0,
                    jerk: 1000.0,
                },
                program: Some(10.0),
                spindle: 1,
            },
            ends: SegmentEnd::ExactStop,
        })
        .unwrap_err();
    assert!(matches!(e.kind, MotionErrorKind::BadOrientProgram { .. }));
}

/// A stop during a G28 C orientation: program C already reads the reference (the planner
/// went on from it) and the offset holds where the spindle stopped, so machine C does not
/// jump and orienting again finishes the job.
#[test]
fn stop_during_an_orientation_that_sets_program_c_keeps_planner_and_interpolator_agreed() {
    let c = MachineConfig::default_machine();
    let start = xyzc(0.0, 0.0, 0.0, 30.0);
    let mut planner = Planner::new(&c);
    planner.set_position(start);
    let mut ip = Interpolator::new(&c, start);
    ip.start(planner.plan(&orient_to(180.0, -180.0, 1)).unwrap())
        .unwrap();
    let mut ticks = vec![idle_tick(&ip, 1)];
    while !ip.is_held() {
        assert!(ticks.len() < 100_000, "runaway");
        if ticks.len() == 40 {
            ip.request_stop();
        }
        ticks.push(ip.tick());
    }
    // Within the limits, so no jump.
    check_limits(&c, &ticks);
    let last = ip.position().0[3];
    assert!(last > 30.0 && last < 180.0, "{last}");
    assert_eq!(ip.program_position().0[3], -180.0);
    assert_eq!(planner.position().0[3], -180.0);
    assert_eq!(ip.spindle_offset(), last + 180.0);
    assert!(ip.clear_stop());
    ip.start(planner.plan(&orient_to(180.0, -180.0, 2)).unwrap())
        .unwrap();
    let end = loop {
        let t = ip.tick();
        if t.finished {
            break t;
        }
    };
    assert_eq!(end.pos.0[3], 180.0);
    assert_eq!(ip.program_position().0[3], -180.0);
}
