//! Feed hold, resume and overrides on the interpolator: the path decelerates along itself to
//! rest and comes back, every axis within its limits at every tick, the path the same set of
//! points and the end the same as without the hold; override ramps; a rigid tap is neither
//! held nor overridden (Fanuc) and stays coupled; the spindle override ramps the speed.

mod common;

use std::collections::VecDeque;

use cnc402_config::MachineConfig;
use cnc402_motion::*;
use common::*;

/// An operator action at a tick.
#[derive(Clone, Copy, Debug)]
enum Act {
    Hold(bool),
    Feed(f64),
    Spindle(f64),
    Rapid(f64),
}

fn cont(kind: SegmentKind, line: u32) -> Segment {
    Segment {
        kind,
        source: src(line),
        ends: SegmentEnd::Continuous {
            tolerance: 0.01,
            collinear: 0.0,
        },
    }
}

/// Plans `segs` through the lookahead (planner feed scale `scale`) and runs them with the
/// operator's `acts`; as the loop does, no move is started from rest while a hold is on.
fn run_with(
    cfg: &MachineConfig,
    start: AxisPos,
    segs: &[Segment],
    scale: f64,
    acts: &[(usize, Act)],
) -> Vec<Tick> {
    let mut la = Lookahead::new(cfg, 64);
    la.planner_mut().set_position(start);
    la.planner_mut().set_feed_scale(scale);
    let mut queue = VecDeque::new();
    for s in segs {
        la.push(s).expect("plans");
        while let Some(m) = la.pop() {
            queue.push_back(m);
        }
    }
    la.finish().expect("finishes");
    while let Some(m) = la.pop() {
        queue.push_back(m);
    }
    let mut ip = Interpolator::new(cfg, start);
    let mut ticks = vec![idle_tick(&ip, 0)];
    loop {
        for (_, a) in acts.iter().filter(|(t, _)| *t == ticks.len()) {
            match *a {
                Act::Hold(h) => ip.set_feed_hold(h),
                Act::Feed(f) => ip.set_feed_override(f),
                Act::Spindle(f) => ip.set_spindle_override(f),
                Act::Rapid(f) => ip.set_rapid_override(f),
            }
        }
        while ip.is_idle() {
            match queue.front() {
                Some(m) if !ip.holds_before(m) => ip.start(*m).expect("starts"),
                _ => break,
            }
            queue.pop_front();
        }
        let pending = acts.iter().any(|(t, _)| *t > ticks.len());
        if ip.is_idle() && queue.is_empty() && !pending {
            break;
        }
        ticks.push(ip.tick());
        assert!(ticks.len() < 2_000_000, "runaway");
    }
    ticks
}

/// Distance from `p` (X Y) to the polyline through `pts`.
fn off_polyline(p: &AxisPos, pts: &[[f64; 2]]) -> f64 {
    pts.windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let d = [b[0] - a[0], b[1] - a[1]];
            let l2 = d[0] * d[0] + d[1] * d[1];
            let u = (((p.0[0] - a[0]) * d[0] + (p.0[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0);
            let q = [a[0] + u * d[0] - p.0[0], a[1] + u * d[1] - p.0[1]];
            (q[0] * q[0] + q[1] * q[1]).sqrt()
        })
        .fold(f64::INFINITY, f64::min)
}

fn polyline(blended: bool) -> (Vec<[f64; 2]>, Vec<Segment>) {
    let pts = vec![
        [0.0, 0.0],
        [40.0, 0.0],
        [60.0, 15.0],
        [60.0, 40.0],
        [20.0, 45.0],
    ];
    let segs = pts[1..]
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let kind = SegmentKind::Linear {
                end: xyzc(p[0], p[1], 0.0, 0.0),
                feed: 4800.0,
            };
            if blended {
                cont(kind, i as u32 + 1)
            } else {
                seg(kind, i as u32 + 1)
            }
        })
        .collect();
    (pts, segs)
}

fn speeds(t: &[Tick]) -> Vec<f64> {
    t.iter().map(|t| t.path_velocity).collect()
}

/// Every axis within its velocity and acceleration limit on every tick (sampled, up to
/// float rounding): the bound blended runs keep (at a G64 junction the sampled jerk is not
/// bounded, see the lookahead's module doc).
fn check_velocity_acceleration(cfg: &MachineConfig, ticks: &[Tick]) {
    let p = cfg.bus.period_s();
    for (i, ax) in cfg.axes.iter().enumerate().take(3) {
        let x: Vec<f64> = ticks.iter().map(|t| t.pos.0[i]).collect();
        let eps = |m: f64| 256.0 * f64::EPSILON * (m.abs() + 1.0);
        for k in 1..x.len() - 1 {
            let v = (x[k] - x[k - 1]) / p;
            assert!(v.abs() <= ax.max_velocity * (1.0 + 1e-9) + eps(x[k]) / p);
            let a = (x[k + 1] - 2.0 * x[k] + x[k - 1]) / (p * p);
            let lim = ax.max_acceleration * (1.0 + 1e-9) + 4.0 * eps(x[k]) / (p * p);
            assert!(a.abs() <= lim, "{} acceleration {a} at tick {k}", ax.name);
        }
    }
}

/// A hold anywhere along a polyline (accelerating, at cruise, across a corner, braking),
/// exact stop (G61) and blended (G64), stops on the path within every limit, and the
/// resumed run ends exactly where the run without a hold does.
#[test]
fn hold_and_resume_keep_the_path_limits_and_the_end() {
    let cfg = MachineConfig::default_machine();
    let start = xyzc(0.0, 0.0, 0.0, 0.0);
    for blended in [false, true] {
        let (pts, segs) = polyline(blended);
        let plain = run_with(&cfg, start, &segs, 1.0, &[]);
        let end = plain.last().unwrap().pos;
        let off = |t: &[Tick]| {
            t.iter()
                .map(|t| off_polyline(&t.pos, &pts))
                .fold(0.0, f64::max)
        };
        let worst_plain = off(&plain);
        for at in [5, 30, 200, 480, 700, plain.len() - 60] {
            let acts = [(at, Act::Hold(true)), (at + 700, Act::Hold(false))];
            let held = run_with(&cfg, start, &segs, 1.0, &acts);
            if blended {
                check_velocity_acceleration(&cfg, &held);
            } else {
                check_limits(&cfg, &held);
            }
            assert_eq!(held.last().unwrap().pos, end, "hold at {at}: same end");
            let v = speeds(&held);
            let rest = (at + 450..at + 700).all(|k| v[k] == 0.0);
            assert!(rest, "hold at {at}: at rest before the resume");
            let after = &v[(at + 750).min(v.len())..];
            let last_stretch = at + 100 > plain.len();
            assert!(
                last_stretch || after.iter().any(|&s| s > 10.0),
                "hold at {at}: moves again"
            );
            let worst = off(&held);
            assert!(
                worst <= worst_plain + 1e-9 && worst <= 0.01 + 1e-9,
                "hold at {at}: {worst} mm off the path ({worst_plain} without a hold)"
            );
        }
    }
}

/// Feed override 0 stops like a hold; 50 % halves the speed after a smooth ramp; both within
/// every limit and ending where the plain run does.
#[test]
fn feed_override_ramps_within_limits_and_zero_holds() {
    let cfg = MachineConfig::default_machine();
    let start = xyzc(0.0, 0.0, 0.0, 0.0);
    let segs = vec![lin(xyzc(120.0, 30.0, 0.0, 0.0), 3000.0, 1)];
    let plain = run_with(&cfg, start, &segs, 1.0, &[]);
    let cruise = plain[plain.len() / 2].path_velocity;
    let half = run_with(&cfg, start, &segs, 1.0, &[(300, Act::Feed(0.5))]);
    check_limits(&cfg, &half);
    assert_eq!(half.last().unwrap().pos, plain.last().unwrap().pos);
    assert!((half[900].path_velocity - cruise / 2.0).abs() < 1e-6 * cruise);
    let v = speeds(&half);
    for w in v[300..900].windows(2) {
        assert!(w[1] <= w[0] + 1e-12, "the ramp down is monotone");
    }
    assert!(half.len() > plain.len() + 500, "slower");
    let zero = run_with(
        &cfg,
        start,
        &segs,
        1.0,
        &[(300, Act::Feed(0.0)), (1000, Act::Feed(1.0))],
    );
    check_limits(&cfg, &zero);
    assert!(zero[500..1000].iter().all(|t| t.path_velocity == 0.0));
    assert_eq!(zero.last().unwrap().pos, plain.last().unwrap().pos);
}

/// Above 100 % the feed is raised where moves are planned: faster, never past an axis's
/// limits (the planner clamps), and an override back to 100 % slows it to the programmed
/// feed (rate 1/scale).
#[test]
fn feed_override_above_100_is_planned_within_limits() {
    let cfg = MachineConfig::default_machine();
    let start = xyzc(0.0, 0.0, 0.0, 0.0);
    let segs = vec![lin(xyzc(200.0, 0.0, 0.0, 0.0), 9000.0, 1)];
    let plain = run_with(&cfg, start, &segs, 1.0, &[]);
    let fast = run_with(&cfg, start, &segs, 2.0, &[(1, Act::Feed(2.0))]);
    check_limits(&cfg, &fast);
    assert!(fast.len() < plain.len(), "faster");
    let top = speeds(&fast).into_iter().fold(0.0, f64::max);
    assert!(top <= cfg.axes[0].max_velocity * (1.0 + 1e-9), "{top}");
    let back = run_with(&cfg, start, &segs, 1.5, &[(1, Act::Feed(1.0))]);
    let mid = back[back.len() / 2].path_velocity;
    assert!(
        (mid - 150.0).abs() < 0.15,
        "150 mm/s as programmed, got {mid}"
    );
}

fn tap_segs(z0: f64, depth: f64, pitch: f64, rpm: f64) -> Vec<Segment> {
    let tap = |end, line| {
        seg(
            SegmentKind::Tap(TapSegment {
                end,
                feed: rpm * pitch,
                tool: 2,
                spindle: 3,
                pitch,
            }),
            line,
        )
    };
    vec![
        tap(xyzc(0.0, 0.0, z0 - depth, depth / pitch * 360.0), 10),
        tap(xyzc(0.0, 0.0, z0, 0.0), 11),
    ]
}

/// Fanuc: feed hold and feed override do not act in a rigid tap (the hold takes effect
/// after the return to R). The tap runs tick for tick as without them, Z and C within one
/// count of the thread.
#[test]
fn a_rigid_tap_is_neither_held_nor_overridden() {
    let cfg = MachineConfig::default_machine();
    let (z0, pitch) = (2.0, 1.5);
    let segs = tap_segs(z0, 20.0, pitch, 1200.0);
    let start = xyzc(0.0, 0.0, z0, 0.0);
    let plain = run_with(&cfg, start, &segs, 1.0, &[]);
    let cases: [(f64, &[(usize, Act)]); 3] = [
        (1.0, &[(300, Act::Hold(true)), (2000, Act::Hold(false))]),
        (1.0, &[(1, Act::Feed(0.5)), (400, Act::Feed(0.0))]),
        (2.0, &[(1, Act::Feed(2.0))]),
    ];
    for (scale, acts) in cases {
        let t = run_with(&cfg, start, &segs, scale, acts);
        check_limits(&cfg, &t);
        let n = plain.len().min(t.len());
        assert!(
            plain[..n].iter().zip(&t[..n]).all(|(a, b)| a.pos == b.pos),
            "{acts:?}: the tap as without them"
        );
        for tk in &t {
            let (z, c) = (tk.pos.0[2], tk.pos.0[3]);
            let dz = ((z - (z0 - c * pitch / 360.0)) * 10000.0).abs();
            assert!(dz <= 1.0, "{acts:?}: {dz} counts off the thread");
        }
    }
}

/// The spindle override ramps a turning spindle to S × override within its limits, clamped
/// to 50–120 %.
#[test]
fn spindle_override_ramps_the_speed() {
    let cfg = MachineConfig::default_machine();
    let start = xyzc(0.0, 0.0, 0.0, 0.0);
    let segs = vec![
        seg(
            SegmentKind::Spindle {
                rpm: 3000.0,
                dir: SpindleDir::Cw,
                spindle: 1,
            },
            1,
        ),
        lin(xyzc(100.0, 0.0, 0.0, 0.0), 1200.0, 2),
    ];
    let acts = [(1000, Act::Spindle(1.2)), (2500, Act::Spindle(0.3))];
    let t = run_with(&cfg, start, &segs, 1.0, &acts);
    check_limits(&cfg, &t);
    let rps = |k: usize| t[k].spindle_velocity[0] / 360.0 * 60.0;
    assert!((rps(900) - 3000.0).abs() < 1e-6, "{}", rps(900));
    assert!((rps(2400) - 3600.0).abs() < 1e-6, "{}", rps(2400));
    assert!(
        (rps(4000) - 1500.0).abs() < 1e-6,
        "clamped to 50 %: {}",
        rps(4000)
    );
}

/// Rapids ignore the feed override and follow the rapid override (25 %: a quarter of the
/// speed), within every limit and to the same end.
#[test]
fn rapids_follow_the_rapid_override_not_the_feed_override() {
    let cfg = MachineConfig::default_machine();
    let start = xyzc(0.0, 0.0, 0.0, 0.0);
    let segs = vec![rapid(xyzc(150.0, 60.0, -20.0, 0.0), 1)];
    let plain = run_with(&cfg, start, &segs, 1.0, &[]);
    let feed = run_with(&cfg, start, &segs, 1.0, &[(1, Act::Feed(0.3))]);
    assert_eq!(feed.len(), plain.len(), "feed override leaves rapids alone");
    let slow = run_with(&cfg, start, &segs, 1.0, &[(1, Act::Rapid(0.25))]);
    check_limits(&cfg, &slow);
    assert_eq!(slow.last().unwrap().pos, plain.last().unwrap().pos);
    let top = |t: &[Tick]| speeds(t).into_iter().fold(0.0, f64::max);
    let ratio = top(&slow) / top(&plain);
    assert!((ratio - 0.25).abs() < 1e-9, "{ratio}");
}
