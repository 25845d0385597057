//! Jerk-limited 1-D motion profiles: a profile is a short chain of constant-jerk pieces, so
//! position is a C² piecewise cubic in time. [`rest_to_rest`] builds the time-optimal
//! double-S (Biagiotti–Melchiorri, Trajectory Planning for Automatic Machines, §3.4) for a
//! move that starts and ends at rest; [`velocity_change`] builds the 3-piece ramp used for
//! controlled stops and spindle speed changes.

/// Position, velocity and acceleration of a profile at one instant.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct State {
    pub s: f64,
    pub v: f64,
    pub a: f64,
}

/// Bounds on |velocity|, |acceleration| and |jerk| of a 1-D profile (all > 0 and finite).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    pub velocity: f64,
    pub acceleration: f64,
    pub jerk: f64,
}

impl Limits {
    /// True when every bound is finite and strictly positive.
    pub fn is_valid(&self) -> bool {
        [self.velocity, self.acceleration, self.jerk]
            .iter()
            .all(|x| x.is_finite() && *x > 0.0)
    }
}

/// A 1-D motion law s(t) for t ≥ 0. Past `duration()` the profile keeps its final velocity
/// (zero for a move, the cruise speed for a spindle ramp) with zero acceleration.
pub trait PathProfile {
    /// Time at which the profile reaches its final state (s).
    fn duration(&self) -> f64;
    /// The state at time `t` (clamped to the start for `t < 0`).
    fn sample(&self, t: f64) -> State;
    /// The state at `duration()`.
    fn end(&self) -> State;
}

/// Most pieces a profile holds (the double-S needs 7).
pub const MAX_PIECES: usize = 7;

#[derive(Clone, Copy, Debug, PartialEq, Default)]
struct Piece {
    t0: f64,
    s0: f64,
    v0: f64,
    a0: f64,
    j: f64,
}

impl Piece {
    #[inline]
    fn at(&self, t: f64) -> State {
        let d = t - self.t0;
        State {
            s: self.s0 + d * (self.v0 + d * (0.5 * self.a0 + d * (self.j / 6.0))),
            v: self.v0 + d * (self.a0 + d * (0.5 * self.j)),
            a: self.a0 + d * self.j,
        }
    }
}

/// A profile made of up to [`MAX_PIECES`] constant-jerk pieces; `Copy` and heap-free so it
/// can travel in a ring buffer and be sampled in the real-time loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JerkProfile {
    pieces: [Piece; MAX_PIECES],
    len: u8,
    start: State,
    end: State,
    duration: f64,
}

impl JerkProfile {
    /// A profile that stays at `start` (keeping its velocity, zero acceleration) forever.
    pub fn hold(start: State) -> JerkProfile {
        let start = State { a: 0.0, ..start };
        JerkProfile {
            pieces: [Piece::default(); MAX_PIECES],
            len: 0,
            start,
            end: start,
            duration: 0.0,
        }
    }

    /// Appends a piece of jerk `j` lasting `dt` seconds (ignored unless `dt > 0`).
    fn push(&mut self, dt: f64, j: f64) {
        if dt.is_nan() || dt <= 0.0 || self.len as usize >= MAX_PIECES {
            return;
        }
        let p = Piece {
            t0: self.duration,
            s0: self.end.s,
            v0: self.end.v,
            a0: self.end.a,
            j,
        };
        self.pieces[self.len as usize] = p;
        self.len += 1;
        self.duration += dt;
        self.end = p.at(self.duration);
    }

    /// The same motion played `k` times slower (k ≥ 1 keeps every limit): durations × k,
    /// velocity ÷ k, acceleration ÷ k², jerk ÷ k³; positions unchanged.
    pub fn time_scaled(&self, k: f64) -> JerkProfile {
        let mut out = *self;
        for p in out.pieces.iter_mut().take(self.len as usize) {
            p.t0 *= k;
            p.v0 /= k;
            p.a0 /= k * k;
            p.j /= k * k * k;
        }
        out.start.v /= k;
        out.start.a /= k * k;
        out.end.v /= k;
        out.end.a /= k * k;
        out.duration *= k;
        out
    }

    /// The state at time 0.
    pub fn start(&self) -> State {
        self.start
    }

    /// Largest |jerk| of any piece.
    pub fn max_jerk(&self) -> f64 {
        self.pieces[..self.len as usize]
            .iter()
            .fold(0.0, |m, p| f64::max(m, p.j.abs()))
    }

    /// Number of pieces (for tests and diagnostics).
    pub fn pieces(&self) -> usize {
        self.len as usize
    }

    /// The largest |jerk| and |acceleration| over the times [t0, t1] (the profile holds
    /// still before its start and cruises past its end).
    pub fn extremes_within(&self, t0: f64, t1: f64) -> (f64, f64) {
        let (mut jerk, mut acc) = (0.0f64, 0.0f64);
        let n = self.len as usize;
        for (i, p) in self.pieces[..n].iter().enumerate() {
            let end = if i + 1 < n {
                self.pieces[i + 1].t0
            } else {
                self.duration
            };
            let (a, b) = (t0.max(p.t0), t1.min(end));
            if a <= b {
                jerk = jerk.max(p.j.abs());
                // Acceleration is linear in a piece: its extremes are at the ends.
                acc = acc.max(p.at(a).a.abs()).max(p.at(b).a.abs());
            }
        }
        (jerk, acc)
    }
}

impl PathProfile for JerkProfile {
    fn duration(&self) -> f64 {
        self.duration
    }

    #[inline]
    fn sample(&self, t: f64) -> State {
        if t <= 0.0 {
            return self.start;
        }
        if t >= self.duration {
            let d = t - self.duration;
            return State {
                s: if d == 0.0 {
                    self.end.s
                } else {
                    self.end.s + self.end.v * d
                },
                v: self.end.v,
                a: 0.0,
            };
        }
        let n = self.len as usize;
        let mut i = n - 1;
        while i > 0 && self.pieces[i].t0 > t {
            i -= 1;
        }
        self.pieces[i].at(t)
    }

    fn end(&self) -> State {
        self.end
    }
}

/// Why a profile could not be built.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ProfileError {
    /// Distance negative or not finite.
    BadDistance(f64),
    /// A limit is zero, negative or not finite.
    BadLimits(Limits),
    /// A boundary velocity that is negative, above the limit or not finite.
    BadVelocity(f64),
    /// The distance is shorter than the ramp between the boundary velocities needs.
    TooShort { need: f64 },
}

/// The time-optimal jerk-limited profile from rest at s = 0 to rest at s = `distance`,
/// with |v| ≤ `lim.velocity`, |a| ≤ `lim.acceleration`, |j| ≤ `lim.jerk`. Covers the cases
/// where the velocity limit, or also the acceleration limit, is not reached (short moves);
/// `distance = 0` gives an empty profile. The final state is exactly `(distance, 0, 0)`.
///
/// Blending (non-zero start/end velocity) uses [`double_s`]; this closed form is the
/// exact-stop case.
pub fn rest_to_rest(distance: f64, lim: Limits) -> Result<JerkProfile, ProfileError> {
    if !(distance.is_finite() && distance >= 0.0) {
        return Err(ProfileError::BadDistance(distance));
    }
    if !lim.is_valid() {
        return Err(ProfileError::BadLimits(lim));
    }
    let mut p = JerkProfile::hold(State::default());
    if distance == 0.0 {
        return Ok(p);
    }
    let (vm, am, jm) = (lim.velocity, lim.acceleration, lim.jerk);
    // Acceleration phase that reaches vm: with or without reaching am.
    let (mut tj, mut ta) = if vm * jm >= am * am {
        (am / jm, am / jm + vm / am)
    } else {
        let tj = (vm / jm).sqrt();
        (tj, 2.0 * tj)
    };
    let mut tv = distance / vm - ta;
    if tv < 0.0 {
        // vm is not reached: try reaching am, else neither.
        tv = 0.0;
        tj = am / jm;
        ta = 0.5 * (tj + (tj * tj + 4.0 * distance / am).sqrt());
        if ta < 2.0 * tj {
            tj = (distance / (2.0 * jm)).cbrt();
            ta = 2.0 * tj;
        }
    }
    let tconst = (ta - 2.0 * tj).max(0.0);
    p.push(tj, jm);
    p.push(tconst, 0.0);
    p.push(tj, -jm);
    p.push(tv, 0.0);
    p.push(tj, -jm);
    p.push(tconst, 0.0);
    p.push(tj, jm);
    // Integration rounding leaves the end a few ulp off; the move's end is exact by definition.
    p.end = State {
        s: distance,
        v: 0.0,
        a: 0.0,
    };
    Ok(p)
}

/// Distance covered by the symmetric jerk-limited ramp from `va` to `vb` (both with zero
/// acceleration): (va + vb)/2 times its duration.
pub(crate) fn ramp_distance(va: f64, vb: f64, lim: Limits) -> f64 {
    let dv = (vb - va).abs();
    let (a, j) = (lim.acceleration, lim.jerk);
    let t = if dv * j >= a * a {
        dv / a + a / j
    } else {
        2.0 * (dv / j).sqrt()
    };
    0.5 * (va + vb) * t
}

/// Appends `other`'s pieces (its start must be this profile's end).
fn append(p: &mut JerkProfile, other: &JerkProfile) {
    let n = other.len as usize;
    for i in 0..n {
        let end = if i + 1 < n {
            other.pieces[i + 1].t0
        } else {
            other.duration
        };
        p.push(end - other.pieces[i].t0, other.pieces[i].j);
    }
}

/// The time-optimal jerk-limited profile over `distance` that starts at velocity `v_start`
/// and ends at `v_end` (0 ≤ both ≤ `lim.velocity`), with zero acceleration at both ends: a
/// ramp up to a peak velocity, a cruise, a ramp down. The peak is `lim.velocity` when the
/// distance allows, else found by bisection on the (monotone) ramp distance. This is the
/// building block for lookahead blending (exact stop uses `v_start = v_end = 0`, where it
/// equals [`rest_to_rest`]). Errors if the distance is too short to get from `v_start` to
/// `v_end` at all ([`ProfileError::TooShort`]).
pub fn double_s(
    distance: f64,
    v_start: f64,
    v_end: f64,
    lim: Limits,
) -> Result<JerkProfile, ProfileError> {
    if !(distance.is_finite() && distance >= 0.0) {
        return Err(ProfileError::BadDistance(distance));
    }
    if !lim.is_valid() {
        return Err(ProfileError::BadLimits(lim));
    }
    for v in [v_start, v_end] {
        if !(v >= 0.0 && v <= lim.velocity) {
            return Err(ProfileError::BadVelocity(v));
        }
    }
    let total = |vp: f64| ramp_distance(v_start, vp, lim) + ramp_distance(vp, v_end, lim);
    let low = v_start.max(v_end);
    let need = total(low);
    if distance < need * (1.0 - 1e-12) {
        return Err(ProfileError::TooShort { need });
    }
    let peak = if total(lim.velocity) <= distance {
        lim.velocity
    } else {
        // total() is increasing in the peak: keep the largest peak that fits.
        let (mut lo, mut hi) = (low, lim.velocity);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if total(mid) <= distance {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    };
    let start = State {
        s: 0.0,
        v: v_start,
        a: 0.0,
    };
    let mut p = velocity_change(start, peak, lim.acceleration, lim.jerk);
    if peak > 0.0 {
        p.push(((distance - total(peak)) / peak).max(0.0), 0.0);
    }
    let down = velocity_change(p.end, v_end, lim.acceleration, lim.jerk);
    append(&mut p, &down);
    p.end = State {
        s: distance,
        v: v_end,
        a: 0.0,
    };
    Ok(p)
}

/// The time-optimal jerk-limited change from `from` (position, velocity, acceleration with
/// |a| ≤ `acceleration`) to velocity `v_target` with zero acceleration: three pieces
/// (jerk ±j, hold, jerk ∓j). If the acceleration in hand overshoots the target, the ramp
/// goes the other way first, so velocity may pass `v_target` briefly. Past its end the
/// profile cruises at `v_target`.
pub fn velocity_change(from: State, v_target: f64, acceleration: f64, jerk: f64) -> JerkProfile {
    let mut p = JerkProfile::hold(from);
    p.start = from;
    p.end = from;
    let j = jerk;
    // Velocity reached if the acceleration is brought to zero at once.
    let natural = from.a * from.a.abs() / (2.0 * j);
    let dv = v_target - from.v;
    let sigma = if dv - natural >= 0.0 { 1.0 } else { -1.0 };
    let d = sigma * dv; // velocity to gain in the σ frame
    let a0 = sigma * from.a;
    let mut ap = acceleration.max(a0);
    let mut t2 = if ap > 0.0 {
        (d - ap * ap / j + a0 * a0 / (2.0 * j)) / ap
    } else {
        0.0
    };
    if t2 < 0.0 {
        ap = (j * d + 0.5 * a0 * a0).max(0.0).sqrt().max(a0);
        t2 = 0.0;
    }
    p.push((ap - a0) / j, sigma * j);
    p.push(t2, 0.0);
    p.push(ap / j, -sigma * j);
    p.end = State {
        s: p.end.s,
        v: if p.len > 0 { v_target } else { from.v },
        a: 0.0,
    };
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lim(v: f64, a: f64, j: f64) -> Limits {
        Limits {
            velocity: v,
            acceleration: a,
            jerk: j,
        }
    }

    /// Samples densely and checks every bound, monotone s and the exact end.
    fn check(p: &JerkProfile, dist: f64, l: Limits) {
        let n = 20_000;
        let t_end = p.duration();
        let mut last = p.sample(0.0);
        assert_eq!(last, State::default());
        for i in 1..=n {
            let st = p.sample(t_end * i as f64 / n as f64);
            assert!(st.v.abs() <= l.velocity * (1.0 + 1e-9), "v {st:?} {l:?}");
            assert!(
                st.a.abs() <= l.acceleration * (1.0 + 1e-9),
                "a {st:?} {l:?}"
            );
            assert!(st.s >= last.s - 1e-12 * dist.max(1.0), "monotone");
            assert!(st.v >= -1e-9 * l.velocity);
            last = st;
        }
        assert!(p.max_jerk() <= l.jerk * (1.0 + 1e-12));
        assert_eq!(
            p.end(),
            State {
                s: dist,
                v: 0.0,
                a: 0.0
            }
        );
        assert_eq!(p.sample(t_end).s, dist);
        assert_eq!(p.sample(t_end + 1.0).s, dist);
        // The integrated chain meets the exact end to rounding.
        let before = p.sample(t_end * (1.0 - 1e-12));
        assert!(
            (before.s - dist).abs() <= 1e-9 * dist.max(1.0),
            "{before:?} {dist}"
        );
    }

    #[test]
    fn reaches_all_limits_on_a_long_move() {
        let l = lim(200.0, 1500.0, 40000.0);
        let p = rest_to_rest(300.0, l).unwrap();
        check(&p, 300.0, l);
        // Cruise at v_max, a_max reached: T = L/v + v/a + a/j.
        let t = 300.0 / 200.0 + 200.0 / 1500.0 + 1500.0 / 40000.0;
        assert!((p.duration() - t).abs() < 1e-12, "{} {t}", p.duration());
        let mid = p.sample(p.duration() / 2.0);
        assert!((mid.v - 200.0).abs() < 1e-9);
    }

    #[test]
    fn velocity_limit_reached_without_acceleration_limit() {
        // v*j < a²: acceleration peaks at sqrt(v j) < a.
        let l = lim(10.0, 1500.0, 40000.0);
        let p = rest_to_rest(50.0, l).unwrap();
        check(&p, 50.0, l);
        let peak_a = (10.0f64 * 40000.0).sqrt();
        let st = p.sample((10.0f64 / 40000.0).sqrt());
        assert!((st.a - peak_a).abs() < 1e-9 * peak_a);
    }

    #[test]
    fn short_move_reaches_acceleration_but_not_velocity() {
        let l = lim(200.0, 1500.0, 40000.0);
        let p = rest_to_rest(5.0, l).unwrap();
        check(&p, 5.0, l);
        assert_eq!(p.pieces(), 6, "no cruise piece");
        let peak = p.sample(p.duration() / 2.0);
        assert!(peak.v < 200.0 && peak.v > 50.0);
    }

    #[test]
    fn very_short_move_reaches_neither() {
        let l = lim(200.0, 1500.0, 40000.0);
        let p = rest_to_rest(1e-4, l).unwrap();
        check(&p, 1e-4, l);
        assert_eq!(p.pieces(), 4, "pure jerk pieces");
        let tj = (1e-4 / (2.0 * 40000.0f64)).cbrt();
        assert!((p.duration() - 4.0 * tj).abs() < 1e-15);
    }

    #[test]
    fn zero_distance_is_empty_and_bad_input_is_an_error() {
        let l = lim(1.0, 1.0, 1.0);
        let p = rest_to_rest(0.0, l).unwrap();
        assert_eq!(p.duration(), 0.0);
        assert_eq!(p.sample(3.0).s, 0.0);
        assert!(rest_to_rest(-1.0, l).is_err());
        assert!(rest_to_rest(f64::NAN, l).is_err());
        assert!(rest_to_rest(1.0, lim(0.0, 1.0, 1.0)).is_err());
        assert!(rest_to_rest(1.0, lim(1.0, f64::INFINITY, 1.0)).is_err());
    }

    #[test]
    fn time_scaling_keeps_positions_and_lowers_limits() {
        let l = lim(100.0, 1000.0, 20000.0);
        let p = rest_to_rest(20.0, l).unwrap();
        let q = p.time_scaled(1.5);
        assert!((q.duration() - 1.5 * p.duration()).abs() < 1e-12);
        for i in 0..=100 {
            let t = p.duration() * i as f64 / 100.0;
            let (a, b) = (p.sample(t), q.sample(1.5 * t));
            assert!((a.s - b.s).abs() < 1e-12);
            assert!((a.v / 1.5 - b.v).abs() < 1e-9);
            assert!((a.a / 2.25 - b.a).abs() < 1e-9);
        }
        assert_eq!(q.end().s, 20.0);
    }

    #[test]
    fn velocity_change_up_down_and_from_acceleration() {
        let (a, j) = (1000.0, 20000.0);
        for &(v0, a0, v1) in &[
            (0.0, 0.0, 600.0),
            (600.0, 0.0, 0.0),
            (600.0, 0.0, -600.0),
            (100.0, 800.0, 0.0),
            (100.0, -1000.0, 0.0),
            (1.0, -1000.0, 0.0), // overshoot: must turn the acceleration around
            (0.0, 0.0, 1.0),     // tiny: acceleration limit not reached
        ] {
            let p = velocity_change(
                State {
                    s: 5.0,
                    v: v0,
                    a: a0,
                },
                v1,
                a,
                j,
            );
            let e = p.sample(p.duration());
            assert!(
                (e.v - v1).abs() < 1e-9 * (1.0 + v1.abs()),
                "{v0} {a0} {v1}: {e:?}"
            );
            assert_eq!(e.a, 0.0);
            // Continuous at the end: the integrated chain meets the cruise.
            let before = p.sample(p.duration() * (1.0 - 1e-12));
            assert!((before.v - v1).abs() < 1e-6 * (1.0 + v1.abs()));
            assert!(before.a.abs() < 1e-6 * a);
            assert!(p.max_jerk() <= j);
            for i in 0..=1000 {
                let st = p.sample(p.duration() * i as f64 / 1000.0);
                assert!(st.a.abs() <= a * (1.0 + 1e-12) + 1e-9, "{st:?}");
            }
            assert_eq!(
                p.sample(0.0),
                State {
                    s: 5.0,
                    v: v0,
                    a: a0
                }
            );
        }
    }

    #[test]
    fn double_s_from_rest_to_rest_is_the_closed_form() {
        for &(d, v, a, j) in &[
            (300.0, 200.0, 1500.0, 40000.0),
            (50.0, 10.0, 1500.0, 40000.0),
            (5.0, 200.0, 1500.0, 40000.0),
            (1e-4, 200.0, 1500.0, 40000.0),
        ] {
            let l = lim(v, a, j);
            let (p, q) = (
                rest_to_rest(d, l).unwrap(),
                double_s(d, 0.0, 0.0, l).unwrap(),
            );
            assert!(
                (p.duration() - q.duration()).abs() < 1e-9 * p.duration(),
                "{d}"
            );
            for i in 0..=100 {
                let t = p.duration() * i as f64 / 100.0;
                assert!((p.sample(t).s - q.sample(t).s).abs() < 1e-9 * d.max(1.0));
            }
        }
    }

    #[test]
    fn double_s_with_boundary_velocities() {
        let l = lim(200.0, 1500.0, 40000.0);
        // Enter at 100, leave at 50, long enough to reach 200.
        let p = double_s(100.0, 100.0, 50.0, l).unwrap();
        assert_eq!(p.sample(0.0).v, 100.0);
        let e = p.sample(p.duration());
        assert_eq!((e.s, e.v, e.a), (100.0, 50.0, 0.0));
        let before = p.sample(p.duration() * (1.0 - 1e-12));
        assert!((before.s - 100.0).abs() < 1e-9 && (before.v - 50.0).abs() < 1e-6);
        assert!((p.sample(p.duration() / 2.0).v - 200.0).abs() < 1e-9);
        // Too short to brake from 200 to 0: an error, not a violation.
        assert!(matches!(
            double_s(1.0, 200.0, 0.0, l),
            Err(ProfileError::TooShort { .. })
        ));
        assert!(matches!(
            double_s(1.0, 250.0, 0.0, l),
            Err(ProfileError::BadVelocity(_))
        ));
        // Just long enough: a pure ramp, no cruise.
        let need = ramp_distance(200.0, 0.0, l);
        let q = double_s(need, 200.0, 0.0, l).unwrap();
        assert!((q.duration() - (200.0 / 1500.0 + 1500.0 / 40000.0)).abs() < 1e-9);
    }

    #[test]
    fn stop_from_cruise_is_the_mirror_of_the_ramp() {
        let (a, j) = (1500.0, 40000.0);
        let up = velocity_change(State::default(), 200.0, a, j);
        let down = velocity_change(
            State {
                s: 0.0,
                v: 200.0,
                a: 0.0,
            },
            0.0,
            a,
            j,
        );
        assert!((up.duration() - down.duration()).abs() < 1e-12);
        // Stopping distance = v·T/2 for a symmetric ramp.
        assert!((down.end().s - 200.0 * down.duration() / 2.0).abs() < 1e-9);
    }
}
