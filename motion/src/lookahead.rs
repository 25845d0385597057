//! The lookahead planner: blends runs of `Continuous` segments (G64) so a program runs at its
//! feed instead of stopping at every block end. It holds a window of path segments, finds a
//! speed for every junction, and gives out moves whose jerk-limited profiles join at those
//! speeds; exact-stop segments and every non-path segment still end at rest, planned exactly
//! as [`Planner::plan`] plans them.
//!
//! # Method: velocity jumps at junctions, bounded per tick (junction deviation and more)
//! The path stays on the programmed polyline and arcs (deviation 0 ≤ P): at a junction the
//! path speed is continuous and the direction turns at once, so each axis's velocity jumps by
//! v·|Δu_k| (u = the unit tangents). The interpolator samples every period T, and a sampled
//! second difference averages the acceleration over ±T with a hat weight, so a jump shows as
//! an acceleration of at most |Δv|/T, and jumps spaced δ < T apart add up to about
//! |Δv|·(1/δ + 1/T) (δ = the shorter neighbour's time, ℓ/v). The junction speed is the
//! largest v with v·|Δu_k|·(1/T + v/ℓ) ≤ `JUMP_SHARE`·a_k on every axis k: the 1/T term is the
//! bound grbl and Smoothieware leave to the stepper's "instant" corner, the v/ℓ term is the
//! centripetal acceleration of a fine polyline that approximates a curve. grbl's junction
//! deviation (the speed of a circular blend of deviation P through the corner with the path
//! acceleration) caps it further, so P bounds the corner speed the way it does in grbl. The
//! profiles themselves use the rest of the acceleration (`ACCEL_SHARE`), so the sampled
//! acceleration of every axis stays within its limit; arcs keep their centripetal bounds.
//! We chose this over LinuxCNC's tangent blend arcs (tp.c/blendmath.c: exact but many pages
//! of geometry per corner type) and over time-overlapped profiles (needs two moves sampled
//! at once) because it keeps the interpolator sampling one curve at a time and its bounds can
//! be checked on every tick. Jerk: within a profile |j| ≤ the axes' limits; at a junction
//! the sampled jerk is not bounded by the jerk limit (a velocity jump of |Δv| shows as a
//! sampled jerk up to |Δv|/T²). Sources: grbl `planner.c` (Sungeun Jeon, junction
//! deviation), Smoothieware `Planner.cpp`, LinuxCNC `src/emc/tp/tp.c` (G64 P/Q semantics),
//! Biagiotti–Melchiorri §3.4 (double-S).
//!
//! # Speeds over the window
//! Consecutive segments whose limits agree (feed cap within `VELOCITY_SPREAD`, acceleration
//! and jerk at least the group's) form a group planned as one double-S over its whole length
//! (a = 0 only at group ends), so fine segments do not each need a ramp. A backward pass from
//! rest at the window's end and a forward pass from the speed in hand give every group end
//! its speed; the window can therefore always stop within what it holds. When the window is
//! full, half of it is given out, cutting a group if needed at the speed the passes allow.

use std::collections::VecDeque;

use cnc402_config::MachineConfig;

use crate::collinear::CollinearChain;
use crate::error::{MotionError, MotionErrorKind};
use crate::planner::{MoveKind, PathMove, PlannedMove, Planner};
use crate::profile::{JerkProfile, Limits, PathProfile, double_s, ramp_distance};
use crate::segment::{MAX_AXES, Segment, SegmentEnd};

/// Share of each axis's acceleration that the path profiles of blended moves use.
pub const ACCEL_SHARE: f64 = 0.7;
/// Share of each axis's acceleration left to the turning of the path (velocity jumps at
/// junctions, curvature), as the samples show it; the rest is margin for the speed changing
/// within a period.
pub const JUMP_SHARE: f64 = 0.25;
/// A group's acceleration and jerk are this share of its first segment's, so that segments
/// whose direction (and so whose projected limits) change a little still join it.
const GROUP_MARGIN: f64 = 0.9;
/// A segment joins a group if its speed cap is at most this factor above the group's.
const VELOCITY_SPREAD: f64 = 1.1;
/// Bisection steps for speeds and times (relative precision 2⁻⁶⁰).
const BISECTIONS: u32 = 60;

/// A path segment in the window.
#[derive(Clone, Copy, Debug)]
struct Pending {
    /// As [`Planner::plan`] planned it (exact stop, full limits).
    mv: PlannedMove,
    path: PathMove,
    /// Its limits with [`ACCEL_SHARE`] of the acceleration.
    blend: Limits,
    /// The corner tolerance after it (`Continuous`), or `None` (exact stop).
    tolerance: Option<f64>,
    /// Highest speed at the junction to the next segment (0 until that one is known).
    after: f64,
    /// `after` is final: the sampled-path check (see [`Lookahead::refine_junctions`]) has
    /// seen enough of the path on both sides; before that it is the local bound.
    after_final: bool,
    /// The path distance from the program's (or the last rest's) start to this segment's
    /// start.
    s_start: f64,
}

/// Consecutive window segments planned under one profile.
#[derive(Clone, Copy, Debug)]
struct Group {
    first: usize,
    count: usize,
    length: f64,
    lim: Limits,
    /// Highest speed at its end.
    after: f64,
    v_in: f64,
    v_out: f64,
}

/// See the module doc. Feed segments with [`Lookahead::push`], take moves with
/// [`Lookahead::pop`], and call [`Lookahead::finish`] at the end of the program.
#[derive(Clone, Debug)]
pub struct Lookahead {
    planner: Planner,
    capacity: usize,
    window: VecDeque<Pending>,
    out: VecDeque<PlannedMove>,
    groups: Vec<Group>,
    /// Path speed at the end of the last move given out.
    v_now: f64,
    /// The limits of the group the last move given out belongs to, while at speed.
    carried: Option<Limits>,
    accel: [f64; MAX_AXES],
    n_axes: usize,
    period: f64,
    /// Junctions whose planned speed could not be reached exactly (0 unless rounding bites).
    infeasible: u64,
    /// Window entries before this one have their final junction speed.
    refine_from: usize,
    /// A lone segment between two junctions may use the axes' whole acceleration: near its
    /// ends its acceleration is at most jerk·T, which with the jump fits every axis's limit.
    lone_full: bool,
    /// Feed lines waiting to be merged under `G64 Q` (see [`crate::collinear`]).
    chain: CollinearChain,
    /// The operator's feed override in % (0–200), read before each segment is planned:
    /// above 100 % it raises the feed of the moves planned from then on
    /// ([`Planner::set_feed_scale`]).
    feed_override: Option<std::sync::Arc<std::sync::atomic::AtomicU32>>,
}

impl Lookahead {
    /// A lookahead of `capacity` path segments (at least 2) over a planner for `config`.
    pub fn new(config: &MachineConfig, capacity: usize) -> Lookahead {
        let planner = Planner::new(config);
        let (accel, n_axes, period) = planner.axis_accelerations();
        let capacity = capacity.max(2);
        let mut linear = [false; MAX_AXES];
        for (l, a) in linear.iter_mut().zip(&config.axes) {
            *l = a.kind == cnc402_config::AxisKind::Linear;
        }
        let lone_full = config
            .axes
            .iter()
            .all(|a| a.max_jerk * period <= (1.0 - JUMP_SHARE) * a.max_acceleration);
        Lookahead {
            planner,
            capacity,
            window: VecDeque::with_capacity(capacity + 1),
            out: VecDeque::with_capacity(capacity + 1),
            groups: Vec::with_capacity(capacity),
            v_now: 0.0,
            carried: None,
            accel,
            n_axes,
            period,
            infeasible: 0,
            refine_from: 0,
            lone_full,
            chain: CollinearChain::new(linear),
            feed_override: None,
        }
    }

    /// The planner (where the next segment starts, whether the spindle runs).
    pub fn planner(&self) -> &Planner {
        &self.planner
    }

    /// The planner, to re-sync its position or spindle state. Only between programs or
    /// after [`Lookahead::finish`]: the window must be empty.
    pub fn planner_mut(&mut self) -> &mut Planner {
        &mut self.planner
    }

    /// Segments held, not yet given out as moves.
    pub fn pending(&self) -> usize {
        self.window.len() + self.chain.len()
    }

    /// How far `G64 Q` merging moved the path: the largest distance (mm) of a programmed
    /// corner from the merged line that replaced it (0 when nothing merged).
    pub fn merge_deviation(&self) -> f64 {
        self.chain.max_deviation()
    }

    /// Junctions planned at a speed the profile could not reach exactly (for tests: 0).
    pub fn infeasible_junctions(&self) -> u64 {
        self.infeasible
    }

    /// The next move ready to run, in program order.
    pub fn pop(&mut self) -> Option<PlannedMove> {
        self.out.pop_front()
    }

    /// Reads the operator's feed override (%) from `source` before planning each segment.
    pub fn set_feed_override_source(
        &mut self,
        source: std::sync::Arc<std::sync::atomic::AtomicU32>,
    ) {
        self.feed_override = Some(source);
    }

    /// Plans `seg` after the segments before it. A `Continuous` path segment waits in the
    /// window (a feed line under `G64 Q` first in the collinear chain, which may merge it with
    /// its neighbours); anything else first brings the window to rest. On error nothing
    /// changes, except that a merged line the error broke off has been planned.
    pub fn push(&mut self, seg: &Segment) -> Result<(), MotionError> {
        if let Some(f) = &self.feed_override {
            let pct = f.load(std::sync::atomic::Ordering::Acquire);
            self.planner.set_feed_scale(f64::from(pct.max(100)) / 100.0);
        }
        let at = self.chain.end().unwrap_or_else(|| self.planner.position());
        if let Some(q) = self.chain.mergeable(seg, &at) {
            if !self.chain.is_empty() && !self.chain.extend(seg, q) {
                self.flush_chain()?;
            }
            if self.chain.is_empty() {
                self.chain.begin(seg, at);
            }
            return Ok(());
        }
        self.flush_chain()?;
        self.push_one(seg)
    }

    /// Plans the merged line the collinear chain holds, if any.
    fn flush_chain(&mut self) -> Result<(), MotionError> {
        match self.chain.take() {
            Some(line) => self.push_one(&line),
            None => Ok(()),
        }
    }

    /// [`push`](Self::push) past the collinear chain.
    fn push_one(&mut self, seg: &Segment) -> Result<(), MotionError> {
        let start = self.planner.position();
        let mv = self.planner.plan(seg)?;
        let MoveKind::Path(path) = mv.kind else {
            self.flush()?;
            self.out.push_back(mv);
            return Ok(());
        };
        let tolerance = match seg.ends {
            SegmentEnd::Continuous { tolerance, .. } if path.tap.is_none() => Some(tolerance),
            _ => None,
        };
        if tolerance.is_some() && path.length <= 0.0 {
            // No motion and no direction: nothing to blend, nothing to run.
            return Ok(());
        }
        if tolerance.is_none() && self.window.is_empty() && self.v_now == 0.0 {
            self.out.push_back(mv);
            return Ok(());
        }
        let blend = self.blend_limits(seg, start)?;
        let s_start = self
            .window
            .back()
            .map_or(0.0, |p| p.s_start + p.path.length);
        let entry = Pending {
            mv,
            path,
            blend,
            tolerance,
            after: 0.0,
            after_final: false,
            s_start,
        };
        if let Some(last) = self.window.back() {
            let after = self.junction_speed(last, &entry);
            if let Some(last) = self.window.back_mut() {
                last.after = after;
            }
        }
        self.window.push_back(entry);
        self.refine_junctions();
        if tolerance.is_none() {
            self.flush()
        } else if self.window.len() >= self.capacity {
            self.commit(false)
        } else {
            Ok(())
        }
    }

    /// The end of the program: plans what the window holds to rest.
    pub fn finish(&mut self) -> Result<(), MotionError> {
        self.flush_chain()?;
        self.flush()
    }

    fn flush(&mut self) -> Result<(), MotionError> {
        if self.window.is_empty() {
            return Ok(());
        }
        self.commit(true)
    }

    /// `seg`'s path limits with [`ACCEL_SHARE`] of the axes' acceleration.
    fn blend_limits(
        &mut self,
        seg: &Segment,
        start: crate::AxisPos,
    ) -> Result<Limits, MotionError> {
        let end = self.planner.position();
        self.planner.set_position(start);
        self.planner.set_accel_share(ACCEL_SHARE);
        let planned = self.planner.plan(seg);
        self.planner.set_accel_share(1.0);
        self.planner.set_position(end);
        match planned?.kind {
            MoveKind::Path(p) => Ok(p.limits),
            _ => Ok(Limits {
                velocity: 0.0,
                acceleration: 0.0,
                jerk: 0.0,
            }),
        }
    }

    /// The highest speed at the junction from `a` to `b` (see the module doc).
    fn junction_speed(&self, a: &Pending, b: &Pending) -> f64 {
        // Both sides must blend: a segment stamped for an exact stop (a cycle's move, a tap,
        // G61/G9) is also entered from rest, so it runs exactly as it always has.
        let Some(tol) = a.tolerance else { return 0.0 };
        if b.tolerance.is_none()
            || b.path.tap.is_some()
            || a.path.length <= 0.0
            || b.path.length <= 0.0
        {
            return 0.0;
        }
        let u1 = a.path.tangent(a.path.length);
        let u2 = b.path.tangent(0.0);
        let ell = a.path.length.min(b.path.length);
        let mut v = a.blend.velocity.min(b.blend.velocity);
        for k in 0..self.n_axes {
            let d = (u2.0[k] - u1.0[k]).abs();
            if d > 0.0 {
                // (d/ℓ)·v² + (d/T)·v ≤ JUMP_SHARE·a_k, solved for v without cancellation.
                let (qa, qb, qc) = (d / ell, d / self.period, JUMP_SHARE * self.accel[k]);
                let root = 2.0 * qc / (qb + (qb * qb + 4.0 * qa * qc).sqrt());
                v = v.min(root);
            }
        }
        let a_path = a.blend.acceleration.min(b.blend.acceleration);
        v.min(deviation_speed(&u1, &u2, self.n_axes, tol, a_path))
            .max(0.0)
    }

    /// Replaces the local junction bound by the sampled-path bound wherever the window holds
    /// enough path after the junction: at speed v the setpoints are the path's points D = v·T
    /// apart, and their second difference P(s+D) − 2P(s) + P(s−D) over T² is what the drives
    /// see as acceleration (beyond the profile's own). Checked centred on the junction and
    /// ±D from it (where that piecewise-linear function of s has its corners); rounding
    /// noise in CAM output cancels here where the local bound would add it up.
    fn refine_junctions(&mut self) {
        let n = self.window.len();
        let end = self.window[n - 1].s_start + self.window[n - 1].path.length;
        for i in self.refine_from..n.saturating_sub(1) {
            let e = self.window[i];
            if e.after_final || e.after <= 0.0 {
                self.refine_from = i + 1;
                continue;
            }
            let s = e.s_start + e.path.length;
            let cap = e.blend.velocity.min(self.window[i + 1].blend.velocity);
            if end - s < 2.0 * cap * self.period {
                break; // not enough path after it yet (nor after the ones that follow)
            }
            let sampled = self.sampled_speed(s, cap);
            // Keep grbl's tolerance cap, which the local bound included.
            let tol_cap = self.tolerance_cap(i);
            let w = &mut self.window[i];
            w.after = sampled.min(tol_cap);
            w.after_final = true;
            self.refine_from = i + 1;
        }
    }

    /// The highest speed ≤ `cap` at which the sampled path around `s` keeps every axis's
    /// second difference within [`JUMP_SHARE`] of its acceleration.
    fn sampled_speed(&self, s: f64, cap: f64) -> f64 {
        let ok = |v: f64| self.sampled_demand(s, v * self.period) <= JUMP_SHARE;
        if ok(cap) {
            return cap;
        }
        let (mut lo, mut hi) = (0.0, cap);
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if ok(mid) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    }

    /// The largest |P(c+D) − 2P(c) + P(c−D)|_k / (T²·a_k) for c = s − D, s, s + D.
    fn sampled_demand(&self, s: f64, d: f64) -> f64 {
        let t2 = self.period * self.period;
        let pts = [-2.0, -1.0, 0.0, 1.0, 2.0].map(|m| self.point_at(s + m * d));
        let mut worst: f64 = 0.0;
        for c in 1..4 {
            for k in 0..self.n_axes {
                let dd = pts[c + 1].0[k] - 2.0 * pts[c].0[k] + pts[c - 1].0[k];
                worst = worst.max(dd.abs() / (t2 * self.accel[k]));
            }
        }
        worst
    }

    /// The path point at distance `s` (window coordinates); before the window, straight on
    /// back along its first segment (the machine came from rest or along it).
    fn point_at(&self, s: f64) -> crate::AxisPos {
        let i = self
            .window
            .partition_point(|p| p.s_start + p.path.length < s)
            .min(self.window.len() - 1);
        let p = &self.window[i];
        let local = s - p.s_start;
        if local < 0.0 {
            let u = p.path.tangent(0.0);
            let mut q = p.path.start;
            for k in 0..self.n_axes {
                q.0[k] += u.0[k] * local;
            }
            return q;
        }
        p.path.point(local.min(p.path.length))
    }

    /// grbl's junction deviation at the junction after window segment `i`.
    fn tolerance_cap(&self, i: usize) -> f64 {
        let (a, b) = (&self.window[i], &self.window[i + 1]);
        let Some(tol) = a.tolerance else { return 0.0 };
        let u1 = a.path.tangent(a.path.length);
        let u2 = b.path.tangent(0.0);
        deviation_speed(
            &u1,
            &u2,
            self.n_axes,
            tol,
            a.blend.acceleration.min(b.blend.acceleration),
        )
    }

    /// Groups the window (into `self.groups`), runs the backward and forward passes, and
    /// gives out moves: all of them (`all`, ending at rest), or about half the window.
    fn commit(&mut self, all: bool) -> Result<(), MotionError> {
        self.form_groups();
        let n = self.groups.len();
        // Backward: rest after the window; every group entry reachable from its exit.
        let mut exit: f64 = 0.0;
        for g in self.groups.iter_mut().rev() {
            g.v_out = exit.min(g.after);
            exit = max_reach(g.length, g.v_out, g.lim);
        }
        // Forward, from the speed in hand.
        let mut v_in = self.v_now;
        for g in self.groups.iter_mut() {
            g.v_in = v_in;
            g.v_out = g.v_out.min(max_reach(g.length, v_in, g.lim));
            v_in = g.v_out;
        }
        let target = if all {
            self.window.len()
        } else {
            self.capacity / 2
        };
        let mut given = 0;
        for gi in 0..n {
            let g = self.groups[gi];
            if given >= target {
                break;
            }
            if !all && g.first + g.count > target && self.try_cut(g, target)? {
                given = target;
                break;
            }
            // The whole group: its end speed is one the window can stop from. It starts at
            // the speed the last one really ended at.
            self.emit(g.first, g.count, g.length, self.v_now, g.v_out, g.lim)?;
            given = g.first + g.count;
            self.carried = None;
        }
        self.window.drain(..given);
        self.refine_from = self.refine_from.saturating_sub(given);
        if all {
            self.v_now = 0.0;
            self.carried = None;
        }
        Ok(())
    }

    /// Gives out the first `target − g.first` segments of group `g` at the speed the passes
    /// allow at the cut. False (nothing given) when no speed works there.
    fn try_cut(&mut self, g: Group, target: usize) -> Result<bool, MotionError> {
        let k = target - g.first;
        if k == 0 || k >= g.count {
            return Ok(false);
        }
        let head: f64 = self
            .window
            .range(g.first..target)
            .map(|p| p.path.length)
            .sum();
        let tail = g.length - head;
        let v = max_reach(tail, g.v_out, g.lim).min(max_reach(head, g.v_in, g.lim));
        if ramp_distance(g.v_in, v, g.lim) > head || v <= 0.0 {
            return Ok(false);
        }
        self.emit(g.first, k, head, g.v_in, v, g.lim)?;
        self.carried = Some(g.lim);
        Ok(true)
    }

    /// Splits the window into groups (see the module doc).
    fn form_groups(&mut self) {
        self.groups.clear();
        let n = self.window.len();
        let mut i = 0;
        while i < n {
            let c = self.window[i].blend;
            let lim = match self.carried {
                Some(l) if i == 0 && fits(l, c) => l,
                _ => Limits {
                    velocity: c.velocity,
                    acceleration: c.acceleration * GROUP_MARGIN,
                    jerk: c.jerk * GROUP_MARGIN,
                },
            };
            let carried = i == 0 && self.carried == Some(lim);
            let mut length = self.window[i].path.length;
            let mut j = i;
            while j + 1 < n
                && self.window[j].after >= lim.velocity
                && fits(lim, self.window[j + 1].blend)
            {
                j += 1;
                length += self.window[j].path.length;
            }
            // Jumps only at its ends, where a = 0: the whole acceleration is free.
            let lim = if j == i && !carried && self.lone_full {
                self.window[i].path.limits
            } else {
                lim
            };
            self.groups.push(Group {
                first: i,
                count: j - i + 1,
                length,
                lim,
                after: self.window[j].after,
                v_in: 0.0,
                v_out: 0.0,
            });
            i = j + 1;
        }
    }

    /// Gives out window segments `first..first + count` (total `length`) under one profile
    /// from `v_in` to `v_out`.
    fn emit(
        &mut self,
        first: usize,
        count: usize,
        length: f64,
        v_in: f64,
        v_out: f64,
        lim: Limits,
    ) -> Result<(), MotionError> {
        let e0 = self.window[first];
        if count == 1 && v_in == 0.0 && v_out == 0.0 {
            // One segment from rest to rest: exactly what an exact stop gives.
            self.out.push_back(e0.mv);
            return Ok(());
        }
        let err = |p: &Pending, kind| MotionError {
            line: p.mv.line,
            n: p.mv.n,
            kind,
        };
        // Rounding may leave the speed a hair beyond what the distance allows: take the
        // nearest that works and count it.
        let mut v_out = v_out.min(lim.velocity);
        // The same slack as `double_s` (lengths summed in another order differ by an ulp).
        if ramp_distance(v_in, v_out, lim) > length * (1.0 + 1e-12) {
            self.infeasible += 1;
            v_out = reachable_near(length, v_in, v_out, lim);
        }
        let profile = double_s(length, v_in.min(lim.velocity), v_out, lim)
            .map_err(|_| err(&e0, MotionErrorKind::BadLimits))?;
        let (mut s, mut t) = (0.0, 0.0);
        for i in first..first + count {
            let p = self.window[i];
            let last = i + 1 == first + count;
            s += p.path.length;
            let t_end = if last {
                profile.duration()
            } else {
                time_at(&profile, s, t)
            };
            let end_speed = if last {
                v_out
            } else {
                profile.sample(t_end).v.max(f64::MIN_POSITIVE)
            };
            let mut path = p.path;
            path.profile = profile;
            path.limits = lim;
            path.s_offset = s - p.path.length;
            path.t_begin = t;
            path.t_end = t_end;
            path.end_speed = end_speed;
            path.ticks = (((t_end - t) / self.period).ceil() as u64).max(1);
            self.out.push_back(PlannedMove {
                kind: MoveKind::Path(path),
                ..p.mv
            });
            t = t_end;
        }
        self.v_now = v_out;
        Ok(())
    }
}

/// grbl's junction deviation: the speed of a circle through the corner from direction `u1`
/// to `u2` that stays within `tol` of it, at path acceleration `a` (0 for a reversal,
/// unbounded straight on).
fn deviation_speed(u1: &crate::AxisPos, u2: &crate::AxisPos, n: usize, tol: f64, a: f64) -> f64 {
    let (mut dot, mut n1, mut n2) = (0.0, 0.0, 0.0);
    for k in 0..n {
        dot += u1.0[k] * u2.0[k];
        n1 += u1.0[k] * u1.0[k];
        n2 += u2.0[k] * u2.0[k];
    }
    let cos_theta = -dot / (n1 * n2).sqrt().max(f64::MIN_POSITIVE);
    if cos_theta > 0.999_999 {
        return 0.0;
    }
    if cos_theta <= -0.999_999 {
        return f64::INFINITY;
    }
    let sin_half = (0.5 * (1.0 - cos_theta)).sqrt();
    let radius = tol * sin_half / (1.0 - sin_half);
    (a * radius).sqrt()
}

/// True when a segment with limits `c` may join a group planned under `lim`.
fn fits(lim: Limits, c: Limits) -> bool {
    c.velocity >= lim.velocity
        && c.velocity <= lim.velocity * VELOCITY_SPREAD
        && c.acceleration >= lim.acceleration
        && c.jerk >= lim.jerk
}

/// The highest speed (≤ the limit) reachable from `v0`, up or down, within `distance`.
fn max_reach(distance: f64, v0: f64, lim: Limits) -> f64 {
    if ramp_distance(v0, lim.velocity, lim) <= distance {
        return lim.velocity;
    }
    let (mut lo, mut hi) = (v0.min(lim.velocity), lim.velocity);
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (lo + hi);
        if ramp_distance(v0, mid, lim) <= distance {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// The speed nearest `want` that can be reached from `v0` within `distance`. The ramp
/// distance is not monotone in the end speed below `v0`, so the nearest reachable speed is
/// first bracketed by a scan from `want` towards `v0`, then refined.
fn reachable_near(distance: f64, v0: f64, want: f64, lim: Limits) -> f64 {
    const STEPS: u32 = 64;
    let at = |i: u32| want + (v0 - want) * f64::from(i) / f64::from(STEPS);
    let first_ok = (0..=STEPS)
        .find(|&i| ramp_distance(v0, at(i), lim) <= distance)
        .unwrap_or(STEPS);
    if first_ok == 0 {
        return want;
    }
    let (mut ok, mut bad) = (at(first_ok), at(first_ok - 1));
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (ok + bad);
        if ramp_distance(v0, mid, lim) <= distance {
            ok = mid;
        } else {
            bad = mid;
        }
    }
    ok
}

/// The time ≥ `t_lo` at which `profile` reaches `s` (s is non-decreasing in t).
fn time_at(profile: &JerkProfile, s: f64, t_lo: f64) -> f64 {
    let (mut lo, mut hi) = (t_lo, profile.duration());
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (lo + hi);
        if profile.sample(mid).s < s {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}
