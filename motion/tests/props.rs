//! Property tests: random machines (random per-axis limits) run random programs of lines,
//! rapids, arcs/helices, taps, dwells and spindle orientations, optionally with a stop at a
//! random tick. From the sampled trace, by finite differences, no axis exceeds its velocity,
//! acceleration or jerk limit (tolerance: see `common::check_limits`); every move ends
//! bit-for-bit on its end point (C: plus the spindle offset); every orientation lands on its
//! angle; every tap keeps Z and C within one count of the ideal coupling.

mod common;

use std::f64::consts::TAU;

use cnc402_config::MachineConfig;
use cnc402_motion::*;
use common::*;
use proptest::prelude::*;

#[derive(Clone, Debug)]
enum Spec {
    Line {
        to: [f64; 3],
        feed: f64,
    },
    Rapid {
        to: [f64; 3],
    },
    Arc {
        r: f64,
        phi: f64,
        sweep: f64,
        ccw: bool,
        turns: u32,
        dz: f64,
        feed: f64,
        plane: u8,
    },
    Tap {
        pitch: f64,
        depth: f64,
        rpm: f64,
        left: bool,
    },
    Dwell {
        ms: f64,
    },
    Orient {
        angle: f64,
        /// `Some(n)`: program C becomes angle + 360·n (as G28/G30 C set it).
        turns: Option<i32>,
    },
}

fn spec() -> impl Strategy<Value = Spec> {
    let p = -80.0..80.0f64;
    prop_oneof![
        ([p.clone(), p.clone(), p.clone()], 600.0..20000.0f64)
            .prop_map(|(to, feed)| Spec::Line { to, feed }),
        [p.clone(), p.clone(), p].prop_map(|to| Spec::Rapid { to }),
        (
            0.5..30.0f64,
            0.0..TAU,
            0.02..TAU,
            any::<bool>(),
            0u32..2,
            -10.0..10.0f64,
            600.0..15000.0f64,
            0u8..3
        )
            .prop_map(|(r, phi, sweep, ccw, turns, dz, feed, plane)| Spec::Arc {
                r,
                phi,
                sweep,
                ccw,
                turns,
                dz,
                feed,
                plane
            }),
        (0.3..3.0f64, 0.5..30.0f64, 50.0..3000.0f64, any::<bool>()).prop_map(
            |(pitch, depth, rpm, left)| Spec::Tap {
                pitch,
                depth,
                rpm,
                left
            }
        ),
        (0.0..30.0f64).prop_map(|ms| Spec::Dwell { ms }),
        // Half of them set program C as G28/G30 C do (to the angle plus whole turns).
        (0.0..360.0f64, proptest::option::of(-3i32..4))
            .prop_map(|(angle, turns)| Spec::Orient { angle, turns }),
    ]
}

#[derive(Clone, Debug)]
struct AxisLimits {
    v: f64,
    a: f64,
    j: f64,
}

fn linear_limits() -> impl Strategy<Value = AxisLimits> {
    (5.0..500.0f64, 50.0..10000.0f64, 500.0..200000.0f64).prop_map(|(v, a, j)| AxisLimits {
        v,
        a,
        j,
    })
}

fn spindle_limits() -> impl Strategy<Value = AxisLimits> {
    (3600.0..36000.0f64, 3600.0..72000.0f64, 36000.0..1.44e6f64).prop_map(|(v, a, j)| AxisLimits {
        v,
        a,
        j,
    })
}

fn machine(l: &[AxisLimits]) -> MachineConfig {
    let mut c = MachineConfig::default_machine();
    for (ax, l) in c.axes.iter_mut().zip(l) {
        ax.max_velocity = l.v;
        ax.max_acceleration = l.a;
        ax.max_jerk = l.j;
        ax.soft_limits = None;
    }
    c
}

/// Turns specs into segments from `start`, tracking the position; taps are returned with the
/// (line, z0, c0, pitch, dir) needed to check their coupling.
/// A tap to check: (line, z0, c0, pitch, dir).
type TapCheck = (u32, f64, f64, f64, f64);

fn build(specs: &[Spec], start: AxisPos) -> (Vec<Segment>, Vec<TapCheck>) {
    let mut pos = start;
    let mut segs = Vec::new();
    let mut taps = Vec::new();
    for s in specs {
        let line = segs.len() as u32 + 1;
        match *s {
            Spec::Line { to, feed } => {
                pos.0[..3].copy_from_slice(&to);
                segs.push(lin(pos, feed, line));
            }
            Spec::Rapid { to } => {
                pos.0[..3].copy_from_slice(&to);
                segs.push(rapid(pos, line));
            }
            Spec::Arc {
                r,
                phi,
                sweep,
                ccw,
                turns,
                dz,
                feed,
                plane,
            } => {
                let (pl, a, b, n) = match plane {
                    0 => (Plane::XY, 0, 1, 2),
                    1 => (Plane::ZX, 2, 0, 1),
                    _ => (Plane::YZ, 1, 2, 0),
                };
                let mut center = [0.0; 3];
                center[a] = pos.0[a] - r * phi.cos();
                center[b] = pos.0[b] - r * phi.sin();
                center[n] = pos.0[n];
                let th = if ccw { phi + sweep } else { phi - sweep };
                pos.0[a] = center[a] + r * th.cos();
                pos.0[b] = center[b] + r * th.sin();
                pos.0[n] += dz;
                let dir = if ccw { ArcDir::Ccw } else { ArcDir::Cw };
                segs.push(seg(
                    SegmentKind::Arc {
                        end: pos,
                        center,
                        plane: pl,
                        dir,
                        turns,
                        feed,
                    },
                    line,
                ));
            }
            Spec::Tap {
                pitch,
                depth,
                rpm,
                left,
            } => {
                let dir = if left { -1.0 } else { 1.0 };
                let (z0, c0) = (pos.0[2], pos.0[3]);
                let mut bottom = pos;
                bottom.0[2] = z0 - depth;
                bottom.0[3] = c0 + depth / pitch * 360.0 * dir;
                segs.push(lin(bottom, rpm * pitch, line));
                segs.push(lin(pos, rpm * pitch, line));
                taps.push((line, z0, c0, pitch, dir));
            }
            Spec::Dwell { ms } => segs.push(seg(SegmentKind::Dwell { seconds: ms * 1e-3 }, line)),
            Spec::Orient { angle, turns } => {
                let program = turns.map(|n| angle + 360.0 * f64::from(n));
                if let Some(c) = program {
                    pos.0[3] = c;
                }
                segs.push(seg(
                    SegmentKind::SpindleOrient {
                        angle,
                        program,
                        spindle: 1,
                    },
                    line,
                ));
            }
        }
    }
    (segs, taps)
}

/// Runs the program, stopping after `stop_at` ticks if given; checks exact ends on the way
/// (machine C = program C + the spindle offset that orientations leave) and that every
/// finished orientation puts machine C on its angle.
fn run_checked(c: &MachineConfig, segs: &[Segment], stop_at: Option<usize>) -> Vec<Tick> {
    let mut planner = Planner::new(c);
    let mut ip = Interpolator::new(c, AxisPos::default());
    let mut out = vec![idle_tick(&ip, 0)];
    let mut next = 0;
    let mut end = None;
    let mut angle = None;
    let mut program = None;
    loop {
        if ip.is_idle() {
            let Some(s) = segs.get(next) else { break };
            let mv = planner.plan(s).expect("plans");
            end = match mv.kind {
                MoveKind::Path(m) => Some(m.end),
                _ => None,
            };
            (angle, program) = match mv.kind {
                MoveKind::SpindleOrient { angle, program, .. } => (Some(angle), program),
                _ => (None, None),
            };
            ip.start(mv).expect("starts");
            next += 1;
        }
        if Some(out.len()) == stop_at {
            ip.request_stop();
        }
        let t = ip.tick();
        out.push(t);
        if t.finished
            && let Some(mut e) = end
        {
            e.0[3] += ip.spindle_offset();
            assert_eq!(t.pos, e, "line {}: end not exact", t.line);
        }
        if t.finished
            && let Some(a) = angle
        {
            // Within rounding of angle + 360·n (far below a count).
            let d = (t.pos.0[3] - a).rem_euclid(360.0);
            assert!(
                d.min(360.0 - d) < 1e-9,
                "line {}: orientation {}",
                t.line,
                t.pos.0[3]
            );
            // G28/G30 C: program C is the one given, and the planner continues from it.
            if let Some(p) = program {
                assert_eq!(ip.program_position().0[3], p, "line {}", t.line);
                assert_eq!(planner.position().0[3], p, "line {}", t.line);
            }
        }
        if t.state == TickState::Held {
            break;
        }
        assert!(out.len() < 2_000_000, "runaway");
    }
    out
}

/// The coupling is checked from the tap's machine start: the sample before its first tick
/// (machine C = program `c0` + the offset an orientation left).
fn check_taps(ticks: &[Tick], taps: &[TapCheck]) {
    let (zc, cc) = (10000.0, 131072.0 / 360.0);
    for &(line, z0, _c0_program, pitch, dir) in taps {
        let Some(first) = ticks.iter().position(|t| t.line == line) else {
            continue; // stopped before the tap
        };
        let c0 = ticks[first - 1].pos.0[3];
        assert_eq!(ticks[first - 1].pos.0[2], z0, "tap start Z");
        for t in ticks.iter().filter(|t| t.line == line) {
            let (z, c) = (t.pos.0[2], t.pos.0[3]);
            let c_ideal = c0 + (z0 - z) * 360.0 / pitch * dir;
            let z_ideal = z0 - (c - c0) * pitch / 360.0 * dir;
            assert!(
                ((c * cc).round() - (c_ideal * cc).round()).abs() <= 1.0,
                "C line {line}"
            );
            assert!(
                ((z * zc).round() - (z_ideal * zc).round()).abs() <= 1.0,
                "Z line {line}"
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn random_programs_stay_within_every_axis_limit(
        lims in (proptest::collection::vec(linear_limits(), 3), spindle_limits()),
        specs in proptest::collection::vec(spec(), 1..6),
        stop in proptest::option::of(0.0..1.0f64),
    ) {
        let mut l = lims.0.clone();
        l.push(lims.1.clone());
        let c = machine(&l);
        let (segs, taps) = build(&specs, AxisPos::default());
        let full = run_checked(&c, &segs, None);
        check_limits(&c, &full);
        check_taps(&full, &taps);
        if let Some(f) = stop {
            let at = 1 + (f * (full.len() - 1) as f64) as usize;
            let stopped = run_checked(&c, &segs, Some(at));
            check_limits(&c, &stopped);
            check_taps(&stopped, &taps);
            // Up to the stop both runs are the same samples.
            prop_assert_eq!(&full[..at.min(full.len())].iter().map(|t| t.pos).collect::<Vec<_>>(),
                            &stopped[..at.min(full.len())].iter().map(|t| t.pos).collect::<Vec<_>>());
        }
    }

    #[test]
    fn profiles_meet_their_limits_and_end_exactly(
        dist in 1e-6..1000.0f64,
        v in 0.1..1000.0f64,
        a in 1.0..1e5f64,
        j in 10.0..1e7f64,
    ) {
        let lim = Limits { velocity: v, acceleration: a, jerk: j };
        let p = cnc402_motion::profile::rest_to_rest(dist, lim).unwrap();
        prop_assert!(p.max_jerk() <= j * (1.0 + 1e-12));
        let n = 2000;
        let mut last = 0.0;
        for i in 0..=n {
            let st = p.sample(p.duration() * i as f64 / n as f64);
            prop_assert!(st.v <= v * (1.0 + 1e-9) && st.v >= -1e-9 * v);
            prop_assert!(st.a.abs() <= a * (1.0 + 1e-9));
            prop_assert!(st.s >= last - 1e-12 * dist);
            last = st.s;
        }
        prop_assert_eq!(p.sample(p.duration()).s, dist);
        let before = p.sample(p.duration() * (1.0 - 1e-12));
        prop_assert!((before.s - dist).abs() <= 1e-9 * dist.max(1e-3));
    }

    #[test]
    fn tap_coupling_within_one_count_for_any_pitch_and_depth(
        pitch in 0.2..4.0f64,
        depth in 0.1..60.0f64,
        rpm in 20.0..6000.0f64,
        left in any::<bool>(),
        z0 in -50.0..50.0f64,
        c0 in -1e6..1e6f64,
        pecks in 1usize..4,
    ) {
        let c = MachineConfig::default_machine();
        let dir = if left { -1.0 } else { 1.0 };
        let mut start = AxisPos::default();
        start.0[2] = z0;
        start.0[3] = c0;
        let mut segs = Vec::new();
        for k in 1..=pecks {
            let d = depth * k as f64 / pecks as f64;
            let mut b = start;
            b.0[2] = z0 - d;
            b.0[3] = c0 + d / pitch * 360.0 * dir;
            segs.push(lin(b, rpm * pitch, 1));
            segs.push(lin(start, rpm * pitch, 1));
        }
        let ticks = run(&c, start, &segs);
        check_taps(&ticks, &[(1, z0, c0, pitch, dir)]);
        check_limits(&c, &ticks);
    }
}

/// Any f64 at all, weighted towards the troublesome ones. (A selector instead of
/// `prop_oneof!` keeps proptest's value trees small: nested unions overflow a 2 MB test stack
/// in debug builds.)
fn wild() -> impl Strategy<Value = f64> {
    (0u8..10, any::<f64>(), -1e3..1e3f64).prop_map(|(sel, any, small)| match sel {
        0 => f64::NAN,
        1 => f64::INFINITY,
        2 => f64::NEG_INFINITY,
        3 => 0.0,
        4 => -0.0,
        5 => 1e300,
        6 => -1e300,
        7 => f64::MIN_POSITIVE,
        8 => any,
        _ => small,
    })
}

fn wild_segment() -> impl Strategy<Value = SegmentKind> {
    let pos = || proptest::array::uniform8(wild()).prop_map(AxisPos);
    prop_oneof![
        pos().prop_map(|end| SegmentKind::Rapid { end }),
        (pos(), wild()).prop_map(|(end, feed)| SegmentKind::Linear { end, feed }),
        (
            pos(),
            proptest::array::uniform3(wild()),
            0u8..3,
            any::<bool>(),
            any::<u32>(),
            wild()
        )
            .prop_map(|(end, center, pl, ccw, turns, feed)| SegmentKind::Arc {
                end,
                center,
                plane: [Plane::XY, Plane::ZX, Plane::YZ][pl as usize],
                dir: if ccw { ArcDir::Ccw } else { ArcDir::Cw },
                turns,
                feed,
            }),
        wild().prop_map(|seconds| SegmentKind::Dwell { seconds }),
        // Spindle numbers 0..=3: the machine has spindle 1 only.
        (wild(), 0u8..3, 0u8..4).prop_map(|(rpm, d, spindle)| SegmentKind::Spindle {
            rpm,
            dir: [SpindleDir::Cw, SpindleDir::Ccw, SpindleDir::Stop][d as usize],
            spindle,
        }),
        (wild(), proptest::option::of(wild()), 0u8..4).prop_map(|(angle, program, spindle)| {
            SegmentKind::SpindleOrient {
                angle,
                program,
                spindle,
            }
        }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    /// Whatever the interpreter hands over, planning returns a value (never panics), and what
    /// it accepts the interpolator runs with finite setpoints.
    #[test]
    fn wild_segments_never_panic(kinds in proptest::collection::vec(wild_segment(), 1..6), stop in any::<bool>()) {
        let c = MachineConfig::default_machine();
        let mut planner = Planner::new(&c);
        let mut ip = Interpolator::new(&c, AxisPos::default());
        for (i, k) in kinds.into_iter().enumerate() {
            let Ok(mv) = planner.plan(&seg(k, i as u32 + 1)) else { continue };
            prop_assert!(ip.start(mv).is_ok());
            for n in 0..2000 {
                if stop && n == 500 {
                    ip.request_stop();
                }
                let t = ip.tick();
                prop_assert!(t.pos.0.iter().all(|x| x.is_finite()), "{:?}", t.pos);
                if t.finished || t.state == TickState::Held {
                    break;
                }
            }
            if !ip.is_idle() {
                break; // a long move: enough was run
            }
        }
    }
}
