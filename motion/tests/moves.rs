//! Planner and interpolator on the default machine (X Y Z C): exact end points, limits by
//! finite differences, arcs on the true curve, taps, spindle speed mode, events, errors.

mod common;

use cnc402_config::MachineConfig;
use cnc402_motion::*;
use common::*;

fn cfg() -> MachineConfig {
    MachineConfig::default_machine()
}

#[test]
fn line_lands_bit_for_bit_on_its_end_and_respects_feed() {
    let c = cfg();
    let start = xyzc(0.1, 0.2, 0.3, 0.0);
    let end = xyzc(12.345678901, -7.1, 1.0 / 3.0, 0.0);
    let ticks = run(&c, start, &[lin(end, 3000.0, 7)]);
    let last = ticks.last().unwrap();
    assert!(last.finished);
    assert_eq!(last.pos, end, "bit-for-bit");
    assert_eq!(last.line, 7);
    // Every sample but the last is not finished; path speed never above 50 mm/s.
    assert!(ticks[1..ticks.len() - 1].iter().all(|t| !t.finished));
    let max_v = ticks.iter().fold(0.0f64, |m, t| m.max(t.path_velocity));
    assert!(max_v <= 50.0 * (1.0 + 1e-12) && max_v > 49.0, "{max_v}");
    // The sample before the move is the start.
    assert_eq!(ticks[0].pos, start);
    check_limits(&c, &ticks);
}

#[test]
fn rapid_is_limited_by_the_slowest_axis_share() {
    let c = cfg();
    let end = xyzc(200.0, 0.0, -200.0, 0.0);
    let ticks = run(&c, AxisPos::default(), &[rapid(end, 1)]);
    check_limits(&c, &ticks);
    // Z (200 mm/s) limits a 45° X-Z line to 200·√2 path speed.
    let max_v = ticks.iter().fold(0.0f64, |m, t| m.max(t.path_velocity));
    // (The profile is stretched to a whole number of periods: a hair slower.)
    let lim = 200.0 * 2f64.sqrt();
    assert!(max_v <= lim && max_v > lim * 0.999, "{max_v}");
    assert_eq!(ticks.last().unwrap().pos, end);
}

#[test]
fn arc_samples_lie_on_the_circle_and_end_exactly() {
    let c = cfg();
    let start = xyzc(10.0, 0.0, 0.0, 0.0);
    let end = xyzc(0.0, 10.0, -2.0, 0.0); // quarter turn CCW with a 2 mm helix
    let arc = seg(
        SegmentKind::Arc {
            end,
            center: [0.0, 0.0, 0.0],
            plane: Plane::XY,
            dir: ArcDir::Ccw,
            turns: 0,
            feed: 6000.0,
        },
        3,
    );
    let ticks = run(&c, start, &[arc]);
    for t in &ticks {
        let r = t.pos.0[0].hypot(t.pos.0[1]);
        assert!((r - 10.0).abs() < 1e-9, "{r}");
        // The helix moves Z in proportion to the angle.
        let ang = t.pos.0[1].atan2(t.pos.0[0]);
        assert!((t.pos.0[2] - (-2.0 * ang / std::f64::consts::FRAC_PI_2)).abs() < 1e-9);
    }
    assert_eq!(ticks.last().unwrap().pos, end);
    check_limits(&c, &ticks);
}

#[test]
fn full_circles_cw_small_radius_stay_within_limits() {
    let c = cfg();
    let start = xyzc(2.0, 0.0, 0.0, 0.0);
    // Two full clockwise turns of radius 2 mm at a feed far above what the radius allows.
    let arc = seg(
        SegmentKind::Arc {
            end: start,
            center: [0.0, 0.0, 0.0],
            plane: Plane::XY,
            dir: ArcDir::Cw,
            turns: 2,
            feed: 15000.0,
        },
        1,
    );
    let mut p = Planner::new(&c);
    p.set_position(start);
    let mv = p.plan(&arc).unwrap();
    let MoveKind::Path(m) = mv.kind else { panic!() };
    let Geometry::Arc(g) = m.geometry else {
        panic!()
    };
    assert!((g.sweep + 4.0 * std::f64::consts::PI).abs() < 1e-12);
    let ticks = run(&c, start, &[arc]);
    check_limits(&c, &ticks);
    // The angle decreases (CW) monotonically: unwrap and compare.
    let mut prev = 0.0f64;
    let mut total = 0.0;
    for t in &ticks[1..] {
        let a = t.pos.0[1].atan2(t.pos.0[0]);
        let mut d = a - prev;
        if d > std::f64::consts::PI {
            d -= std::f64::consts::TAU;
        }
        if d < -std::f64::consts::PI {
            d += std::f64::consts::TAU;
        }
        assert!(d <= 1e-12);
        total += d;
        prev = a;
    }
    assert!((total + 4.0 * std::f64::consts::PI).abs() < 1e-6, "{total}");
}

#[test]
fn zx_plane_arc_turns_from_z_towards_x_for_g3() {
    let c = cfg();
    let start = xyzc(0.0, 0.0, 5.0, 0.0); // Z = r, X = 0: angle 0 in (Z, X)
    let end = xyzc(5.0, 0.0, 0.0, 0.0); // angle 90°
    let arc = seg(
        SegmentKind::Arc {
            end,
            center: [0.0, 0.0, 0.0],
            plane: Plane::ZX,
            dir: ArcDir::Ccw,
            turns: 0,
            feed: 1000.0,
        },
        1,
    );
    let ticks = run(&c, start, &[arc]);
    // A quarter turn, never leaving the first quadrant.
    assert!(
        ticks
            .iter()
            .all(|t| t.pos.0[0] >= -1e-12 && t.pos.0[2] >= -1e-12)
    );
    assert_eq!(ticks.last().unwrap().pos, end);
}

/// One count of each axis, per the shipped config.
fn coupling_counts(ticks: &[Tick], z0: f64, c0: f64, pitch: f64, dir: f64) -> (i64, i64) {
    let (zc, cc) = (10000.0, 131072.0 / 360.0);
    let mut worst = (0i64, 0i64);
    for t in ticks {
        let (z, cpos) = (t.pos.0[2], t.pos.0[3]);
        let c_ideal = c0 + (z0 - z) * 360.0 / pitch * dir;
        let z_ideal = z0 - (cpos - c0) * pitch / 360.0 * dir;
        let dc = ((cpos * cc).round() - (c_ideal * cc).round()).abs() as i64;
        let dz = ((z * zc).round() - (z_ideal * zc).round()).abs() as i64;
        worst = (worst.0.max(dz), worst.1.max(dc));
    }
    worst
}

fn tap_segments(z0: f64, c0: f64, depth: f64, pitch: f64, rpm: f64, dir: f64) -> Vec<Segment> {
    let zb = z0 - depth;
    let cb = c0 + depth / pitch * 360.0 * dir;
    vec![
        lin(xyzc(0.0, 0.0, zb, cb), rpm * pitch, 10),
        lin(xyzc(0.0, 0.0, z0, c0), rpm * pitch, 11),
    ]
}

#[test]
fn m10_tap_keeps_z_and_c_within_one_count() {
    let c = cfg();
    let (z0, c0) = (2.0, 0.0);
    let segs = tap_segments(z0, c0, 20.0, 1.5, 800.0, 1.0);
    let ticks = run(&c, xyzc(0.0, 0.0, z0, c0), &segs);
    let w = coupling_counts(&ticks, z0, c0, 1.5, 1.0);
    assert!(w.0 <= 1 && w.1 <= 1, "{w:?}");
    check_limits(&c, &ticks);
    // Reversal at the bottom lands exactly.
    let bottom = ticks.iter().find(|t| t.finished).unwrap();
    assert_eq!(bottom.pos, xyzc(0.0, 0.0, -18.0, 20.0 / 1.5 * 360.0));
    assert_eq!(ticks.last().unwrap().pos, xyzc(0.0, 0.0, z0, c0));
}

#[test]
fn peck_tap_left_hand_stays_coupled() {
    let c = cfg();
    let (z0, c0, pitch, dir) = (1.0, 90.0, 1.25, -1.0);
    let cz = |z: f64| c0 + (z0 - z) * 360.0 / pitch * dir;
    let mut segs = Vec::new();
    for (i, depth) in [3.0, 6.0, 9.5].iter().enumerate() {
        let z = z0 - depth;
        segs.push(lin(xyzc(0.0, 0.0, z, cz(z)), 1000.0 * pitch, 20 + i as u32));
        segs.push(lin(xyzc(0.0, 0.0, z0, c0), 1000.0 * pitch, 30 + i as u32));
    }
    let ticks = run(&c, xyzc(0.0, 0.0, z0, c0), &segs);
    let w = coupling_counts(&ticks, z0, c0, pitch, dir);
    assert!(w.0 <= 1 && w.1 <= 1, "{w:?}");
    check_limits(&c, &ticks);
}

#[test]
fn spindle_ramps_to_speed_then_turns_through_moves_and_rebases_c() {
    let c = cfg();
    let segs = vec![
        seg(
            SegmentKind::Spindle {
                rpm: 3000.0,
                dir: SpindleDir::Cw,
                spindle: 1,
            },
            1,
        ),
        lin(xyzc(10.0, 0.0, 0.0, 0.0), 600.0, 2),
        seg(
            SegmentKind::Spindle {
                rpm: 0.0,
                dir: SpindleDir::Stop,
                spindle: 1,
            },
            3,
        ),
        // A tap-like move of C by 720° from program C = 0.
        lin(xyzc(10.0, 0.0, -3.0, 720.0), 1.5 * 300.0, 4),
    ];
    let ticks = run(&c, AxisPos::default(), &segs);
    check_limits(&c, &ticks);
    let ramp_end = ticks.iter().position(|t| t.finished).unwrap();
    assert_eq!(ticks[ramp_end].state, TickState::SpindleRamp);
    assert!((ticks[ramp_end].spindle_velocity[0] - 18000.0).abs() < 1e-6);
    // Ramp time: 18000/36000 + 36000/720000 = 0.55 s.
    assert!((ramp_end as f64 * 1e-3 - 0.55).abs() < 2e-3, "{ramp_end}");
    // During the linear move the spindle turns at 18000 deg/s.
    let in_move: Vec<&Tick> = ticks.iter().filter(|t| t.line == 2).collect();
    for w in in_move.windows(2) {
        assert!((w[1].pos.0[3] - w[0].pos.0[3] - 18.0).abs() < 1e-9);
    }
    // After M5 the spindle is at rest; the last move turns it by exactly 720°.
    let stop_idx = ticks.iter().rposition(|t| t.line == 3).unwrap();
    let c_stop = ticks[stop_idx].pos.0[3];
    assert!(c_stop > 18000.0 * 0.5);
    assert_eq!(ticks[stop_idx].spindle_velocity[0], 0.0);
    let last = ticks.last().unwrap();
    assert!(
        (last.pos.0[3] - c_stop - 720.0).abs() < 1e-9,
        "{} {}",
        last.pos.0[3],
        c_stop
    );
    assert_eq!(last.pos.0[2], -3.0);
    // C never jumps.
    for w in ticks.windows(2) {
        assert!((w[1].pos.0[3] - w[0].pos.0[3]).abs() <= 36.0 + 1e-9);
    }
}

#[test]
fn spindle_reverses_under_its_limits_and_m5_completes_at_rest() {
    let c = cfg();
    let sp = |rpm, dir, line| {
        seg(
            SegmentKind::Spindle {
                rpm,
                dir,
                spindle: 1,
            },
            line,
        )
    };
    let ticks = run(
        &c,
        AxisPos::default(),
        &[
            sp(6000.0, SpindleDir::Cw, 1),
            sp(6000.0, SpindleDir::Ccw, 2),
            sp(500.0, SpindleDir::Stop, 3),
        ],
    );
    check_limits(&c, &ticks);
    let ends: Vec<&Tick> = ticks.iter().filter(|t| t.finished).collect();
    assert!((ends[0].spindle_velocity[0] - 36000.0).abs() < 1e-6);
    assert!((ends[1].spindle_velocity[0] + 36000.0).abs() < 1e-6);
    assert_eq!(ends[2].spindle_velocity[0], 0.0);
}

#[test]
fn position_move_of_c_while_spindle_runs_is_refused() {
    let c = cfg();
    let mut p = Planner::new(&c);
    p.plan(&seg(
        SegmentKind::Spindle {
            rpm: 100.0,
            dir: SpindleDir::Cw,
            spindle: 1,
        },
        1,
    ))
    .unwrap();
    let e = p
        .plan(&lin(xyzc(0.0, 0.0, -1.0, 360.0), 100.0, 2))
        .unwrap_err();
    assert_eq!(e.kind, MotionErrorKind::SpindleRunning);
    assert_eq!(e.line, 2);
    // Moves that leave C alone are fine.
    assert!(p.plan(&lin(xyzc(1.0, 0.0, 0.0, 0.0), 100.0, 3)).is_ok());
}

#[test]
fn dwell_and_events_pass_through_with_their_lines() {
    let c = cfg();
    let ticks = run(
        &c,
        AxisPos::default(),
        &[
            seg(SegmentKind::Dwell { seconds: 0.0105 }, 5),
            seg(SegmentKind::ToolChange { tool: 3 }, 6),
            seg(
                SegmentKind::Message {
                    text: "hello".into(),
                },
                7,
            ),
            seg(
                SegmentKind::Stop {
                    kind: StopKind::Program,
                },
                8,
            ),
        ],
    );
    let dwell: Vec<&Tick> = ticks.iter().filter(|t| t.line == 5).collect();
    assert_eq!(dwell.len(), 11, "10.5 ms rounds up to 11 periods");
    assert_eq!(dwell[0].state, TickState::Dwelling { remaining: 10 });
    assert!(dwell[10].finished);
    let ev: Vec<(u32, Option<MoveEvent>)> = ticks
        .iter()
        .filter(|t| t.event.is_some())
        .map(|t| (t.line, t.event))
        .collect();
    assert_eq!(
        ev,
        vec![
            (6, Some(MoveEvent::ToolChange { tool: 3 })),
            (7, Some(MoveEvent::Message)),
            (
                8,
                Some(MoveEvent::ProgramStop {
                    kind: StopKind::Program
                })
            )
        ]
    );
    assert!(ticks.iter().all(|t| t.pos == AxisPos::default()));
}

#[test]
fn bad_segments_are_errors_not_panics() {
    let c = cfg();
    let mut p = Planner::new(&c);
    let e = |p: &mut Planner, k: SegmentKind| p.plan(&seg(k, 9)).unwrap_err().kind;
    for f in [0.0, -5.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            e(
                &mut p,
                SegmentKind::Linear {
                    end: xyzc(1.0, 0.0, 0.0, 0.0),
                    feed: f
                }
            ),
            MotionErrorKind::BadFeed(_)
        ));
    }
    assert_eq!(
        e(
            &mut p,
            SegmentKind::Rapid {
                end: xyzc(f64::NAN, 0.0, 0.0, 0.0)
            }
        ),
        MotionErrorKind::NonFinite { axis: 'X' }
    );
    assert!(matches!(
        e(
            &mut p,
            SegmentKind::Rapid {
                end: xyzc(301.0, 0.0, 0.0, 0.0)
            }
        ),
        MotionErrorKind::SoftLimit { axis: 'X', .. }
    ));
    assert!(matches!(
        e(&mut p, SegmentKind::Dwell { seconds: -1.0 }),
        MotionErrorKind::BadDwell(_)
    ));
    assert!(matches!(
        e(
            &mut p,
            SegmentKind::Spindle {
                rpm: 7000.0,
                dir: SpindleDir::Cw,
                spindle: 1,
            }
        ),
        MotionErrorKind::SpindleTooFast { .. }
    ));
    assert!(matches!(
        e(
            &mut p,
            SegmentKind::Spindle {
                rpm: f64::NAN,
                dir: SpindleDir::Cw,
                spindle: 1,
            }
        ),
        MotionErrorKind::BadRpm(_)
    ));
    let arc = |end, center| SegmentKind::Arc {
        end,
        center,
        plane: Plane::XY,
        dir: ArcDir::Cw,
        turns: 0,
        feed: 100.0,
    };
    assert_eq!(
        e(&mut p, arc(xyzc(1.0, 0.0, 0.0, 0.0), [0.0, 0.0, 0.0])),
        MotionErrorKind::ZeroRadius
    );
    assert!(matches!(
        e(&mut p, arc(xyzc(10.0, 0.0, 0.0, 0.0), [4.0, 1.0, 0.0])),
        MotionErrorKind::RadiusMismatch { .. }
    ));
    // An arc whose bulge leaves the X soft limit (±300) although both ends are inside.
    p.set_position(xyzc(290.0, 10.0, 0.0, 0.0));
    assert!(matches!(
        e(&mut p, arc(xyzc(290.0, -10.0, 0.0, 0.0), [295.0, 0.0, 0.0])),
        MotionErrorKind::SoftLimit { axis: 'X', .. }
    ));
    // Nothing was planned: the position did not move.
    assert_eq!(p.position(), xyzc(290.0, 10.0, 0.0, 0.0));
    // The short way round (CCW) stays inside.
    let ok = SegmentKind::Arc {
        end: xyzc(290.0, -10.0, 0.0, 0.0),
        center: [295.0, 0.0, 0.0],
        plane: Plane::XY,
        dir: ArcDir::Ccw,
        turns: 0,
        feed: 100.0,
    };
    assert!(p.plan(&seg(ok, 9)).is_ok());
    assert!(
        format!(
            "{}",
            p.plan(&seg(SegmentKind::Dwell { seconds: -1.0 }, 4))
                .unwrap_err()
        )
        .starts_with("line 4: dwell")
    );
}

#[test]
fn interpolator_refuses_moves_that_do_not_chain() {
    let c = cfg();
    let mut p = Planner::new(&c);
    let mut ip = Interpolator::new(&c, AxisPos::default());
    let a = p.plan(&lin(xyzc(1.0, 0.0, 0.0, 0.0), 600.0, 1)).unwrap();
    let b = p.plan(&lin(xyzc(2.0, 0.0, 0.0, 0.0), 600.0, 2)).unwrap();
    assert_eq!(ip.start(b).unwrap_err().kind, MotionErrorKind::NotAtStart);
    ip.start(a).unwrap();
    assert_eq!(ip.start(b).unwrap_err().kind, MotionErrorKind::Busy);
}

#[test]
fn zero_length_move_takes_one_tick() {
    let c = cfg();
    let start = xyzc(1.0, 2.0, 3.0, 4.0);
    let ticks = run(&c, start, &[lin(start, 100.0, 1)]);
    assert_eq!(ticks.len(), 2);
    assert!(ticks[1].finished);
    assert_eq!(ticks[1].pos, start);
}

/// Regression (found by `wild_segments_never_panic`): a rapid that moved Y a little and the
/// spindle axis 1e300° planned a profile lasting 10^295 s, whose tick count saturated and
/// "stretched" it by k ≪ 1: setpoints became NaN. Now it is refused.
#[test]
fn absurdly_long_move_is_refused_not_nan() {
    let c = cfg();
    let mut p = Planner::new(&c);
    let e = p.plan(&rapid(xyzc(0.0, -6.5, 0.0, 1e300), 1)).unwrap_err();
    assert_eq!(e.kind, MotionErrorKind::TooLong);
}

#[test]
fn spindle_offset_at_start_up_keeps_the_first_setpoint_on_the_actual_position() {
    let c = cfg();
    // The drive reports C at 1234.5° while the program starts at C = 0.
    let mut ip = Interpolator::new(&c, AxisPos::default());
    assert!(ip.set_spindle_offset(1234.5));
    assert_eq!(ip.position().0[3], 1234.5);
    assert_eq!(ip.tick().pos.0[3], 1234.5);
    let mut p = Planner::new(&c);
    ip.start(p.plan(&lin(xyzc(0.0, 0.0, -1.5, 360.0), 150.0, 1)).unwrap())
        .unwrap();
    let mut last = ip.tick();
    assert!(!ip.set_spindle_offset(0.0), "not while moving");
    while !last.finished {
        last = ip.tick();
    }
    assert_eq!(last.pos.0[3], 360.0 + 1234.5);
    assert!(!ip.set_spindle_offset(f64::NAN));
}

fn tap(end: AxisPos, feed: f64, pitch: f64, line: u32) -> Segment {
    seg(
        SegmentKind::Tap(TapSegment {
            end,
            feed,
            tool: 2,
            spindle: 3,
            pitch,
        }),
        line,
    )
}

/// A tap is planned like the same linear move (timing and setpoints identical), and its
/// planned move carries the coupling (pitch / 360) and how the segment ends.
#[test]
fn a_tap_plans_like_its_linear_move_and_carries_its_coupling() {
    let c = cfg();
    let start = xyzc(5.0, 5.0, 3.0, 0.0);
    let end = xyzc(5.0, 5.0, -10.0, 3120.0);
    let pitch = -13.0 / 3120.0 * 360.0;
    let mut as_tap = tap(end, 750.0, pitch, 4);
    as_tap.ends = SegmentEnd::Continuous {
        tolerance: 0.02,
        collinear: 0.0,
    };
    let mut planner = Planner::new(&c);
    planner.set_position(start);
    let t = planner.plan(&as_tap).unwrap();
    planner.set_position(start);
    let l = planner.plan(&lin(end, 750.0, 4)).unwrap();
    let (MoveKind::Path(tp), MoveKind::Path(lp)) = (t.kind, l.kind) else {
        panic!("{t:?} {l:?}")
    };
    assert_eq!(
        tp.tap,
        Some(TapCoupling {
            tool: 2,
            spindle: 3,
            ratio: pitch / 360.0
        })
    );
    assert_eq!(lp.tap, None);
    assert_eq!(PathMove { tap: None, ..tp }, lp);
    assert_eq!(
        t.ends,
        SegmentEnd::Continuous {
            tolerance: 0.02,
            collinear: 0.0,
        }
    );
    assert_eq!(l.ends, SegmentEnd::ExactStop);
    let tap_ticks = run(&c, start, &[tap(end, 750.0, pitch, 4)]);
    assert_eq!(tap_ticks, run(&c, start, &[lin(end, 750.0, 4)]));
}

/// A tap that names no linear tool axis, not the spindle, or no usable pitch is a planning
/// error, never a panic (the loop indexes its axis arrays with the tap's axes).
#[test]
fn a_bad_tap_is_an_error() {
    let c = cfg();
    let end = xyzc(0.0, 0.0, -5.0, 1200.0);
    for (tool, spindle, pitch) in [
        (3, 3, -1.5),
        (200, 3, -1.5),
        (2, 2, -1.5),
        (2, 200, -1.5),
        (2, 3, 0.0),
        (2, 3, f64::NAN),
        (2, 3, f64::INFINITY),
    ] {
        let mut p = Planner::new(&c);
        let s = seg(
            SegmentKind::Tap(TapSegment {
                end,
                feed: 300.0,
                tool,
                spindle,
                pitch,
            }),
            9,
        );
        let e = p.plan(&s).unwrap_err();
        assert!(
            matches!(e.kind, MotionErrorKind::BadTap { tool: t, spindle: sp, pitch: pi }
                if (t, sp) == (tool, spindle) && pi.to_bits() == pitch.to_bits()),
            "{tool} {spindle} {pitch}: {e}"
        );
        assert_eq!(e.line, 9);
    }
}

/// The planner's path length is motion's one `path_length` (the interpreter's `@ITPPATH` and
/// the report use it too): lines over the linear axes (rotary only when only they move),
/// taps as lines, helices along the helix.
#[test]
fn planned_lengths_are_path_length() {
    let c = cfg();
    let axes = PathAxes::new(&c);
    let start = xyzc(1.0, 2.0, 3.0, 10.0);
    let kinds = [
        SegmentKind::Rapid {
            end: xyzc(4.0, 6.0, 3.0, 100.0),
        },
        SegmentKind::Linear {
            end: xyzc(1.0, 2.0, 3.0, 100.0),
            feed: 600.0,
        },
        SegmentKind::Tap(TapSegment {
            end: xyzc(1.0, 2.0, -3.0, 10.0 + 6.0 / 1.5 * 360.0),
            feed: 300.0,
            tool: 2,
            spindle: 3,
            pitch: -1.5,
        }),
        SegmentKind::Arc {
            end: xyzc(1.0, 2.0, 1.0, 10.0),
            center: [0.0, 2.0, 0.0],
            plane: Plane::XY,
            dir: ArcDir::Ccw,
            turns: 2,
            feed: 600.0,
        },
    ];
    let want = [5.0, 90.0, 6.0, (2.0 * std::f64::consts::TAU).hypot(2.0)];
    for (k, w) in kinds.into_iter().zip(want) {
        let mut p = Planner::new(&c);
        p.set_position(start);
        let mv = p.plan(&seg(k.clone(), 1)).unwrap();
        let MoveKind::Path(m) = mv.kind else {
            panic!("{mv:?}")
        };
        assert_eq!(m.length, path_length(&start, &k, &axes), "{k:?}");
        assert!((m.length - w).abs() < 1e-9, "{k:?}: {}", m.length);
    }
    // Non-path kinds have none.
    assert_eq!(
        path_length(&start, &SegmentKind::Dwell { seconds: 1.0 }, &axes),
        0.0
    );
}
