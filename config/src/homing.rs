//! The machine-reference keys of an `[[axis]]`: `homing` (CiA 402 homing mode on the drive,
//! or an absolute encoder with a stored offset), `polarity` (0x607E), `gear_ratio` (0x6091)
//! and `feed_constant` (0x6092), and the simulated machine under `sim` (switches, index
//! pulses, power-on position) that makes homing testable without hardware.

use serde::Deserialize;
use toml::Spanned;

use cia402::HomingMethod;

use crate::check::{Invalid, MAX_COUNTS, int_in};

/// How an axis gets its machine reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Homing {
    /// The drive runs CiA 402 homing mode with this method; the master waits for it.
    Drive(DriveHoming),
    /// An absolute encoder: no motion; machine position = drive position + `offset`.
    Absolute {
        /// Axis units added to the drive's position.
        offset: f64,
    },
}

/// `homing = { method = …, speed_switch = …, speed_zero = …, acceleration = …, offset = …,
/// timeout_s = … }`, in axis units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveHoming {
    pub method: HomingMethod,
    /// 0x6099:1, units/s: the search for the switch.
    pub speed_switch: f64,
    /// 0x6099:2, units/s: the search for the edge or index pulse.
    pub speed_zero: f64,
    /// 0x609A, units/s².
    pub acceleration: f64,
    /// 0x607C, units: the position the home point reads after homing.
    pub offset: f64,
    /// How long the master waits for "homing attained" before giving up, seconds.
    pub timeout_s: f64,
}

impl Homing {
    /// Whether the axis needs the drive to move (CiA 402 homing mode).
    pub fn drive(&self) -> Option<&DriveHoming> {
        match self {
            Homing::Drive(d) => Some(d),
            Homing::Absolute { .. } => None,
        }
    }
}

/// The simulated machine around a simulated drive (the `sim` keys; axis units in the motor's
/// frame, before `polarity` and homing): where the motor is at power-on, the home switch,
/// the limit switches and the encoder's index pulses.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SimMachine {
    /// `sim.power_on_position`: the motor's position at power-on (default 0).
    pub power_on_position: f64,
    /// `sim.home_switch`: the home switch's edge; active above it unless
    /// `sim.home_switch_active = "below"`.
    pub home_switch: Option<f64>,
    /// `sim.home_switch_active = "above"` (default) or `"below"`.
    pub home_switch_above: bool,
    /// `sim.limit_switches = [negative, positive]`: active beyond each.
    pub limit_switches: Option<(f64, f64)>,
    /// `sim.index_pulse_counts`: one encoder index pulse every this many counts (at count 0
    /// and its multiples in the motor's frame).
    pub index_pulse_counts: Option<u32>,
    /// `sim.inputs`: further 0x60FD bits that are always on (e.g. a closed E-stop chain).
    pub inputs: u32,
}

/// Largest homing time-out the master accepts (s): a search longer than an hour is a typo.
const MAX_TIMEOUT_S: f64 = 3600.0;
/// The time-out when none is given (s).
pub const DEFAULT_TIMEOUT_S: f64 = 60.0;

/// `homing` as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawHoming {
    method: Option<Spanned<i64>>,
    absolute: Option<Spanned<bool>>,
    speed_switch: Option<Spanned<f64>>,
    speed_zero: Option<Spanned<f64>>,
    acceleration: Option<Spanned<f64>>,
    offset: Option<Spanned<f64>>,
    timeout_s: Option<Spanned<f64>>,
}

/// The `sim` keys of the simulated machine as written (copied out of the `sim` table, which
/// refuses unknown keys and so cannot be split with `flatten`).
pub(crate) struct RawSimMachine {
    pub power_on_position: Option<Spanned<f64>>,
    pub home_switch: Option<Spanned<f64>>,
    pub home_switch_active: Option<Spanned<String>>,
    pub limit_switches: Option<Spanned<[f64; 2]>>,
    pub index_pulse_counts: Option<Spanned<i64>>,
    pub inputs: Option<Spanned<i64>>,
}

/// What the homing checks need to know of the axis.
pub(crate) struct AxisScale {
    pub k: usize,
    pub counts_per_unit: f64,
    pub max_velocity: f64,
}

fn finite(v: &Spanned<f64>, key: String) -> Result<f64, Invalid> {
    let x = *v.get_ref();
    if x.is_finite() {
        Ok(x)
    } else {
        Err((v.span(), key, format!("must be a finite number, got {x}")))
    }
}

/// A position in axis units whose count fits the drive's INT32 position.
fn position(v: &Spanned<f64>, key: String, cpu: f64) -> Result<f64, Invalid> {
    let x = finite(v, key.clone())?;
    if (x * cpu).abs() > MAX_COUNTS {
        return Err((
            v.span(),
            key,
            format!("{x} is beyond the drive's 32-bit position at this scale"),
        ));
    }
    Ok(x)
}

/// A speed in units/s: positive, at most `max`, and at least 1 count/s (0x6099 is UNSIGNED32
/// counts/s).
fn speed(v: &Spanned<f64>, key: String, cpu: f64, max: f64) -> Result<f64, Invalid> {
    let x = *v.get_ref();
    let counts = x * cpu;
    if !(x.is_finite() && x > 0.0 && x <= max && counts >= 1.0 && counts <= u32::MAX as f64) {
        return Err((
            v.span(),
            key,
            format!("must be positive, at least 1 count/s and at most {max} (the axis's), got {x}"),
        ));
    }
    Ok(x)
}

impl RawHoming {
    /// `homing` of axis `a`: a supported method with its speeds, or `absolute = true` with
    /// only an offset.
    pub(crate) fn validate(
        &self,
        span: std::ops::Range<usize>,
        a: &AxisScale,
    ) -> Result<Homing, Invalid> {
        let key = |f: &str| format!("axis[{}].homing{f}", a.k);
        let cpu = a.counts_per_unit;
        let offset = match &self.offset {
            Some(v) => position(v, key(".offset"), cpu)?,
            None => 0.0,
        };
        if self.absolute.as_ref().is_some_and(|v| *v.get_ref()) {
            let motion_key = [
                (self.method.as_ref().map(|v| v.span()), "method"),
                (self.speed_switch.as_ref().map(|v| v.span()), "speed_switch"),
                (self.speed_zero.as_ref().map(|v| v.span()), "speed_zero"),
                (self.acceleration.as_ref().map(|v| v.span()), "acceleration"),
                (self.timeout_s.as_ref().map(|v| v.span()), "timeout_s"),
            ]
            .into_iter()
            .find_map(|(s, f)| s.map(|s| (s, f)));
            if let Some((s, f)) = motion_key {
                return Err((
                    s,
                    key(&format!(".{f}")),
                    "an absolute encoder is not homed by motion: give only `offset`".into(),
                ));
            }
            return Ok(Homing::Absolute { offset });
        }
        let Some(m) = &self.method else {
            return Err((
                span,
                key(".method"),
                format!(
                    "missing: a CiA 402 homing method ({}), or absolute = true",
                    HomingMethod::supported_list()
                ),
            ));
        };
        let n = *m.get_ref();
        let method = i8::try_from(n)
            .ok()
            .and_then(HomingMethod::new)
            .ok_or_else(|| {
                (
                    m.span(),
                    key(".method"),
                    format!(
                        "homing method {n} is not supported; supported: {}",
                        HomingMethod::supported_list()
                    ),
                )
            })?;
        let missing = |f: &str| {
            (
                span.clone(),
                key(&format!(".{f}")),
                format!("missing: {method} needs {f}"),
            )
        };
        let (speed_switch, speed_zero, acceleration) = if method.moves() {
            let sw = self
                .speed_switch
                .as_ref()
                .ok_or_else(|| missing("speed_switch"))?;
            let sw = speed(sw, key(".speed_switch"), cpu, a.max_velocity)?;
            let zero = self
                .speed_zero
                .as_ref()
                .ok_or_else(|| missing("speed_zero"))?;
            let zero = speed(zero, key(".speed_zero"), cpu, sw)?;
            let acc = self
                .acceleration
                .as_ref()
                .ok_or_else(|| missing("acceleration"))?;
            let accel = speed(acc, key(".acceleration"), cpu, f64::MAX)?;
            (sw, zero, accel)
        } else {
            (0.0, 0.0, 0.0)
        };
        let timeout_s = match &self.timeout_s {
            Some(v) => {
                let t = *v.get_ref();
                if !(t.is_finite() && t > 0.0 && t <= MAX_TIMEOUT_S) {
                    return Err((
                        v.span(),
                        key(".timeout_s"),
                        format!("must be in 0..={MAX_TIMEOUT_S} s (not 0), got {t}"),
                    ));
                }
                t
            }
            None => DEFAULT_TIMEOUT_S,
        };
        Ok(Homing::Drive(DriveHoming {
            method,
            speed_switch,
            speed_zero,
            acceleration,
            offset,
            timeout_s,
        }))
    }
}

impl RawSimMachine {
    /// The simulated machine of axis `k`.
    pub(crate) fn validate(&self, k: usize, cpu: f64) -> Result<SimMachine, Invalid> {
        let key = |f: &str| format!("axis[{k}].sim.{f}");
        let pos = |v: &Option<Spanned<f64>>, f: &str| {
            v.as_ref().map(|v| position(v, key(f), cpu)).transpose()
        };
        let home_switch_above = match &self.home_switch_active {
            None => true,
            Some(s) => match s.get_ref().as_str() {
                "above" => true,
                "below" => false,
                o => {
                    return Err((
                        s.span(),
                        key("home_switch_active"),
                        format!("expected \"above\" or \"below\", got {o:?}"),
                    ));
                }
            },
        };
        let limit_switches = match &self.limit_switches {
            None => None,
            Some(v) => {
                let [lo, hi] = *v.get_ref();
                // Beyond the soft limits, maybe beyond the drive's 32-bit position at a fine
                // scale: the simulated machine works in f64 counts.
                if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                    return Err((
                        v.span(),
                        key("limit_switches"),
                        format!(
                            "must be [negative, positive] with negative < positive, got [{lo}, {hi}]"
                        ),
                    ));
                }
                Some((lo, hi))
            }
        };
        Ok(SimMachine {
            power_on_position: pos(&self.power_on_position, "power_on_position")?.unwrap_or(0.0),
            home_switch: pos(&self.home_switch, "home_switch")?,
            home_switch_above,
            limit_switches,
            inputs: self
                .inputs
                .as_ref()
                .map(|v| int_in(v, &key("inputs"), 0, u32::MAX as i64).map(|n| n as u32))
                .transpose()?
                .unwrap_or(0),
            index_pulse_counts: self
                .index_pulse_counts
                .as_ref()
                .map(|v| {
                    int_in(v, &key("index_pulse_counts"), 1, MAX_COUNTS as i64).map(|n| n as u32)
                })
                .transpose()?,
        })
    }
}

/// `gear_ratio = [motor, shaft]` or `feed_constant = [feed, shaft]`: two UNSIGNED32 values,
/// not 0.
pub(crate) fn ratio(
    v: &Option<Spanned<[i64; 2]>>,
    key: String,
) -> Result<Option<(u32, u32)>, Invalid> {
    let Some(v) = v else { return Ok(None) };
    let [a, b] = *v.get_ref();
    let ok = |x: i64| (1..=u32::MAX as i64).contains(&x);
    if !(ok(a) && ok(b)) {
        return Err((
            v.span(),
            key,
            format!("must be two whole numbers 1..={}, got [{a}, {b}]", u32::MAX),
        ));
    }
    Ok(Some((a as u32, b as u32)))
}

/// `polarity = "normal"` (default) or `"inverted"`: whether 0x607E inverts position and
/// velocity.
pub(crate) fn polarity(v: &Option<Spanned<String>>, key: String) -> Result<bool, Invalid> {
    match v {
        None => Ok(false),
        Some(s) => match s.get_ref().as_str() {
            "normal" => Ok(false),
            "inverted" => Ok(true),
            o => Err((
                s.span(),
                key,
                format!("expected \"normal\" or \"inverted\", got {o:?}"),
            )),
        },
    }
}
