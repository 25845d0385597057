//! Feed hold and feed override as time scaling: a path move's planned profile is sampled at
//! a clock τ that runs at rate r = dτ/dt ∈ [0, 1] instead of 1. The path stays the planned
//! one (every axis on its planned curve, a tap's Z and C on one parameter), and with
//! r ≤ 1 speed scales by r and acceleration by r²; r itself ramps jerk-limited, and each
//! tick takes the steepest change of r that keeps the scaled acceleration and jerk in limits.

use crate::planner::PathMove;
use crate::profile::{JerkProfile, Limits, PathProfile, State};

/// Share of the move's path acceleration and jerk (at its planned speed) that a change of
/// rate may use on its own; the rest stays for the profile's own motion.
const RATE_ACCEL_SHARE: f64 = 0.5;
const RATE_JERK_SHARE: f64 = 0.25;
/// Share of the limits a tick's continuous-time check may fill: the rest covers what a
/// period's sampling adds (the profile's jerk switching inside it).
const FIT_SHARE: f64 = 0.9;

/// The operator's feed controls as the interpolator applies them.
#[derive(Clone, Copy, Debug)]
pub(super) struct RateClock {
    /// dτ/dt of the last tick, and its derivative (1/s).
    pub(super) r: f64,
    pub(super) rd: f64,
    /// Feed hold: the path decelerates to rest (r → 0) and stays there.
    pub(super) hold: bool,
    /// Feed override as a factor (0–2).
    pub(super) feed: f64,
    /// Rapid override as a factor (0–1).
    pub(super) rapid: f64,
}

/// The path's motion at the current profile time: state, and the largest |jerk| the
/// profile has over the coming period (a jerk phase may begin or end inside it).
#[derive(Clone, Copy, Debug)]
pub(super) struct ProfileNow {
    pub(super) state: State,
    pub(super) jerk: f64,
}

impl RateClock {
    pub(super) fn new() -> RateClock {
        RateClock {
            r: 1.0,
            rd: 0.0,
            hold: false,
            feed: 1.0,
            rapid: 1.0,
        }
    }

    /// The rate `mv` should run at: 0 in a feed hold, else the feed override over the one it
    /// was planned with (at most 1); a rigid tap always runs at 1 (Fanuc: feed hold and
    /// override do not act during G84/G74 — the hold takes effect after the return to R),
    /// a rapid at the rapid override (its own, as on Fanuc's panel).
    pub(super) fn target(&self, mv: &PathMove) -> f64 {
        if mv.tap.is_some() {
            1.0
        } else if self.hold {
            0.0
        } else if mv.rapid {
            self.rapid
        } else {
            (self.feed / mv.feed_scale).clamp(0.0, 1.0)
        }
    }

    /// A move starting from rest: the rate may jump (speed and acceleration are 0 there).
    pub(super) fn start_at_rest(&mut self, target: f64) {
        self.r = target;
        self.rd = 0.0;
    }

    /// Whether the clock runs at 1 (the profile as planned, bit for bit).
    #[inline]
    pub(super) fn is_unit(&self) -> bool {
        self.r == 1.0 && self.rd == 0.0
    }

    /// One period of `mv` sampled last at profile time `t_now`: how much profile time falls
    /// behind the period (0, exactly, at rate 1).
    #[inline]
    pub(super) fn lag_step(&mut self, mv: &PathMove, t_now: f64, period: f64) -> f64 {
        let target = self.target(mv);
        if self.is_unit() && target == 1.0 {
            return 0.0;
        }
        self.advance(target, &mv.profile, t_now, mv.limits, period) - period
    }

    /// Advances one period of `period` s toward `target` and returns the profile time to
    /// advance by. `profile` is the move's planned profile, `t_now` the profile time of the
    /// last sample, `lim` the move's path limits.
    pub(super) fn advance(
        &mut self,
        target: f64,
        profile: &JerkProfile,
        t_now: f64,
        lim: Limits,
        period: f64,
    ) -> f64 {
        if self.r == target && self.rd == 0.0 {
            return self.r * period;
        }
        let state = profile.sample(t_now);
        let v_ref = if lim.velocity.is_finite() && lim.velocity > 0.0 {
            lim.velocity
        } else {
            state.v.abs().max(1e-9)
        };
        let rho1 = RATE_ACCEL_SHARE * lim.acceleration / v_ref;
        let rho2 = RATE_JERK_SHARE * lim.jerk / v_ref;
        let brake = (-self.rd / period).clamp(-rho2, rho2);
        // A sampled change of rate acts on the samples around it: the profile's motion from
        // two periods back to past the time r' needs to come back to 0.
        let step = self.r * period;
        let settle = self.rd.abs() / rho2 + 2.0 * period;
        let (jerk_near, _) = profile.extremes_within(t_now - 2.0 * step, t_now + step);
        let (jerk_soon, acc_soon) =
            profile.extremes_within(t_now - 2.0 * step, t_now + self.r * settle);
        let now = ProfileNow {
            state,
            jerk: jerk_near,
        };
        let crowded = self.rd != 0.0
            && (jerk_soon > 0.0
                || acc_soon * self.r * self.r + (state.v * self.rd).abs()
                    > FIT_SHARE * lim.acceleration);
        let chosen = if crowded {
            // The profile's own jerk or acceleration is coming: r' back to 0 first.
            brake
        } else {
            let toward = self.toward(target, rho1, rho2, period);
            [toward, 0.0]
                .into_iter()
                .find(|&rdd| self.fits(rdd, now, lim, period))
                .unwrap_or(brake)
        };
        let err = target - self.r;
        let rd = self.rd + chosen * period;
        let mut r = self.r + rd * period;
        let crossed = (target - r) * err <= 0.0;
        let settled = (target - r).abs() < 1e-9 && rd.abs() <= rho2 * period;
        if crossed || settled {
            // Arrived (r' is small here: braking lands on the target).
            r = target;
            self.rd = 0.0;
        } else {
            self.rd = rd;
        }
        self.r = r.clamp(0.0, 1.0);
        self.r * period
    }

    /// The rate jerk that closes in on `target`: r' toward ±rho1, or, within braking
    /// distance (one period early, for the sampling), the constant rate jerk that lands on
    /// the target with r' = 0 (≈ rho2 when braking began on time; no chattering).
    fn toward(&self, target: f64, rho1: f64, rho2: f64, period: f64) -> f64 {
        let err = target - self.r;
        let sign = err.signum();
        let closing = self.rd * sign;
        let stop_dist = self.rd * self.rd / (2.0 * rho2);
        if closing > 0.0 && err.abs() - closing * period <= stop_dist {
            let needed = self.rd * self.rd / (2.0 * err.abs().max(f64::MIN_POSITIVE));
            (-sign * needed.min(rho2)).clamp(-rho2, rho2)
        } else {
            ((sign * rho1 - self.rd) / period).clamp(-rho2, rho2)
        }
    }

    /// Whether rate jerk `rdd` over the next period keeps the path's acceleration
    /// (a·r² + v·r') and jerk (j·r³ + 3·a·r·r' + v·r'') within `lim`.
    fn fits(&self, rdd: f64, now: ProfileNow, lim: Limits, period: f64) -> bool {
        if rdd == 0.0 && self.rd == 0.0 {
            // The planned profile at a constant rate ≤ 1: within limits as planned.
            return true;
        }
        let rd = self.rd + rdd * period;
        let r = (self.r + rd * period).clamp(0.0, 1.0);
        let State { v, a, .. } = now.state;
        let acc = a * r * r + v * rd;
        // The profile's jerk may have either sign within the period: the worse one.
        let jerk = (3.0 * a * r * rd + v * rdd).abs() + now.jerk * r * r * r;
        acc.abs() <= FIT_SHARE * lim.acceleration && jerk.abs() <= FIT_SHARE * lim.jerk
    }

    /// The profile's state seen in real time at this rate: speed × r, acceleration
    /// a·r² + v·r'.
    #[inline]
    pub(super) fn scale(&self, st: State) -> State {
        if self.is_unit() {
            return st;
        }
        State {
            s: st.s,
            v: st.v * self.r,
            a: st.a * self.r * self.r + st.v * self.rd,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lim() -> Limits {
        Limits {
            velocity: 100.0,
            acceleration: 2000.0,
            jerk: 50000.0,
        }
    }

    /// At cruise a hold brings the rate from 1 to 0 and back, monotonically, with the
    /// scaled acceleration and jerk within the path limits at every tick.
    #[test]
    fn rate_ramps_down_and_up_within_limits_at_cruise() {
        let mut c = RateClock::new();
        let now = JerkProfile::hold(State {
            s: 0.0,
            v: 100.0,
            a: 0.0,
        });
        let p = 0.001;
        let mut last = (1.0, 0.0);
        for target in [0.0, 1.0] {
            let mut ticks = 0;
            while c.r != target || c.rd != 0.0 {
                c.advance(target, &now, 0.0, lim(), p);
                let acc = 100.0 * c.rd;
                let jerk = 100.0 * (c.rd - last.1) / p;
                assert!(acc.abs() <= 2000.0 + 1e-9, "{acc}");
                assert!(jerk.abs() <= 50000.0 * (1.0 + 1e-9), "{jerk}");
                assert!((c.r - last.0) * (target - 0.5) >= -1e-15, "monotone");
                last = (c.r, c.rd);
                ticks += 1;
                assert!(ticks < 10_000, "the rate arrives");
            }
        }
    }

    #[test]
    fn taps_run_at_one_and_holds_stop_rapids() {
        let mut c = RateClock::new();
        let cfg = cnc402_config::MachineConfig::default_machine();
        let mut planner = crate::planner::Planner::new(&cfg);
        let mut end = crate::segment::AxisPos::default();
        end.0[0] = 10.0;
        let seg = crate::segment::Segment {
            kind: crate::segment::SegmentKind::Linear { end, feed: 600.0 },
            source: crate::segment::Source {
                file: "t.nc".into(),
                line: 1,
                n: None,
            },
            ends: crate::segment::SegmentEnd::ExactStop,
        };
        let crate::planner::MoveKind::Path(mut mv) = planner.plan(&seg).unwrap().kind else {
            panic!("a line is a path move");
        };
        c.feed = 0.5;
        assert_eq!(c.target(&mv), 0.5);
        mv.feed_scale = 1.5;
        c.feed = 1.2;
        assert!((c.target(&mv) - 0.8).abs() < 1e-12);
        mv.rapid = true;
        assert_eq!(c.target(&mv), 1.0);
        c.rapid = 0.25;
        assert_eq!(c.target(&mv), 0.25, "rapids have their own override");
        c.hold = true;
        assert_eq!(c.target(&mv), 0.0);
        mv.tap = Some(crate::segment::TapCoupling {
            tool: 2,
            spindle: 3,
            ratio: 1.5 / 360.0,
        });
        assert_eq!(c.target(&mv), 1.0, "a rigid tap ignores hold and override");
    }
}
