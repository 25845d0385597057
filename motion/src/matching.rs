//! Dynamic matching of coupled axes (a rigid tap's tool axis and spindle, the contouring
//! axes a config names): each axis's setpoints are shaped so that, through its own drive, it
//! lags exactly like the slowest axis of its set — the largest dead time and the lowest
//! closed-loop bandwidth of the master's drive models. Fixed-size state, no allocation: it
//! runs in the 1 ms loop.

use cnc402_config::{DriveModel, MAX_MODEL_DELAY_CYCLES};

const DELAY_LEN: usize = MAX_MODEL_DELAY_CYCLES as usize + 1;

/// The first-order loop's per-cycle gain 1 − e^(−2π·f·T) (1 for an ideal loop, f = 0): the
/// simulated drive's and the model's discrete step y += a·(u − y).
fn loop_gain(bandwidth_hz: f64, period_s: f64) -> f64 {
    if bandwidth_hz > 0.0 {
        1.0 - (-2.0 * std::f64::consts::PI * bandwidth_hz * period_s).exp()
    } else {
        1.0
    }
}

/// The model every axis of a coupled set is matched to: the largest dead time and the lowest
/// bandwidth of `models` (an ideal loop, 0 Hz, is the fastest).
pub fn slowest(models: &[DriveModel]) -> Option<DriveModel> {
    let delay_cycles = models.iter().map(|m| m.delay_cycles).max()?;
    let bandwidth_hz = models
        .iter()
        .map(|m| m.bandwidth_hz)
        .filter(|&b| b > 0.0)
        .fold(0.0, |lo: f64, b| if lo == 0.0 { b } else { lo.min(b) });
    Some(DriveModel {
        delay_cycles,
        bandwidth_hz,
    })
}

/// Cycles after which a shaper matching to `target` has caught up with an input that stopped
/// changing, to 1e-13 of the step it lagged by: the delay line empties, then the target's
/// lag decays by 1 − gain a cycle (30 natural time constants). A bound for the loop: the
/// shaped setpoints of a set at rest reach the commanded ones within it.
pub fn settling_cycles(target: DriveModel, period_s: f64) -> u32 {
    let pole = 1.0 - loop_gain(target.bandwidth_hz, period_s);
    let lag = if pole > 0.0 {
        (30.0 / -pole.ln()).ceil().min(1e6) as u32
    } else {
        0
    };
    target.delay_cycles + 2 + lag
}

/// The shaping filter of one axis: `extra` cycles of delay, then `F_target / F_own` — the
/// inverse of the axis's own first-order loop (a causal lead, since the loop passes part of
/// a step in the same cycle) followed by the target's first-order lag. Through the drive
/// (`z^-d_own · F_own`) the axis then moves as `z^-d_target · F_target`.
#[derive(Clone, Copy, Debug)]
pub struct AxisShaper {
    extra: usize,
    own_gain: f64,
    target_gain: f64,
    /// The last `extra + 1` inputs (ring); positions relative to `anchor`.
    line: [f64; DELAY_LEN],
    head: usize,
    /// The delayed input of the previous cycle (for the lead).
    prev_delayed: f64,
    /// The output of the previous cycle (for the lag).
    out: f64,
    anchor: f64,
}

impl AxisShaper {
    /// A shaper matching `own` to `target` (`target` at least as slow: see [`slowest`]) at
    /// `period_s`, standing at `pos`.
    pub fn new(own: DriveModel, target: DriveModel, period_s: f64, pos: f64) -> AxisShaper {
        let extra = target.delay_cycles.saturating_sub(own.delay_cycles) as usize;
        AxisShaper {
            extra: extra.min(DELAY_LEN - 1),
            own_gain: loop_gain(own.bandwidth_hz, period_s),
            target_gain: loop_gain(target.bandwidth_hz, period_s),
            line: [0.0; DELAY_LEN],
            head: 0,
            prev_delayed: 0.0,
            out: 0.0,
            anchor: pos,
        }
    }

    /// Whether the shaper passes its input through unchanged (same model as the target).
    pub fn is_identity(&self) -> bool {
        self.extra == 0 && self.own_gain == self.target_gain
    }

    /// The shaped setpoint for this cycle's path setpoint `x`.
    pub fn shape(&mut self, x: f64) -> f64 {
        if self.is_identity() {
            return x;
        }
        self.line[self.head] = x - self.anchor;
        let delayed = self.line[(self.head + DELAY_LEN - self.extra) % DELAY_LEN];
        self.head = (self.head + 1) % DELAY_LEN;
        // The input that makes the own loop's output equal `delayed`.
        let lead = (delayed - (1.0 - self.own_gain) * self.prev_delayed) / self.own_gain;
        self.prev_delayed = delayed;
        self.out += self.target_gain * (lead - self.out);
        self.out + self.anchor
    }

    /// Whether the input has stood at `x` for the whole delay line and the output is within
    /// `tolerance` of it: the shaper can be left without a visible step.
    pub fn settled_at(&self, x: f64, tolerance: f64) -> bool {
        let rel = x - self.anchor;
        (0..=self.extra).all(|k| self.line[(self.head + DELAY_LEN - 1 - k) % DELAY_LEN] == rel)
            && self.prev_delayed == rel
            && (self.out - rel).abs() <= tolerance
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(delay_cycles: u32, bandwidth_hz: f64) -> DriveModel {
        DriveModel {
            delay_cycles,
            bandwidth_hz,
        }
    }

    /// A drive as the simulator models it: a pure delay, then y += a·(u − y).
    struct Drive {
        line: Vec<f64>,
        gain: f64,
        y: f64,
    }
    impl Drive {
        fn new(m: DriveModel) -> Drive {
            Drive {
                line: vec![0.0; m.delay_cycles as usize],
                gain: loop_gain(m.bandwidth_hz, 0.001),
                y: 0.0,
            }
        }
        fn follow(&mut self, u: f64) -> f64 {
            self.line.push(u);
            let d = self.line.remove(0);
            self.y += self.gain * (d - self.y);
            self.y
        }
    }

    #[test]
    fn the_slowest_takes_the_largest_delay_and_the_lowest_bandwidth() {
        let s = slowest(&[model(1, 150.0), model(2, 400.0), model(0, 0.0)]).unwrap();
        assert_eq!(s, model(2, 150.0));
        assert_eq!(slowest(&[model(0, 0.0)]).unwrap(), model(0, 0.0));
        assert!(slowest(&[]).is_none());
    }

    #[test]
    fn a_shaped_fast_drive_moves_exactly_like_the_slow_one() {
        for (fast, slow) in [
            (model(1, 150.0), model(2, 40.0)),
            (model(0, 0.0), model(3, 25.0)),
            (model(2, 300.0), model(2, 300.0)),
        ] {
            let target = slowest(&[fast, slow]).unwrap();
            let mut shaper = AxisShaper::new(fast, target, 0.001, 5.0);
            let (mut a, mut b) = (Drive::new(fast), Drive::new(slow));
            let mut worst: f64 = 0.0;
            for k in 0..2000 {
                // A jerky ramp up, a reversal and a stop.
                let x = match k {
                    0..400 => 0.0001 * (k * k) as f64,
                    400..1200 => 16.0 - 0.02 * (k - 400) as f64,
                    _ => 0.0,
                };
                let ya = a.follow(shaper.shape(x + 5.0) - 5.0);
                let yb = b.follow(x);
                worst = worst.max((ya - yb).abs());
            }
            assert!(worst < 1e-9, "{fast:?} vs {slow:?}: {worst}");
            assert!(shaper.settled_at(5.0, 1e-9));
        }
    }

    #[test]
    fn a_rested_input_is_caught_up_within_the_settling_cycles() {
        for (own, target) in [
            (model(1, 150.0), model(2, 40.0)),
            (model(0, 0.0), model(16, 1.0)),
            (model(0, 0.0), model(3, 0.0)),
        ] {
            let n = settling_cycles(target, 0.001);
            let mut s = AxisShaper::new(own, target, 0.001, 0.0);
            // A 1 m step: the largest lag a set could be left with at rest.
            let mut k = 0;
            while !s.settled_at(1000.0, 1e-8) {
                s.shape(1000.0);
                k += 1;
                assert!(k <= n, "{own:?} -> {target:?}: not caught up in {n} cycles");
            }
        }
        assert_eq!(settling_cycles(model(3, 0.0), 0.001), 5);
    }

    #[test]
    fn equal_models_pass_setpoints_through_unchanged() {
        let m = model(1, 150.0);
        let mut s = AxisShaper::new(m, m, 0.001, 1.0e6);
        assert!(s.is_identity());
        for x in [1.0e6, 1.0e6 + 0.123, 1.0e6 + 7.5, 1.0e6 - 3.25] {
            assert_eq!(s.shape(x), x);
        }
    }
}
