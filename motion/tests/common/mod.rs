//! Helpers shared by the motion integration tests: segment builders and a runner that feeds
//! planned moves to the interpolator and records every tick.
#![allow(dead_code)]

use std::sync::Arc;

use cnc402_config::MachineConfig;
use cnc402_motion::*;

pub fn src(line: u32) -> Source {
    Source {
        file: Arc::from("test.nc"),
        line,
        n: None,
    }
}

pub fn seg(kind: SegmentKind, line: u32) -> Segment {
    Segment {
        kind,
        source: src(line),
        ends: SegmentEnd::ExactStop,
    }
}

/// X Y Z C positions (default machine order).
pub fn xyzc(x: f64, y: f64, z: f64, c: f64) -> AxisPos {
    let mut p = AxisPos::default();
    p.0[0] = x;
    p.0[1] = y;
    p.0[2] = z;
    p.0[3] = c;
    p
}

pub fn lin(end: AxisPos, feed: f64, line: u32) -> Segment {
    seg(SegmentKind::Linear { end, feed }, line)
}

pub fn rapid(end: AxisPos, line: u32) -> Segment {
    seg(SegmentKind::Rapid { end }, line)
}

/// Plans and runs every segment, returning all ticks (including the start as tick 0, with
/// line 0 and state Idle). Panics (in tests only) on a planning error.
/// The tick an interpolator at rest would give: where it stands, at `line`, nothing moving
/// (the first entry of a recorded run, so that differences start from rest).
pub fn idle_tick(ip: &Interpolator, line: u32) -> Tick {
    Tick {
        pos: ip.position(),
        line,
        n: None,
        state: TickState::Idle,
        finished: false,
        event: None,
        path_velocity: 0.0,
        spindle_velocity: [0.0; 2],
    }
}

pub fn run(cfg: &MachineConfig, start: AxisPos, segs: &[Segment]) -> Vec<Tick> {
    let mut planner = Planner::new(cfg);
    planner.set_position(start);
    let mut ip = Interpolator::new(cfg, start);
    let mut out = Vec::new();
    out.push(idle_tick(&ip, 0));
    for s in segs {
        let mv = planner.plan(s).expect("plans");
        ip.start(mv).expect("starts");
        loop {
            let t = ip.tick();
            out.push(t);
            if t.finished {
                break;
            }
            assert!(out.len() < 50_000_000, "runaway");
        }
    }
    out
}

/// Checks, by finite differences of the commanded positions, that every configured axis stays
/// within its velocity, acceleration and jerk limits.
///
/// Tolerance: sampled values carry rounding of a few ulp of |x|, amplified by 2^n / P^n in the
/// n-th difference; we allow 2^n · 64 · ε · (max|x| + 1) / P^n plus 1e-9 relative. No other
/// allowance is needed: the n-th difference quotient of a C² piecewise cubic is an average of
/// its n-th derivative (B-spline kernel), so it never exceeds the continuous bound.
pub fn check_limits(cfg: &MachineConfig, ticks: &[Tick]) {
    let p = cfg.bus.period_s();
    for (i, ax) in cfg.axes.iter().enumerate() {
        let x: Vec<f64> = ticks.iter().map(|t| t.pos.0[i]).collect();
        let xmax = x.iter().fold(0.0f64, |m, v| m.max(v.abs())) + 1.0;
        let tol = |n: i32| 2f64.powi(n) * 64.0 * f64::EPSILON * xmax / p.powi(n);
        let lims = [ax.max_velocity, ax.max_acceleration, ax.max_jerk];
        let mut d = x.clone();
        for (n, lim) in lims.iter().enumerate() {
            d = d.windows(2).map(|w| (w[1] - w[0]) / p).collect();
            let allowed = lim * (1.0 + 1e-9) + tol(n as i32 + 1);
            for (k, v) in d.iter().enumerate() {
                assert!(
                    v.abs() <= allowed,
                    "axis {} derivative {} = {} > {} at tick {} (line {})",
                    ax.name,
                    n + 1,
                    v,
                    allowed,
                    k,
                    ticks[k + 1].line
                );
            }
        }
    }
}
