//! The path figures of a run that the report gives beside the program time: the time the
//! feed alone would need, the largest distance of the commanded setpoints and of the actual
//! positions from the programmed path, and the exact stops (junctions where the path came to
//! rest). Kept by the 1 ms loop in fixed-size state: the last few moves and a few numbers, no
//! allocation.

use cnc402_motion::{Geometry, MAX_AXES, PathMove, TickState};

/// A path speed at or below this (path units/s) is at rest: an exact stop samples its end
/// at 0 up to rounding, a blended junction passes at a speed many orders above it.
const REST_SPEED: f64 = 1e-6;

/// Path moves the actual positions are measured against: the drives lag the setpoints by a
/// few cycles, which on fine segments is several moves (at 100 mm/s and a 6 ms lag, 12 moves
/// of 0.05 mm). An actual position lagging further is measured against the oldest kept, so
/// the figure errs on the large side.
pub const RECENT_MOVES: usize = 32;

/// Cycles of actual positions kept per axis to compare the axes at equal sample age (a late
/// TPDO leaves one axis's position a cycle older: at 100 mm/s that alone would read as tens
/// of µm off a circle).
const ACT_HISTORY: usize = 8;

/// See the module doc.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PathFigures {
    /// Σ length / velocity bound over the path moves started: the programmed feed (a
    /// rapid: the rapid rate), as the planner capped it by the axes' velocity limits along
    /// the move (and on arcs by the centripetal acceleration). Seconds.
    pub feed_time_s: f64,
    /// Largest distance over the linear axes of a commanded setpoint from the programmed
    /// segment it lies on (the move executing, or the one before it at a junction). mm.
    pub max_deviation: f64,
    /// The same for the drives' actual positions, against the nearest of the last
    /// [`RECENT_MOVES`] path moves (the contour error the drives' lags make). mm.
    pub max_deviation_act: f64,
    /// Times the path came to rest between two path motions.
    pub exact_stops: u64,
    /// Path moves started.
    pub path_moves: u64,
}

/// The loop's side: the figures plus the moves a setpoint is checked against.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathTracker {
    pub figures: PathFigures,
    current: Option<PathMove>,
    previous: Option<PathMove>,
    /// The path has moved since the start, and has rested since it last moved.
    moved: bool,
    rested: bool,
    /// The last path moves' programmed curves (a ring; `recent_n` of them valid).
    recent: [Curve; RECENT_MOVES],
    recent_n: usize,
    recent_head: usize,
    /// Per axis, the actual positions by the tick they were sampled at (tick + 1; 0: none),
    /// in a ring indexed by that tick.
    act_history: [[(u64, f64); ACT_HISTORY]; MAX_AXES],
}

/// What [`deviation`] needs of a move: its end points and its geometry.
#[derive(Clone, Copy, Debug, Default)]
struct Curve {
    start: [f64; MAX_AXES],
    end: [f64; MAX_AXES],
    arc: Option<ArcBand>,
}

/// An arc's plane axes, centre and radius band.
#[derive(Clone, Copy, Debug)]
struct ArcBand {
    axes: [usize; 2],
    center: [f64; 2],
    radii: (f64, f64),
}

impl Curve {
    fn of(m: &PathMove) -> Curve {
        Curve {
            start: m.start.0,
            end: m.end.0,
            arc: match &m.geometry {
                Geometry::Line => None,
                Geometry::Arc(a) => Some(ArcBand {
                    axes: a.axes,
                    center: a.center_2d,
                    radii: (
                        a.start_radius.min(a.end_radius),
                        a.start_radius.max(a.end_radius),
                    ),
                }),
            },
        }
    }
}

impl PathTracker {
    /// A move was started: `Some` for a path move.
    pub fn started(&mut self, mv: Option<&PathMove>) {
        self.previous = self.current.take();
        if let Some(p) = mv {
            self.figures.path_moves += 1;
            if p.limits.velocity > 0.0 && p.limits.velocity.is_finite() {
                self.figures.feed_time_s += p.length / p.limits.velocity;
            }
            self.current = Some(*p);
            self.recent[self.recent_head] = Curve::of(p);
            self.recent_head = (self.recent_head + 1) % RECENT_MOVES;
            self.recent_n = (self.recent_n + 1).min(RECENT_MOVES);
        }
    }

    /// Tick `tick`'s actual positions `act`, each sampled `age` cycles before it (only while
    /// the drives follow the path: the caller leaves out stops after a drive fault and
    /// drive-led tap follows). The linear axes are measured together at the newest tick all
    /// of them have a sample of.
    pub fn sample_actual(
        &mut self,
        linear: &[bool],
        act: &[f64; MAX_AXES],
        age: &[u32; MAX_AXES],
        tick: u64,
    ) {
        let axes = || (0..linear.len().min(MAX_AXES)).filter(|&i| linear[i]);
        let mut common = tick;
        for i in axes() {
            let sampled = tick.saturating_sub(u64::from(age[i]));
            self.act_history[i][sampled as usize % ACT_HISTORY] = (sampled + 1, act[i]);
            common = common.min(sampled);
        }
        let mut pos = [0.0; MAX_AXES];
        for i in axes() {
            match self.act_history[i][common as usize % ACT_HISTORY] {
                (k, p) if k == common + 1 => pos[i] = p,
                _ => return,
            }
        }
        let d = self.recent[..self.recent_n]
            .iter()
            .map(|c| deviation(linear, c, &pos))
            .fold(f64::INFINITY, f64::min);
        if d.is_finite() && d > self.figures.max_deviation_act {
            self.figures.max_deviation_act = d;
        }
    }

    /// One tick's setpoint `pos` (ignored when `off_path`: a drive-led tap follow) at path
    /// speed `speed` in interpolator state `state`; `linear` says which configured axes are
    /// linear (one entry per axis).
    pub fn sample(
        &mut self,
        linear: &[bool],
        pos: &[f64; cnc402_motion::MAX_AXES],
        speed: f64,
        state: TickState,
        off_path: bool,
    ) {
        let on_path =
            self.current.is_some() && matches!(state, TickState::Moving | TickState::Stopping);
        let moving = on_path && speed > REST_SPEED;
        if moving {
            if self.rested {
                self.figures.exact_stops += 1;
            }
            (self.moved, self.rested) = (true, false);
        } else if self.moved {
            self.rested = true;
        }
        if !on_path || off_path {
            return;
        }
        let d = [self.current, self.previous]
            .iter()
            .flatten()
            .map(|m| deviation(linear, &Curve::of(m), pos))
            .fold(f64::INFINITY, f64::min);
        if d.is_finite() && d > self.figures.max_deviation {
            self.figures.max_deviation = d;
        }
    }
}

/// Distance over the linear axes of `pos` from move `m`'s programmed curve: a line's segment;
/// an arc's radius band in its plane (start to end radius) and, along the other axes, the
/// range they travel (a helix's pitch is not checked point by point).
fn deviation(linear: &[bool], m: &Curve, pos: &[f64; MAX_AXES]) -> f64 {
    let n = linear.len().min(MAX_AXES);
    let lin = |i: usize| linear[i];
    match &m.arc {
        None => {
            let (mut dd, mut dp) = (0.0, 0.0);
            for i in (0..n).filter(|&i| lin(i)) {
                let d = m.end[i] - m.start[i];
                dd += d * d;
                dp += d * (pos[i] - m.start[i]);
            }
            let u = if dd > 0.0 {
                (dp / dd).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (0..n)
                .filter(|&i| lin(i))
                .map(|i| {
                    let q = m.start[i] + (m.end[i] - m.start[i]) * u;
                    (pos[i] - q).powi(2)
                })
                .sum::<f64>()
                .sqrt()
        }
        Some(a) => {
            let [p, q] = a.axes;
            let r = (pos[p] - a.center[0]).hypot(pos[q] - a.center[1]);
            let (r0, r1) = a.radii;
            let radial = (r0 - r).max(r - r1).max(0.0);
            let axial: f64 = (0..n)
                .filter(|&i| lin(i) && i != p && i != q)
                .map(|i| {
                    let (lo, hi) = (m.start[i].min(m.end[i]), m.start[i].max(m.end[i]));
                    (lo - pos[i]).max(pos[i] - hi).max(0.0).powi(2)
                })
                .sum();
            (radial * radial + axial).sqrt()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cnc402_config::MachineConfig;
    use cnc402_motion::{AxisPos, Planner, Segment, SegmentKind};

    fn planned(cfg: &MachineConfig, from: [f64; 3], kind: SegmentKind) -> PathMove {
        let mut p = Planner::new(cfg);
        let mut start = AxisPos::default();
        start.0[..3].copy_from_slice(&from);
        p.set_position(start);
        let seg = Segment {
            kind,
            source: cnc402_motion::Source {
                file: "t.nc".into(),
                line: 1,
                n: None,
            },
            ends: cnc402_motion::SegmentEnd::ExactStop,
        };
        match p.plan(&seg).unwrap().kind {
            cnc402_motion::MoveKind::Path(m) => m,
            k => panic!("{k:?}"),
        }
    }

    #[test]
    fn deviation_is_measured_off_lines_and_arcs_and_stops_are_counted() {
        let cfg = MachineConfig::default_machine();
        let axes = crate::controller::AxisTable::new(&cfg);
        let linear = &axes.linear[..axes.n];
        let (x, y) = (cfg.axis_index('X').unwrap(), cfg.axis_index('Y').unwrap());
        let mut end = AxisPos::default();
        end.0[x] = 10.0;
        let line = planned(&cfg, [0.0; 3], SegmentKind::Linear { end, feed: 600.0 });
        let mut t = PathTracker::default();
        t.started(Some(&line));
        assert!(
            (t.figures.feed_time_s - 1.0).abs() < 1e-9,
            "10 mm at 10 mm/s"
        );
        let mut pos = [0.0; cnc402_motion::MAX_AXES];
        pos[x] = 5.0;
        t.sample(linear, &pos, 10.0, TickState::Moving, false);
        assert_eq!(t.figures.max_deviation, 0.0);
        pos[y] = 0.003;
        t.sample(linear, &pos, 10.0, TickState::Moving, false);
        assert!((t.figures.max_deviation - 0.003).abs() < 1e-12);
        // Past the end: the distance to the end point.
        pos[x] = 10.004;
        pos[y] = 0.0;
        t.sample(linear, &pos, 0.0, TickState::Moving, false);
        assert!((t.figures.max_deviation - 0.004).abs() < 1e-12);
        // At rest, then moving again: one exact stop; a drive-led follow is not measured.
        pos[x] = 10.5;
        t.sample(linear, &pos, 3.0, TickState::Moving, true);
        assert_eq!(t.figures.exact_stops, 1);
        assert!((t.figures.max_deviation - 0.004).abs() < 1e-12);
        t.sample(linear, &pos, 3.0, TickState::Moving, false);
        assert!((t.figures.max_deviation - 0.5).abs() < 1e-12);
        assert_eq!(t.figures.exact_stops, 1, "no new stop without rest");
        // A quarter arc of radius 10 about (10, 10): 2 µm outside the radius.
        let mut end = AxisPos::default();
        end.0[x] = 20.0;
        end.0[y] = 10.0;
        let arc = planned(
            &cfg,
            [10.0, 0.0, 0.0],
            SegmentKind::Arc {
                end,
                center: [10.0, 10.0, 0.0],
                plane: cnc402_motion::Plane::XY,
                dir: cnc402_motion::ArcDir::Ccw,
                turns: 0,
                feed: 600.0,
            },
        );
        let mut t = PathTracker::default();
        t.started(Some(&arc));
        let a = std::f64::consts::FRAC_PI_4;
        pos[x] = 10.0 + 10.002 * a.sin();
        pos[y] = 10.0 - 10.002 * a.cos();
        t.sample(linear, &pos, 10.0, TickState::Moving, false);
        assert!(
            (t.figures.max_deviation - 0.002).abs() < 1e-9,
            "{:?}",
            t.figures
        );
    }

    #[test]
    fn actual_positions_are_measured_at_equal_age_against_the_recent_moves() {
        let cfg = MachineConfig::default_machine();
        let axes = crate::controller::AxisTable::new(&cfg);
        let linear = &axes.linear[..axes.n];
        let (x, y) = (cfg.axis_index('X').unwrap(), cfg.axis_index('Y').unwrap());
        // Ten 1 mm moves along X, then one along Y.
        let mut t = PathTracker::default();
        for k in 0..10 {
            let mut end = AxisPos::default();
            end.0[x] = k as f64 + 1.0;
            let from = [k as f64, 0.0, 0.0];
            t.started(Some(&planned(
                &cfg,
                from,
                SegmentKind::Linear { end, feed: 600.0 },
            )));
        }
        let mut end = AxisPos::default();
        end.0[x] = 10.0;
        end.0[y] = 5.0;
        let up = SegmentKind::Linear { end, feed: 600.0 };
        t.started(Some(&planned(&cfg, [10.0, 0.0, 0.0], up)));
        // The actual lagging eight moves behind is on the path.
        let mut act = [0.0; cnc402_motion::MAX_AXES];
        act[x] = 2.5;
        t.sample_actual(linear, &act, &[0; cnc402_motion::MAX_AXES], 1);
        assert_eq!(t.figures.max_deviation_act, 0.0);
        // Y a cycle older than X: X's sample of that cycle is taken, not this one's.
        act[x] = 10.0;
        act[y] = 1.0;
        t.sample_actual(linear, &act, &[0; cnc402_motion::MAX_AXES], 2);
        assert_eq!(t.figures.max_deviation_act, 0.0);
        act[x] = 10.003;
        act[y] = 1.5;
        let mut age = [0; cnc402_motion::MAX_AXES];
        t.sample_actual(linear, &act, &age, 3);
        assert!((t.figures.max_deviation_act - 0.003).abs() < 1e-12);
        act[x] = 10.05;
        age[y] = 1;
        t.sample_actual(linear, &act, &age, 4);
        assert!(
            (t.figures.max_deviation_act - 0.003).abs() < 1e-12,
            "(10.05, 1.5) is not a position the axes were at together"
        );
        age[y] = 0;
        t.sample_actual(linear, &act, &age, 5);
        assert!((t.figures.max_deviation_act - 0.05).abs() < 1e-12);
    }
}
