//! Continuous-path benchmark: three G64 programs run through the lookahead and the 1 ms
//! interpolator, their program time printed against the time the machine's limits allow.
//! Run: `cargo bench -p cnc402-motion --bench continuous`.
//!
//! The bound: the path is cut at every junction where a circular blend staying within P
//! (grbl's junction deviation, with the smallest full acceleration of the axes that move)
//! must be slower than the feed; each stretch between such corners is one time-optimal
//! jerk-limited double-S (Biagiotti–Melchiorri §3.4) from corner speed to corner speed at
//! the feed, with the axes' full velocity, acceleration and jerk projected on the stretch's
//! steepest direction. The time inside the blends and the curvature of fine polylines are
//! not counted, so no planner that keeps the limits and stays within P can do much better.

use std::time::Instant;

use cnc402_config::MachineConfig;
use cnc402_motion::profile::double_s;
use cnc402_motion::*;

fn src(line: u32) -> Source {
    Source {
        file: "bench.nc".into(),
        line,
        n: None,
    }
}

fn xyz(x: f64, y: f64, z: f64) -> AxisPos {
    let mut p = AxisPos::default();
    p.0[..3].copy_from_slice(&[x, y, z]);
    p
}

fn polyline(pts: &[AxisPos], feed: f64, tol: f64) -> Vec<Segment> {
    pts[1..]
        .iter()
        .enumerate()
        .map(|(i, p)| Segment {
            kind: SegmentKind::Linear { end: *p, feed },
            source: src(i as u32 + 1),
            ends: SegmentEnd::Continuous {
                tolerance: tol,
                collinear: 0.0,
            },
        })
        .collect()
}

/// Program time (s) of `segs` from `start`: lookahead of the configured window + interpolator.
fn program_time(cfg: &MachineConfig, start: AxisPos, segs: &[Segment]) -> (f64, u64) {
    let mut la = Lookahead::new(cfg, cfg.planner.lookahead);
    la.planner_mut().set_position(start);
    let mut ip = Interpolator::new(cfg, start);
    let mut queue = std::collections::VecDeque::new();
    let mut ticks = 0u64;
    let mut it = segs.iter();
    let mut done = false;
    loop {
        while queue.len() < 64 && !done {
            match it.next() {
                Some(s) => la.push(s).expect("plans"),
                None => {
                    la.finish().expect("finishes");
                    done = true;
                }
            }
            while let Some(m) = la.pop() {
                queue.push_back(m);
            }
        }
        while ip.is_idle() {
            match queue.pop_front() {
                Some(m) => ip.start(m).expect("starts"),
                None => break,
            }
        }
        if ip.is_idle() && queue.is_empty() && done {
            break;
        }
        ip.tick();
        ticks += 1;
    }
    (ticks as f64 * cfg.bus.period_s(), la.infeasible_junctions())
}

/// The time the limits allow (see the module doc).
fn bound(cfg: &MachineConfig, pts: &[AxisPos], feed: f64, tol: f64) -> f64 {
    let axes: Vec<_> = cfg.axes.iter().take(3).collect();
    let dir = |a: &AxisPos, b: &AxisPos| {
        let l = (0..3)
            .map(|k| (b.0[k] - a.0[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        ((0..3).map(|k| (b.0[k] - a.0[k]) / l).collect::<Vec<_>>(), l)
    };
    let mut total = 0.0;
    let (mut len, mut v_in): (f64, f64) = (0.0, 0.0);
    let mut lim = Limits {
        velocity: feed / 60.0,
        acceleration: f64::INFINITY,
        jerk: f64::INFINITY,
    };
    for i in 1..pts.len() {
        let (u, l) = dir(&pts[i - 1], &pts[i]);
        len += l;
        for (k, ax) in axes.iter().enumerate() {
            let c = u[k].abs().max(1e-12);
            lim.velocity = lim.velocity.min(ax.max_velocity / c);
            lim.acceleration = lim.acceleration.min(ax.max_acceleration / c);
            lim.jerk = lim.jerk.min(ax.max_jerk / c);
        }
        let corner = if i + 1 < pts.len() {
            let (w, _) = dir(&pts[i], &pts[i + 1]);
            let cos = -(0..3).map(|k| u[k] * w[k]).sum::<f64>();
            let a = axes
                .iter()
                .map(|a| a.max_acceleration)
                .fold(f64::INFINITY, f64::min);
            if cos <= -0.999_999 {
                f64::INFINITY
            } else {
                let sh = (0.5 * (1.0 - cos)).sqrt();
                (a * tol * sh / (1.0 - sh)).sqrt()
            }
        } else {
            0.0
        };
        if corner < lim.velocity {
            let v_out = corner.min(lim.velocity);
            let p = double_s(len, v_in.min(lim.velocity), v_out, lim).expect("bound profile");
            total += p.duration();
            len = 0.0;
            v_in = v_out;
            lim = Limits {
                velocity: feed / 60.0,
                acceleration: f64::INFINITY,
                jerk: f64::INFINITY,
            };
        }
    }
    total
}

struct Case {
    name: &'static str,
    pts: Vec<AxisPos>,
    feed: f64,
    tol: f64,
}

fn cases() -> Vec<Case> {
    let circle: Vec<AxisPos> = (0..=100_000)
        .map(|i| {
            let a = i as f64 * 0.01 / 10.0;
            // Four decimals, as a CAM post writes them.
            let r = |x: f64| (x * 1e4).round() / 1e4;
            xyz(r(10.0 * a.cos()), r(10.0 * a.sin()), 0.0)
        })
        .collect();
    let mut surface = vec![xyz(0.0, 0.0, 0.0)];
    'rows: for row in 0.. {
        let y = row as f64 * 0.5;
        for i in 0..=500 {
            let i = if row % 2 == 0 { i } else { 500 - i };
            let x = i as f64 * 0.2;
            surface.push(xyz(x, y, 2.0 * (x / 10.0).sin() * (y / 7.0).cos()));
            if surface.len() > 50_000 {
                break 'rows;
            }
        }
    }
    let mut pocket = vec![xyz(0.0, 0.0, 0.0)];
    for k in 0..20 {
        let (a, h) = (k as f64, 40.0 - 2.0 * k as f64);
        for (x, y) in [(a, a), (a + h, a), (a + h, a + h), (a, a + h), (a, a)] {
            pocket.push(xyz(x, y, 0.0));
        }
    }
    pocket.dedup();
    vec![
        Case {
            name: "(a) fine circle: 100,000 blocks, r 10 mm, 0.01 mm, F3000",
            pts: circle,
            feed: 3000.0,
            tol: 0.01,
        },
        Case {
            name: "(b) 3D surface: 50,000 blocks of 0.2 mm, F6000",
            pts: surface,
            feed: 6000.0,
            tol: 0.01,
        },
        Case {
            name: "(c) pocket, 100 sharp corners, G64 P0.01, F3000",
            pts: pocket,
            feed: 3000.0,
            tol: 0.01,
        },
    ]
}

fn main() {
    let cfg = MachineConfig::default_machine();
    println!(
        "continuous path, lookahead {} segments, period {} ms",
        cfg.planner.lookahead,
        cfg.bus.period_s() * 1e3
    );
    println!(
        "{:<58} {:>10} {:>10} {:>10} {:>7} {:>9}",
        "program", "time s", "bound s", "feed s", "ratio", "plan+run"
    );
    for c in cases() {
        let segs = polyline(&c.pts, c.feed, c.tol);
        let wall = Instant::now();
        let (t, infeasible) = program_time(&cfg, c.pts[0], &segs);
        let wall = wall.elapsed().as_secs_f64();
        let b = bound(&cfg, &c.pts, c.feed, c.tol);
        let len: f64 = c
            .pts
            .windows(2)
            .map(|w| {
                (0..3)
                    .map(|k| (w[1].0[k] - w[0].0[k]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .sum();
        println!(
            "{:<58} {:>10.3} {:>10.3} {:>10.3} {:>6.3}× {:>8.2}s{}",
            c.name,
            t,
            b,
            len / (c.feed / 60.0),
            t / b,
            wall,
            if infeasible > 0 {
                format!("  ({infeasible} junctions adjusted)")
            } else {
                String::new()
            }
        );
    }
}
