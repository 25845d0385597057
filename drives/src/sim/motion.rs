//! The simulated motor and position loop of one drive, advanced once per SYNC: a pure delay
//! of `delay_cycles` setpoints, then first-order tracking at `bandwidth_hz` (0 = ideal), in
//! INT32 counts with wrapping arithmetic, plus the quick stop / fault reaction ramp.

use std::collections::VecDeque;

/// Follows CSP setpoints. Positions are INT32 counts that wrap; the loop works on wrapped
/// differences, so a spindle crossing 2^31 sees no jump.
#[derive(Clone, Debug)]
pub struct AxisModel {
    delay: VecDeque<i32>,
    delay_cycles: usize,
    bandwidth_hz: f64,
    /// Actual position, integer part (wrapping).
    actual: i32,
    /// Sub-count remainder of the actual position, in [-0.5, 0.5).
    frac: f64,
    /// Counts per cycle moved in the last step.
    velocity: f64,
    demand: i32,
    /// (dt, 1 − e^(−2π·f·dt)) of the last step: exp() once per period change, not per cycle.
    gain: (f64, f64),
}

impl AxisModel {
    /// A motor standing at `position`.
    pub fn new(delay_cycles: u32, bandwidth_hz: f64, position: i32) -> AxisModel {
        let delay_cycles = delay_cycles.min(10_000) as usize;
        let mut m = AxisModel {
            delay: VecDeque::with_capacity(delay_cycles + 1),
            delay_cycles,
            bandwidth_hz: if bandwidth_hz.is_finite() && bandwidth_hz > 0.0 {
                bandwidth_hz
            } else {
                0.0
            },
            actual: position,
            frac: 0.0,
            velocity: 0.0,
            demand: position,
            gain: (0.0, 1.0),
        };
        m.hold();
        m
    }

    /// Actual position (0x6064).
    pub fn actual(&self) -> i32 {
        self.actual
    }

    /// Position demand the loop is tracking (0x6062): the setpoint after the pure delay.
    pub fn demand(&self) -> i32 {
        self.demand
    }

    /// Following error demand − actual, wrapped (0x60F4).
    pub fn following_error(&self) -> i32 {
        self.demand.wrapping_sub(self.actual)
    }

    /// Velocity in counts per cycle.
    pub fn velocity(&self) -> f64 {
        self.velocity
    }

    /// Power stage off or holding: the delay line fills with the actual position so that a
    /// later enable starts from where the motor is, and velocity is zero.
    pub fn hold(&mut self) {
        self.delay.clear();
        for _ in 0..self.delay_cycles {
            self.delay.push_back(self.actual);
        }
        self.demand = self.actual;
        self.velocity = 0.0;
    }

    /// One cycle of CSP following towards `target`, with the cycle time `dt_s`.
    pub fn follow(&mut self, target: i32, dt_s: f64) {
        self.delay.push_back(target);
        self.demand = self.delay.pop_front().unwrap_or(target);
        let err = self.demand.wrapping_sub(self.actual) as f64 - self.frac;
        let step = if self.bandwidth_hz == 0.0 || dt_s <= 0.0 {
            err
        } else {
            if self.gain.0 != dt_s {
                let alpha = 1.0 - (-2.0 * std::f64::consts::PI * self.bandwidth_hz * dt_s).exp();
                self.gain = (dt_s, alpha);
            }
            err * self.gain.1
        };
        self.advance(step);
    }

    /// One cycle of braking at `decel` counts/cycle²; returns true once stopped. The demand
    /// follows the actual position (no following error while braking).
    pub fn brake(&mut self, decel: f64) -> bool {
        let v = self.velocity;
        let dv = decel.abs().max(f64::MIN_POSITIVE);
        let next = if v.abs() <= dv {
            0.0
        } else {
            v - dv * v.signum()
        };
        self.advance(next);
        self.demand = self.actual;
        self.delay.clear();
        for _ in 0..self.delay_cycles {
            self.delay.push_back(self.actual);
        }
        next == 0.0
    }

    fn advance(&mut self, step: f64) {
        let total = self.frac + step;
        let whole = total.round();
        // Wrapping: whole counts can exceed i32 only for absurd steps; clamp through i64.
        let whole_i = (whole.clamp(i64::MIN as f64, i64::MAX as f64) as i64) as i32;
        self.actual = self.actual.wrapping_add(whole_i);
        self.frac = total - whole;
        self.velocity = step;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ideal_follows_exactly_and_wraps() {
        let mut m = AxisModel::new(0, 0.0, i32::MAX - 5);
        m.follow(i32::MAX, 0.001);
        assert_eq!(m.actual(), i32::MAX);
        m.follow(i32::MAX.wrapping_add(10), 0.001);
        assert_eq!(m.actual(), i32::MIN + 9);
        assert_eq!(m.following_error(), 0);
        assert_eq!(m.velocity(), 10.0);
    }

    #[test]
    fn pure_delay_shifts_by_cycles() {
        let mut m = AxisModel::new(2, 0.0, 0);
        let mut seen = vec![];
        for k in 1..=5 {
            m.follow(k * 100, 0.001);
            seen.push(m.actual());
        }
        assert_eq!(seen, vec![0, 0, 100, 200, 300]);
    }

    #[test]
    fn first_order_step_response_matches_bandwidth() {
        // 10 Hz at 1 ms: after one time constant (15.9 ms) the step is 63 % done.
        let mut m = AxisModel::new(0, 10.0, 0);
        let tau_cycles = (1000.0 / (2.0 * std::f64::consts::PI * 10.0)).round() as usize;
        for _ in 0..tau_cycles {
            m.follow(1_000_000, 0.001);
        }
        let done = m.actual() as f64 / 1e6;
        assert!((done - 0.632).abs() < 0.01, "{done}");
        for _ in 0..2000 {
            m.follow(1_000_000, 0.001);
        }
        assert_eq!(m.actual(), 1_000_000);
    }

    #[test]
    fn ramp_lag_is_velocity_over_omega_across_the_wrap() {
        // Constant velocity through the INT32 wrap: the lag settles at v / (2π f) and the
        // actual position never jumps.
        let (f, v) = (150.0, 2000.0);
        let start = i32::MAX - 1_000_000;
        let mut m = AxisModel::new(0, f, start);
        let mut target = start;
        let mut last = m.actual();
        for _ in 0..2000 {
            target = target.wrapping_add(v as i32);
            m.follow(target, 0.001);
            let step = m.actual().wrapping_sub(last);
            assert!((0..=2 * v as i32).contains(&step), "{step}");
            last = m.actual();
        }
        let lag = target.wrapping_sub(m.actual()) as f64;
        let alpha = 1.0 - (-2.0 * std::f64::consts::PI * f * 0.001).exp();
        // Discrete first-order lag: v (1 - α) / α.
        let expected = v * (1.0 - alpha) / alpha;
        assert!((lag - expected).abs() <= 1.0, "{lag} vs {expected}");
        assert!(m.actual() < 0, "wrapped");
    }

    #[test]
    fn brake_ramps_to_zero_and_hold_resets_demand() {
        let mut m = AxisModel::new(1, 0.0, 0);
        for k in 1..=10 {
            m.follow(k * 100, 0.001);
        }
        assert_eq!(m.velocity(), 100.0);
        let mut cycles = 0;
        while !m.brake(30.0) {
            cycles += 1;
            assert!(cycles < 10);
        }
        assert_eq!(cycles, 3);
        let stopped = m.actual();
        m.hold();
        m.follow(stopped, 0.001);
        assert_eq!(m.actual(), stopped);
        assert_eq!(m.following_error(), 0);
    }
}
