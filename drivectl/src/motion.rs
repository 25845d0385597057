//! `jog` and `move`: one axis in cyclic synchronous position mode through the cnc402
//! master (boot, PDO mapping, enable with target = actual), setpoints from a jerk-limited
//! profile with the config's velocity/acceleration/jerk limits, soft limits respected, and
//! Ctrl-C answered with a jerk-limited ramp to standstill before the drive is disabled.

use core::time::Duration;
use std::time::Instant as WallInstant;

use cnc402_config::AxisConfig;
use cnc402_drives::master::{Feedback, Master, MasterOptions, SafetyStop};
use cnc402_motion::profile::{
    JerkProfile, Limits, PathProfile, State, rest_to_rest, velocity_change,
};
use serde_json::json;

use crate::Ctx;
use crate::error::{CliError, Exit, Result};

/// A profile in axis coordinates: `p0 + sign · profile(t - t0)`.
#[derive(Clone, Copy, Debug)]
struct Law {
    profile: JerkProfile,
    t0: f64,
    p0: f64,
    sign: f64,
}

impl Law {
    fn at(&self, t: f64) -> State {
        let s = self.profile.sample(t - self.t0);
        State {
            s: self.p0 + self.sign * s.s,
            v: self.sign * s.v,
            a: self.sign * s.a,
        }
    }
    fn ends_at(&self) -> f64 {
        self.t0 + self.profile.duration()
    }
    /// A ramp to standstill from `from` at time `t`.
    fn stop_from(from: State, t: f64, lim: Limits) -> Law {
        Law {
            profile: velocity_change(from, 0.0, lim.acceleration, lim.jerk),
            t0: t,
            p0: 0.0,
            sign: 1.0,
        }
    }
}

pub(crate) fn axis_of(ctx: &Ctx, node: u8) -> Result<AxisConfig> {
    ctx.cfg
        .axes
        .iter()
        .find(|a| a.node == Some(node))
        .cloned()
        .ok_or_else(|| {
            CliError::usage(format!(
                "node {node} is not an axis of {} (jog/move need its limits and scaling)",
                ctx.cfg.path.display()
            ))
        })
}

pub(crate) fn limits(axis: &AxisConfig) -> Result<Limits> {
    let l = Limits {
        velocity: axis.max_velocity,
        acceleration: axis.max_acceleration,
        jerk: axis.max_jerk,
    };
    if l.is_valid() {
        Ok(l)
    } else {
        Err(CliError::new(
            Exit::Config,
            format!("axis {}: limits {l:?} are not all positive", axis.name),
        ))
    }
}

pub(crate) fn check_soft(axis: &AxisConfig, p: f64) -> Result<()> {
    if let Some((lo, hi)) = axis.soft_limits
        && !(lo..=hi).contains(&p)
    {
        return Err(CliError::usage(format!(
            "axis {}: {p} is outside the soft limits {lo}..{hi}",
            axis.name
        )));
    }
    Ok(())
}

/// A target must be a position the drive can take: INT32 counts (0x607A). Rotary axes have
/// no soft limits, so `move 4 1e12` was taken and ran for days of wrapping counts.
pub(crate) fn check_counts(axis: &AxisConfig, p: f64) -> Result<()> {
    let reach = i32::MAX as f64 / axis.counts_per_unit;
    if p.abs() > reach {
        return Err(CliError::usage(format!(
            "axis {}: {p} is beyond the drive's 32-bit position (±{reach} at {} counts per unit)",
            axis.name, axis.counts_per_unit
        )));
    }
    Ok(())
}

/// What to run: a move to a target, or a jog.
enum Plan {
    Move {
        target: f64,
    },
    Jog {
        velocity: f64,
        duration: Option<f64>,
    },
}

/// `drivectl jog NODE --velocity V [--for S]`.
pub fn jog(
    ctx: &mut Ctx,
    node: u8,
    velocity: f64,
    duration: Option<f64>,
    interrupt_after: Option<f64>,
) -> Result<()> {
    let axis = axis_of(ctx, node)?;
    let lim = limits(&axis)?;
    if !velocity.is_finite() || velocity.abs() > lim.velocity {
        return Err(CliError::usage(format!(
            "axis {}: velocity {velocity} outside ±{} (max_velocity)",
            axis.name, lim.velocity
        )));
    }
    if let Some(d) = duration
        && !(d.is_finite() && (0.0..=crate::cli::MAX_SECONDS).contains(&d))
    {
        return Err(CliError::usage(format!(
            "--for {d} is not a time in seconds 0..={}",
            crate::cli::MAX_SECONDS
        )));
    }
    run(
        ctx,
        node,
        axis,
        lim,
        Plan::Jog { velocity, duration },
        interrupt_after,
    )
}

/// `drivectl move NODE POSITION`.
pub fn move_to(ctx: &mut Ctx, node: u8, target: f64, interrupt_after: Option<f64>) -> Result<()> {
    let axis = axis_of(ctx, node)?;
    let lim = limits(&axis)?;
    if !target.is_finite() {
        return Err(CliError::usage(format!(
            "position {target} is not a number"
        )));
    }
    check_soft(&axis, target)?;
    check_counts(&axis, target)?;
    run(ctx, node, axis, lim, Plan::Move { target }, interrupt_after)
}

/// A master for the one axis, booted to Operation Enabled in cyclic synchronous position.
pub(crate) fn boot_one(ctx: &mut Ctx, node: u8, axis: &AxisConfig) -> Result<Master> {
    let mut one = ctx.cfg.clone();
    one.axes = vec![axis.clone()];
    let options = MasterOptions {
        boot_timeout: Duration::from_secs(2).max(ctx.timeout * 5),
        ..MasterOptions::default()
    };
    let mut m = Master::with_options(&one, options)
        .map_err(|e| CliError::new(Exit::Config, e.to_string()))?;
    if !ctx.json {
        ctx.say(format!(
            "{}: boot (reset communication, PDO mapping, CSP), enable",
            ctx.label(node)
        ));
    }
    m.boot(&mut ctx.link)?;
    Ok(m)
}

/// The motion law a plan starts with: a rest-to-rest move, or a ramp to the jog velocity.
fn initial_law(plan: &Plan, p0: f64, lim: Limits) -> Result<Law> {
    Ok(match *plan {
        Plan::Move { target } => {
            let d = target - p0;
            let profile = rest_to_rest(d.abs(), lim)
                .map_err(|e| CliError::usage(format!("no profile for {d}: {e:?}")))?;
            Law {
                profile,
                t0: 0.0,
                p0,
                sign: if d < 0.0 { -1.0 } else { 1.0 },
            }
        }
        Plan::Jog { velocity, .. } => Law {
            profile: velocity_change(
                State {
                    s: p0,
                    v: 0.0,
                    a: 0.0,
                },
                velocity,
                lim.acceleration,
                lim.jerk,
            ),
            t0: 0.0,
            p0: 0.0,
            sign: 1.0,
        },
    })
}

/// Why a run stops on Ctrl-C (or the tests' interrupt time).
const STOP_CTRL_C: &str = "Ctrl-C";
/// Why a jog stops before a soft limit.
const STOP_SOFT_LIMIT: &str = "soft limit ahead";

/// Whether a ramp to standstill starting at `t` on `law` would end outside the axis's soft
/// limits (none: never).
fn passes_soft_limit(law: &Law, t: f64, axis: &AxisConfig, lim: Limits) -> bool {
    let Some((lo, hi)) = axis.soft_limits else {
        return false;
    };
    let end = Law::stop_from(law.at(t), 0.0, lim).at(f64::MAX / 4.0).s;
    end > hi || end < lo
}

/// Sleeps until `t` seconds after `wall0` on the wall clock (at once if that has passed).
fn sleep_until(wall0: WallInstant, t: f64) {
    let wall = wall0.elapsed().as_secs_f64();
    if t > wall {
        std::thread::sleep(Duration::from_secs_f64(t - wall));
    }
}

/// One master cycle `t` s after `start` (bus time, wall clock) commanding `cmd`: the bus
/// advanced to that time, and on the simulator virtual time paced to the wall clock (live
/// there too).
pub(crate) fn cycle_at(
    ctx: &mut Ctx,
    m: &mut Master,
    start: (cnc402_drives::Instant, WallInstant),
    t: f64,
    cmd: f64,
) -> core::result::Result<Feedback, SafetyStop> {
    if ctx.link.sim().is_some() {
        sleep_until(start.1, t);
    }
    let when = start.0 + Duration::from_secs_f64(t);
    ctx.link.pass_until(when);
    m.cycle(&mut ctx.link, when, &[cmd])
}

/// Ten more cycles holding `cmd` after cycle `k` (each `period` s after `t_start`), the last
/// actual position into `actual`; returns the number of the last cycle.
pub(crate) fn settle(
    ctx: &mut Ctx,
    m: &mut Master,
    t_start: cnc402_drives::Instant,
    period: f64,
    mut k: u64,
    cmd: f64,
    actual: &mut f64,
) -> u64 {
    for _ in 0..10 {
        k += 1;
        let when = t_start + Duration::from_secs_f64(k as f64 * period);
        ctx.link.pass_until(when);
        if let Ok(fb) = m.cycle(&mut ctx.link, when, &[cmd]) {
            *actual = fb.actual[0];
        }
    }
    k
}

fn run(
    ctx: &mut Ctx,
    node: u8,
    axis: AxisConfig,
    lim: Limits,
    plan: Plan,
    interrupt_after: Option<f64>,
) -> Result<()> {
    let mut m = boot_one(ctx, node, &axis)?;
    let p0 = m.positions()[0];
    let period = m.period().as_secs_f64();
    let mut law = initial_law(&plan, p0, lim)?;
    let stop_at = match plan {
        Plan::Jog { duration, .. } => duration,
        Plan::Move { .. } => None,
    };
    let mut stopping = false;
    let mut interrupted = false;
    let mut soft_stop = false;
    let t_start = ctx.now();
    let wall0 = WallInstant::now();
    let mut k: u64 = 0;
    let mut last_print = -1.0f64;
    let mut result: Result<()> = Ok(());
    let mut cmd;
    let mut actual = p0;
    loop {
        k += 1;
        let t = k as f64 * period;
        // Decide on a stop (Ctrl-C, the jog time, a soft limit ahead) from the state now.
        if !stopping {
            let now_state = law.at(t);
            let why = if ctx.interrupted() || interrupt_after.is_some_and(|s| t >= s) {
                Some(STOP_CTRL_C)
            } else if stop_at.is_some_and(|d| t >= d) {
                Some("jog time over")
            } else if matches!(plan, Plan::Jog { .. })
                && passes_soft_limit(&law, t + period, &axis, lim)
            {
                Some(STOP_SOFT_LIMIT)
            } else {
                None
            };
            interrupted |= why == Some(STOP_CTRL_C);
            soft_stop |= why == Some(STOP_SOFT_LIMIT);
            if let Some(w) = why {
                if !ctx.json {
                    ctx.say(format!(
                        "  {w}: ramp to standstill from v = {:.3}",
                        now_state.v
                    ));
                }
                law = Law::stop_from(now_state, t, lim);
                stopping = true;
            }
        }
        let s = law.at(t);
        cmd = s.s;
        match cycle_at(ctx, &mut m, (t_start, wall0), t, cmd) {
            Ok(fb) => {
                actual = fb.actual[0];
                if !ctx.json && t - last_print >= 0.1 {
                    last_print = t;
                    ctx.say(format!(
                        "  t {t:7.3} s  command {cmd:10.4}  actual {actual:10.4}  following error {:.4}",
                        fb.following_error[0]
                    ));
                }
            }
            Err(stop) => {
                result = Err(CliError::state(format!(
                    "{}: safety stop: {stop}",
                    ctx.label(node)
                )));
                break;
            }
        }
        let done = t >= law.ends_at() && (stopping || matches!(plan, Plan::Move { .. }));
        if done {
            break;
        }
    }
    // Settle a few cycles at the end point, then disable.
    if result.is_ok() {
        k = settle(ctx, &mut m, t_start, period, k, cmd, &mut actual);
    }
    let fe_max = m.max_following_errors()[0];
    let disabled = m.disable(&mut ctx.link);
    let elapsed = ctx.now().saturating_since(t_start).as_secs_f64();
    // With --json an error is the one document main prints; the summary is for success.
    if ctx.json && result.is_ok() {
        ctx.emit_json(&json!({
            "node": node, "axis": axis.name.to_string(), "start": p0, "command_end": cmd,
            "actual_end": actual, "max_following_error": fe_max, "seconds": elapsed,
            "cycles": k, "interrupted": interrupted, "soft_limit_stop": soft_stop,
            "error": result.as_ref().err().map(|e| e.message.clone()),
        }));
    } else {
        ctx.say(format!(
            "{}: {} from {p0:.4} to {cmd:.4} (actual {actual:.4}) in {elapsed:.3} s, max following error {fe_max:.4}{}",
            ctx.label(node),
            if interrupted { "stopped by Ctrl-C" } else if soft_stop { "stopped before the soft limit" } else { "done" },
            if disabled.is_ok() { "; drive disabled" } else { "" }
        ));
    }
    result?;
    disabled.map_err(CliError::from)
}
