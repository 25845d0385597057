//! `identify NODE`: measures a drive's dead time and closed position loop bandwidth (the
//! master's `dynamics` model) from a small test motion in CSP. The axis strokes out by the
//! amplitude and back with the config's jerk-limited profile, 0x6064 is recorded against
//! the setpoint of every cycle, and a first-order-plus-dead-time model is fitted by least
//! squares of the simulated output over every candidate dead time (`fit`, pure).

use std::time::Instant as WallInstant;

use cia402::{State, Statusword, objects as obj};
use cnc402_config::{AxisConfig, MAX_MODEL_DELAY_CYCLES};
use cnc402_drives::master::emcy_text;
use cnc402_motion::profile::{JerkProfile, Limits, PathProfile, rest_to_rest};
use serde_json::json;

use crate::Ctx;
use crate::error::{CliError, Result};
use crate::motion::{axis_of, boot_one, check_counts, check_soft, cycle_at, limits, settle};

/// Longest test motion (s): identification needs a second or two, never minutes.
pub const MAX_DURATION_S: f64 = 10.0;
/// Rest at each end of a stroke (s): the drive settles and the record holds both the
/// transient and its end.
const DWELL_S: f64 = 0.05;
/// Bandwidths searched (Hz): the master's model takes 1 Hz and up; beyond 10⁴ Hz a loop at
/// a 1 ms period is ideal.
const MIN_BANDWIDTH_HZ: f64 = 1.0;
const MAX_BANDWIDTH_HZ: f64 = 1e4;
/// Golden-section steps per dead time: the bracket shrinks to 0.618^60 of its log width.
const SEARCH_STEPS: usize = 60;
/// A loop whose fitted α = 1 − e^(−2π·f·T) is this close to 1 follows each setpoint within
/// the cycle: reported as ideal (bandwidth 0).
const IDEAL_ALPHA: f64 = 0.999;

/// A fitted model of the drive: dead time, bandwidth (0 = ideal), and how well it fits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    pub delay_cycles: u32,
    pub bandwidth_hz: f64,
    /// Root mean square of actual − model over the recorded samples (axis units).
    pub rms_residual: f64,
}

/// The record: per cycle j, the setpoint the drive took at SYNC j and the actual position
/// after it (`None` where no sample answers that SYNC).
#[derive(Clone, Debug, Default)]
pub struct Record {
    pub start: f64,
    pub commands: Vec<f64>,
    pub actual: Vec<Option<f64>>,
}

impl Record {
    /// Stores the setpoint of cycle `j` (in order) and a sample of the actual position
    /// after SYNC `j - 1 - age` when fresh.
    fn push(&mut self, command: f64, sample: Option<(u32, f64)>) {
        self.commands.push(command);
        self.actual.push(None);
        if let Some((age, actual)) = sample {
            let j = self.commands.len() - 1;
            if let Some(at) = j.checked_sub(1 + age as usize) {
                self.actual[at] = Some(actual);
            }
        }
    }
}

/// The sum of squared output errors of a dead time `delay` and gain `alpha` over `rec`.
fn cost(rec: &Record, delay: usize, alpha: f64) -> f64 {
    let mut y = rec.start;
    let mut sum = 0.0;
    for (j, actual) in rec.actual.iter().enumerate() {
        let u = j.checked_sub(delay).map_or(rec.start, |i| rec.commands[i]);
        y += alpha * (u - y);
        if let Some(a) = actual {
            sum += (a - y) * (a - y);
        }
    }
    sum
}

fn alpha_of(bandwidth_hz: f64, period_s: f64) -> f64 {
    1.0 - (-2.0 * std::f64::consts::PI * bandwidth_hz * period_s).exp()
}

/// The best first-order-plus-dead-time model of `rec` (period `period_s`): for each dead
/// time 0..=16 cycles a golden-section search of the bandwidth on a log scale, then the
/// dead time with the least squared error. `None` when nothing was sampled.
pub fn fit(rec: &Record, period_s: f64) -> Option<Fit> {
    let samples = rec.actual.iter().flatten().count();
    if samples == 0 || period_s.is_nan() || period_s <= 0.0 {
        return None;
    }
    let cost_at = |delay: usize, log_f: f64| cost(rec, delay, alpha_of(log_f.exp(), period_s));
    let mut best: Option<(f64, usize, f64)> = None;
    for delay in 0..=MAX_MODEL_DELAY_CYCLES as usize {
        let (mut lo, mut hi) = (MIN_BANDWIDTH_HZ.ln(), MAX_BANDWIDTH_HZ.ln());
        let g = (5f64.sqrt() - 1.0) / 2.0;
        let (mut a, mut b) = (hi - g * (hi - lo), lo + g * (hi - lo));
        let (mut ca, mut cb) = (cost_at(delay, a), cost_at(delay, b));
        for _ in 0..SEARCH_STEPS {
            if ca <= cb {
                hi = b;
                (b, cb) = (a, ca);
                a = hi - g * (hi - lo);
                ca = cost_at(delay, a);
            } else {
                lo = a;
                (a, ca) = (b, cb);
                b = lo + g * (hi - lo);
                cb = cost_at(delay, b);
            }
        }
        let log_f = (lo + hi) / 2.0;
        let c = cost_at(delay, log_f);
        if best.is_none_or(|(bc, _, _)| c < bc) {
            best = Some((c, delay, log_f.exp()));
        }
    }
    let (c, delay, f) = best?;
    Some(Fit {
        delay_cycles: delay as u32,
        bandwidth_hz: if alpha_of(f, period_s) >= IDEAL_ALPHA {
            0.0
        } else {
            f
        },
        rms_residual: (c / samples as f64).sqrt(),
    })
}

/// The test motion: strokes from `start` by `amplitude` and back, each a rest-to-rest
/// profile followed by a dwell, repeated to fill the duration (at least one).
struct Strokes {
    profile: JerkProfile,
    start: f64,
    amplitude: f64,
    count: u32,
}

impl Strokes {
    fn half(&self) -> f64 {
        self.profile.duration() + DWELL_S
    }
    fn ends_at(&self) -> f64 {
        2.0 * self.half() * self.count as f64
    }
    fn at(&self, t: f64) -> f64 {
        if t >= self.ends_at() {
            return self.start;
        }
        let phase = t.rem_euclid(2.0 * self.half());
        let (out, s) = if phase < self.half() {
            (true, phase)
        } else {
            (false, phase - self.half())
        };
        let frac = (self.profile.sample(s).s / self.amplitude.abs()).clamp(0.0, 1.0);
        let frac = if out { frac } else { 1.0 - frac };
        self.start + self.amplitude * frac
    }
}

/// What `identify` was asked for.
#[derive(Clone, Copy, Debug)]
pub struct Request {
    pub node: u8,
    /// Stroke in axis units; sign = direction; `None`: the axis's following error window.
    pub amplitude: Option<f64>,
    pub duration_s: f64,
}

/// The drive must be OPERATION ENABLED (the operator enabled it) and not in FAULT; nothing
/// moves otherwise.
fn check_enabled(ctx: &mut Ctx, node: u8) -> Result<()> {
    let id = crate::node_id(node)?;
    let sw = Statusword(ctx.with_sdo(|sdo| sdo.read_u16(id, obj::STATUSWORD, 0))?);
    match sw.state() {
        Some(State::OperationEnabled) => Ok(()),
        Some(s) if s.is_fault() => Err(CliError::state(format!(
            "{}: in {} ({}): identify refused, nothing moved; clear the cause and \
             `drivectl fault-reset {node}`, then `drivectl enable {node}`",
            ctx.label(node),
            s.name(),
            match ctx.with_sdo(|sdo| sdo.read_u16(id, obj::ERROR_CODE, 0)) {
                Ok(c) => format!("error code 0x603F = {c:#06x} ({})", emcy_text(c)),
                Err(e) => format!("error code unreadable: {e}"),
            }
        ))),
        s => Err(CliError::state(format!(
            "{}: statusword {:#06x} ({}), not OPERATION ENABLED: identify moves only a drive \
             that is enabled (`drivectl enable {node}`); nothing moved",
            ctx.label(node),
            sw.0,
            s.map_or("no CiA 402 state", State::name)
        ))),
    }
}

/// The stroke `req` asks for on `axis` (a usage error when it is no distance or the duration is
/// out of range), checked before the bus is asked anything.
fn amplitude_of(req: &Request, axis: &AxisConfig) -> Result<f64> {
    let amplitude = req.amplitude.unwrap_or(axis.following_error_window);
    if !(amplitude.is_finite() && amplitude != 0.0) {
        return Err(CliError::usage(format!(
            "--amplitude {amplitude}: must be a non-zero distance in axis units"
        )));
    }
    if !(req.duration_s.is_finite() && (0.0..=MAX_DURATION_S).contains(&req.duration_s)) {
        return Err(CliError::usage(format!(
            "--duration {}: must be 0..={MAX_DURATION_S} s",
            req.duration_s
        )));
    }
    Ok(amplitude)
}

/// The strokes for `req` on `axis` from `start`, refused (a usage error) outside the axis limits.
fn plan(req: &Request, axis: &AxisConfig, lim: Limits, start: f64) -> Result<Strokes> {
    let amplitude = amplitude_of(req, axis)?;
    let end = start + amplitude;
    check_soft(axis, end).map_err(|e| {
        CliError::usage(format!(
            "{} (the stroke from {start} by {amplitude}; try the other sign or a smaller \
             --amplitude)",
            e.message
        ))
    })?;
    check_counts(axis, end)?;
    let profile = rest_to_rest(amplitude.abs(), lim)
        .map_err(|e| CliError::usage(format!("no profile for {amplitude}: {e:?}")))?;
    let mut s = Strokes {
        profile,
        start,
        amplitude,
        count: 1,
    };
    s.count = ((req.duration_s / (2.0 * s.half())).floor() as u32).max(1);
    Ok(s)
}

/// `drivectl identify NODE [--amplitude A] [--duration S]`.
pub fn identify(ctx: &mut Ctx, req: Request) -> Result<()> {
    let node = req.node;
    let axis = axis_of(ctx, node)?;
    let lim = limits(&axis)?;
    // Arguments first (nothing on the bus), then the drive's state, then the start position.
    amplitude_of(&req, &axis)?;
    check_enabled(ctx, node)?;
    let start = read_position(ctx, node, &axis)?;
    let strokes = plan(&req, &axis, lim, start)?;
    let mut m = boot_one(ctx, node, &axis)?;
    let period = m.period().as_secs_f64();
    let start = m.positions()[0];
    let strokes = Strokes { start, ..strokes };
    let mut rec = Record {
        start,
        ..Record::default()
    };
    let t_start = ctx.now();
    let wall0 = WallInstant::now();
    let mut k: u64 = 0;
    let mut result = Ok(());
    let mut actual = start;
    let mut cmd = start;
    let mut interrupted = false;
    // Record through the motion and long enough after it for the slowest model to settle.
    let end = strokes.ends_at() + DWELL_S;
    while (k as f64) * period < end {
        k += 1;
        let t = k as f64 * period;
        if ctx.interrupted() {
            interrupted = true;
            break;
        }
        cmd = strokes.at(t);
        match cycle_at(ctx, &mut m, (t_start, wall0), t, cmd) {
            Ok(fb) => {
                actual = fb.actual[0];
                rec.push(cmd, fb.fresh[0].then_some((fb.age[0], actual)));
            }
            Err(stop) => {
                result = Err(CliError::state(format!(
                    "{}: safety stop during identify: {stop}",
                    ctx.label(node)
                )));
                break;
            }
        }
    }
    // Hold the last setpoint a few cycles before disabling (on Ctrl-C too: a stroke is
    // short and slow, the drive's loop stops it within them).
    if result.is_ok() {
        settle(ctx, &mut m, t_start, period, k, cmd, &mut actual);
    }
    let disabled = m.disable(&mut ctx.link);
    if interrupted {
        result = Err(CliError::state(format!(
            "{}: Ctrl-C: identify stopped at {actual:.4}, no model",
            ctx.label(node)
        )));
    }
    result?;
    disabled.map_err(CliError::from)?;
    let fit = fit(&rec, period).ok_or_else(|| {
        CliError::state(format!(
            "{}: no position samples during the test motion",
            ctx.label(node)
        ))
    })?;
    report(ctx, &axis, &strokes, rec.commands.len(), fit);
    Ok(())
}

/// 0x6064 in axis units, before anything moves.
fn read_position(ctx: &mut Ctx, node: u8, axis: &AxisConfig) -> Result<f64> {
    let id = crate::node_id(node)?;
    let counts = ctx.with_sdo(|sdo| sdo.read_i32(id, cia402::objects::POSITION_ACTUAL, 0))?;
    Ok(counts as f64 / axis.counts_per_unit)
}

fn report(ctx: &Ctx, axis: &AxisConfig, strokes: &Strokes, cycles: usize, fit: Fit) {
    let node = axis.node.unwrap_or(0);
    let bw = (fit.bandwidth_hz * 10.0).round() / 10.0;
    if ctx.json {
        ctx.emit_json(&json!({
            "node": node, "axis": axis.name.to_string(), "delay_cycles": fit.delay_cycles,
            "bandwidth_hz": bw, "rms_residual": fit.rms_residual,
            "amplitude": strokes.amplitude, "strokes": strokes.count, "cycles": cycles,
        }));
        return;
    }
    let tau = if fit.bandwidth_hz > 0.0 {
        format!(
            "time constant {:.2} ms",
            1e3 / (2.0 * std::f64::consts::PI * fit.bandwidth_hz)
        )
    } else {
        "ideal: follows each setpoint within the cycle".into()
    };
    ctx.say(format!(
        "{}: {} strokes of {} over {cycles} cycles",
        ctx.label(node),
        strokes.count * 2,
        strokes.amplitude
    ));
    ctx.say(format!(
        "  model: dead time {} cycles, closed position loop {bw} Hz ({tau}); rms residual {:.3e}",
        fit.delay_cycles, fit.rms_residual
    ));
    ctx.say(format!(
        "  paste into [[axis]] {} of the config:\n  dynamics = {{ delay_cycles = {}, bandwidth_hz = {bw:.1} }}",
        axis.name, fit.delay_cycles
    ));
}

#[cfg(test)]
mod tests {
    use super::*;
    use cnc402_drives::sim::{AxisModel, DriveDynamics};

    /// The record of the simulated drive `d` under `commands` (counts, 1 ms), as identify
    /// takes it: every sample fresh and one cycle old.
    fn record(d: DriveDynamics, commands: &[f64]) -> Record {
        let mut m = AxisModel::new(d, 0);
        let mut rec = Record::default();
        for &c in commands {
            let before = m.actual() as f64;
            m.follow(c.round() as i32, 0.001);
            rec.push(c, Some((0, before)));
        }
        rec
    }

    fn stroke_commands() -> Vec<f64> {
        let lim = Limits {
            velocity: 250.0,
            acceleration: 2000.0,
            jerk: 50000.0,
        };
        let s = Strokes {
            profile: rest_to_rest(0.5, lim).unwrap(),
            start: 0.0,
            amplitude: 0.5,
            count: 3,
        };
        (1..=(s.ends_at() * 1000.0) as usize + 50)
            .map(|k| s.at(k as f64 * 1e-3) * 10_000.0)
            .collect()
    }

    #[test]
    fn the_fit_finds_dead_time_and_bandwidth_of_first_order_drives() {
        let cmds = stroke_commands();
        for (delay, f) in [(0, 300.0), (1, 150.0), (2, 40.0), (3, 20.0), (5, 8.0)] {
            let rec = record(DriveDynamics::first_order(delay, f), &cmds);
            let fit = fit(&rec, 0.001).unwrap();
            assert_eq!(fit.delay_cycles, delay, "{fit:?}");
            assert!((fit.bandwidth_hz / f - 1.0).abs() < 0.05, "{f}: {fit:?}");
        }
    }

    #[test]
    fn an_ideal_drive_is_reported_ideal() {
        let rec = record(DriveDynamics::first_order(2, 0.0), &stroke_commands());
        let fit = fit(&rec, 0.001).unwrap();
        assert_eq!((fit.delay_cycles, fit.bandwidth_hz), (2, 0.0), "{fit:?}");
    }

    #[test]
    fn nothing_sampled_is_no_fit() {
        let mut rec = Record::default();
        rec.push(1.0, None);
        assert_eq!(fit(&rec, 0.001), None);
    }
}
