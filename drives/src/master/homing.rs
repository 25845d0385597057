//! Machine reference: what boot writes for it (0x607E polarity, 0x6091 gear ratio, 0x6092
//! feed constant), and [`Master::home`], which runs CiA 402 homing mode on drives that are
//! enabled and cycling: per axis, 0x6098/0x6099/0x609A/0x607C from the config, 0x6060 = 6
//! (confirmed by 0x6061), controlword bit 4 until statusword bits 12
//! and 10 say "homing completed" (bit 13: error; a time-out names the state), then 0x6060 = 8
//! and the axis's position is taken afresh. The other axes hold their positions meanwhile,
//! and every safety monitor but the following error of the homing axis keeps running.

use core::fmt;
use core::time::Duration;

use cia402::homing::HOMING_START;
use cia402::objects as obj;
use cia402::{HomingMethod, HomingStatus, OperationMode, Statusword};
use cnc402_config::{DriveHoming, Homing, MAX_AXES};

use super::sdo::{BlockingSdo, SdoError};
use super::stop::{Emcy, SafetyStop};
use super::{COMMAND_HISTORY, Master, Phase, TimedBus};
use crate::bus::BusError;
use crate::time::Instant;
use crate::wire::NodeId;

/// What boot writes to a drive for its machine reference and scaling (from the axis config).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct ReferenceSetup {
    pub polarity_inverted: bool,
    pub gear_ratio: Option<(u32, u32)>,
    pub feed_constant: Option<(u32, u32)>,
    pub homing: Option<Homing>,
    pub counts_per_unit: f64,
    /// Map 0x60FD into TPDO3 (limit switches or the E-stop input are on this drive).
    pub inputs_pdo: bool,
    /// The inputs TPDO's event timer (ms).
    pub refresh_ms: u16,
}

/// A value in axis units as counts for a UNSIGNED32 object (speeds, acceleration).
fn unsigned_counts(units: f64, counts_per_unit: f64) -> u32 {
    (units * counts_per_unit)
        .round()
        .clamp(1.0, u32::MAX as f64) as u32
}

/// Writes the scaling objects of one drive (boot, before NMT start): only what the config
/// gives, so a drive without these objects is not touched unless it must be.
pub(crate) fn write_at_boot<B: TimedBus + ?Sized>(
    sdo: &mut BlockingSdo<'_, B>,
    node: NodeId,
    r: &ReferenceSetup,
) -> Result<(), super::boot::MapPdoError> {
    if r.polarity_inverted {
        sdo.write_u8(node, obj::POLARITY, 0, obj::POLARITY_INVERTED)?;
    }
    for (index, value) in [
        (obj::GEAR_RATIO, r.gear_ratio),
        (obj::FEED_CONSTANT, r.feed_constant),
    ] {
        if let Some((a, b)) = value {
            sdo.write_u32(node, index, 1, a)?;
            sdo.write_u32(node, index, 2, b)?;
        }
    }
    if r.inputs_pdo {
        super::inputs::map_inputs_tpdo(sdo, node, r.refresh_ms)?;
    }
    Ok(())
}

/// Writes axis homing's parameters (0x6098 method, 0x607C home offset, 0x6099 speeds, 0x609A
/// acceleration) in counts: when homing starts, so boot touches no homing object.
fn write_homing_parameters<B: TimedBus + ?Sized>(
    sdo: &mut BlockingSdo<'_, B>,
    node: NodeId,
    h: &DriveHoming,
    cpu: f64,
) -> Result<(), SdoError> {
    let offset = (h.offset * cpu)
        .round()
        .clamp(i32::MIN as f64, i32::MAX as f64) as i32;
    sdo.write_i8(node, obj::HOMING_METHOD, 0, h.method.number())?;
    sdo.write_i32(node, obj::HOME_OFFSET, 0, offset)?;
    if h.method.moves() {
        let speeds = [
            (obj::HOMING_SPEEDS, 1, h.speed_switch),
            (obj::HOMING_SPEEDS, 2, h.speed_zero),
            (obj::HOMING_ACCELERATION, 0, h.acceleration),
        ];
        for (index, sub, v) in speeds {
            sdo.write_u32(node, index, sub, unsigned_counts(v, cpu))?;
        }
    }
    Ok(())
}

/// One axis homed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisHomed {
    /// Axis letter.
    pub axis: char,
    /// Node id.
    pub node: u8,
    /// The method the drive ran (`None`: an absolute encoder, referenced at boot).
    pub method: Option<HomingMethod>,
    /// Machine position after homing, axis units.
    pub position: f64,
    /// Bus time homing took.
    pub took: Duration,
}

/// What [`Master::home`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct HomingReport {
    /// Per axis, in the order homed.
    pub axes: Vec<AxisHomed>,
    /// The last homing cycle's time: the next cycle is one period later.
    pub last_cycle: Instant,
}

/// Why homing failed; each names the axis and its node.
#[derive(Clone, Debug, PartialEq)]
pub enum HomingError {
    /// `home` called outside [`Phase::Running`].
    WrongPhase(Phase),
    /// The axis has no `homing` key (or no drive).
    NotConfigured {
        /// Axis letter.
        axis: char,
    },
    /// An SDO transfer failed (mode change or confirmation).
    Sdo {
        /// Axis letter.
        axis: char,
        /// The transfer's error (node, object, abort code or time-out).
        error: SdoError,
    },
    /// 0x6061 did not confirm the mode written to 0x6060.
    ModeNotConfirmed {
        /// Axis letter.
        axis: char,
        /// Node id.
        node: u8,
        /// The mode written.
        mode: i8,
        /// What 0x6061 said.
        display: i8,
    },
    /// The drive set statusword bit 13 (homing error).
    Failed {
        /// Axis letter.
        axis: char,
        /// Node id.
        node: u8,
        /// The method it ran.
        method: HomingMethod,
        /// The last statusword.
        statusword: Option<Statusword>,
        /// The drive's last EMCY since homing began.
        emcy: Option<Emcy>,
    },
    /// Homing did not complete within the axis's `timeout_s`.
    Timeout {
        /// Axis letter.
        axis: char,
        /// Node id.
        node: u8,
        /// The method it ran.
        method: HomingMethod,
        /// How long the master waited.
        waited: Duration,
        /// The last statusword.
        statusword: Option<Statusword>,
    },
    /// A safety monitor tripped while homing (the stop reaction has been sent).
    Stopped(SafetyStop),
    /// The transport failed.
    Bus(BusError),
}

impl fmt::Display for HomingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let state = |sw: &Option<Statusword>| match sw {
            Some(sw) => format!("{} (statusword {sw})", HomingStatus::of(*sw)),
            None => "no statusword received".to_string(),
        };
        match self {
            HomingError::WrongPhase(p) => write!(f, "homing is not possible in phase {p:?}"),
            HomingError::NotConfigured { axis } => write!(
                f,
                "axis {axis} has no `homing` key in the config (or no drive)"
            ),
            HomingError::Sdo { axis, error } => write!(f, "homing axis {axis}: {error}"),
            HomingError::ModeNotConfirmed {
                axis,
                node,
                mode,
                display,
            } => write!(
                f,
                "homing axis {axis} (node {node}): 0x6060 = {mode} written, 0x6061 shows {display}"
            ),
            HomingError::Failed {
                axis,
                node,
                method,
                statusword,
                emcy,
            } => {
                write!(
                    f,
                    "homing axis {axis} (node {node}, {method}) failed: {}",
                    state(statusword)
                )?;
                if let Some(e) = emcy {
                    write!(f, "; last {e}")?;
                }
                Ok(())
            }
            HomingError::Timeout {
                axis,
                node,
                method,
                waited,
                statusword,
            } => write!(
                f,
                "homing axis {axis} (node {node}, {method}) did not complete within {:.1} s: \
                 {}; raise homing.timeout_s if the search is that long, else check the switch",
                waited.as_secs_f64(),
                state(statusword)
            ),
            HomingError::Stopped(s) => write!(f, "while homing: {s}"),
            HomingError::Bus(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for HomingError {}

impl From<BusError> for HomingError {
    fn from(e: BusError) -> HomingError {
        HomingError::Bus(e)
    }
}

/// How often 0x6061 is read for the new mode before the drive is said not to confirm it.
const MODE_READS: u32 = 10;

/// Cycles to let pass after a controlword or mode change before a statusword is taken as
/// its answer: the RPDO goes out, the drive applies it at the SYNC, its TPDO comes back one
/// cycle later — plus the drive's dead time and, with the compact layout, the statusword's
/// inhibit time.
fn settle_cycles(m: &Master, i: usize) -> u32 {
    let inhibit = cnc402_config::busload::COMPACT_EVENT_INHIBIT_MS * 1000 / m.period_us.max(1);
    let compact = matches!(m.pdo_layout, cnc402_config::busload::PdoLayout::Compact);
    3 + m.axes[i].fe_lag as u32 + if compact { inhibit + 1 } else { 0 }
}

impl Master {
    /// Whether axis `i` has its machine reference: homed since boot, or an absolute encoder.
    pub fn is_homed(&self, axis: usize) -> bool {
        self.axes.get(axis).is_some_and(|a| a.homed)
    }

    /// The axes (indices) that have a `homing` key, in config order.
    pub fn homing_axes(&self) -> Vec<usize> {
        (0..self.n_axes)
            .filter(|&i| self.axes[i].node.is_some() && self.axes[i].reference.homing.is_some())
            .collect()
    }

    /// Homes `axes` one after the other (blocking, cycling at the period with every other
    /// axis held), after [`boot`](Self::boot). Absolute axes were referenced at boot and are
    /// reported at once. On success the master is back in [`Phase::Running`] and
    /// [`positions`](Self::positions) are machine positions: start the interpolator there.
    pub fn home<B: TimedBus + ?Sized>(
        &mut self,
        bus: &mut B,
        axes: &[usize],
    ) -> Result<HomingReport, HomingError> {
        if self.phase != Phase::Running {
            return Err(HomingError::WrongPhase(self.phase));
        }
        let mut report = HomingReport {
            axes: Vec::with_capacity(axes.len()),
            last_cycle: bus.now(),
        };
        let mut t = bus.now();
        for &i in axes {
            let a = self.axes.get(i).filter(|_| i < self.n_axes);
            let (Some(a), Some(node)) = (a, a.and_then(|a| a.node)) else {
                return Err(HomingError::NotConfigured {
                    axis: a.map_or('?', |a| a.name),
                });
            };
            let (name, homing) = (a.name, a.reference.homing);
            let started = t;
            let method = match homing {
                None => return Err(HomingError::NotConfigured { axis: name }),
                Some(Homing::Absolute { .. }) => None,
                Some(Homing::Drive(h)) => {
                    t = self.home_axis(bus, i, &h, t)?;
                    Some(h.method)
                }
            };
            report.axes.push(AxisHomed {
                axis: name,
                node: node.get(),
                method,
                position: self.axes[i].actual,
                took: t.saturating_since(started),
            });
        }
        report.last_cycle = t;
        Ok(report)
    }

    /// One cycle of the homing loop at `t` (every axis held at its last command, the homing
    /// axis `i` at its actual position).
    fn homing_cycle<B: TimedBus + ?Sized>(
        &mut self,
        bus: &mut B,
        i: usize,
        t: Instant,
    ) -> Result<(), HomingError> {
        self.wait_until(bus, t)?;
        let mut hold: [f64; MAX_AXES] = core::array::from_fn(|k| self.axes[k].last_command);
        hold[i] = self.axes[i].actual;
        self.cycle(bus, t, &hold[..self.n_axes])
            .map(|_| ())
            .map_err(HomingError::Stopped)
    }

    /// Writes 0x6060 = `mode` on axis `i` and reads 0x6061 until it agrees (at most
    /// [`MODE_READS`] reads, a cycle apart). The transfers are blocking, between two cycles:
    /// the axes stand still then, and a full bus (4 axes at 1 ms use 98 % of 1 Mbit/s) leaves
    /// no room for SDO inside the cycles. Returns the next cycle's time.
    fn switch_mode<B: TimedBus + ?Sized>(
        &mut self,
        bus: &mut B,
        i: usize,
        mode: OperationMode,
        mut t: Instant,
    ) -> Result<Instant, HomingError> {
        let (axis, node) = (self.axes[i].name, self.axes[i].node);
        let node = node.ok_or(HomingError::NotConfigured { axis })?;
        let v = mode.to_i8();
        let sdo_error = |error| HomingError::Sdo { axis, error };
        self.with_sdo(bus, |sdo| sdo.write_i8(node, obj::MODES_OF_OPERATION, 0, v))
            .map_err(sdo_error)?;
        let mut display = 0;
        for _ in 0..MODE_READS {
            t = self.next_slot(bus, t);
            self.homing_cycle(bus, i, t)?;
            display = self
                .with_sdo(bus, |sdo| {
                    sdo.read_i8(node, obj::MODES_OF_OPERATION_DISPLAY, 0)
                })
                .map_err(sdo_error)?;
            if display == v {
                return Ok(self.next_slot(bus, t));
            }
        }
        Err(HomingError::ModeNotConfirmed {
            axis,
            node: node.get(),
            mode: v,
            display,
        })
    }

    /// The first cycle time on the period grid from `t` that is still ahead of the bus's
    /// clock (a blocking transfer may have taken a cycle or two).
    fn next_slot<B: TimedBus + ?Sized>(&self, bus: &B, t: Instant) -> Instant {
        let period = self.period.as_nanos().max(1) as u64;
        let behind = bus.now().nanos().saturating_sub(t.nanos());
        let k = behind / period + 1;
        Instant::from_nanos(t.nanos() + k * period)
    }

    /// Homing mode on axis `i` from the time `t` (see the module doc); returns the last
    /// cycle's time.
    fn home_axis<B: TimedBus + ?Sized>(
        &mut self,
        bus: &mut B,
        i: usize,
        h: &DriveHoming,
        t: Instant,
    ) -> Result<Instant, HomingError> {
        self.axes[i].homing_active = true;
        self.axes[i].homed = false;
        let r = self.run_homing_mode(bus, i, h, t);
        self.axes[i].mode_bits = 0;
        let back = r.and_then(|t| {
            // The position jumped to the new reference: the history restarts there before
            // anything compares with it. Back in CSP the drive follows 0x607A, which the
            // homing cycles kept at its actual position.
            self.take_reference(i);
            self.switch_mode(bus, i, OperationMode::CyclicSyncPosition, t)
        });
        self.axes[i].homing_active = false;
        let t = back?;
        self.take_reference(i);
        self.axes[i].homed = true;
        Ok(t)
    }

    /// Mode 6, start, wait for "homing completed" (bits 12 and 10), or fail.
    fn run_homing_mode<B: TimedBus + ?Sized>(
        &mut self,
        bus: &mut B,
        i: usize,
        h: &DriveHoming,
        t: Instant,
    ) -> Result<Instant, HomingError> {
        let (axis, cpu) = (self.axes[i].name, self.axes[i].counts_per_unit);
        let node = self.axes[i]
            .node
            .ok_or(HomingError::NotConfigured { axis })?;
        // Between two cycles, as the mode changes (see `switch_mode`).
        self.with_sdo(bus, |sdo| write_homing_parameters(sdo, node, h, cpu))
            .map_err(|error| HomingError::Sdo { axis, error })?;
        let mut t = self.switch_mode(bus, i, OperationMode::Homing, t)?;
        self.axes[i].emcy = None;
        self.axes[i].mode_bits = HOMING_START;
        let started = t;
        let settle = settle_cycles(self, i);
        let timeout = Duration::from_secs_f64(h.timeout_s);
        let mut cycles = 0u32;
        loop {
            self.homing_cycle(bus, i, t)?;
            cycles = cycles.saturating_add(1);
            let a = &self.axes[i];
            let node = a.node.map_or(0, NodeId::get);
            // Statuswords from before the start edge took effect say nothing of this run.
            if cycles > settle {
                match a.statusword.map(HomingStatus::of) {
                    Some(HomingStatus::Completed) => return Ok(t),
                    Some(HomingStatus::Error) => {
                        return Err(HomingError::Failed {
                            axis: a.name,
                            node,
                            method: h.method,
                            statusword: a.statusword,
                            emcy: a.emcy,
                        });
                    }
                    _ => {}
                }
            }
            if t.saturating_since(started) >= timeout {
                return Err(HomingError::Timeout {
                    axis: a.name,
                    node,
                    method: h.method,
                    waited: t.saturating_since(started),
                    statusword: a.statusword,
                });
            }
            t += self.period;
        }
    }

    /// After homing: the drive's position is a new one (the home point reads the home
    /// offset); the unwrapped count, the command history and the drive model restart there.
    fn take_reference(&mut self, i: usize) {
        let a = &mut self.axes[i];
        a.reset_actual(a.actual_raw);
        a.target = a.actual_raw;
        a.history = [a.actual; COMMAND_HISTORY];
        a.expected = a.actual;
        a.last_command = a.actual;
        a.following_error = 0.0;
        a.max_following_error = 0.0;
        a.fe_beyond = 0;
    }
}
