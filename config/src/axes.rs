//! `[[axis]]`: each axis's name, kind, drive node, scaling, dynamic limits, soft limits,
//! following error supervision, reference positions and simulated dynamics. An axis is
//! checked against the bus (the master's node id) and the axes before it (names, nodes, at
//! most [`MAX_SPINDLES`] spindles, each with its own number).

use serde::Deserialize;
use toml::Spanned;

use crate::check::{Invalid, Table, int_in, positive, positive_at_most, sp, table};
use crate::homing::{self, AxisScale, Homing, RawHoming, RawSimMachine, SimMachine};
use crate::{BusConfig, MAX_AXES};

pub(crate) use crate::check::MAX_COUNTS;
/// Ceilings of the dynamic limits (units/s, /s², /s³): far beyond any machine (10 km/s,
/// 10⁵ g), low enough that the planner's products (a², v·j ≤ 10¹⁹) stay exact enough.
const MAX_VELOCITY: f64 = 1e7;
const MAX_ACCELERATION: f64 = 1e9;
const MAX_JERK: f64 = 1e12;
/// Longest ramp from rest to max_velocity the limits may ask for (s): the planner's moves
/// and stops are made of such ramps, so a longer one means absurd tick counts (and with
/// max_jerk = 1e-300, a non-finite one).
const MAX_RAMP_S: f64 = 60.0;
/// Ceiling of the simulated drive's tracking bandwidth (Hz): beyond it the loop is ideal.
const MAX_BANDWIDTH_HZ: f64 = 1e6;
/// Longest dead time the master's drive model may state (cycles): the matching delay lines
/// in the 1 ms loop are this long (fixed size, no allocation).
pub const MAX_MODEL_DELAY_CYCLES: u32 = 16;
/// Lowest closed-loop bandwidth the master's model may state (Hz), 0 (ideal) aside: a
/// slower loop lags by more than 0.16 s, which matching would copy onto every coupled axis
/// (a tap would crawl behind its path) — no drive that can tap is that slow.
pub const MIN_MODEL_BANDWIDTH_HZ: f64 = 1.0;
/// Most spindle axes a machine may have (source 001's machine: five feed axes and two
/// spindles); programs select one by number (Fanuc `P`, LinuxCNC `$`).
pub const MAX_SPINDLES: usize = 2;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AxisKind {
    /// mm
    Linear,
    /// degrees, a positioning axis
    Rotary,
    /// degrees, the spindle: position-controlled for rigid tapping, speed mode for M3/M4
    Spindle,
}

impl AxisKind {
    pub fn is_rotary(self) -> bool {
        !matches!(self, AxisKind::Linear)
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct AxisConfig {
    /// Address letter: X, Y, Z, A, B, C, U, V, W.
    pub name: char,
    pub kind: AxisKind,
    /// CANopen node id 1..=127, or `None` for a virtual axis with no drive on the bus.
    pub node: Option<u8>,
    /// Drive position counts per mm (linear) or per degree (rotary).
    pub counts_per_unit: f64,
    /// units/s
    pub max_velocity: f64,
    /// units/s²
    pub max_acceleration: f64,
    /// units/s³
    pub max_jerk: f64,
    /// Soft limits in machine coordinates (linear axes; rotary axes have none).
    pub soft_limits: Option<(f64, f64)>,
    /// Largest allowed |commanded − actual|, in units.
    pub following_error_window: f64,
    pub following_error_timeout_ms: u32,
    /// Spindle only.
    pub max_rpm: Option<f64>,
    /// Spindle only: its number 1..=[`MAX_SPINDLES`] (key `spindle`, default: 1 for the
    /// first spindle axis, 2 for the second), what a program's `P` (or `$`) selects.
    pub spindle: Option<u8>,
    /// The drive's dead time (cycles) between taking a setpoint and its position loop acting
    /// on it; the master's following error rule does not count it as error. Default 1.
    pub feedback_delay_cycles: u32,
    /// Reference positions in machine coordinates: `[0]` the first (G28; key `reference`,
    /// default 0), `[1..4]` the second to fourth (G30 P2..P4; `second_reference`,
    /// `third_reference`, `fourth_reference`; `None` when not configured).
    pub references: [Option<f64>; 4],
    /// The drive this axis must have (`identity = { vendor = …, product = …, revision_min =
    /// … }`): boot compares it with the drive's 0x1018 and refuses start-up on a mismatch.
    pub identity: Option<ExpectedIdentity>,
    /// What the master believes of the drive's dynamics (`dynamics = { delay_cycles = …,
    /// bandwidth_hz = … }`), for matching coupled axes; `None` when not given.
    pub dynamics: Option<DriveModel>,
    /// How the axis gets its machine reference (`homing = { … }`); `None`: machine position
    /// is whatever the drive reports at power-on.
    pub homing: Option<Homing>,
    /// `polarity = "inverted"`: the master writes 0x607E = 0xC0 at boot (position and
    /// velocity inverted in the drive; the master's scaling is unchanged).
    pub polarity_inverted: bool,
    /// `gear_ratio = [motor revolutions, shaft revolutions]`, written to 0x6091 at boot.
    pub gear_ratio: Option<(u32, u32)>,
    /// `feed_constant = [feed, shaft revolutions]`, written to 0x6092 at boot (the drive's
    /// position unit is then the feed's; `counts_per_unit` is in that unit).
    pub feed_constant: Option<(u32, u32)>,
    /// `limit_switch_inputs = true`: the drive's 0x60FD goes to the master in an event TPDO,
    /// and a limit switch (bit 0 or 1) stops the machine (not while the axis homes).
    pub limit_switch_inputs: bool,
    /// The drive sends its 0x60FD in TPDO3 (`limit_switch_inputs`, or `[machine]
    /// estop_input` is on it): set once the whole config is read; the load plan counts it.
    pub inputs_pdo: bool,
    /// The master sends this drive its 0x60FE:1 in RPDO3 (`[machine] outputs` has a bit on
    /// it): set once the whole config is read; the load plan counts it.
    pub outputs_pdo: bool,
    pub sim: SimDynamics,
    /// The DCF/EDS and SDO writes boot applies after its own set-up (`dcf`, `sdo`; see
    /// `commissioning`).
    pub commissioning: crate::commissioning::Commissioning,
}

/// The master's model of a drive from setpoint to actual position: a dead time of
/// `delay_cycles` setpoints, then a first-order closed position loop at `bandwidth_hz`
/// (0 = ideal). The `sim` keys are the simulator's truth; the master reads only this.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveModel {
    pub delay_cycles: u32,
    pub bandwidth_hz: f64,
}

/// The identity (0x1018) an axis's drive must report: the right device on the right node,
/// before anything is written to it (a swapped cable or a replacement drive of another model
/// would otherwise be configured and enabled with this axis's scaling).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExpectedIdentity {
    /// 0x1018:1 vendor id (CiA-assigned): must be equal.
    pub vendor: u32,
    /// 0x1018:2 product code: must be equal when given.
    pub product: Option<u32>,
    /// 0x1018:3 revision number (major in the high word, minor in the low word): must be at
    /// least this when given (a firmware the machine was commissioned with, or newer).
    pub revision_min: Option<u32>,
}

/// How the simulated drive of an axis follows its CSP setpoints: a dead time, a P position
/// loop (gain Kv = 2π·`bandwidth_hz`) with optional velocity feedforward, velocity and
/// acceleration (current) limits, and an encoder of finite resolution. With the defaults of
/// the new keys (no feedforward, no limits, one-count encoder) it is the first-order model
/// of `delay_cycles` and `bandwidth_hz` alone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimDynamics {
    /// Pure delay between a setpoint taking effect and the position loop seeing it.
    pub delay_cycles: u32,
    /// Bandwidth of the closed position loop without feedforward (Hz): the loop gain is
    /// Kv = 2π·f (1/s); 0 = ideal (actual = target). Key `bandwidth_hz`, or `kv` in 1/s.
    pub bandwidth_hz: f64,
    /// Fraction of the demand velocity fed forward to the velocity loop, 0 (off) ..= 1 (full).
    pub velocity_feedforward: f64,
    /// Largest motor speed, axis units/s; 0 = unlimited.
    pub max_velocity: f64,
    /// Largest motor acceleration (the current limit), axis units/s²; 0 = unlimited.
    pub max_acceleration: f64,
    /// Encoder resolution, axis units: 0x6064 and the position loop see the position
    /// truncated to a multiple of it; 0 = one count.
    pub encoder_resolution: f64,
    /// The machine around the motor: switches, index pulses, power-on position.
    pub machine: SimMachine,
}

impl Default for SimDynamics {
    /// The keys' defaults: 1 cycle, 150 Hz, no feedforward, no limits, one-count encoder.
    fn default() -> SimDynamics {
        SimDynamics {
            delay_cycles: 1,
            bandwidth_hz: 150.0,
            velocity_feedforward: 0.0,
            max_velocity: 0.0,
            max_acceleration: 0.0,
            encoder_resolution: 0.0,
            machine: SimMachine {
                home_switch_above: true,
                ..SimMachine::default()
            },
        }
    }
}

impl SimDynamics {
    /// The position loop gain Kv (1/s); 0 = ideal.
    pub fn kv(&self) -> f64 {
        2.0 * std::f64::consts::PI * self.bandwidth_hz
    }

    /// The first-order-plus-dead-time model this drive behaves like for the master (what
    /// `drivectl identify` should find): the dead time, and the bandwidth whose ramp lag
    /// equals the drive's, Kv·/(2π·(1 − feedforward)); 0 (ideal) with full feedforward or an
    /// ideal loop. Limits and encoder steps are not part of it (a small motion stays within
    /// them).
    pub fn equivalent_model(&self) -> DriveModel {
        let residual = 1.0 - self.velocity_feedforward;
        let bandwidth_hz = if self.bandwidth_hz == 0.0 || residual <= 0.0 {
            0.0
        } else {
            self.bandwidth_hz / residual
        };
        DriveModel {
            delay_cycles: self.delay_cycles,
            bandwidth_hz,
        }
    }
}

/// One `[[axis]]` as written, with spans.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawAxis {
    name: Spanned<String>,
    kind: Spanned<String>,
    node: Option<Spanned<i64>>,
    #[serde(rename = "virtual")]
    is_virtual: Option<Spanned<bool>>,
    counts_per_unit: Option<Spanned<f64>>,
    counts_per_rev: Option<Spanned<f64>>,
    max_velocity: Spanned<f64>,
    max_acceleration: Spanned<f64>,
    max_jerk: Spanned<f64>,
    min: Option<Spanned<f64>>,
    max: Option<Spanned<f64>>,
    following_error_window: Spanned<f64>,
    #[serde(default = "default_fe_timeout")]
    following_error_timeout_ms: Spanned<i64>,
    max_rpm: Option<Spanned<f64>>,
    spindle: Option<Spanned<i64>>,
    #[serde(default = "default_feedback_delay")]
    feedback_delay_cycles: Spanned<i64>,
    reference: Option<Spanned<f64>>,
    second_reference: Option<Spanned<f64>>,
    third_reference: Option<Spanned<f64>>,
    fourth_reference: Option<Spanned<f64>>,
    identity: Option<Spanned<RawIdentity>>,
    dynamics: Option<Spanned<RawModel>>,
    homing: Option<Spanned<RawHoming>>,
    polarity: Option<Spanned<String>>,
    gear_ratio: Option<Spanned<[i64; 2]>>,
    feed_constant: Option<Spanned<[i64; 2]>>,
    limit_switch_inputs: Option<Spanned<bool>>,
    #[serde(default, deserialize_with = "table")]
    sim: RawSim,
    dcf: Option<Spanned<String>>,
    #[serde(default)]
    sdo: Vec<Spanned<Table<crate::commissioning::RawSdoWrite>>>,
}

/// `dynamics = { delay_cycles = N, bandwidth_hz = F }` as written (both required).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawModel {
    delay_cycles: Spanned<i64>,
    bandwidth_hz: Spanned<f64>,
}

/// `identity = { vendor = 0x…, product = 0x…, revision_min = 0x… }` as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawIdentity {
    vendor: Spanned<i64>,
    product: Option<Spanned<i64>>,
    revision_min: Option<Spanned<i64>>,
}

fn default_fe_timeout() -> Spanned<i64> {
    sp(10)
}
fn default_feedback_delay() -> Spanned<i64> {
    sp(1)
}

#[derive(Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawSim {
    delay_cycles: Option<Spanned<i64>>,
    bandwidth_hz: Option<Spanned<f64>>,
    kv: Option<Spanned<f64>>,
    velocity_feedforward: Option<Spanned<f64>>,
    max_velocity: Option<Spanned<f64>>,
    max_acceleration: Option<Spanned<f64>>,
    encoder_resolution: Option<Spanned<f64>>,
    power_on_position: Option<Spanned<f64>>,
    home_switch: Option<Spanned<f64>>,
    home_switch_active: Option<Spanned<String>>,
    limit_switches: Option<Spanned<[f64; 2]>>,
    index_pulse_counts: Option<Spanned<i64>>,
    inputs: Option<Spanned<i64>>,
}

/// Checks the `[[axis]]` list in order against the bus (no axis may use
/// `bus.master_node_id`; a cycle's step must fit the wire).
pub(crate) fn validate(
    raw: &[Table<RawAxis>],
    bus: &BusConfig,
) -> Result<Vec<AxisConfig>, Invalid> {
    if raw.is_empty() {
        return Err((
            0..0,
            "axis".into(),
            "at least one [[axis]] is required".into(),
        ));
    }
    if raw.len() > MAX_AXES {
        return Err((
            raw[MAX_AXES].0.name.span(),
            format!("axis[{MAX_AXES}]"),
            format!("at most {MAX_AXES} axes"),
        ));
    }
    let mut axes: Vec<AxisConfig> = Vec::new();
    for (k, a) in raw.iter().enumerate() {
        let axis = a.0.validate(k, &axes, bus)?;
        axes.push(axis);
    }
    spindle_numbers_dense(raw, &axes)?;
    models_complete(raw, &axes)?;
    Ok(axes)
}

/// The spindles are numbered 1..=their count (each number once, checked per axis): a lone
/// spindle numbered 2 would leave a program's default spindle 1 with no axis.
fn spindle_numbers_dense(raw: &[Table<RawAxis>], axes: &[AxisConfig]) -> Result<(), Invalid> {
    let count = axes.iter().filter(|a| a.spindle.is_some()).count();
    for (k, a) in axes.iter().enumerate() {
        if let Some(n) = a.spindle
            && usize::from(n) > count
        {
            let span = raw[k]
                .0
                .spindle
                .as_ref()
                .map_or(raw[k].0.kind.span(), |s| s.span());
            return Err((
                span,
                format!("axis[{k}].spindle"),
                format!(
                    "spindle {n} on a machine with {count} spindle axis: number the spindles \
                     1..={count}"
                ),
            ));
        }
    }
    Ok(())
}

impl crate::MachineConfig {
    /// The axis of spindle `number` (1..=[`MAX_SPINDLES`]), if configured.
    pub fn spindle_axis(&self, number: u8) -> Option<usize> {
        self.axes.iter().position(|a| a.spindle == Some(number))
    }

    /// The spindle axes by number: `[0]` is spindle 1's axis, `[1]` spindle 2's.
    pub fn spindle_axes(&self) -> [Option<usize>; MAX_SPINDLES] {
        std::array::from_fn(|k| self.spindle_axis(k as u8 + 1))
    }

    /// The number of the spindle on `axis`, if it is a spindle axis.
    pub fn spindle_number(&self, axis: usize) -> Option<u8> {
        self.axes.get(axis).and_then(|a| a.spindle)
    }
}

/// A tap couples the spindle with any linear axis that has a drive: matching needs a model
/// of both, so either all of them have `dynamics` or none does.
fn models_complete(raw: &[Table<RawAxis>], axes: &[AxisConfig]) -> Result<(), Invalid> {
    let tap_axis = |a: &AxisConfig| a.node.is_some() && a.kind != AxisKind::Rotary;
    let Some(given) = axes
        .iter()
        .position(|a| tap_axis(a) && a.dynamics.is_some())
    else {
        return Ok(());
    };
    match axes
        .iter()
        .position(|a| tap_axis(a) && a.dynamics.is_none())
    {
        None => Ok(()),
        Some(k) => Err((
            raw[k].0.name.span(),
            format!("axis[{k}].dynamics"),
            format!(
                "missing: axis {} has a drive model, and a rigid tap couples the spindle with \
                 every linear axis, so each needs one to be matched (give dynamics on all or \
                 none)",
                axes[given].name
            ),
        )),
    }
}

/// A finite number in `lo..=hi`.
fn in_range(v: &Spanned<f64>, key: &str, lo: f64, hi: f64) -> Result<f64, Invalid> {
    let x = *v.get_ref();
    if x.is_finite() && (lo..=hi).contains(&x) {
        Ok(x)
    } else {
        Err((
            v.span(),
            key.to_string(),
            format!("must be a number in {lo}..={hi}, got {x}"),
        ))
    }
}

impl RawSim {
    /// The simulated drive of axis `k` (`counts_per_unit` scales the encoder check). The
    /// loop gain is given as `bandwidth_hz` or as `kv` (1/s), not both.
    fn validate(&self, k: usize, counts_per_unit: f64) -> Result<SimDynamics, Invalid> {
        let key = |f: &str| format!("axis[{k}].sim.{f}");
        let d = SimDynamics::default();
        let opt = |v: &Option<Spanned<f64>>, f: &str, hi: f64, default: f64| {
            v.as_ref()
                .map_or(Ok(default), |v| in_range(v, &key(f), 0.0, hi))
        };
        let bandwidth_hz = match (&self.bandwidth_hz, &self.kv) {
            (Some(_), Some(kv)) => {
                return Err((
                    kv.span(),
                    key("kv"),
                    "give the position loop as bandwidth_hz or as kv (= 2π·bandwidth_hz), not both"
                        .into(),
                ));
            }
            (_, Some(kv)) => {
                in_range(
                    kv,
                    &key("kv"),
                    0.0,
                    2.0 * std::f64::consts::PI * MAX_BANDWIDTH_HZ,
                )? / (2.0 * std::f64::consts::PI)
            }
            (bw, None) => opt(bw, "bandwidth_hz", MAX_BANDWIDTH_HZ, d.bandwidth_hz)?,
        };
        let encoder_resolution = opt(&self.encoder_resolution, "encoder_resolution", 1e6, 0.0)?;
        let steps = encoder_resolution * counts_per_unit;
        if encoder_resolution > 0.0 && !(1.0..=MAX_COUNTS).contains(&steps) {
            let span = self.encoder_resolution.as_ref().map_or(0..0, |v| v.span());
            return Err((
                span,
                key("encoder_resolution"),
                format!(
                    "must be 0 (one count) or 1..=2^31-1 counts, got {encoder_resolution} = {steps} counts"
                ),
            ));
        }
        Ok(SimDynamics {
            delay_cycles: match &self.delay_cycles {
                Some(v) => int_in(v, &key("delay_cycles"), 0, 100)? as u32,
                None => d.delay_cycles,
            },
            bandwidth_hz,
            velocity_feedforward: opt(
                &self.velocity_feedforward,
                "velocity_feedforward",
                1.0,
                0.0,
            )?,
            max_velocity: opt(&self.max_velocity, "max_velocity", MAX_VELOCITY, 0.0)?,
            max_acceleration: opt(
                &self.max_acceleration,
                "max_acceleration",
                MAX_ACCELERATION,
                0.0,
            )?,
            encoder_resolution,
            machine: RawSimMachine {
                power_on_position: self.power_on_position.clone(),
                home_switch: self.home_switch.clone(),
                home_switch_active: self.home_switch_active.clone(),
                limit_switches: self.limit_switches.clone(),
                index_pulse_counts: self.index_pulse_counts.clone(),
                inputs: self.inputs.clone(),
            }
            .validate(k, counts_per_unit)?,
        })
    }
}

impl RawAxis {
    /// Checks axis `k` against the axes before it (`earlier`). The checks run in a fixed
    /// order, so the first error a file has is always the one reported.
    fn validate(
        &self,
        k: usize,
        earlier: &[AxisConfig],
        bus: &BusConfig,
    ) -> Result<AxisConfig, Invalid> {
        let a = self;
        let key = |f: &str| format!("axis[{k}].{f}");
        let name = a.name(k, earlier)?;
        let kind = a.kind(k, earlier)?;
        let node = a.node(k, earlier, bus.master_node_id)?;
        let counts_per_unit = a.counts_per_unit(k, kind)?;
        let soft_limits = a.soft_limits(k, kind)?;
        a.counts_fit(k, counts_per_unit, soft_limits)?;
        let (max_velocity, max_acceleration, max_jerk) = a.dynamics(k, counts_per_unit, bus)?;
        let max_rpm = a.max_rpm(k, kind, max_velocity)?;
        let spindle = a.spindle_number(k, kind, earlier)?;
        let references = a.references(k, soft_limits, counts_per_unit)?;
        let identity = a.identity(k, node)?;
        let dynamics = a.model(k)?;
        let sim = a.sim.validate(k, counts_per_unit)?;
        let homing = match &a.homing {
            Some(h) => Some(h.get_ref().validate(
                h.span(),
                &AxisScale {
                    k,
                    counts_per_unit,
                    max_velocity,
                },
            )?),
            None => None,
        }
        // Checked on a virtual axis too (a config switched to virtual keeps its keys), unused
        // there: an axis without a drive has nothing to home.
        .filter(|_| node.is_some());
        Ok(AxisConfig {
            name,
            kind,
            node,
            counts_per_unit,
            max_velocity,
            max_acceleration,
            max_jerk,
            soft_limits,
            following_error_window: a.following_error_window(k, counts_per_unit)?,
            following_error_timeout_ms: int_in(
                &a.following_error_timeout_ms,
                &key("following_error_timeout_ms"),
                0,
                65535,
            )? as u32,
            max_rpm,
            spindle,
            feedback_delay_cycles: int_in(
                &a.feedback_delay_cycles,
                &key("feedback_delay_cycles"),
                0,
                16,
            )? as u32,
            references,
            identity,
            dynamics,
            homing,
            polarity_inverted: homing::polarity(&a.polarity, key("polarity"))?,
            gear_ratio: homing::ratio(&a.gear_ratio, key("gear_ratio"))?,
            feed_constant: homing::ratio(&a.feed_constant, key("feed_constant"))?,
            limit_switch_inputs: a
                .limit_switch_inputs
                .as_ref()
                .is_some_and(|v| *v.get_ref() && node.is_some()),
            outputs_pdo: false,
            inputs_pdo: a
                .limit_switch_inputs
                .as_ref()
                .is_some_and(|v| *v.get_ref() && node.is_some()),
            sim,
            // Resolved with the config's path (crate::commissioning::validate).
            commissioning: Default::default(),
        })
    }

    /// The commissioning keys as written: `dcf` and `sdo`.
    pub(crate) fn commissioning_keys(
        &self,
    ) -> (
        Option<&Spanned<String>>,
        &[Spanned<Table<crate::commissioning::RawSdoWrite>>],
    ) {
        (self.dcf.as_ref(), &self.sdo)
    }

    /// The address letter, upper case, not used by an earlier axis.
    fn name(&self, k: usize, earlier: &[AxisConfig]) -> Result<char, Invalid> {
        let s = self.name.get_ref();
        let mut cs = s.chars();
        let name = match (cs.next(), cs.next()) {
            (Some(c), None) if "XYZABCUVW".contains(c.to_ascii_uppercase()) => {
                c.to_ascii_uppercase()
            }
            _ => {
                return Err((
                    self.name.span(),
                    format!("axis[{k}].name"),
                    format!("expected one of X Y Z A B C U V W, got {s:?}"),
                ));
            }
        };
        if let Some(prev) = earlier.iter().find(|p| p.name == name) {
            return Err((
                self.name.span(),
                format!("axis[{k}].name"),
                format!("axis {} is configured twice", prev.name),
            ));
        }
        Ok(name)
    }

    /// `identity`: UNSIGNED32 values, on an axis with a drive.
    fn identity(&self, k: usize, node: Option<u8>) -> Result<Option<ExpectedIdentity>, Invalid> {
        let Some(raw) = &self.identity else {
            return Ok(None);
        };
        let key = |f: &str| format!("axis[{k}].identity.{f}");
        if node.is_none() {
            return Err((
                raw.span(),
                format!("axis[{k}].identity"),
                "a virtual axis has no drive to identify".into(),
            ));
        }
        let r = raw.get_ref();
        let u32_at =
            |v: &Spanned<i64>, f: &str| int_in(v, &key(f), 0, u32::MAX as i64).map(|x| x as u32);
        let optional =
            |v: &Option<Spanned<i64>>, f: &str| v.as_ref().map(|v| u32_at(v, f)).transpose();
        Ok(Some(ExpectedIdentity {
            vendor: u32_at(&r.vendor, "vendor")?,
            product: optional(&r.product, "product")?,
            revision_min: optional(&r.revision_min, "revision_min")?,
        }))
    }

    /// `dynamics` (read on a virtual axis too, unused there): a dead time the matching delay lines hold and a
    /// bandwidth of 0 (ideal) or in [`MIN_MODEL_BANDWIDTH_HZ`]..=`MAX_BANDWIDTH_HZ`.
    fn model(&self, k: usize) -> Result<Option<DriveModel>, Invalid> {
        let Some(raw) = &self.dynamics else {
            return Ok(None);
        };
        let key = |f: &str| format!("axis[{k}].dynamics{f}");
        let r = raw.get_ref();
        let delay = int_in(
            &r.delay_cycles,
            &key(".delay_cycles"),
            0,
            MAX_MODEL_DELAY_CYCLES as i64,
        )? as u32;
        let bw = *r.bandwidth_hz.get_ref();
        let ok = bw == 0.0 || (MIN_MODEL_BANDWIDTH_HZ..=MAX_BANDWIDTH_HZ).contains(&bw);
        if !ok {
            return Err((
                r.bandwidth_hz.span(),
                key(".bandwidth_hz"),
                format!(
                    "must be 0 (ideal) or {MIN_MODEL_BANDWIDTH_HZ}..={MAX_BANDWIDTH_HZ} Hz, got {bw}"
                ),
            ));
        }
        Ok(Some(DriveModel {
            delay_cycles: delay,
            bandwidth_hz: bw,
        }))
    }

    /// The kind; at most [`MAX_SPINDLES`] spindles.
    fn kind(&self, k: usize, earlier: &[AxisConfig]) -> Result<AxisKind, Invalid> {
        let kind = match self.kind.get_ref().as_str() {
            "linear" => AxisKind::Linear,
            "rotary" => AxisKind::Rotary,
            "spindle" => AxisKind::Spindle,
            o => {
                return Err((
                    self.kind.span(),
                    format!("axis[{k}].kind"),
                    format!("expected \"linear\", \"rotary\" or \"spindle\", got {o:?}"),
                ));
            }
        };
        let spindles = earlier.iter().filter(|p| p.kind == AxisKind::Spindle);
        if kind == AxisKind::Spindle && spindles.count() >= MAX_SPINDLES {
            return Err((
                self.kind.span(),
                format!("axis[{k}].kind"),
                format!("at most {MAX_SPINDLES} spindle axes are supported"),
            ));
        }
        Ok(kind)
    }

    /// `spindle`: the number of a spindle axis, 1..=[`MAX_SPINDLES`], not an earlier
    /// spindle's; by default the spindle axes are numbered in config order.
    fn spindle_number(
        &self,
        k: usize,
        kind: AxisKind,
        earlier: &[AxisConfig],
    ) -> Result<Option<u8>, Invalid> {
        let key = format!("axis[{k}].spindle");
        let number = match (&self.spindle, kind) {
            (Some(n), AxisKind::Spindle) => int_in(n, &key, 1, MAX_SPINDLES as i64)? as u8,
            (None, AxisKind::Spindle) => {
                earlier.iter().filter(|p| p.spindle.is_some()).count() as u8 + 1
            }
            (Some(n), _) => {
                return Err((n.span(), key, "only a spindle axis has a number".into()));
            }
            (None, _) => return Ok(None),
        };
        if let Some(p) = earlier.iter().find(|p| p.spindle == Some(number)) {
            let span = self.spindle.as_ref().map_or(self.kind.span(), |s| s.span());
            return Err((
                span,
                key,
                format!(
                    "spindle {number} is already axis {} (numbers default to the spindles' \
                     order: give each spindle axis its own `spindle = 1` or `2`)",
                    p.name
                ),
            ));
        }
        Ok(Some(number))
    }

    /// The drive's node id (`None` for a virtual axis): in range, not the master's, not an
    /// earlier axis's.
    fn node(
        &self,
        k: usize,
        earlier: &[AxisConfig],
        master_node_id: u8,
    ) -> Result<Option<u8>, Invalid> {
        let key = format!("axis[{k}].node");
        let is_virtual = self
            .is_virtual
            .as_ref()
            .map(|v| *v.get_ref())
            .unwrap_or(false);
        match (&self.node, is_virtual) {
            (Some(n), false) => {
                let id = int_in(n, &key, 1, 127)? as u8;
                if id == master_node_id {
                    return Err((
                        n.span(),
                        key,
                        format!("node id {id} is the master's (bus.master_node_id)"),
                    ));
                }
                if let Some(p) = earlier.iter().find(|p| p.node == Some(id)) {
                    return Err((
                        n.span(),
                        key,
                        format!("node id {id} is already used by axis {}", p.name),
                    ));
                }
                Ok(Some(id))
            }
            (Some(n), true) => Err((n.span(), key, "a virtual axis has no node id".into())),
            (None, true) => Ok(None),
            (None, false) => Err((
                self.name.span(),
                key,
                "missing: give a CANopen node id 1..127, or virtual = true".into(),
            )),
        }
    }

    /// Counts per unit, from `counts_per_unit` or (rotary axes) `counts_per_rev`.
    fn counts_per_unit(&self, k: usize, kind: AxisKind) -> Result<f64, Invalid> {
        let key = |f: &str| format!("axis[{k}].{f}");
        match (&self.counts_per_unit, &self.counts_per_rev) {
            (Some(c), None) => positive(c, &key("counts_per_unit")),
            (None, Some(c)) if kind.is_rotary() => {
                let n = positive(c, &key("counts_per_rev"))?;
                if n.fract() != 0.0 || n > MAX_COUNTS {
                    return Err((
                        c.span(),
                        key("counts_per_rev"),
                        format!("must be a whole number of counts 1..={MAX_COUNTS}, got {n}"),
                    ));
                }
                Ok(n / 360.0)
            }
            (None, Some(c)) => Err((
                c.span(),
                key("counts_per_rev"),
                "only rotary axes take counts_per_rev".into(),
            )),
            (Some(c), Some(_)) => Err((
                c.span(),
                key("counts_per_unit"),
                "give counts_per_unit or counts_per_rev, not both".into(),
            )),
            (None, None) => Err((self.name.span(), key("counts_per_unit"), "missing".into())),
        }
    }

    /// `min` and `max`: both required and ordered on a linear axis, absent on a rotary one.
    fn soft_limits(&self, k: usize, kind: AxisKind) -> Result<Option<(f64, f64)>, Invalid> {
        let key = |f: &str| format!("axis[{k}].{f}");
        match (&self.min, &self.max, kind) {
            (Some(lo), Some(hi), AxisKind::Linear) => {
                if !(lo.get_ref().is_finite()
                    && hi.get_ref().is_finite()
                    && lo.get_ref() < hi.get_ref())
                {
                    return Err((
                        hi.span(),
                        key("max"),
                        format!("must be greater than min ({})", lo.get_ref()),
                    ));
                }
                Ok(Some((*lo.get_ref(), *hi.get_ref())))
            }
            (None, None, AxisKind::Linear) => Err((
                self.name.span(),
                key("min"),
                "a linear axis needs soft limits min and max".into(),
            )),
            (Some(l), None, AxisKind::Linear) => {
                Err((l.span(), key("max"), "missing (min is given)".into()))
            }
            (None, Some(h), AxisKind::Linear) => {
                Err((h.span(), key("min"), "missing (max is given)".into()))
            }
            (None, None, _) => Ok(None),
            (Some(l), _, _) | (_, Some(l), _) => Err((
                l.span(),
                key("min"),
                "rotary axes have no soft limits".into(),
            )),
        }
    }

    /// `max_rpm`: required on the spindle, refused elsewhere; at most `max_velocity` / 6
    /// (deg/s per rpm), which the planner caps the spindle at: a larger one let the
    /// interpreter take an S word the planner then refused.
    fn max_rpm(&self, k: usize, kind: AxisKind, max_velocity: f64) -> Result<Option<f64>, Invalid> {
        let key = format!("axis[{k}].max_rpm");
        match (&self.max_rpm, kind) {
            (Some(r), AxisKind::Spindle) => {
                let rpm = positive(r, &key)?;
                if rpm * 6.0 > max_velocity * (1.0 + 1e-12) {
                    return Err((
                        r.span(),
                        key,
                        format!(
                            "must be at most max_velocity / 6 = {} rpm, got {rpm}",
                            max_velocity / 6.0
                        ),
                    ));
                }
                Ok(Some(rpm))
            }
            (None, AxisKind::Spindle) => {
                Err((self.kind.span(), key, "a spindle needs max_rpm".into()))
            }
            (Some(r), _) => Err((r.span(), key, "only the spindle has max_rpm".into())),
            (None, _) => Ok(None),
        }
    }

    /// The four reference positions (the first defaults to 0): finite, inside the soft
    /// limits (linear axes) or the drive's 32-bit position (rotary axes).
    fn references(
        &self,
        k: usize,
        soft_limits: Option<(f64, f64)>,
        counts_per_unit: f64,
    ) -> Result<[Option<f64>; 4], Invalid> {
        let reach = MAX_COUNTS / counts_per_unit;
        let mut references = [Some(0.0), None, None, None];
        for (slot, (v, name)) in [
            (&self.reference, "reference"),
            (&self.second_reference, "second_reference"),
            (&self.third_reference, "third_reference"),
            (&self.fourth_reference, "fourth_reference"),
        ]
        .into_iter()
        .enumerate()
        {
            let Some(v) = v else { continue };
            let x = *v.get_ref();
            let bad = if !x.is_finite() {
                Some("must be a finite number".to_string())
            } else if let Some((lo, hi)) = soft_limits {
                (x < lo || x > hi)
                    .then(|| format!("{x} is outside the axis's soft limits {lo}..{hi}"))
            } else {
                (x.abs() > reach).then(|| {
                    format!("{x} is beyond the drive's 32-bit position (±{reach} at this scale)")
                })
            };
            if let Some(m) = bad {
                return Err((v.span(), format!("axis[{k}].{name}"), m));
            }
            references[slot] = Some(x);
        }
        Ok(references)
    }

    /// The span and key of the scale as written (`counts_per_unit` or `counts_per_rev`).
    fn scale_key(&self, k: usize) -> (std::ops::Range<usize>, String) {
        match (&self.counts_per_unit, &self.counts_per_rev) {
            (None, Some(c)) => (c.span(), format!("axis[{k}].counts_per_rev")),
            (c, _) => (
                c.as_ref().map_or(self.name.span(), |c| c.span()),
                format!("axis[{k}].counts_per_unit"),
            ),
        }
    }

    /// The drive's position is INT32 counts: every position of a linear axis's soft-limit
    /// range, and one turn of a rotary axis (whose counts wrap), must fit in it.
    fn counts_fit(
        &self,
        k: usize,
        counts_per_unit: f64,
        soft_limits: Option<(f64, f64)>,
    ) -> Result<(), Invalid> {
        let (reach, what) = match soft_limits {
            Some((lo, hi)) if lo.abs() > hi.abs() => (lo.abs(), format!("the soft limit {lo}")),
            Some((_, hi)) => (hi.abs(), format!("the soft limit {hi}")),
            None => (360.0, "one turn (360°)".to_string()),
        };
        let counts = reach * counts_per_unit;
        if counts <= MAX_COUNTS {
            return Ok(());
        }
        let (span, key) = self.scale_key(k);
        Err((
            span,
            key,
            format!(
                "{what} is {counts:e} counts, beyond the drive's 32-bit position (±{MAX_COUNTS})"
            ),
        ))
    }

    /// `following_error_window`: positive, and in counts (0x6065, UNSIGNED32; 0x60F4 is
    /// INT32) at least 1 (a smaller one rounds to 0, which the master wrote as 0xFFFFFFFF,
    /// supervision off) and at most 2^31 − 1 (a following error can never exceed it).
    fn following_error_window(&self, k: usize, counts_per_unit: f64) -> Result<f64, Invalid> {
        let key = format!("axis[{k}].following_error_window");
        let w = positive(&self.following_error_window, &key)?;
        let counts = w * counts_per_unit;
        if (1.0..=MAX_COUNTS).contains(&counts) {
            return Ok(w);
        }
        Err((
            self.following_error_window.span(),
            key,
            format!(
                "{w} is {counts:e} counts at this axis's scale; the drive's window takes 1..={MAX_COUNTS} counts"
            ),
        ))
    }

    /// `max_velocity`, `max_acceleration`, `max_jerk`: positive, at most their ceilings; the
    /// velocity at least 1 count/s and at most 2^31 − 1 counts per bus cycle (so that
    /// consecutive INT32 setpoints differ by their true difference across the wrap); and the
    /// ramp from rest to max_velocity (the double-S's acceleration phase) at most
    /// [`MAX_RAMP_S`].
    fn dynamics(
        &self,
        k: usize,
        counts_per_unit: f64,
        bus: &BusConfig,
    ) -> Result<(f64, f64, f64), Invalid> {
        let key = |f: &str| format!("axis[{k}].{f}");
        let v = positive_at_most(&self.max_velocity, &key("max_velocity"), MAX_VELOCITY)?;
        let per_second = v * counts_per_unit;
        let per_cycle = per_second * bus.period_s();
        if per_second < 1.0 || per_cycle > MAX_COUNTS {
            return Err((
                self.max_velocity.span(),
                key("max_velocity"),
                format!(
                    "{v} is {per_second:e} counts/s ({per_cycle:e} per bus cycle): it must be \
                     at least 1 count/s and at most {MAX_COUNTS} counts per cycle"
                ),
            ));
        }
        let a = positive_at_most(
            &self.max_acceleration,
            &key("max_acceleration"),
            MAX_ACCELERATION,
        )?;
        let j = positive_at_most(&self.max_jerk, &key("max_jerk"), MAX_JERK)?;
        // The double-S acceleration phase to v (see motion::profile::rest_to_rest).
        let ramp = if v * j >= a * a {
            v / a + a / j
        } else {
            2.0 * (v / j).sqrt()
        };
        if ramp <= MAX_RAMP_S {
            return Ok((v, a, j));
        }
        let (blamed, field) = if v / a > MAX_RAMP_S {
            (&self.max_acceleration, "max_acceleration")
        } else {
            (&self.max_jerk, "max_jerk")
        };
        Err((
            blamed.span(),
            key(field),
            format!(
                "max_velocity {v} takes {ramp:e} s to reach from rest at max_acceleration {a} \
                 and max_jerk {j}; at most {MAX_RAMP_S} s"
            ),
        ))
    }
}

#[cfg(test)]
mod tests {
    use crate::{ConfigError, MachineConfig};
    use std::path::Path;

    const SHIPPED: &str = include_str!("../machine.toml");

    /// A spindle axis `name` on `node` with `extra` keys (e.g. `spindle = 2`).
    fn spindle(name: &str, node: u8, extra: &str) -> String {
        format!(
            "\n[[axis]]\nname = \"{name}\"\nkind = \"spindle\"\nnode = {node}\n\
             counts_per_rev = 131072\nmax_velocity = 36000.0\nmax_acceleration = 36000.0\n\
             max_jerk = 720000.0\nmax_rpm = 6000.0\nfollowing_error_window = 90.0\n\
             dynamics = {{ delay_cycles = 1, bandwidth_hz = 150.0 }}\n{extra}\n"
        )
    }

    /// The shipped machine (spindle C, node 4) at 2 ms (room on the bus) plus `more`.
    fn with(more: &str) -> Result<MachineConfig, ConfigError> {
        let text = SHIPPED.replace("period_us = 1000", "period_us = 2000") + more;
        MachineConfig::parse(&text, Path::new("m.toml"))
    }

    fn line_of(text: &str, needle: &str, nth: usize) -> usize {
        let text = SHIPPED.replace("period_us = 1000", "period_us = 2000") + text;
        let at = text.match_indices(needle).nth(nth).expect("needle").0;
        text[..at].lines().count() + 1
    }

    #[test]
    fn two_spindles_are_numbered_in_order_by_default() {
        let c = with(&spindle("A", 5, "")).unwrap();
        assert_eq!(c.spindle_axes(), [Some(3), Some(4)]);
        assert_eq!(c.spindle_index(), Some(3));
        assert_eq!(
            (c.spindle_number(3), c.spindle_number(4)),
            (Some(1), Some(2))
        );
        assert_eq!(c.spindle_number(0), None);
    }

    #[test]
    fn spindle_numbers_may_swap_the_order() {
        let more = spindle("A", 5, "spindle = 1");
        let text = SHIPPED
            .replace("period_us = 1000", "period_us = 2000")
            .replace("max_rpm = 6000.0\n", "max_rpm = 6000.0\nspindle = 2\n")
            + &more;
        let c = MachineConfig::parse(&text, Path::new("m.toml")).unwrap();
        assert_eq!(c.spindle_axes(), [Some(4), Some(3)]);
        assert_eq!(
            c.spindle_index(),
            Some(4),
            "spindle 1 is the program's default"
        );
    }

    #[test]
    fn a_third_spindle_is_refused_with_its_key_and_line() {
        let more = spindle("A", 5, "") + &spindle("B", 6, "");
        let e = with(&more).unwrap_err();
        assert_eq!(e.key, "axis[5].kind", "{e}");
        assert_eq!(e.line, line_of(&more, "kind = \"spindle\"", 2), "{e}");
        assert!(e.message.contains("at most 2 spindle axes"), "{e}");
    }

    #[test]
    fn a_duplicate_spindle_number_is_refused_with_its_key_and_line() {
        let more = spindle("A", 5, "spindle = 1");
        let e = with(&more).unwrap_err();
        assert_eq!(e.key, "axis[4].spindle", "{e}");
        assert_eq!(e.line, line_of(&more, "spindle = 1", 0), "{e}");
        assert!(e.message.contains("spindle 1 is already axis C"), "{e}");
    }

    #[test]
    fn bad_spindle_numbers_are_refused() {
        for (extra, key, says) in [
            ("spindle = 3", "axis[4].spindle", "1..=2"),
            ("spindle = 0", "axis[4].spindle", "1..=2"),
        ] {
            let e = with(&spindle("A", 5, extra)).unwrap_err();
            assert_eq!(e.key, key, "{extra}: {e}");
            assert!(e.message.contains(says), "{extra}: {e}");
        }
        // A lone spindle numbered 2: a program's default spindle 1 would have no axis.
        let text = SHIPPED.replace("max_rpm = 6000.0\n", "max_rpm = 6000.0\nspindle = 2\n");
        let e = MachineConfig::parse(&text, Path::new("m.toml")).unwrap_err();
        assert_eq!(e.key, "axis[3].spindle", "{e}");
        assert!(e.message.contains("number the spindles 1..=1"), "{e}");
        // A number on a feed axis.
        let text = SHIPPED.replacen("max = 300.0\n", "max = 300.0\nspindle = 1\n", 1);
        let e = MachineConfig::parse(&text, Path::new("m.toml")).unwrap_err();
        assert_eq!(e.key, "axis[0].spindle", "{e}");
        assert!(e.message.contains("only a spindle axis"), "{e}");
    }
}
