//! The CANopen master for CiA 402 drives in cyclic synchronous position mode. A caller that
//! owns the bus drives it:
//!
//! ```text
//! let mut m = Master::new(&config)?;            // per-axis state in fixed arrays
//! let report = m.boot(&mut bus)?;               // blocking, over a TimedBus (see `boot`)
//! let mut cmd = m.positions();                  // start the interpolator here: first setpoint = actual
//! let mut now = report.enabled_at + m.period(); // the first cyclic SYNC
//! loop {                                        // once per period, at absolute deadlines
//!     match m.cycle(&mut bus, now, &cmd[..m.axis_count()]) {   // no allocation, no clock
//!         Ok(fb) => ...,                        // fb.actual / following_error / statusword / age
//!         Err(stop) => ...,                     // stop.at_line(line); interpolator.request_stop();
//!     }                                         // keep cycling: fb.stopping, m.quick_stop()
//!     now += m.period();
//! }
//! m.disable(&mut bus)?;                         // blocking: drives to SWITCH ON DISABLED
//! m.reenable(&mut bus)?;                        // or: back to Running after a stop
//! ```
//!
//! `cycle` first takes in everything received since the last call (TPDO1s answering the
//! previous SYNC, EMCY, heartbeats, SDO responses), runs the safety monitors, then sends one
//! RPDO1 per drive, a SYNC, the master's heartbeat when due (drives quick-stop when it
//! stops: 0x1016/0x6007, set at boot), and SDO frames of an in-cycle transfer (`start_sdo_upload`,
//! paced to the bus time the PDOs leave). Feedback is therefore one period old; the following
//! error rule accounts for it (see [`cyclic`]). Modules: `sdo` (client), `boot`, `cyclic`,
//! `stop` (safety stop values), `timed` (how blocking helpers wait), `service` (one-drive
//! helpers for tools: NMT, the CiA 402 state machine over SDO).

pub mod boot;
pub mod cyclic;
pub mod homing;
pub mod inputs;
pub mod outputs;
pub mod sdo;
pub mod service;
pub mod stop;
pub mod timed;

use core::fmt;
use core::time::Duration;

use cia402::{Controlword, EnableSequencer, Goal, Statusword};
use cnc402_config::{ExpectedIdentity, MAX_AXES, MachineConfig};

use crate::time::Instant;
use crate::wire::{NmtState, NodeId};
use cnc402_config::busload::{self, BusLoad, PdoLayout};
use cnc402_motion::to_counts_wrapping;

pub use boot::{BootError, BootReport, DriveIdentity, InterpolationPeriod};
pub use cyclic::Feedback;
pub use homing::{AxisHomed, HomingError, HomingReport};
pub use outputs::Output;
pub use sdo::{BlockingSdo, ProtocolViolation, SdoClient, SdoError, SdoErrorKind, SdoEvent};
pub use service::{SequenceError, send_nmt, sequence_over_sdo};
pub use stop::{Emcy, SafetyStop, StopReason, emcy_text};
pub use timed::TimedBus;

/// Commands older than this many cycles are not kept for the following error comparison.
pub const COMMAND_HISTORY: usize = 32;

/// What the master does to the drives when a safety monitor trips.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopMode {
    /// Every drive gets the controlword quick stop (0x02) at once and brakes on its own quick
    /// stop ramp (0x605A/0x6085). The default.
    QuickStop,
    /// Healthy drives stay enabled and keep following the caller's setpoints (the interpolator
    /// decelerating along the path after `request_stop`, so Z and C stay coupled in a tap);
    /// only the drive that tripped gets quick stop. The caller calls
    /// [`Master::quick_stop`] once the path has stopped.
    FollowPath,
}

/// Master settings that are not in the machine config.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MasterOptions {
    /// How long boot waits for every drive's boot-up (a drive that boots late).
    pub boot_timeout: Duration,
    /// How long the enable sequence may take (fault reset included).
    pub enable_timeout: Duration,
    /// Send NMT reset communication to each drive before waiting for its boot-up (so drives
    /// that were already running announce themselves again).
    pub reset_communication: bool,
    /// The stop reaction.
    pub stop_mode: StopMode,
}

impl Default for MasterOptions {
    fn default() -> MasterOptions {
        MasterOptions {
            boot_timeout: Duration::from_secs(10),
            enable_timeout: Duration::from_secs(3),
            reset_communication: true,
            stop_mode: StopMode::QuickStop,
        }
    }
}

/// Why a [`Master`] could not be built from a config.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MasterConfigError {
    /// More axes than [`MAX_AXES`].
    TooManyAxes(usize),
    /// A node id outside 1..=127.
    BadNode {
        /// Axis letter.
        axis: char,
        /// The id.
        node: u8,
    },
    /// Two axes on one node.
    DuplicateNode(u8),
    /// An axis on the master's own node id (`bus.master_node_id`).
    MasterNode {
        /// Axis letter.
        axis: char,
        /// The id.
        node: u8,
    },
    /// `period_us` has no 0x60C2 representation (value 1..=255 × 10^exp s, exp −6..=−3).
    UnsupportedPeriod(u32),
}

impl fmt::Display for MasterConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MasterConfigError::TooManyAxes(n) => write!(f, "{n} axes, at most {MAX_AXES}"),
            MasterConfigError::BadNode { axis, node } => {
                write!(f, "axis {axis}: node id {node} outside 1..=127")
            }
            MasterConfigError::DuplicateNode(n) => write!(f, "two axes on node {n}"),
            MasterConfigError::MasterNode { axis, node } => write!(
                f,
                "axis {axis}: node id {node} is the master's own (bus.master_node_id)"
            ),
            MasterConfigError::UnsupportedPeriod(p) => write!(
                f,
                "bus.period_us = {p} cannot be written to 0x60C2 (value 1..=255 × 10^-3..-6 s)"
            ),
        }
    }
}

impl std::error::Error for MasterConfigError {}

/// Where the master is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Built, not booted.
    Idle,
    /// Drives configured and started, enable sequence running.
    Enabling,
    /// Every drive in OPERATION ENABLED, following setpoints.
    Running,
    /// A safety stop (or `quick_stop`) happened; the stop reaction runs.
    Stopping,
    /// Drives are being taken to SWITCH ON DISABLED.
    Disabling,
}

/// One axis: its config and the master's per-cycle state (fixed size, no heap).
#[derive(Clone, Debug)]
pub(crate) struct AxisSlot {
    pub name: char,
    pub node: Option<NodeId>,
    pub counts_per_unit: f64,
    pub window: f64,
    pub window_counts: u32,
    pub fe_timeout_ms: u16,
    /// The identity (0x1018) the config expects, checked at boot.
    pub identity: Option<ExpectedIdentity>,
    /// `following_error_timeout_ms` in whole cycles: the monitor trips when |error| has been
    /// beyond the window in more consecutive fresh, comparable samples than this.
    pub fe_timeout_cycles: u32,
    /// Consecutive fresh, comparable samples with |error| beyond the window.
    pub fe_beyond: u32,
    /// Whether the sample in `actual` could be compared with the command it answers (false
    /// when it is older than the command history).
    pub fe_comparable: bool,
    /// Fresh samples too old for the command history since boot (not compared).
    pub fe_not_comparable: u64,
    /// Cycles between a command leaving the master and the actual that answers it.
    pub fe_lag: usize,
    /// The drive model's first-order loop per cycle, 1 − e^(−2π·f·T) (1: no lag, the
    /// command itself is expected).
    pub model_alpha: f64,
    /// The model's response to the commands so far (axis units): where the drive should be
    /// once the dead time has passed.
    pub expected: f64,
    pub sequencer: EnableSequencer,
    pub controlword: Controlword,
    /// Compact layout: the controlword last sent in RPDO2 (`None`: send it next cycle) and
    /// the cycles until it is sent again unchanged (a lost RPDO2 heals within that).
    pub controlword_sent: Option<Controlword>,
    pub controlword_refresh_in: u32,
    pub quick_stop: bool,
    /// The last target sent (counts, wrapped).
    pub target: i32,
    pub statusword: Option<Statusword>,
    /// The last raw 0x6064 value and its unwrapped count.
    pub actual_raw: i32,
    pub actual_counts: i64,
    /// Actual position in axis units.
    pub actual: f64,
    pub tpdo_this_cycle: bool,
    pub tpdo_missing: u32,
    /// TPDO1s received since boot (a statistic; ages come from `owed`).
    pub tpdos: u64,
    /// SYNCs whose TPDO1 has neither arrived nor been written off as lost.
    pub owed: u32,
    /// TPDO1s taken in since the last cycle.
    pub window_tpdos: u32,
    /// The drive's steady lateness (cycles), learnt in the enable phase; `u32::MAX` = unknown.
    pub late_base: u32,
    /// Consecutive cycles with exactly one TPDO1 while `owed` was above `late_base`.
    pub ambiguous_cycles: u32,
    /// Age of the sample in `actual` (cycles older than the last SYNC's answer).
    pub age: u32,
    pub last_heartbeat: Option<Instant>,
    pub nmt: Option<NmtState>,
    pub booted: bool,
    pub emcy: Option<Emcy>,
    /// EMCY messages received since boot (the first since a clear is kept in `emcy`).
    pub emcys: u64,
    /// Boot-up messages since the last NMT reset communication (two mean two devices on one
    /// node id, or a drive that reset itself while being configured).
    pub boot_ups: u32,
    /// Expected positions in axis units, a ring indexed by the cycle count: the commands
    /// through the drive model's first-order loop (the commands themselves without a model).
    pub history: [f64; COMMAND_HISTORY],
    pub last_command: f64,
    pub following_error: f64,
    pub max_following_error: f64,
    pub sdo: Option<SdoClient>,
    pub sdo_outcome: Option<Result<(), SdoError>>,
    /// An SDO frame to send in the next send phase.
    pub sdo_tx: Option<crate::wire::CanFrame>,
    /// Disabling: the sequencer reached SWITCH ON DISABLED.
    pub disabled: bool,
    /// Enabling: the sequencer's last progress.
    pub progress: cia402::Progress,
    /// The PDO layouts the drive has (set at boot; a fixed mapping the master accepted).
    pub pdos: boot::MappedPdos,
    /// When a statusword last arrived (the compact layout's staleness monitor).
    pub statusword_at: Option<Instant>,
    /// Scaling and machine reference from the config (written at boot).
    pub reference: homing::ReferenceSetup,
    /// Axis units added to the drive's position (an absolute encoder's stored offset).
    pub origin: f64,
    /// Homed since boot, or an absolute encoder.
    pub homed: bool,
    /// The drive is homing: its position moves on its own (no following error check, the
    /// command follows the actual position).
    pub homing_active: bool,
    /// Mode-specific controlword bits (4..=6) sent with enable operation while running.
    pub mode_bits: u16,
    /// The drive's 0x60FD as last received in TPDO3 (`None`: not mapped, or none yet).
    pub inputs: Option<u32>,
    /// `limit_switch_inputs`: a limit switch in `inputs` stops the machine.
    pub watch_limit_switches: bool,
}

impl AxisSlot {
    fn empty() -> AxisSlot {
        AxisSlot {
            name: ' ',
            node: None,
            counts_per_unit: 1.0,
            window: 0.0,
            window_counts: 0,
            fe_timeout_ms: 0,
            identity: None,
            fe_timeout_cycles: 0,
            fe_beyond: 0,
            fe_comparable: true,
            fe_not_comparable: 0,
            fe_lag: 1,
            model_alpha: 1.0,
            expected: 0.0,
            sequencer: EnableSequencer::new(Goal::OperationEnabled),
            controlword: Controlword::DISABLE_VOLTAGE,
            controlword_sent: None,
            controlword_refresh_in: 0,
            quick_stop: false,
            target: 0,
            statusword: None,
            actual_raw: 0,
            actual_counts: 0,
            actual: 0.0,
            tpdo_this_cycle: false,
            tpdo_missing: 0,
            tpdos: 0,
            owed: 0,
            window_tpdos: 0,
            late_base: u32::MAX,
            ambiguous_cycles: 0,
            age: 0,
            last_heartbeat: None,
            nmt: None,
            booted: false,
            emcy: None,
            emcys: 0,
            boot_ups: 0,
            history: [0.0; COMMAND_HISTORY],
            last_command: 0.0,
            following_error: 0.0,
            max_following_error: 0.0,
            sdo: None,
            sdo_outcome: None,
            sdo_tx: None,
            disabled: false,
            progress: cia402::Progress::Moving(None),
            pdos: boot::MappedPdos::of(PdoLayout::Standard),
            statusword_at: None,
            reference: homing::ReferenceSetup::default(),
            origin: 0.0,
            homed: false,
            homing_active: false,
            mode_bits: 0,
            inputs: None,
            watch_limit_switches: false,
        }
    }

    /// A position in axis units as the drive's count (wrapping), the origin taken off.
    pub(crate) fn to_counts(&self, units: f64) -> i32 {
        to_counts_wrapping(units - self.origin, self.counts_per_unit)
    }

    /// Takes in a new raw 0x6064 value: the unwrapped count moves by the wrapping difference,
    /// so the f64 position keeps counting past ±2^31 counts.
    pub(crate) fn set_actual_raw(&mut self, raw: i32) {
        let delta = raw.wrapping_sub(self.actual_raw) as i64;
        self.actual_raw = raw;
        self.actual_counts = self.actual_counts.wrapping_add(delta);
        self.actual = self.actual_counts as f64 / self.counts_per_unit + self.origin;
    }

    /// Sets the position from a fresh read (boot): the unwrapped count starts at `raw`.
    pub(crate) fn reset_actual(&mut self, raw: i32) {
        self.actual_raw = raw;
        self.actual_counts = raw as i64;
        self.actual = raw as f64 / self.counts_per_unit + self.origin;
    }
}

/// The per-cycle gain of a first-order loop of `bandwidth_hz` at `period_us`: 1 (no lag)
/// for an ideal loop (0 Hz) or one fast enough to follow within the cycle.
fn model_alpha(bandwidth_hz: f64, period_us: u32) -> f64 {
    if !(bandwidth_hz.is_finite() && bandwidth_hz > 0.0) {
        return 1.0;
    }
    let t = period_us as f64 * 1e-6;
    (1.0 - (-2.0 * core::f64::consts::PI * bandwidth_hz * t).exp()).clamp(f64::MIN_POSITIVE, 1.0)
}

/// The CANopen master for the machine's drives (see the module doc for the call sequence).
#[derive(Clone, Debug)]
pub struct Master {
    pub(crate) axes: [AxisSlot; MAX_AXES],
    pub(crate) n_axes: usize,
    pub(crate) options: MasterOptions,
    pub(crate) period: Duration,
    pub(crate) period_us: u32,
    pub(crate) heartbeat_ms: u16,
    pub(crate) heartbeat_timeout: Duration,
    /// The master's node id: its heartbeat goes out on 0x700 + id, the drives consume it.
    pub(crate) master_node: NodeId,
    /// When the master's next heartbeat is due (`None`: at the next cycle).
    pub(crate) next_heartbeat: Option<Instant>,
    /// Heartbeats the master sent.
    pub(crate) heartbeats_sent: u64,
    pub(crate) tpdo_timeout_cycles: u32,
    pub(crate) sdo_timeout: Duration,
    pub(crate) interpolation: InterpolationPeriod,
    pub(crate) phase: Phase,
    pub(crate) cycles: u64,
    pub(crate) sync_sent: bool,
    /// SYNCs sent since boot.
    pub(crate) syncs: u64,
    pub(crate) stop: Option<SafetyStop>,
    pub(crate) unexpected_frames: u64,
    /// Bits per cycle the cyclic frames and heartbeats leave free on the bus.
    pub(crate) sdo_free_bits: f64,
    pub(crate) sdo_credit: f64,
    pub(crate) last_feedback: Feedback,
    pub(crate) cyclic_bits: f64,
    pub(crate) bits_per_cycle: f64,
    /// What the cyclic PDOs carry (`bus.pdo_layout`).
    pub(crate) pdo_layout: PdoLayout,
    /// Compact layout: the statusword's event timer and the controlword's refresh (ms, and
    /// in cycles).
    pub(crate) event_refresh_ms: u16,
    pub(crate) event_refresh_cycles: u32,
    /// Compact layout: a statusword older than this trips [`StopReason::StatuswordStale`].
    pub(crate) statusword_timeout: Duration,
    /// Per axis, what boot writes after its own set-up (`dcf`, `sdo` in the config).
    pub(crate) commissioning: Vec<cnc402_config::Commissioning>,
    /// `[machine] estop_input`: (axis index, 0x60FD bit), the chain closed when the bit is 1.
    pub(crate) estop_input: Option<(usize, u8)>,
    /// `estop_input`'s category: the stop reaction when it opens.
    pub(crate) estop_category: cnc402_config::StopCategory,
    /// `[machine] outputs`: wanted and acknowledged 0x60FE:1 per drive.
    pub(crate) outputs: outputs::OutputState,
}

impl Master {
    /// A master for `config`'s axes with default options.
    pub fn new(config: &MachineConfig) -> Result<Master, MasterConfigError> {
        Master::with_options(config, MasterOptions::default())
    }

    /// A master for `config`'s axes. Axes with `node: Some(id)` are drives; the others are
    /// virtual (their actual position echoes the command).
    pub fn with_options(
        config: &MachineConfig,
        options: MasterOptions,
    ) -> Result<Master, MasterConfigError> {
        if config.axes.len() > MAX_AXES {
            return Err(MasterConfigError::TooManyAxes(config.axes.len()));
        }
        let interpolation = InterpolationPeriod::from_micros(config.bus.period_us)
            .ok_or(MasterConfigError::UnsupportedPeriod(config.bus.period_us))?;
        let mut axes: [AxisSlot; MAX_AXES] = core::array::from_fn(|_| AxisSlot::empty());
        for (i, a) in config.axes.iter().enumerate() {
            let node = match a.node {
                Some(id) => Some(NodeId::new(id).map_err(|_| MasterConfigError::BadNode {
                    axis: a.name,
                    node: id,
                })?),
                None => None,
            };
            if let Some(n) = node
                && axes[..i].iter().any(|s| s.node == Some(n))
            {
                return Err(MasterConfigError::DuplicateNode(n.get()));
            }
            if let Some(n) = node
                && n.get() == config.bus.master_node_id
            {
                return Err(MasterConfigError::MasterNode {
                    axis: a.name,
                    node: n.get(),
                });
            }
            let s = &mut axes[i];
            s.pdos = boot::MappedPdos::of(config.bus.pdo_layout);
            s.name = a.name;
            s.node = node;
            s.counts_per_unit = if a.counts_per_unit.is_finite() && a.counts_per_unit > 0.0 {
                a.counts_per_unit
            } else {
                1.0
            };
            s.window = a.following_error_window;
            let wc = (a.following_error_window * s.counts_per_unit).round();
            s.window_counts = if wc.is_finite() && wc >= 1.0 {
                wc.min((u32::MAX - 1) as f64) as u32
            } else {
                u32::MAX // 0xFFFF_FFFF: monitoring off in the drive
            };
            s.fe_timeout_ms = a.following_error_timeout_ms.min(u16::MAX as u32) as u16;
            s.identity = a.identity;
            s.fe_timeout_cycles = (u64::from(a.following_error_timeout_ms) * 1000
                / u64::from(config.bus.period_us.max(1)))
            .min(u64::from(u32::MAX)) as u32;
            // The drive model, when given, says what the drive does with a command: its
            // dead time replaces feedback_delay_cycles, its loop is expected to lag.
            let (delay, alpha) = match a.dynamics {
                Some(d) => (
                    d.delay_cycles,
                    model_alpha(d.bandwidth_hz, config.bus.period_us),
                ),
                None => (a.feedback_delay_cycles, 1.0),
            };
            s.reference = homing::ReferenceSetup {
                polarity_inverted: a.polarity_inverted,
                gear_ratio: a.gear_ratio,
                feed_constant: a.feed_constant,
                homing: a.homing,
                counts_per_unit: s.counts_per_unit,
                inputs_pdo: a.inputs_pdo,
                refresh_ms: busload::event_refresh_ms(&config.bus),
            };
            s.watch_limit_switches = a.limit_switch_inputs;
            // An absolute encoder is referenced from the start: its stored offset applies.
            if let Some(cnc402_config::Homing::Absolute { offset }) = a.homing {
                s.origin = offset;
                s.homed = true;
            }
            s.fe_lag = (1 + delay as usize).min(COMMAND_HISTORY - 1);
            s.model_alpha = alpha;
            if let Some(n) = node {
                s.sdo = Some(SdoClient::new(
                    n,
                    Duration::from_millis(config.bus.sdo_timeout_ms as u64),
                ));
            }
        }
        let master_node =
            NodeId::new(config.bus.master_node_id).map_err(|_| MasterConfigError::BadNode {
                axis: ' ',
                node: config.bus.master_node_id,
            })?;
        // SYNC, the PDOs and the heartbeats as the load plan counts them (the config was
        // refused if they and the SDO reserve overload the bus); SDOs get what is left.
        let plan = BusLoad::of_config(&config.bus, &config.axes, config.bus.pdo_layout);
        let event_refresh_ms = busload::event_refresh_ms(&config.bus);
        let bits_per_cycle = plan.capacity_bits();
        let cyclic_bits = plan.traffic_bits();
        Ok(Master {
            sdo_free_bits: (bits_per_cycle - cyclic_bits).max(0.0),
            sdo_credit: 0.0,
            last_feedback: Feedback::EMPTY,
            cyclic_bits,
            bits_per_cycle,
            axes,
            n_axes: config.axes.len(),
            options,
            period: Duration::from_micros(config.bus.period_us as u64),
            period_us: config.bus.period_us,
            heartbeat_ms: config.bus.heartbeat_ms,
            heartbeat_timeout: Duration::from_millis(config.bus.heartbeat_timeout_ms as u64),
            master_node,
            next_heartbeat: None,
            heartbeats_sent: 0,
            tpdo_timeout_cycles: config.bus.tpdo_timeout_cycles.max(1),
            sdo_timeout: Duration::from_millis(config.bus.sdo_timeout_ms as u64),
            interpolation,
            phase: Phase::Idle,
            cycles: 0,
            sync_sent: false,
            syncs: 0,
            stop: None,
            unexpected_frames: 0,
            pdo_layout: config.bus.pdo_layout,
            event_refresh_ms,
            event_refresh_cycles: (u32::from(event_refresh_ms) * 1000
                / config.bus.period_us.max(1))
            .max(1),
            commissioning: config
                .axes
                .iter()
                .map(|a| a.commissioning.clone())
                .collect(),
            // Three event-timer periods (two statuswords lost in a row), and never less than
            // the TPDO time-out the other monitors allow.
            statusword_timeout: Duration::from_millis(3 * u64::from(event_refresh_ms)).max(
                Duration::from_micros(
                    u64::from(config.bus.tpdo_timeout_cycles.max(1))
                        * u64::from(config.bus.period_us),
                ),
            ),
            estop_input: config.machine.estop_input,
            estop_category: config.machine.estop_category,
            outputs: outputs::OutputState::new(config.machine.outputs),
        })
    }

    /// Number of configured axes (commands and feedback are indexed like `config.axes`).
    pub fn axis_count(&self) -> usize {
        self.n_axes
    }

    /// The phase.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The cycle period.
    pub fn period(&self) -> Duration {
        self.period
    }

    /// Actual positions in axis units (indexed like `config.axes`; entries past
    /// [`axis_count`](Self::axis_count) are 0). After boot, start the interpolator here.
    pub fn positions(&self) -> [f64; MAX_AXES] {
        core::array::from_fn(|i| {
            if i < self.n_axes {
                self.axes[i].actual
            } else {
                0.0
            }
        })
    }

    /// The feedback of the last cycle — also of the one that returned a [`SafetyStop`].
    pub fn last_feedback(&self) -> &Feedback {
        &self.last_feedback
    }

    /// The latched safety stop, if one happened.
    pub fn stop_reason(&self) -> Option<&SafetyStop> {
        self.stop.as_ref()
    }

    /// Per axis, fresh samples since boot that were older than the command history
    /// ([`COMMAND_HISTORY`] cycles, after a loop stall or a long bus delay) and therefore not
    /// compared with any command (see [`cyclic`]).
    pub fn following_error_not_comparable(&self) -> [u64; MAX_AXES] {
        core::array::from_fn(|i| self.axes[i].fe_not_comparable)
    }

    /// Largest |following error| per axis since enabling, in axis units.
    pub fn max_following_errors(&self) -> [f64; MAX_AXES] {
        core::array::from_fn(|i| self.axes[i].max_following_error)
    }

    /// Cycles run since enabling.
    pub fn cycles(&self) -> u64 {
        self.cycles
    }

    /// Frames received that no part of the master expected (unknown COB-IDs, malformed).
    pub fn unexpected_frames(&self) -> u64 {
        self.unexpected_frames
    }

    /// Share of the bus (percent) the cyclic frames (SYNC, RPDO1, TPDO1) and heartbeats use,
    /// worst-case bit stuffing.
    pub fn cyclic_load_percent(&self) -> f64 {
        if self.bits_per_cycle > 0.0 {
            100.0 * self.cyclic_bits / self.bits_per_cycle
        } else {
            100.0
        }
    }

    /// The master's node id (heartbeat COB-ID 0x700 + id; what the drives' 0x1016 watches).
    pub fn master_node(&self) -> u8 {
        self.master_node.get()
    }

    /// Heartbeats the master has sent (one per `bus.heartbeat_ms` while it cycles).
    pub fn heartbeats_sent(&self) -> u64 {
        self.heartbeats_sent
    }

    /// SYNCs sent since boot (enable sequence included).
    pub fn syncs_sent(&self) -> u64 {
        self.syncs
    }

    /// TPDO1s received from axis `axis`'s drive since boot; equals
    /// [`syncs_sent`](Self::syncs_sent) minus the ones still in flight when none was lost.
    pub fn tpdos_received(&self, axis: usize) -> u64 {
        self.axes.get(axis).map(|a| a.tpdos).unwrap_or(0)
    }

    /// The axis index of drive `node`.
    pub fn axis_of_node(&self, node: u8) -> Option<usize> {
        self.axes[..self.n_axes]
            .iter()
            .position(|a| a.node.map(NodeId::get) == Some(node))
    }

    /// The first EMCY (code not 0) drive `axis` sent since the last clear (boot, enable):
    /// the cause, when more follow.
    pub fn last_emcy(&self, axis: usize) -> Option<Emcy> {
        self.axes.get(axis).and_then(|a| a.emcy)
    }

    /// EMCY messages received from axis `axis`'s drive since the master was built (an EMCY
    /// storm is counted here, never stored or logged per message).
    pub fn emcys_received(&self, axis: usize) -> u64 {
        self.axes.get(axis).map(|a| a.emcys).unwrap_or(0)
    }
}
