//! Continuous-path motion on the trace: programs of `Continuous` segments run through the
//! lookahead and the interpolator, and every tick is checked — each axis within its velocity
//! and acceleration limit (sampled: first and second differences of the setpoints), every
//! sample on the programmed path (within P), the run ending exactly on the programmed end,
//! and the program running at its feed.

mod common;

use std::collections::VecDeque;

use cnc402_config::MachineConfig;
use cnc402_motion::*;
use common::*;

fn cont(kind: SegmentKind, line: u32, tolerance: f64) -> Segment {
    Segment {
        kind,
        source: src(line),
        ends: SegmentEnd::Continuous {
            tolerance,
            collinear: 0.0,
        },
    }
}

fn feed_to(end: AxisPos, feed: f64, line: u32) -> Segment {
    cont(SegmentKind::Linear { end, feed }, line, 0.01)
}

/// What a blended run gave: every tick (tick 0 the start) and the moves run.
struct Run {
    ticks: Vec<Tick>,
    moves: Vec<PlannedMove>,
    infeasible: u64,
}

/// Plans `segs` with a window of `window` segments and runs them the way the controller
/// does: before each tick, moves are started while the interpolator is idle.
fn run_blended(cfg: &MachineConfig, start: AxisPos, segs: &[Segment], window: usize) -> Run {
    let mut la = Lookahead::new(cfg, window);
    la.planner_mut().set_position(start);
    let mut queue = VecDeque::new();
    for s in segs {
        la.push(s).expect("plans");
        assert!(la.pending() <= window, "the window stays bounded");
        while let Some(m) = la.pop() {
            queue.push_back(m);
        }
    }
    la.finish().expect("finishes");
    while let Some(m) = la.pop() {
        queue.push_back(m);
    }
    let moves: Vec<PlannedMove> = queue.iter().copied().collect();
    let mut ip = Interpolator::new(cfg, start);
    let mut ticks = vec![idle_tick(&ip, 0)];
    loop {
        while ip.is_idle() {
            match queue.pop_front() {
                Some(m) => ip.start(m).expect("starts"),
                None => break,
            }
        }
        if ip.is_idle() && queue.is_empty() {
            break;
        }
        ticks.push(ip.tick());
        assert!(ticks.len() < 20_000_000, "runaway");
    }
    assert_eq!(ip.starved_at_speed(), 0);
    Run {
        ticks,
        moves,
        infeasible: la.infeasible_junctions(),
    }
}

/// Every axis within its velocity and acceleration limit on every tick (sampled, up to
/// float rounding).
fn check_limits(cfg: &MachineConfig, ticks: &[Tick]) {
    let p = cfg.bus.period_s();
    for (i, ax) in cfg.axes.iter().enumerate().take(3) {
        let x: Vec<f64> = ticks.iter().map(|t| t.pos.0[i]).collect();
        let eps = |m: f64| 256.0 * f64::EPSILON * (m.abs() + 1.0);
        for k in 1..x.len() {
            let v = (x[k] - x[k - 1]) / p;
            assert!(
                v.abs() <= ax.max_velocity * (1.0 + 1e-9) + eps(x[k]) / p,
                "{} velocity {v} at tick {k}",
                ax.name
            );
            if k + 1 < x.len() {
                let a = (x[k + 1] - 2.0 * x[k] + x[k - 1]) / (p * p);
                assert!(
                    a.abs() <= ax.max_acceleration * (1.0 + 1e-9) + 4.0 * eps(x[k]) / (p * p),
                    "{} acceleration {a} (limit {}) at tick {k}, line {}",
                    ax.name,
                    ax.max_acceleration,
                    ticks[k].line
                );
            }
        }
    }
}

/// Distance from `q` to the straight segment a–b (X Y Z).
fn dist_to_segment(q: &AxisPos, a: &AxisPos, b: &AxisPos) -> f64 {
    let d: Vec<f64> = (0..3).map(|i| b.0[i] - a.0[i]).collect();
    let w: Vec<f64> = (0..3).map(|i| q.0[i] - a.0[i]).collect();
    let dd: f64 = d.iter().map(|x| x * x).sum();
    let t = if dd > 0.0 {
        (w.iter().zip(&d).map(|(x, y)| x * y).sum::<f64>() / dd).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (0..3)
        .map(|i| (w[i] - t * d[i]).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Every sample within `tol` of the programmed polyline `pts` (segment k from pts[k] to
/// pts[k + 1] is program line k + 1): checked against the segment of the tick's line and its
/// neighbours.
fn check_on_polyline(ticks: &[Tick], pts: &[AxisPos], tol: f64) -> f64 {
    let mut worst: f64 = 0.0;
    for t in &ticks[1..] {
        let l = t.line as usize;
        let mut best = f64::INFINITY;
        for k in l.saturating_sub(2)..(l + 1).min(pts.len() - 1) {
            best = best.min(dist_to_segment(&t.pos, &pts[k], &pts[k + 1]));
        }
        worst = worst.max(best);
    }
    assert!(worst <= tol, "path deviation {worst} > {tol}");
    worst
}

fn polyline(pts: &[AxisPos], feed: f64, tol: f64) -> Vec<Segment> {
    pts[1..]
        .iter()
        .enumerate()
        .map(|(i, p)| cont(SegmentKind::Linear { end: *p, feed }, i as u32 + 1, tol))
        .collect()
}

fn path_length(pts: &[AxisPos]) -> f64 {
    pts.windows(2)
        .map(|w| dist_to_segment(&w[1], &w[0], &w[0]))
        .sum()
}

fn circle_points(n: usize, r: f64, step: f64) -> Vec<AxisPos> {
    (0..=n)
        .map(|i| {
            let a = i as f64 * step / r;
            xyzc(r * a.cos(), r * a.sin(), 0.0, 0.0)
        })
        .collect()
}

#[test]
fn fine_segment_circle_runs_at_the_feed_within_limits() {
    let cfg = MachineConfig::default_machine();
    let pts = circle_points(20_000, 10.0, 0.01);
    let segs = polyline(&pts, 3000.0, 0.01);
    let run = run_blended(&cfg, pts[0], &segs, 1000);
    check_limits(&cfg, &run.ticks);
    check_on_polyline(&run.ticks, &pts, 1e-9);
    assert_eq!(
        run.ticks.last().unwrap().pos,
        *pts.last().unwrap(),
        "exact end"
    );
    assert_eq!(run.infeasible, 0);
    let secs = (run.ticks.len() - 1) as f64 * cfg.bus.period_s();
    let feed_only = path_length(&pts) / 50.0;
    assert!(
        secs < feed_only * 1.10,
        "{secs} s against {feed_only} s at the feed"
    );
    // Exactly the programmed feed in the middle.
    let mid = &run.ticks[run.ticks.len() / 2];
    assert!(
        (mid.path_velocity - 50.0).abs() < 1e-6,
        "{}",
        mid.path_velocity
    );
}

#[test]
fn cam_like_3d_path_stays_within_limits_and_on_the_path() {
    let cfg = MachineConfig::default_machine();
    let mut pts = vec![xyzc(0.0, 0.0, 0.0, 0.0)];
    for row in 0..6 {
        let y = row as f64 * 0.5;
        for i in 0..=250 {
            let i = if row % 2 == 0 { i } else { 250 - i };
            let x = i as f64 * 0.2;
            let z = 2.0 * (x / 10.0).sin() * (y / 7.0).cos();
            pts.push(xyzc(x, y, z, 0.0));
        }
    }
    let segs = polyline(&pts, 6000.0, 0.01);
    let run = run_blended(&cfg, pts[0], &segs, 500);
    check_limits(&cfg, &run.ticks);
    check_on_polyline(&run.ticks, &pts, 1e-9);
    assert_eq!(run.ticks.last().unwrap().pos, *pts.last().unwrap());
    assert_eq!(run.infeasible, 0);
}

#[test]
fn sharp_corner_pocket_under_g64_p001() {
    let cfg = MachineConfig::default_machine();
    let mut pts = vec![xyzc(0.0, 0.0, 0.0, 0.0)];
    for k in 0..5 {
        let (a, h) = (k as f64, 40.0 - 2.0 * k as f64);
        for (x, y) in [(a, a), (a + h, a), (a + h, a + h), (a, a + h), (a, a)] {
            pts.push(xyzc(x, y, 0.0, 0.0));
        }
    }
    let segs = polyline(&pts, 3000.0, 0.01);
    let run = run_blended(&cfg, pts[0], &segs, 100);
    check_limits(&cfg, &run.ticks);
    check_on_polyline(&run.ticks, &pts, 0.01);
    assert_eq!(run.ticks.last().unwrap().pos, *pts.last().unwrap());
    // No stop at the corners: blended corners take less time than exact stops.
    let exact: Vec<Segment> = segs
        .iter()
        .cloned()
        .map(|mut s| {
            s.ends = SegmentEnd::ExactStop;
            s
        })
        .collect();
    let stopped = common::run(&cfg, pts[0], &exact);
    assert!(
        run.ticks.len() < stopped.len(),
        "{} vs {}",
        run.ticks.len(),
        stopped.len()
    );
}

#[test]
fn nearly_collinear_run_passes_at_full_feed() {
    let cfg = MachineConfig::default_machine();
    // 200 blocks of 0.5 mm along X, every other vertex 0.5 µm off the line (a CAM
    // program's rounding to three decimals).
    let pts: Vec<AxisPos> = (0..=200)
        .map(|i| {
            xyzc(
                i as f64 * 0.5,
                if i % 2 == 0 { 0.0 } else { 0.0005 },
                0.0,
                0.0,
            )
        })
        .collect();
    let segs = polyline(&pts, 3000.0, 0.01);
    let run = run_blended(&cfg, pts[0], &segs, 100);
    check_limits(&cfg, &run.ticks);
    let top = run
        .ticks
        .iter()
        .map(|t| t.path_velocity)
        .fold(0.0, f64::max);
    assert!((top - 50.0).abs() < 1e-6, "top speed {top}");
    // A 100 mm line alone at the feed, exact stop at its end: the run is no slower.
    let one = run_blended(&cfg, pts[0], &[lin(*pts.last().unwrap(), 3000.0, 1)], 100);
    assert!(
        run.ticks.len() as f64 <= one.ticks.len() as f64 * 1.01,
        "{} ticks vs {}",
        run.ticks.len(),
        one.ticks.len()
    );
}

#[test]
fn lookahead_never_plans_a_speed_it_cannot_stop_from_within_the_window() {
    let cfg = MachineConfig::default_machine();
    // A long straight run cut into short blocks, and a window far shorter than the braking
    // distance at the feed: the speed stays where the window can still stop.
    let pts: Vec<AxisPos> = (0..=400)
        .map(|i| xyzc(i as f64 * 0.05, 0.0, 0.0, 0.0))
        .collect();
    let segs = polyline(&pts, 12000.0, 0.01);
    for window in [2, 8, 40] {
        let mut la = Lookahead::new(&cfg, window);
        la.planner_mut().set_position(pts[0]);
        let mut given = Vec::new();
        for s in &segs {
            la.push(s).unwrap();
            while let Some(m) = la.pop() {
                given.push(m);
            }
            // What is held: every move given out can still stop within it.
            let held: f64 = segs.len() as f64; // upper bound only used for the message
            if let Some(MoveKind::Path(p)) = given.last().map(|m| m.kind) {
                let room = la.pending() as f64 * 0.05;
                let lim = p.limits;
                let need = stop_distance(p.end_speed, lim);
                assert!(
                    need <= room * (1.0 + 1e-9) + 1e-12,
                    "window {window}: {need} mm to stop, {room} mm held ({held})"
                );
            }
        }
        la.finish().unwrap();
        while let Some(m) = la.pop() {
            given.push(m);
        }
        let MoveKind::Path(last) = given.last().unwrap().kind else {
            panic!()
        };
        assert_eq!(last.end_speed, 0.0, "the program ends at rest");
        assert_eq!(last.end, *pts.last().unwrap());
    }
    // And the run itself, ending abruptly after the last block, is within the limits.
    let run = run_blended(&cfg, pts[0], &segs, 8);
    check_limits(&cfg, &run.ticks);
    assert_eq!(run.ticks.last().unwrap().pos, *pts.last().unwrap());
}

/// Distance a jerk-limited ramp from `v` (a = 0) to rest needs.
fn stop_distance(v: f64, lim: Limits) -> f64 {
    let (a, j) = (lim.acceleration, lim.jerk);
    let t = if v * j >= a * a {
        v / a + a / j
    } else {
        2.0 * (v / j).sqrt()
    };
    0.5 * v * t
}

#[test]
fn exact_stop_segments_run_exactly_as_without_lookahead() {
    let cfg = MachineConfig::default_machine();
    let segs = vec![
        rapid(xyzc(10.0, 5.0, 2.0, 0.0), 1),
        lin(xyzc(20.0, 5.0, 0.0, 0.0), 1200.0, 2),
        lin(xyzc(20.0, 15.0, -1.0, 0.0), 900.0, 3),
    ];
    let plain = common::run(&cfg, AxisPos::default(), &segs);
    let blended = run_blended(&cfg, AxisPos::default(), &segs, 50);
    assert_eq!(plain.len(), blended.ticks.len());
    for (a, b) in plain.iter().zip(&blended.ticks) {
        assert_eq!(a.pos, b.pos);
    }
    assert_eq!(blended.moves.len(), 3);
}

#[test]
fn arcs_blend_tangentially_within_limits() {
    let cfg = MachineConfig::default_machine();
    // A slot: line, half circle, line back, half circle, all tangent.
    let arc = |end: AxisPos, c: [f64; 3], line| {
        cont(
            SegmentKind::Arc {
                end,
                center: c,
                plane: Plane::XY,
                dir: ArcDir::Ccw,
                turns: 0,
                feed: 3000.0,
            },
            line,
            0.01,
        )
    };
    let segs = vec![
        feed_to(xyzc(30.0, 0.0, 0.0, 0.0), 3000.0, 1),
        arc(xyzc(30.0, 10.0, 0.0, 0.0), [30.0, 5.0, 0.0], 2),
        feed_to(xyzc(0.0, 10.0, 0.0, 0.0), 3000.0, 3),
        arc(xyzc(0.0, 0.0, 0.0, 0.0), [0.0, 5.0, 0.0], 4),
    ];
    let run = run_blended(&cfg, AxisPos::default(), &segs, 20);
    check_limits(&cfg, &run.ticks);
    assert_eq!(run.ticks.last().unwrap().pos, AxisPos::default());
    // Tangent junctions pass without slowing below the arcs' own speed bound.
    let slowest_inside = run.ticks[run.ticks.len() / 4..3 * run.ticks.len() / 4]
        .iter()
        .map(|t| t.path_velocity)
        .fold(f64::INFINITY, f64::min);
    assert!(slowest_inside > 40.0, "{slowest_inside}");
}

/// CAM output rounds coordinates (here to 0.1 µm, four decimals): on 0.01 mm blocks that
/// turns each junction by up to 0.01 rad at random. The samples average the noise out, and
/// the planner judges junctions by the samples, so the circle still runs at the feed.
#[test]
fn rounded_fine_circle_runs_at_the_feed_within_limits() {
    let cfg = MachineConfig::default_machine();
    let round = |x: f64| (x * 1e4).round() / 1e4;
    let pts: Vec<AxisPos> = circle_points(20_000, 10.0, 0.01)
        .iter()
        .map(|p| xyzc(round(p.0[0]), round(p.0[1]), 0.0, 0.0))
        .collect();
    let segs = polyline(&pts, 3000.0, 0.01);
    let run = run_blended(&cfg, pts[0], &segs, 2000);
    check_limits(&cfg, &run.ticks);
    check_on_polyline(&run.ticks, &pts, 1e-9);
    assert_eq!(run.ticks.last().unwrap().pos, *pts.last().unwrap());
    let secs = (run.ticks.len() - 1) as f64 * cfg.bus.period_s();
    let feed_only = path_length(&pts) / 50.0;
    assert!(
        secs < feed_only * 1.10,
        "{secs} s against {feed_only} s at the feed"
    );
}

/// A zigzag of 2 µm on 0.5 mm blocks: the samples see it, so the speed stays where every
/// axis's acceleration holds — and close to the feed.
#[test]
fn zigzag_within_microns_stays_within_limits_near_the_feed() {
    let cfg = MachineConfig::default_machine();
    let pts: Vec<AxisPos> = (0..=200)
        .map(|i| {
            xyzc(
                i as f64 * 0.5,
                if i % 2 == 0 { 0.0 } else { 0.002 },
                0.0,
                0.0,
            )
        })
        .collect();
    let run = run_blended(&cfg, pts[0], &polyline(&pts, 3000.0, 0.01), 100);
    check_limits(&cfg, &run.ticks);
    let top = run
        .ticks
        .iter()
        .map(|t| t.path_velocity)
        .fold(0.0, f64::max);
    assert!(top > 40.0, "top speed {top}");
}

/// The benchmark's surface raster (rows of 501 points, 0.5 mm apart, turning at the ends):
/// every tick within the limits (regression: a velocity jump of 30 mm/s at a turnaround).
#[test]
fn surface_raster_with_turnarounds_stays_within_limits() {
    let cfg = MachineConfig::default_machine();
    let mut pts = vec![xyzc(0.0, 0.0, 0.0, 0.0)];
    // Thirty rows: the eleventh turnaround once met a cut whose lengths, summed again, were
    // an ulp short of the braking distance, and the fallback picked a speed 30 mm/s off.
    for row in 0..30 {
        let y = row as f64 * 0.5;
        for i in 0..=500 {
            let i = if row % 2 == 0 { i } else { 500 - i };
            let x = i as f64 * 0.2;
            pts.push(xyzc(x, y, 2.0 * (x / 10.0).sin() * (y / 7.0).cos(), 0.0));
        }
    }
    pts.dedup();
    let run = run_blended(
        &cfg,
        pts[0],
        &polyline(&pts, 6000.0, 0.01),
        cfg.planner.lookahead,
    );
    check_limits(&cfg, &run.ticks);
    check_on_polyline(&run.ticks, &pts, 1e-9);
    assert_eq!(run.infeasible, 0);
}

/// Runs `segs` blended and requests a stop at tick `stop_at`; the ticks until held.
fn run_stopping(
    cfg: &MachineConfig,
    start: AxisPos,
    segs: &[Segment],
    stop_at: usize,
) -> Vec<Tick> {
    let mut la = Lookahead::new(cfg, 1000);
    la.planner_mut().set_position(start);
    let mut queue = VecDeque::new();
    for s in segs {
        la.push(s).unwrap();
    }
    la.finish().unwrap();
    while let Some(m) = la.pop() {
        queue.push_back(m);
    }
    let mut ip = Interpolator::new(cfg, start);
    let mut ticks = vec![idle_tick(&ip, 0)];
    for k in 0..200_000 {
        if k == stop_at {
            ip.request_stop();
        }
        while ip.is_idle() || ip.wants_next_move() {
            match queue.pop_front() {
                Some(m) => ip.start(m).expect("starts"),
                None => break,
            }
        }
        ticks.push(ip.tick());
        if ip.is_held() || (ip.is_idle() && queue.is_empty()) {
            break;
        }
    }
    assert_eq!(ip.starved_at_speed(), 0, "stop at {stop_at}");
    ticks
}

/// Stops requested at every few ticks through a raster turnaround (braking, the corner,
/// speeding up again) all stay within the limits and on the path.
#[test]
fn stops_requested_anywhere_around_a_turnaround_stay_within_limits() {
    let cfg = MachineConfig::default_machine();
    let mut pts = vec![xyzc(0.0, 0.0, 0.0, 0.0)];
    for row in 0..2 {
        for i in 1..=100 {
            let i = if row % 2 == 0 { i } else { 100 - i };
            pts.push(xyzc(i as f64 * 0.2, row as f64 * 0.5, 0.0, 0.0));
        }
    }
    let segs = polyline(&pts, 6000.0, 0.01);
    let whole = run_blended(&cfg, pts[0], &segs, 1000).ticks.len();
    for stop_at in (5..whole).step_by(3) {
        let ticks = run_stopping(&cfg, pts[0], &segs, stop_at);
        check_limits(&cfg, &ticks);
        check_on_polyline(&ticks, &pts, 1e-9);
    }
}

/// A stop requested in the middle of fine blended blocks decelerates along the path across
/// the blocks that follow (the stop ramp is handed from move to move), within the limits,
/// and comes to rest on the path.
#[test]
fn stop_along_blended_moves_decelerates_across_moves_within_limits() {
    let cfg = MachineConfig::default_machine();
    let pts = circle_points(5_000, 10.0, 0.01);
    let segs = polyline(&pts, 3000.0, 0.01);
    let mut la = Lookahead::new(&cfg, 1000);
    la.planner_mut().set_position(pts[0]);
    let mut queue = VecDeque::new();
    for s in &segs {
        la.push(s).unwrap();
    }
    la.finish().unwrap();
    while let Some(m) = la.pop() {
        queue.push_back(m);
    }
    let mut ip = Interpolator::new(&cfg, pts[0]);
    let mut ticks = vec![idle_tick(&ip, 0)];
    for k in 0..20_000 {
        if k == 400 {
            ip.request_stop();
        }
        while ip.is_idle() || ip.wants_next_move() {
            match queue.pop_front() {
                Some(m) => ip.start(m).expect("starts"),
                None => break,
            }
        }
        ticks.push(ip.tick());
        if ip.is_held() {
            break;
        }
    }
    assert!(ip.is_held(), "came to rest");
    assert_eq!(ip.starved_at_speed(), 0);
    check_limits(&cfg, &ticks);
    check_on_polyline(&ticks, &pts, 1e-9);
    let moving_at_request = ticks[400].path_velocity;
    assert!((moving_at_request - 50.0).abs() < 1e-6);
    assert_eq!(ticks.last().unwrap().path_velocity, 0.0);
    // It stopped well before the end of the program.
    assert!(ticks.len() < 600, "{}", ticks.len());
}

/// `G64 P… Q…`: the same polyline with collinearity tolerance `q` (LinuxCNC's naive CAM).
fn polyline_q(pts: &[AxisPos], feed: f64, tol: f64, q: f64) -> Vec<Segment> {
    let mut segs = polyline(pts, feed, tol);
    for s in &mut segs {
        s.ends = SegmentEnd::Continuous {
            tolerance: tol,
            collinear: q,
        };
    }
    segs
}

/// Every sample within `tol` of the programmed polyline `pts`, searching the blocks a merged
/// move can stand for (a merged move carries its last block's line).
fn check_near_polyline(ticks: &[Tick], pts: &[AxisPos], tol: f64) -> f64 {
    let mut worst: f64 = 0.0;
    for t in &ticks[1..] {
        let l = t.line as usize;
        let from = l.saturating_sub(cnc402_motion::collinear::MAX_CHAIN + 2);
        let best = (from..(l + 1).min(pts.len() - 1))
            .map(|k| dist_to_segment(&t.pos, &pts[k], &pts[k + 1]))
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(best);
    }
    assert!(worst <= tol, "path deviation {worst} > {tol}");
    worst
}

#[test]
fn g64_q_merges_noisy_collinear_cam_steps_into_few_moves() {
    let cfg = MachineConfig::default_machine();
    // 1000 blocks of 0.1 mm along X, each vertex up to 3 µm off the line (CAM noise).
    let pts: Vec<AxisPos> = (0..=1000)
        .map(|i| {
            let noise = 0.003 * ((i * 7919) % 13) as f64 / 12.0 - 0.0015;
            xyzc(
                i as f64 * 0.1,
                if i == 0 || i == 1000 { 0.0 } else { noise },
                0.0,
                0.0,
            )
        })
        .collect();
    let segs = polyline_q(&pts, 3000.0, 0.01, 0.01);
    let run = run_blended(&cfg, pts[0], &segs, 200);
    assert!(
        run.moves.len() <= 11,
        "{} moves for 1000 blocks: at most 100 blocks a move",
        run.moves.len()
    );
    check_limits(&cfg, &run.ticks);
    let dev = check_near_polyline(&run.ticks, &pts, 0.01);
    assert!(dev > 0.0, "merging moved the path off the noisy vertices");
    assert_eq!(
        run.ticks.last().unwrap().pos,
        *pts.last().unwrap(),
        "exact end"
    );
    let secs = (run.ticks.len() - 1) as f64 * cfg.bus.period_s();
    assert!(secs < 100.0 / 50.0 * 1.10, "{secs} s for 100 mm at 50 mm/s");
    // The same program with Q = 0 merges nothing.
    let plain = run_blended(&cfg, pts[0], &polyline_q(&pts, 3000.0, 0.01, 0.0), 200);
    assert_eq!(plain.moves.len(), 1000);
}

#[test]
fn g64_q_never_merges_across_a_corner_beyond_q() {
    let cfg = MachineConfig::default_machine();
    let mut pts = vec![xyzc(0.0, 0.0, 0.0, 0.0)];
    for (x, y) in [(20.0, 0.0), (20.0, 20.0), (0.0, 20.0), (0.0, 0.0)] {
        pts.push(xyzc(x, y, 0.0, 0.0));
    }
    let with_q = run_blended(&cfg, pts[0], &polyline_q(&pts, 3000.0, 0.01, 0.01), 100);
    let without = run_blended(&cfg, pts[0], &polyline_q(&pts, 3000.0, 0.01, 0.0), 100);
    let kinds = |r: &Run| r.moves.iter().map(|m| m.kind).collect::<Vec<_>>();
    assert_eq!(
        kinds(&with_q),
        kinds(&without),
        "90° corners are never merged"
    );
}

/// Merging a curve's fine blocks into chords stays within Q and every limit, but the chords
/// meet at sharper corners (about 5° for r 10 mm, Q 0.01 mm), which this planner takes
/// slower: why `G64 P` alone does not merge in cnc402 (README "Continuous path").
#[test]
fn fine_circle_under_g64_q_stays_within_q_and_the_limits() {
    let cfg = MachineConfig::default_machine();
    let pts = circle_points(6_000, 10.0, 0.01);
    let segs = polyline_q(&pts, 3000.0, 0.01, 0.01);
    let run = run_blended(&cfg, pts[0], &segs, 1000);
    // Chords within 0.01 mm of a 10 mm radius span about 0.9 mm: about 90 blocks a move.
    assert!(run.moves.len() < 6_000 / 50, "{} moves", run.moves.len());
    check_limits(&cfg, &run.ticks);
    check_near_polyline(&run.ticks, &pts, 0.01);
    assert_eq!(run.ticks.last().unwrap().pos, *pts.last().unwrap());
    let secs = (run.ticks.len() - 1) as f64 * cfg.bus.period_s();
    let feed_only = path_length(&pts) / 50.0;
    println!("fine circle under G64 P0.01 Q0.01: {secs} s against {feed_only} s at the feed");
}
