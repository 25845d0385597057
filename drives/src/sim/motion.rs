//! The simulated motor and position loop of one drive, advanced once per SYNC: a pure delay
//! of `delay_cycles` setpoints, then a P position loop (Kv = 2π·`bandwidth_hz`, 0 = ideal)
//! with optional velocity feedforward, velocity and acceleration (current) limits, and an
//! encoder of finite resolution, in INT32 counts with wrapping arithmetic; plus the quick
//! stop / fault reaction ramp. With no feedforward, limits or encoder steps it is exactly
//! the first-order tracking the golden fixtures were made with.

use std::collections::VecDeque;

use cnc402_config::AxisConfig;

/// The simulated drive's dynamics in counts: the `sim` keys of an axis, scaled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveDynamics {
    /// Setpoints between taking one and the position loop seeing it.
    pub delay_cycles: u32,
    /// Closed position loop bandwidth without feedforward (Hz), Kv = 2π·f; 0 = ideal.
    pub bandwidth_hz: f64,
    /// Fraction of the demand velocity fed forward, 0..=1.
    pub feedforward: f64,
    /// Largest speed, counts/s; 0 = unlimited.
    pub max_velocity: f64,
    /// Largest acceleration (current limit), counts/s²; 0 = unlimited.
    pub max_acceleration: f64,
    /// Encoder step, counts: the loop and 0x6064 see the position truncated to a multiple
    /// of it; 0 = the loop sees the exact position and 0x6064 the nearest count.
    pub encoder_step: f64,
}

impl DriveDynamics {
    /// Pure delay then first-order tracking, nothing else.
    pub fn first_order(delay_cycles: u32, bandwidth_hz: f64) -> DriveDynamics {
        DriveDynamics {
            delay_cycles,
            bandwidth_hz,
            feedforward: 0.0,
            max_velocity: 0.0,
            max_acceleration: 0.0,
            encoder_step: 0.0,
        }
    }

    /// The `sim` keys of `axis`, in counts.
    pub fn of_axis(axis: &AxisConfig) -> DriveDynamics {
        let cpu = axis.counts_per_unit.abs();
        let s = &axis.sim;
        DriveDynamics {
            delay_cycles: s.delay_cycles,
            bandwidth_hz: s.bandwidth_hz,
            feedforward: s.velocity_feedforward,
            max_velocity: s.max_velocity * cpu,
            max_acceleration: s.max_acceleration * cpu,
            encoder_step: s.encoder_resolution * cpu,
        }
    }

    /// Values a config could not hold (non-finite, negative) made harmless: ideal loop, no
    /// limit, no encoder step, feedforward within 0..=1.
    fn sanitised(self) -> DriveDynamics {
        let non_negative = |x: f64| if x.is_finite() && x > 0.0 { x } else { 0.0 };
        DriveDynamics {
            delay_cycles: self.delay_cycles.min(10_000),
            bandwidth_hz: non_negative(self.bandwidth_hz),
            feedforward: non_negative(self.feedforward).min(1.0),
            max_velocity: non_negative(self.max_velocity),
            max_acceleration: non_negative(self.max_acceleration),
            encoder_step: non_negative(self.encoder_step),
        }
    }
}

/// Follows CSP setpoints. Positions are INT32 counts that wrap; the loop works on wrapped
/// differences, so a spindle crossing 2^31 sees no jump.
#[derive(Clone, Debug)]
pub struct AxisModel {
    delay: VecDeque<i32>,
    dynamics: DriveDynamics,
    /// True position, nearest whole count (unwrapped: the encoder's steps are taken on it).
    position: i64,
    /// Sub-count remainder of the true position, in [-0.5, 0.5].
    frac: f64,
    /// What the encoder reports (0x6064), wrapping.
    reported: i32,
    /// Counts per cycle moved in the last step.
    velocity: f64,
    demand: i32,
    /// (dt, 1 − e^(−2π·f·dt)) of the last step: exp() once per period change, not per cycle.
    gain: (f64, f64),
}

impl AxisModel {
    /// A motor standing at `position`.
    pub fn new(dynamics: DriveDynamics, position: i32) -> AxisModel {
        let dynamics = dynamics.sanitised();
        let mut m = AxisModel {
            delay: VecDeque::with_capacity(dynamics.delay_cycles as usize + 1),
            dynamics,
            position: position as i64,
            frac: 0.0,
            reported: position,
            velocity: 0.0,
            demand: position,
            gain: (0.0, 1.0),
        };
        m.report();
        m.hold();
        m
    }

    /// The dynamics this model runs with.
    pub fn dynamics(&self) -> DriveDynamics {
        self.dynamics
    }

    /// Actual position (0x6064), as the encoder reports it.
    pub fn actual(&self) -> i32 {
        self.reported
    }

    /// Position demand the loop is tracking (0x6062): the setpoint after the pure delay.
    pub fn demand(&self) -> i32 {
        self.demand
    }

    /// Following error demand − actual, wrapped (0x60F4).
    pub fn following_error(&self) -> i32 {
        self.demand.wrapping_sub(self.reported)
    }

    /// Velocity in counts per cycle.
    pub fn velocity(&self) -> f64 {
        self.velocity
    }

    /// Power stage off or holding: the delay line fills with the actual position so that a
    /// later enable starts from where the motor is, and velocity is zero.
    pub fn hold(&mut self) {
        self.rest_demand();
        self.velocity = 0.0;
    }

    /// The demand and the delay line at the reported position (no following error).
    fn rest_demand(&mut self) {
        self.delay.clear();
        for _ in 0..self.dynamics.delay_cycles {
            self.delay.push_back(self.reported);
        }
        self.demand = self.reported;
    }

    /// One cycle of CSP following towards `target`, with the cycle time `dt_s`.
    pub fn follow(&mut self, target: i32, dt_s: f64) {
        self.delay.push_back(target);
        let demand = self.delay.pop_front().unwrap_or(target);
        let demand_step = demand.wrapping_sub(self.demand) as f64;
        self.demand = demand;
        // The loop sees the encoder, which lags the true position by up to one step.
        let err = demand.wrapping_sub(self.position as i32) as f64 - self.frac + self.encoder_lag();
        let bw = self.dynamics.bandwidth_hz;
        let step = if bw == 0.0 || dt_s <= 0.0 {
            err
        } else {
            if self.gain.0 != dt_s {
                let alpha = 1.0 - (-2.0 * std::f64::consts::PI * bw * dt_s).exp();
                self.gain = (dt_s, alpha);
            }
            // Feedforward moves by its share of the demand's step; the P loop (exact
            // discretisation of Kv over one period) closes what remains.
            let ff = self.dynamics.feedforward * demand_step;
            ff + (err - ff) * self.gain.1
        };
        let step = self.limited(step, dt_s);
        self.advance(step);
    }

    /// `step` (counts this cycle) within the acceleration and velocity limits.
    fn limited(&self, step: f64, dt_s: f64) -> f64 {
        let d = &self.dynamics;
        let mut step = step;
        if d.max_acceleration > 0.0 && dt_s > 0.0 {
            let dv = d.max_acceleration * dt_s * dt_s;
            step = step.clamp(self.velocity - dv, self.velocity + dv);
        }
        if d.max_velocity > 0.0 && dt_s > 0.0 {
            let vm = d.max_velocity * dt_s;
            step = step.clamp(-vm, vm);
        }
        step
    }

    /// The true (unquantised) position, counts: where the switches and index pulses are
    /// looked for.
    pub fn true_position(&self) -> f64 {
        self.position as f64 + self.frac
    }

    /// Moves by `step` counts this cycle, the drive's own motion (homing): no setpoint, no
    /// following error (the demand follows the actual position).
    pub fn drive_by(&mut self, step: f64) {
        self.advance(step);
        self.rest_demand();
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
        self.rest_demand();
        next == 0.0
    }

    fn advance(&mut self, step: f64) {
        let total = self.frac + step;
        let whole = total.round();
        // Whole counts can exceed i64 only for absurd steps; the cast saturates.
        self.position = self.position.wrapping_add(whole as i64);
        self.frac = total - whole;
        self.velocity = step;
        self.report();
    }

    /// How far the encoder's reading is behind the true position (0 ≤ lag < one step).
    fn encoder_lag(&self) -> f64 {
        let q = self.dynamics.encoder_step;
        if q == 0.0 {
            return 0.0;
        }
        let p = self.position as f64 + self.frac;
        p - (p / q).floor() * q
    }

    /// Sets 0x6064 from the true position: the nearest count, or the encoder's last step.
    fn report(&mut self) {
        self.reported = if self.dynamics.encoder_step == 0.0 {
            self.position as i32
        } else {
            let below = (self.frac - self.encoder_lag()).round() as i64;
            self.position.wrapping_add(below) as i32
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ideal_follows_exactly_and_wraps() {
        let mut m = AxisModel::new(DriveDynamics::first_order(0, 0.0), i32::MAX - 5);
        m.follow(i32::MAX, 0.001);
        assert_eq!(m.actual(), i32::MAX);
        m.follow(i32::MAX.wrapping_add(10), 0.001);
        assert_eq!(m.actual(), i32::MIN + 9);
        assert_eq!(m.following_error(), 0);
        assert_eq!(m.velocity(), 10.0);
    }

    #[test]
    fn pure_delay_shifts_by_cycles() {
        let mut m = AxisModel::new(DriveDynamics::first_order(2, 0.0), 0);
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
        let mut m = AxisModel::new(DriveDynamics::first_order(0, 10.0), 0);
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
        let mut m = AxisModel::new(DriveDynamics::first_order(0, f), start);
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
        let mut m = AxisModel::new(DriveDynamics::first_order(1, 0.0), 0);
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

    fn richer(f: impl FnOnce(&mut DriveDynamics)) -> DriveDynamics {
        let mut d = DriveDynamics::first_order(0, 50.0);
        f(&mut d);
        d
    }

    /// Step response: nothing for `delay` cycles, then 63 % after one time constant.
    #[test]
    fn step_response_shows_dead_time_then_the_bandwidth() {
        for (delay, f) in [(1u32, 150.0), (2, 40.0), (3, 20.0)] {
            let mut m = AxisModel::new(DriveDynamics::first_order(delay, f), 0);
            let mut seen = vec![];
            for _ in 0..400 {
                m.follow(1_000_000, 0.001);
                seen.push(m.actual() as f64 / 1e6);
            }
            assert!(
                seen[..delay as usize].iter().all(|&x| x == 0.0),
                "{delay}: {seen:?}"
            );
            assert!(seen[delay as usize] > 0.0);
            let tau = 1000.0 / (2.0 * std::f64::consts::PI * f);
            let at_tau = seen[delay as usize - 1 + tau.round() as usize];
            assert!((at_tau - 0.632).abs() < 0.03, "{delay}/{f}: {at_tau}");
        }
    }

    #[test]
    fn velocity_and_acceleration_limits_saturate_the_step() {
        // 1e6 counts/s and 1e8 counts/s² at 1 ms: at most 1000 counts and ±100 counts per
        // cycle of change, whatever the loop asks.
        let d = richer(|d| {
            d.bandwidth_hz = 200.0;
            d.max_velocity = 1e6;
            d.max_acceleration = 1e8;
        });
        let mut m = AxisModel::new(d, 0);
        let (mut last_v, mut peak) = (0.0f64, 0.0f64);
        for k in 0..2000 {
            m.follow(200_000, 0.001);
            let v = m.velocity();
            assert!(v.abs() <= 1000.0 + 1e-9, "{k}: {v}");
            assert!(
                (v - last_v).abs() <= 100.0 + 1e-9,
                "{k}: {v} after {last_v}"
            );
            peak = peak.max(v);
            last_v = v;
        }
        assert_eq!(peak, 1000.0, "the velocity limit is reached");
        assert!((m.actual() - 200_000).abs() <= 1, "{}", m.actual());
        // Unlimited, the same loop takes 200000 · α ≈ 143000 counts in the first cycle.
        let mut free = AxisModel::new(richer(|d| d.bandwidth_hz = 200.0), 0);
        free.follow(200_000, 0.001);
        assert!(free.velocity() > 100_000.0);
    }

    #[test]
    fn the_encoder_reports_whole_steps_and_the_loop_settles_within_one() {
        let d = richer(|d| {
            d.bandwidth_hz = 100.0;
            d.encoder_step = 64.0;
        });
        let mut m = AxisModel::new(d, 0);
        let mut seen = std::collections::BTreeSet::new();
        for _ in 0..300 {
            m.follow(10_000, 0.001);
            assert_eq!(m.actual().rem_euclid(64), 0, "{}", m.actual());
            seen.insert(m.actual());
        }
        assert!(seen.len() >= 8, "moves in steps: {seen:?}");
        assert!((m.actual() - 10_000).abs() < 64, "{}", m.actual());
        // Without an encoder step the same loop reports every count it passes.
        let mut fine = AxisModel::new(richer(|d| d.bandwidth_hz = 100.0), 0);
        for _ in 0..300 {
            fine.follow(10_000, 0.001);
        }
        assert_eq!(fine.actual(), 10_000);
    }

    #[test]
    fn feedforward_removes_the_ramp_lag_in_proportion() {
        // Ramp of 100 counts per cycle: lag v(1 − α)/α without feedforward, (1 − ff) of it
        // with, none with full feedforward.
        let f = 30.0;
        let alpha = 1.0 - (-2.0 * std::f64::consts::PI * f * 0.001).exp();
        for ff in [0.0, 0.5, 1.0] {
            let mut m = AxisModel::new(
                richer(|d| {
                    d.bandwidth_hz = f;
                    d.feedforward = ff;
                }),
                0,
            );
            let mut target = 0;
            for _ in 0..1000 {
                target += 100;
                m.follow(target, 0.001);
            }
            let lag = (target - m.actual()) as f64;
            let expected = (1.0 - ff) * 100.0 * (1.0 - alpha) / alpha;
            assert!(
                (lag - expected).abs() <= 1.0,
                "ff {ff}: {lag} vs {expected}"
            );
        }
    }

    #[test]
    fn the_plain_model_is_unchanged_by_the_new_terms_at_their_defaults() {
        // The defaults are the first-order model step for step (golden fixtures rely on it).
        let mut a = AxisModel::new(DriveDynamics::first_order(1, 150.0), 17);
        let mut b = AxisModel::new(
            richer(|d| {
                d.delay_cycles = 1;
                d.bandwidth_hz = 150.0;
            }),
            17,
        );
        for k in 0..500i32 {
            let t = 17 + (k * k) % 9973;
            a.follow(t, 0.001);
            b.follow(t, 0.001);
            assert_eq!(a.actual(), b.actual());
        }
    }
}
