//! Boot and configuration of the drives (blocking, over a [`TimedBus`]): wait for each
//! drive's boot-up (after NMT reset communication), check 0x1000 is CiA 402, read 0x1018 and
//! 0x1008 for the report, map RPDO1 = 0x6040 + 0x607A and TPDO1 = 0x6041 + 0x6064
//! (synchronous) in the CiA 301 remap sequence, set CSP, 0x60C2, 0x6065/0x6066, the
//! heartbeat, the master's heartbeat as consumer (0x1016) with quick stop on its loss (0x6007
//! = 3), NMT start, write 0x607A = 0x6064, then run the CiA 402 enable sequence cyclically
//! with the target held at the actual position (enabling never moves an axis).

use core::fmt;
use core::time::Duration;

use cia402::{EnableSequencer, Goal, Progress, State, Statusword, Stuck, objects as obj};
use cnc402_config::busload::PdoLayout as BusPdoLayout;
use cnc402_config::{ExpectedIdentity, SdoWrite};

use super::sdo::{BlockingSdo, SdoError, SdoErrorKind};
use super::stop::{Emcy, SafetyStop};
use super::timed::TimedBus;
use super::{COMMAND_HISTORY, Master, Phase};
use crate::bus::BusError;
use crate::time::Instant;
use crate::wire::{
    AbortCode, CanFrame, MappingEntry, NmtCommand, NmtRepr, NmtTarget, NodeId, PdoDirection,
    PdoLayout, PdoObject,
};

/// The 0x60C2 representation of the cycle period: `value · 10^exponent` seconds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InterpolationPeriod {
    /// Sub 1, UNSIGNED8.
    pub value: u8,
    /// Sub 2, INTEGER8 (−3 = ms … −6 = µs).
    pub exponent: i8,
}

impl InterpolationPeriod {
    /// The exact representation of `us` microseconds with the coarsest unit that fits
    /// (1000 µs → 1 × 10^−3; 250 µs → 25 × 10^−5; 125 µs → 125 × 10^−6); `None` if none.
    pub fn from_micros(us: u32) -> Option<InterpolationPeriod> {
        for (exponent, unit) in [(-3i8, 1000u32), (-4, 100), (-5, 10), (-6, 1)] {
            if us.is_multiple_of(unit) && (1..=255).contains(&(us / unit)) {
                return Some(InterpolationPeriod {
                    value: (us / unit) as u8,
                    exponent,
                });
            }
        }
        None
    }
}

/// What boot learnt about one drive (for the log and the run report).
#[derive(Clone, Debug, PartialEq)]
pub struct DriveIdentity {
    /// Axis letter.
    pub axis: char,
    /// Node id.
    pub node: u8,
    /// 0x1000.
    pub device_type: u32,
    /// 0x1018:1..4 (sub 2..4 are optional in CiA 301).
    pub vendor: u32,
    /// 0x1018:2.
    pub product: Option<u32>,
    /// 0x1018:3.
    pub revision: Option<u32>,
    /// 0x1018:4.
    pub serial: Option<u32>,
    /// 0x1008 (optional).
    pub name: Option<String>,
    /// When its boot-up (or first heartbeat) was seen.
    pub seen_at: Instant,
    /// Statusword read before enabling.
    pub initial_statusword: Statusword,
    /// The drive was in FAULT before enabling (it was fault-reset); with its EMCY if one came.
    pub fault_at_power_on: Option<Option<Emcy>>,
    /// 0x6064 read before enabling (counts) = the target written to 0x607A.
    pub position_counts: i32,
    /// The same in axis units.
    pub position: f64,
    /// The drive watches the master's heartbeat (0x1016:1 written). `false`: it has no
    /// consumer heartbeat object (or heartbeats are off), so a dead master leaves it enabled.
    pub supervises_master: bool,
    /// 0x6007 written to [`ABORT_CONNECTION_QUICK_STOP`]; `false`: the drive has no 0x6007
    /// and takes its own default reaction when the master falls silent.
    pub abort_connection_quick_stop: bool,
    /// The commissioning writes made (the DCF's parameter values, then the config's `sdo`
    /// list), after the master's own set-up.
    pub commissioning_writes: usize,
    /// The DCF's parameter values not written, and why (read-only, set by the master …).
    pub skipped_parameters: Vec<cnc402_config::SkippedParameter>,
}

/// 0x6007 abort connection option code written at boot: 3 = quick stop (CiA 402: 0 no
/// action, 1 fault signal, 2 disable voltage, 3 quick stop). A CNC axis losing its master
/// brakes on its quick stop ramp rather than coasting with the power stage off (2) or going
/// on holding the last target (0).
pub const ABORT_CONNECTION_QUICK_STOP: i16 = 3;

/// What boot did.
#[derive(Clone, Debug, PartialEq)]
pub struct BootReport {
    /// Per drive, in config order.
    pub drives: Vec<DriveIdentity>,
    /// When every drive was in OPERATION ENABLED.
    pub enabled_at: Instant,
    /// Cycles the enable sequence took.
    pub enable_cycles: u32,
}

/// Why boot failed; every variant names the node (and the object, abort code or timeout).
#[derive(Clone, Debug, PartialEq)]
pub enum BootError {
    /// No boot-up or heartbeat from this drive within the boot timeout.
    NoBootUp {
        /// Axis letter.
        axis: char,
        /// Node id.
        node: u8,
        /// How long the master waited.
        waited: Duration,
    },
    /// An SDO transfer failed (names node, index:sub, abort code or timeout).
    Sdo(SdoError),
    /// 0x1000 does not say CiA 402 (low word 0x0192).
    NotCia402 {
        /// Axis letter.
        axis: char,
        /// Node id.
        node: u8,
        /// The 0x1000 value read.
        device_type: u32,
    },
    /// The enable sequence did not reach OPERATION ENABLED in time.
    Enable {
        /// Axis letter.
        axis: char,
        /// Node id.
        node: u8,
        /// The last statusword.
        statusword: Option<Statusword>,
        /// The sequencer's diagnosis, if it had one.
        stuck: Option<Stuck>,
        /// The last EMCY from the drive.
        emcy: Option<Emcy>,
        /// How long the master tried.
        waited: Duration,
    },
    /// 0x1018 differs from the identity the config expects for this axis.
    WrongIdentity {
        /// Axis letter.
        axis: char,
        /// Node id.
        node: u8,
        /// The 0x1018 sub-index (1 vendor, 2 product, 3 revision).
        sub: u8,
        /// The value expected (for the revision: the least one).
        expected: u32,
        /// The value read (`None`: the drive has no such sub-index).
        actual: Option<u32>,
    },
    /// More than one boot-up from this node after the master's reset communication, and SDO
    /// answers that did not match the requests while it was being configured: two devices
    /// answer on one node id, or the drive reset itself in the middle.
    DuplicateBootUp {
        /// Axis letter.
        axis: char,
        /// Node id.
        node: u8,
        /// Boot-up messages seen.
        boot_ups: u32,
    },
    /// A commissioning write (DCF parameter value or config `sdo` entry) failed.
    Commissioning {
        /// Axis letter.
        axis: char,
        /// The write, with where it was asked for.
        write: Box<SdoWrite>,
        /// The failed transfer (node, object, abort code or timeout).
        error: SdoError,
    },
    /// A PDO the drive will not remap, whose fixed mapping lacks what the master needs.
    FixedMapping {
        /// Axis letter.
        axis: char,
        /// Node id.
        node: u8,
        /// The PDO (`RPDO1`, `TPDO2` …).
        pdo: String,
        /// The mapping the drive has (index, sub, bits).
        found: Vec<MappingEntry>,
        /// What is missing or in the way.
        problem: String,
    },
    /// A monitor tripped while enabling.
    Stopped(SafetyStop),
    /// The transport failed.
    Bus(BusError),
    /// `boot` or `disable` called in the wrong phase.
    WrongPhase(Phase),
}

impl fmt::Display for BootError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BootError::NoBootUp { axis, node, waited } => write!(
                f,
                "axis {axis} (node {node}): no boot-up or heartbeat within {} ms",
                waited.as_millis()
            ),
            BootError::Sdo(e) => write!(f, "{e}"),
            BootError::NotCia402 {
                axis,
                node,
                device_type,
            } => write!(
                f,
                "axis {axis} (node {node}): 0x1000 device type {device_type:#010x} is not a \
                 CiA 402 drive (low word must be 0x0192)"
            ),
            BootError::Enable {
                axis,
                node,
                statusword,
                stuck,
                emcy,
                waited,
            } => {
                write!(
                    f,
                    "axis {axis} (node {node}): not OPERATION ENABLED after {} ms",
                    waited.as_millis()
                )?;
                match (stuck, statusword) {
                    (Some(s), _) => write!(f, ": {s}")?,
                    (None, Some(sw)) => write!(f, ": statusword {sw}")?,
                    (None, None) => write!(f, ": no statusword received")?,
                }
                if let Some(e) = emcy {
                    write!(f, "; last {e}")?;
                }
                Ok(())
            }
            BootError::DuplicateBootUp {
                axis,
                node,
                boot_ups,
            } => write!(
                f,
                "axis {axis} (node {node}): {boot_ups} boot-up messages after one reset: two \
                 devices on node id {node}, or the drive reset itself while being configured"
            ),
            BootError::WrongIdentity {
                axis,
                node,
                sub,
                expected,
                actual,
            } => {
                let (what, rule) = match sub {
                    1 => ("vendor id", ""),
                    2 => ("product code", ""),
                    _ => ("revision number", "at least "),
                };
                write!(f, "axis {axis} (node {node}): 0x1018:{sub} {what} ")?;
                match actual {
                    Some(v) => write!(f, "{v:#010x}")?,
                    None => write!(f, "absent")?,
                }
                write!(
                    f,
                    ", the config expects {rule}{expected:#010x} (axis identity): another \
                     device than the one commissioned on this node"
                )
            }
            BootError::Commissioning { axis, write, error } => {
                write!(f, "axis {axis}: commissioning write ")?;
                if let Some(n) = &write.name {
                    write!(f, "\"{n}\" ")?;
                }
                write!(
                    f,
                    "({}) from {} failed: {error}",
                    write.data_type, write.origin
                )
            }
            BootError::FixedMapping {
                axis,
                node,
                pdo,
                found,
                problem,
            } => {
                write!(
                    f,
                    "axis {axis} (node {node}): {pdo} has a fixed mapping the drive will not \
                     change ["
                )?;
                for (k, e) in found.iter().enumerate() {
                    let sep = if k > 0 { ", " } else { "" };
                    write!(f, "{sep}{:#06x}:{:02x}/{}", e.index, e.sub, e.bits)?;
                }
                write!(f, "], and it is unusable: {problem}")
            }
            BootError::Stopped(s) => write!(f, "while enabling: {s}"),
            BootError::Bus(e) => write!(f, "{e}"),
            BootError::WrongPhase(p) => write!(f, "not possible in phase {p:?}"),
        }
    }
}

impl std::error::Error for BootError {}

impl From<SdoError> for BootError {
    fn from(e: SdoError) -> BootError {
        BootError::Sdo(e)
    }
}

impl From<BusError> for BootError {
    fn from(e: BusError) -> BootError {
        BootError::Bus(e)
    }
}

/// RPDO1 mapping: controlword + target position.
pub const RPDO1_MAPPING: [MappingEntry; 2] = [
    MappingEntry::new(obj::CONTROLWORD, 0, 16),
    MappingEntry::new(obj::TARGET_POSITION, 0, 32),
];
/// TPDO1 mapping: statusword + position actual.
pub const TPDO1_MAPPING: [MappingEntry; 2] = [
    MappingEntry::new(obj::STATUSWORD, 0, 16),
    MappingEntry::new(obj::POSITION_ACTUAL, 0, 32),
];

/// RPDO1 as boot maps it ([`RPDO1_MAPPING`]) and the cyclic loop packs it. Validated when
/// the crate compiles: an invalid mapping, or one without the controlword and the target,
/// does not build.
pub const RPDO1_LAYOUT: PdoLayout = match PdoLayout::new(PdoDirection::Rpdo, &RPDO1_MAPPING) {
    Ok(l) if l.maps(PdoObject::Controlword) && l.maps(PdoObject::TargetPosition) => l,
    _ => panic!("RPDO1_MAPPING must be a valid RPDO with controlword and target position"),
};
/// TPDO1 as boot maps it ([`TPDO1_MAPPING`]) and the cyclic loop unpacks it; validated when
/// the crate compiles, like [`RPDO1_LAYOUT`].
pub const TPDO1_LAYOUT: PdoLayout = match PdoLayout::new(PdoDirection::Tpdo, &TPDO1_MAPPING) {
    Ok(l) if l.maps(PdoObject::Statusword) && l.maps(PdoObject::PositionActual) => l,
    _ => panic!("TPDO1_MAPPING must be a valid TPDO with statusword and position actual"),
};
/// Transmission type 1: synchronous, every SYNC.
pub const SYNCHRONOUS_EVERY_SYNC: u8 = 1;
/// Transmission type 255: event-driven (device profile specific).
pub const EVENT_DRIVEN: u8 = 255;

const COMPACT_RPDO1_MAPPING: [MappingEntry; 1] = [MappingEntry::new(obj::TARGET_POSITION, 0, 32)];
const COMPACT_RPDO2_MAPPING: [MappingEntry; 1] = [MappingEntry::new(obj::CONTROLWORD, 0, 16)];
const COMPACT_TPDO1_MAPPING: [MappingEntry; 1] = [MappingEntry::new(obj::POSITION_ACTUAL, 0, 32)];
const COMPACT_TPDO2_MAPPING: [MappingEntry; 1] = [MappingEntry::new(obj::STATUSWORD, 0, 16)];

/// `bus.pdo_layout = "compact"`, RPDO1: target position alone, synchronous.
pub const COMPACT_RPDO1_LAYOUT: PdoLayout =
    valid_layout(PdoDirection::Rpdo, &COMPACT_RPDO1_MAPPING);
/// Compact RPDO2: controlword alone, event-driven (sent on change and every refresh period).
pub const COMPACT_RPDO2_LAYOUT: PdoLayout =
    valid_layout(PdoDirection::Rpdo, &COMPACT_RPDO2_MAPPING);
/// Compact TPDO1: position actual alone, synchronous.
pub const COMPACT_TPDO1_LAYOUT: PdoLayout =
    valid_layout(PdoDirection::Tpdo, &COMPACT_TPDO1_MAPPING);
/// Compact TPDO2: statusword alone, event-driven with an inhibit time and an event timer.
pub const COMPACT_TPDO2_LAYOUT: PdoLayout =
    valid_layout(PdoDirection::Tpdo, &COMPACT_TPDO2_MAPPING);

const fn valid_layout(direction: PdoDirection, entries: &[MappingEntry]) -> PdoLayout {
    match PdoLayout::new(direction, entries) {
        Ok(l) => l,
        Err(_) => panic!("a compact PDO mapping must be valid"),
    }
}

/// The compact statusword TPDO2's inhibit time (0x1801:3, 100 µs units): at most one
/// statusword per `COMPACT_EVENT_INHIBIT_MS`, the rate the load plan counts.
const COMPACT_TPDO2_INHIBIT_100US: u16 =
    (cnc402_config::busload::COMPACT_EVENT_INHIBIT_MS * 10) as u16;

const COB_INVALID: u32 = 0x8000_0000;
const COB_NO_RTR: u32 = 0x4000_0000;

fn optional<T>(r: Result<T, SdoError>) -> Result<Option<T>, SdoError> {
    match r {
        Ok(v) => Ok(Some(v)),
        Err(e)
            if matches!(
                e.abort_code(),
                Some(AbortCode::NoObject | AbortCode::NoSubIndex | AbortCode::UnsupportedAccess)
            ) =>
        {
            Ok(None)
        }
        Err(e) => Err(e),
    }
}

/// One PDO as boot maps it.
pub struct PdoSpec<'a> {
    /// Communication parameter index (0x1400.. / 0x1800..).
    pub comm: u16,
    /// Mapping parameter index (0x1600.. / 0x1A00..).
    pub mapping: u16,
    pub cob_id: u16,
    pub layout: &'a PdoLayout,
    pub transmission_type: u8,
    /// TPDOs: inhibit time (sub 3, 100 µs units) and event timer (sub 5, ms); written while
    /// the PDO is invalid (CiA 301 forbids changing the inhibit time of a valid PDO).
    pub event_timing: Option<(u16, u16)>,
}

impl PdoSpec<'_> {
    /// `RPDO1` … `TPDO4`, for messages.
    pub(crate) fn name(&self) -> String {
        match self.comm {
            c @ 0x1400..=0x15FF => format!("RPDO{}", c - 0x1400 + 1),
            c => format!("TPDO{}", c.wrapping_sub(0x1800) + 1),
        }
    }
}

/// Why a PDO could not be mapped: a transfer failed, or the drive keeps a fixed mapping
/// that lacks what the master needs.
#[derive(Clone, Debug, PartialEq)]
pub enum MapPdoError {
    /// An SDO transfer failed.
    Sdo(SdoError),
    /// The drive refused the remap and its own mapping is unusable.
    Fixed {
        /// `RPDO1` …
        pdo: String,
        /// The mapping the drive has.
        found: Vec<MappingEntry>,
        /// What is missing or in the way.
        problem: String,
    },
}

impl MapPdoError {
    /// The boot error of axis `axis` on `node`.
    pub(crate) fn into_boot_error(self, axis: char, node: NodeId) -> BootError {
        match self {
            MapPdoError::Sdo(e) => BootError::Sdo(e),
            MapPdoError::Fixed {
                pdo,
                found,
                problem,
            } => BootError::FixedMapping {
                axis,
                node: node.get(),
                pdo,
                found,
                problem,
            },
        }
    }
}

impl From<SdoError> for MapPdoError {
    fn from(e: SdoError) -> MapPdoError {
        MapPdoError::Sdo(e)
    }
}

/// Maps `pdo` as [`map_pdo`] does, for a PDO whose frames the master reads or writes by
/// `pdo.layout` alone (the machine inputs and outputs): a fixed mapping is accepted only when
/// it is that layout; `what` names the PDO's content in the refusal.
pub(crate) fn map_pdo_exactly<B: TimedBus + ?Sized>(
    sdo: &mut BlockingSdo<'_, B>,
    node: NodeId,
    pdo: &PdoSpec<'_>,
    what: &str,
) -> Result<(), MapPdoError> {
    let layout = map_pdo(sdo, node, pdo)?;
    if layout != *pdo.layout {
        return Err(MapPdoError::Fixed {
            pdo: pdo.name(),
            found: layout.entries().collect(),
            problem: format!("the {what} PDO must carry {what} alone (its mapping is fixed)"),
        });
    }
    Ok(())
}

/// The abort codes by which a drive says a PDO's mapping cannot be changed (a read-only
/// mapping object, or one that takes no other objects).
fn refuses_remap(e: &SdoError) -> bool {
    matches!(
        e.abort_code(),
        Some(
            AbortCode::WriteReadOnly
                | AbortCode::UnsupportedAccess
                | AbortCode::CannotMap
                | AbortCode::MappingTooLong
                | AbortCode::ParameterIncompatible
                | AbortCode::DeviceIncompatible
        )
    )
}

/// Maps one PDO in the CiA 301 sequence: COB-ID bit 31 set (invalid) → mapping sub0 = 0 →
/// the layout's entries → sub0 = n → transmission type (and event timing) → COB-ID valid.
/// The COB-ID's bit 30 (RTR not allowed) is kept as the drive reports it. A drive that
/// refuses to change the mapping ([`refuses_remap`]) keeps its own if [`fixed_layout`]
/// accepts it. Returns the layout in use.
pub fn map_pdo<B: TimedBus + ?Sized>(
    sdo: &mut BlockingSdo<'_, B>,
    node: NodeId,
    pdo: &PdoSpec<'_>,
) -> Result<PdoLayout, MapPdoError> {
    let (comm, mapping) = (pdo.comm, pdo.mapping);
    let current = sdo.read_u32(node, comm, 1)?;
    let valid = (current & COB_NO_RTR) | pdo.cob_id as u32;
    sdo.write_u32(node, comm, 1, valid | COB_INVALID)?;
    let layout = match sdo.write_u8(node, mapping, 0, 0) {
        Ok(()) => {
            let entries = pdo.layout.entries();
            let count = entries.len() as u8;
            for (i, e) in entries.enumerate() {
                sdo.write_u32(node, mapping, i as u8 + 1, e.to_u32())?;
            }
            sdo.write_u8(node, mapping, 0, count)?;
            *pdo.layout
        }
        Err(e) if refuses_remap(&e) => {
            let found = read_mapping(sdo, node, mapping)?;
            fixed_layout(pdo.layout, &found).map_err(|problem| MapPdoError::Fixed {
                pdo: pdo.name(),
                found,
                problem,
            })?
        }
        Err(e) => return Err(e.into()),
    };
    sdo.write_u8(node, comm, 2, pdo.transmission_type)?;
    if let Some((inhibit_100us, event_timer_ms)) = pdo.event_timing {
        sdo.write_u16(node, comm, 3, inhibit_100us)?;
        sdo.write_u16(node, comm, 5, event_timer_ms)?;
    }
    sdo.write_u32(node, comm, 1, valid)?;
    Ok(layout)
}

/// The mapping a drive has at `mapping` (sub 0 = count, at most 8 entries read).
fn read_mapping<B: TimedBus + ?Sized>(
    sdo: &mut BlockingSdo<'_, B>,
    node: NodeId,
    mapping: u16,
) -> Result<Vec<MappingEntry>, SdoError> {
    let count = sdo.read_u8(node, mapping, 0)?.min(8);
    (1..=count)
        .map(|sub| sdo.read_u32(node, mapping, sub).map(MappingEntry::from_u32))
        .collect()
}

/// A drive's own mapping `found` as the layout the master uses instead of `wanted`: it must
/// be a valid layout of known objects carrying every object of `wanted`; an RPDO may carry
/// nothing else but the mode of operation (sent as CSP), since the master would write 0 to
/// any other object.
pub fn fixed_layout(wanted: &PdoLayout, found: &[MappingEntry]) -> Result<PdoLayout, String> {
    let layout = PdoLayout::new(wanted.direction(), found).map_err(|e| e.to_string())?;
    let missing: Vec<String> = wanted
        .fields()
        .iter()
        .filter(|f| !layout.maps(f.object))
        .map(|f| object_label(f.object))
        .collect();
    if !missing.is_empty() {
        return Err(format!("it lacks {}", missing.join(" and ")));
    }
    if matches!(wanted.direction(), PdoDirection::Rpdo) {
        let extra: Vec<String> = layout
            .fields()
            .iter()
            .filter(|f| !wanted.maps(f.object) && f.object != PdoObject::ModesOfOperation)
            .map(|f| object_label(f.object))
            .collect();
        if !extra.is_empty() {
            return Err(format!(
                "it also carries {}, which the master does not drive",
                extra.join(" and ")
            ));
        }
    }
    Ok(layout)
}

fn object_label(o: PdoObject) -> String {
    let e = o.entry();
    format!("{:?} {:#06x}", o, e.index)
}

/// The configuration one drive gets (from the machine config).
struct DriveSetup {
    axis: char,
    node: NodeId,
    period: InterpolationPeriod,
    period_us: u32,
    window_counts: u32,
    fe_timeout_ms: u16,
    heartbeat_ms: u16,
    counts_per_unit: f64,
    /// The master's node id and the drive's consumer timeout for it (0: no supervision).
    master_node: NodeId,
    master_timeout_ms: u16,
    /// The identity the config expects (checked before anything is written).
    identity: Option<ExpectedIdentity>,
    pdo_layout: BusPdoLayout,
    /// The compact layout's statusword event timer (ms).
    refresh_ms: u16,
    /// The commissioning writes (after the master's own set-up) and the DCF values skipped.
    commissioning: cnc402_config::Commissioning,
}

/// 0x1018 as read against the identity the config expects: the first sub-index that differs.
fn check_identity(
    d: &DriveSetup,
    vendor: u32,
    product: Option<u32>,
    revision: Option<u32>,
) -> Result<(), BootError> {
    let Some(want) = d.identity else {
        return Ok(());
    };
    let wrong = |sub, expected, actual| BootError::WrongIdentity {
        axis: d.axis,
        node: d.node.get(),
        sub,
        expected,
        actual,
    };
    if vendor != want.vendor {
        return Err(wrong(1, want.vendor, Some(vendor)));
    }
    if let Some(p) = want.product
        && product != Some(p)
    {
        return Err(wrong(2, p, product));
    }
    if let Some(r) = want.revision_min
        && revision.is_none_or(|v| v < r)
    {
        return Err(wrong(3, r, revision));
    }
    Ok(())
}

/// An RPDO the master does not use.
pub const UNUSED_RPDO: PdoLayout = valid_layout(PdoDirection::Rpdo, &[]);
/// A TPDO the master does not use.
pub const UNUSED_TPDO: PdoLayout = valid_layout(PdoDirection::Tpdo, &[]);

/// The layouts of PDO 1 and 2 each way as a drive has them after boot: what the master
/// mapped, or a drive's fixed mapping it accepted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MappedPdos {
    /// RPDO1, RPDO2.
    pub rx: [PdoLayout; 2],
    /// TPDO1, TPDO2.
    pub tx: [PdoLayout; 2],
}

impl MappedPdos {
    /// What `layout` maps when the drive takes it as written.
    pub const fn of(layout: BusPdoLayout) -> MappedPdos {
        match layout {
            BusPdoLayout::Standard => MappedPdos {
                rx: [RPDO1_LAYOUT, UNUSED_RPDO],
                tx: [TPDO1_LAYOUT, UNUSED_TPDO],
            },
            BusPdoLayout::Compact => MappedPdos {
                rx: [COMPACT_RPDO1_LAYOUT, COMPACT_RPDO2_LAYOUT],
                tx: [COMPACT_TPDO1_LAYOUT, COMPACT_TPDO2_LAYOUT],
            },
        }
    }
}

/// The PDOs of `layout`: standard = RPDO1 and TPDO1 as [`RPDO1_LAYOUT`] and
/// [`TPDO1_LAYOUT`], synchronous, TPDO2..4 off; compact = RPDO1/TPDO1 target/position alone,
/// synchronous, RPDO2 controlword and TPDO2 statusword event-driven (the statusword with the
/// inhibit time the load plan counts and an event timer of `refresh_ms`), TPDO3..4 off.
/// Returns the layouts in use (a drive's fixed mapping where it keeps one).
fn map_cyclic_pdos<B: TimedBus + ?Sized>(
    sdo: &mut BlockingSdo<'_, B>,
    n: NodeId,
    layout: BusPdoLayout,
    refresh_ms: u16,
) -> Result<MappedPdos, MapPdoError> {
    let id = n.get() as u16;
    let mut mapped = MappedPdos::of(layout);
    let sync = SYNCHRONOUS_EVERY_SYNC;
    // (RPDO?, transmission type, TPDO event timing) of PDO 1, 2 … each way, in map order.
    type Plan = (bool, u8, Option<(u16, u16)>);
    let (kinds, used): (&[Plan], u16) = match layout {
        BusPdoLayout::Standard => (&[(true, sync, None), (false, sync, None)], 1),
        BusPdoLayout::Compact => (
            &[
                (true, sync, None),
                (true, EVENT_DRIVEN, None),
                (false, sync, None),
                (
                    false,
                    EVENT_DRIVEN,
                    Some((COMPACT_TPDO2_INHIBIT_100US, refresh_ms)),
                ),
            ],
            2,
        ),
    };
    let (mut next_rx, mut next_tx) = (0usize, 0usize);
    for &(rpdo, transmission_type, event_timing) in kinds {
        let (p, slot) = if rpdo {
            next_rx += 1;
            (next_rx - 1, &mut mapped.rx[next_rx - 1])
        } else {
            next_tx += 1;
            (next_tx - 1, &mut mapped.tx[next_tx - 1])
        };
        let p16 = p as u16;
        let spec = PdoSpec {
            comm: if rpdo {
                obj::RPDO_COMMUNICATION
            } else {
                obj::TPDO_COMMUNICATION
            } + p16,
            mapping: if rpdo {
                obj::RPDO_MAPPING
            } else {
                obj::TPDO_MAPPING
            } + p16,
            cob_id: if rpdo { 0x200 } else { 0x180 } + 0x100 * p16 + id,
            layout: &*slot,
            transmission_type,
            event_timing,
        };
        let in_use = map_pdo(sdo, n, &spec)?;
        *slot = in_use;
    }
    // The other TPDOs off: a drive's default mapping would only add bus load (4 CSP axes at
    // 1 ms already use ~97 % of 1 Mbit/s with the standard layout).
    for p in used..4u16 {
        let comm = obj::TPDO_COMMUNICATION + p;
        if let Some(cob) = optional(sdo.read_u32(n, comm, 1))?
            && cob & COB_INVALID == 0
        {
            sdo.write_u32(n, comm, 1, cob | COB_INVALID)?;
        }
    }
    Ok(mapped)
}

/// CSP mode, the interpolation and SYNC period, the following-error window and time-out,
/// and the drive's heartbeat.
fn write_cyclic_parameters<B: TimedBus + ?Sized>(
    sdo: &mut BlockingSdo<'_, B>,
    d: &DriveSetup,
) -> Result<(), SdoError> {
    let n = d.node;
    sdo.write_i8(n, obj::MODES_OF_OPERATION, 0, 8)?;
    sdo.write_u8(
        n,
        obj::INTERPOLATION_TIME_PERIOD,
        obj::INTERPOLATION_TIME_PERIOD_VALUE_SUB,
        d.period.value,
    )?;
    sdo.write_i8(
        n,
        obj::INTERPOLATION_TIME_PERIOD,
        obj::INTERPOLATION_TIME_PERIOD_INDEX_SUB,
        d.period.exponent,
    )?;
    // 0x1006 lets the drive watch the SYNC period; optional in CiA 301.
    optional(sdo.write_u32(n, obj::COMMUNICATION_CYCLE_PERIOD, 0, d.period_us))?;
    sdo.write_u32(n, obj::FOLLOWING_ERROR_WINDOW, 0, d.window_counts)?;
    sdo.write_u16(n, obj::FOLLOWING_ERROR_TIMEOUT, 0, d.fe_timeout_ms)?;
    sdo.write_u16(n, obj::PRODUCER_HEARTBEAT_TIME, 0, d.heartbeat_ms)?;
    Ok(())
}

/// The drive's supervision of the master (0x1016:1, 0x6007); returns whether it watches the
/// master's heartbeat and whether it takes quick stop on its loss.
fn supervise_master<B: TimedBus + ?Sized>(
    sdo: &mut BlockingSdo<'_, B>,
    d: &DriveSetup,
) -> Result<(bool, bool), SdoError> {
    let n = d.node;
    // The drive watches the master: 0x1016:1 = node << 16 | timeout ms (0 = off), and quick
    // stops when it misses it (0x6007). Both optional in CiA 301/402: a drive without them is
    // reported, not refused.
    let consumer = if d.master_timeout_ms > 0 {
        (d.master_node.get() as u32) << 16 | d.master_timeout_ms as u32
    } else {
        0
    };
    let supervises_master = optional(sdo.write_u32(n, obj::CONSUMER_HEARTBEAT_TIME, 1, consumer))?
        .is_some()
        && consumer != 0;
    // A drive with 0x6007 but without the quick stop reaction refuses the value: also
    // reported, it keeps its own reaction.
    let abort_connection_quick_stop = match sdo.write_i16(
        n,
        obj::ABORT_CONNECTION_OPTION,
        0,
        ABORT_CONNECTION_QUICK_STOP,
    ) {
        Ok(()) => true,
        Err(e)
            if matches!(
                e.abort_code(),
                Some(AbortCode::InvalidValue | AbortCode::ValueTooHigh | AbortCode::ValueTooLow)
            ) =>
        {
            false
        }
        Err(e) => optional::<()>(Err(e))?.is_some(),
    };
    Ok((supervises_master, abort_connection_quick_stop))
}

/// Identity, checks and configuration of one drive, up to NMT start (exclusive).
fn configure<B: TimedBus + ?Sized>(
    sdo: &mut BlockingSdo<'_, B>,
    d: &DriveSetup,
    seen_at: Instant,
) -> Result<(DriveIdentity, MappedPdos), BootError> {
    let n = d.node;
    let device_type = sdo.read_u32(n, obj::DEVICE_TYPE, 0)?;
    if device_type & 0xFFFF != 0x0192 {
        return Err(BootError::NotCia402 {
            axis: d.axis,
            node: n.get(),
            device_type,
        });
    }
    let vendor = sdo.read_u32(n, obj::IDENTITY, 1)?;
    let product = optional(sdo.read_u32(n, obj::IDENTITY, 2))?;
    let revision = optional(sdo.read_u32(n, obj::IDENTITY, 3))?;
    check_identity(d, vendor, product, revision)?;
    let serial = optional(sdo.read_u32(n, obj::IDENTITY, 4))?;
    let name = optional(sdo.read_string(n, obj::DEVICE_NAME, 0))?;

    let pdos = map_cyclic_pdos(sdo, n, d.pdo_layout, d.refresh_ms)
        .map_err(|e| e.into_boot_error(d.axis, n))?;
    write_cyclic_parameters(sdo, d)?;
    let (supervises_master, abort_connection_quick_stop) = supervise_master(sdo, d)?;
    commission(sdo, d)?;
    let initial_statusword = Statusword(sdo.read_u16(n, obj::STATUSWORD, 0)?);
    let ident = DriveIdentity {
        axis: d.axis,
        node: n.get(),
        device_type,
        vendor,
        product,
        revision,
        serial,
        name,
        seen_at,
        initial_statusword,
        fault_at_power_on: None,
        position_counts: 0,
        position: 0.0,
        supervises_master,
        abort_connection_quick_stop,
        commissioning_writes: d.commissioning.writes.len(),
        skipped_parameters: d.commissioning.skipped.clone(),
    };
    Ok((ident, pdos))
}

/// The commissioning writes in order (the DCF's values, then the config's `sdo` list), after
/// the master's set-up so an explicit entry may override what the master wrote. The first
/// refused write stops boot, naming the object and where it was asked for.
fn commission<B: TimedBus + ?Sized>(
    sdo: &mut BlockingSdo<'_, B>,
    d: &DriveSetup,
) -> Result<(), BootError> {
    for w in &d.commissioning.writes {
        sdo.download(d.node, w.index, w.sub, &w.data)
            .map_err(|error| BootError::Commissioning {
                axis: d.axis,
                write: Box::new(w.clone()),
                error,
            })?;
    }
    Ok(())
}

impl Master {
    fn drive_indices(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.n_axes).filter(|&i| self.axes[i].node.is_some())
    }

    fn absorb_all(&mut self, frames: &mut Vec<CanFrame>, now: Instant) {
        for f in frames.drain(..) {
            self.absorb(&f, now);
        }
    }

    /// Boots, configures and enables every drive (blocking; see the module doc). On success
    /// the master is in [`Phase::Running`] and [`positions`](Self::positions) are the actual
    /// positions the drives were enabled at.
    pub fn boot<B: TimedBus + ?Sized>(&mut self, bus: &mut B) -> Result<BootReport, BootError> {
        if self.phase != Phase::Idle {
            return Err(BootError::WrongPhase(self.phase));
        }
        let r = self.boot_inner(bus);
        if r.is_err() {
            // A failed boot can be retried from the start (it resets communication first).
            self.phase = Phase::Idle;
            self.stop = None;
        }
        r
    }

    /// The boot steps in order (see the module doc): drain, reset communication, wait for
    /// every boot-up, configure and start each drive, then the enable sequence.
    fn boot_inner<B: TimedBus + ?Sized>(&mut self, bus: &mut B) -> Result<BootReport, BootError> {
        let t0 = bus.now();
        while let Some(f) = bus.recv()? {
            self.absorb(&f, t0);
        }
        let drives: Vec<usize> = self.drive_indices().collect();
        if self.options.reset_communication {
            self.reset_communication(bus, &drives)?;
        }
        let seen_at = self.wait_for_boot_up(bus, &drives, t0)?;
        let mut report = BootReport {
            drives: Vec::with_capacity(drives.len()),
            enabled_at: Instant::ZERO,
            enable_cycles: 0,
        };
        for &i in &drives {
            if let Some(ident) = self.set_up_drive(bus, i, seen_at[i])? {
                report.drives.push(ident);
            }
        }
        // No drive has seen a SYNC yet: SYNC and TPDO counts start together.
        self.syncs = 0;
        for a in self.axes[..self.n_axes].iter_mut() {
            a.tpdos = 0;
            a.owed = 0;
        }
        let (enabled_at, cycles) = self.run_enable(bus)?;
        report.enabled_at = enabled_at;
        report.enable_cycles = cycles;
        Ok(report)
    }

    /// NMT reset communication to each drive of `drives`; each is then unbooted until its
    /// boot-up comes.
    fn reset_communication<B: TimedBus + ?Sized>(
        &mut self,
        bus: &mut B,
        drives: &[usize],
    ) -> Result<(), BusError> {
        for &i in drives {
            if let Some(n) = self.axes[i].node {
                bus.send(
                    &NmtRepr {
                        command: NmtCommand::ResetCommunication,
                        target: NmtTarget::Node(n),
                    }
                    .emit(),
                )?;
            }
            self.axes[i].booted = false;
            self.axes[i].boot_ups = 0;
            self.axes[i].last_heartbeat = None;
        }
        Ok(())
    }

    /// Waits for every drive's boot-up (a late drive: up to the boot timeout from `t0`);
    /// returns when each was seen, indexed like the axes.
    fn wait_for_boot_up<B: TimedBus + ?Sized>(
        &mut self,
        bus: &mut B,
        drives: &[usize],
        t0: Instant,
    ) -> Result<[Instant; cnc402_config::MAX_AXES], BootError> {
        let boot_deadline = t0 + self.options.boot_timeout;
        let mut seen_at = [Instant::ZERO; cnc402_config::MAX_AXES];
        loop {
            for &i in drives {
                if self.axes[i].booted && seen_at[i] == Instant::ZERO {
                    seen_at[i] = self.axes[i].last_heartbeat.unwrap_or(bus.now());
                }
            }
            if drives.iter().all(|&i| self.axes[i].booted) {
                return Ok(seen_at);
            }
            match bus.recv_until(boot_deadline)? {
                Some(f) => {
                    let now = bus.now();
                    self.absorb(&f, now);
                }
                None => {
                    let i = drives
                        .iter()
                        .copied()
                        .find(|&i| !self.axes[i].booted)
                        .unwrap_or(0);
                    return Err(BootError::NoBootUp {
                        axis: self.axes[i].name,
                        node: self.axes[i].node.map(NodeId::get).unwrap_or(0),
                        waited: bus.now().saturating_since(t0),
                    });
                }
            }
        }
    }

    /// What drive axis `i` (node `node`) is configured with.
    fn drive_setup(&self, i: usize, node: NodeId) -> DriveSetup {
        let a = &self.axes[i];
        DriveSetup {
            axis: a.name,
            node,
            period: self.interpolation,
            period_us: self.period_us,
            window_counts: a.window_counts,
            fe_timeout_ms: a.fe_timeout_ms,
            heartbeat_ms: self.heartbeat_ms,
            counts_per_unit: a.counts_per_unit,
            master_node: self.master_node,
            // Off with heartbeats off: the master then produces none.
            master_timeout_ms: if self.heartbeat_ms > 0 {
                self.heartbeat_timeout.as_millis().min(u16::MAX as u128) as u16
            } else {
                0
            },
            identity: a.identity,
            pdo_layout: self.pdo_layout,
            refresh_ms: self.event_refresh_ms,
            commissioning: self.commissioning.get(i).cloned().unwrap_or_default(),
        }
    }

    /// Runs `transfer` with a blocking SDO client on `bus`; the other frames that arrive
    /// meanwhile are taken in afterwards, whether it succeeded or not.
    pub(crate) fn with_sdo<B: TimedBus + ?Sized, T, E>(
        &mut self,
        bus: &mut B,
        transfer: impl FnOnce(&mut BlockingSdo<'_, B>) -> Result<T, E>,
    ) -> Result<T, E> {
        let mut queue: Vec<CanFrame> = Vec::new();
        let mut push = |f: &CanFrame| queue.push(*f);
        let value = transfer(&mut BlockingSdo::new(
            &mut *bus,
            self.sdo_timeout,
            &mut push,
        ));
        let now = bus.now();
        self.absorb_all(&mut queue, now);
        value
    }

    /// [`BootError::DuplicateBootUp`] when drive axis `i` announced itself more than once
    /// since the reset communication.
    fn check_single_boot_up(&self, i: usize) -> Result<(), BootError> {
        let a = &self.axes[i];
        if a.boot_ups > 1 {
            return Err(BootError::DuplicateBootUp {
                axis: a.name,
                node: a.node.map(NodeId::get).unwrap_or(0),
                boot_ups: a.boot_ups,
            });
        }
        Ok(())
    }

    /// Configures drive axis `i` (seen booted at `seen_at`), starts it (NMT) and holds its
    /// target at its actual position; `None` for a virtual axis.
    fn set_up_drive<B: TimedBus + ?Sized>(
        &mut self,
        bus: &mut B,
        i: usize,
        seen_at: Instant,
    ) -> Result<Option<DriveIdentity>, BootError> {
        let Some(node) = self.axes[i].node else {
            return Ok(None);
        };
        let setup = self.drive_setup(i, node);
        let configured = self.with_sdo(bus, |sdo| configure(sdo, &setup, seen_at));
        // A second device on the node answers every request too: its answer to one request
        // arrives during the next, a protocol error. With two boot-ups since the reset, that
        // names the cause better. (Two boot-ups alone are no proof: a drive powering up just
        // as the master resets it sends its power-on boot-up and then the reset's.)
        if let Err(BootError::Sdo(e)) = &configured
            && matches!(e.kind, SdoErrorKind::Protocol { .. })
        {
            self.check_single_boot_up(i)?;
        }
        let (mut ident, pdos) = configured?;
        self.axes[i].pdos = pdos;
        let reference = self.axes[i].reference;
        self.with_sdo(bus, |sdo| {
            super::homing::write_at_boot(sdo, node, &reference)
        })
        .map_err(|e| e.into_boot_error(setup.axis, node))?;
        self.set_up_outputs(bus, i, node)
            .map_err(|e| e.into_boot_error(setup.axis, node))?;
        self.write_estop_option(bus, node)?;
        bus.send(
            &NmtRepr {
                command: NmtCommand::Start,
                target: NmtTarget::Node(node),
            }
            .emit(),
        )?;
        // The NMT state is unknown until the next heartbeat (the boot-up is history).
        self.axes[i].nmt = None;
        // The heartbeat producer was configured just now: the monitor's clock starts here,
        // not at the boot-up (a drive seen long before the last one booted would otherwise
        // count as silent since its boot-up).
        self.axes[i].last_heartbeat = Some(bus.now());
        // The first setpoint is the actual position: 0x607A = 0x6064 before enabling.
        let pos = self.with_sdo(bus, |sdo| {
            let pos = sdo.read_i32(node, obj::POSITION_ACTUAL, 0)?;
            sdo.write_i32(node, obj::TARGET_POSITION, 0, pos)?;
            Ok::<i32, SdoError>(pos)
        })?;
        ident.position_counts = pos;
        ident.position = pos as f64 / setup.counts_per_unit;
        if ident
            .initial_statusword
            .state()
            .is_some_and(State::is_fault)
        {
            ident.fault_at_power_on = Some(self.axes[i].emcy);
        }
        let a = &mut self.axes[i];
        a.reset_actual(pos);
        a.target = pos;
        a.statusword = Some(ident.initial_statusword);
        Ok(Some(ident))
    }

    /// The enable sequence: cycles at the period with every drive's target held at its
    /// actual position until all are OPERATION ENABLED; then [`Phase::Running`]. Returns the
    /// last enable cycle's time and the number of cycles.
    fn run_enable<B: TimedBus + ?Sized>(
        &mut self,
        bus: &mut B,
    ) -> Result<(Instant, u32), BootError> {
        self.start_enabling();
        let drives: Vec<usize> = self.drive_indices().collect();
        let t_enable = bus.now();
        let deadline = t_enable + self.options.enable_timeout;
        let mut next = t_enable + self.period;
        let hold = self.positions();
        let mut stuck: [Option<Stuck>; cnc402_config::MAX_AXES] = [None; cnc402_config::MAX_AXES];
        let mut cycles = 0u32;
        loop {
            self.wait_until(bus, next)?;
            let progress = self.enable_step(bus, next, &hold[..self.n_axes])?;
            cycles += 1;
            let mut all = true;
            for &i in &drives {
                match progress[i] {
                    Progress::Reached => {}
                    Progress::Stuck(s) => {
                        stuck[i] = Some(s);
                        all = false;
                    }
                    Progress::Moving(_) => all = false,
                }
            }
            if all {
                break;
            }
            if next >= deadline {
                let i = drives
                    .iter()
                    .copied()
                    .find(|&i| progress[i] != Progress::Reached)
                    .unwrap_or(0);
                return Err(self.goal_not_reached(i, stuck[i], next.saturating_since(t_enable)));
            }
            next += self.period;
        }
        self.start_running(next);
        Ok((next, cycles))
    }

    /// Enables the drives again after a stop (or a disable) without booting: clears the
    /// latched stop, holds each drive's target at its last reported actual position, runs the
    /// enable sequence (fault reset included) and returns to [`Phase::Running`]. Start the
    /// interpolator at [`positions`](Self::positions) afterwards. Returns the time of the last
    /// enable cycle (the next cycle is one period later).
    pub fn reenable<B: TimedBus + ?Sized>(&mut self, bus: &mut B) -> Result<Instant, BootError> {
        if self.phase == Phase::Idle {
            return Err(BootError::WrongPhase(self.phase));
        }
        self.stop = None;
        // One period without SYNC lets every TPDO in flight arrive; then the counts agree
        // again (a drive that dropped TPDOs before the stop starts afresh).
        let settle = bus.now() + self.period;
        self.wait_until(bus, settle)?;
        let syncs = self.syncs;
        for a in self.axes[..self.n_axes].iter_mut() {
            a.tpdos = syncs;
            a.owed = 0;
            if a.node.is_some() {
                a.target = a.actual_raw;
            } else {
                a.actual = a.last_command;
            }
            a.emcy = None;
        }
        match self.run_enable(bus) {
            Ok((t, _)) => Ok(t),
            Err(e) => {
                // Leave the drives held with power off rather than half-enabled.
                self.request_disable();
                Err(e)
            }
        }
    }

    /// The error of drive axis `i` when it has not reached its enable (or disable) goal after
    /// `waited`, with what it last reported.
    fn goal_not_reached(&self, i: usize, stuck: Option<Stuck>, waited: Duration) -> BootError {
        let a = &self.axes[i];
        BootError::Enable {
            axis: a.name,
            node: a.node.map(NodeId::get).unwrap_or(0),
            statusword: a.statusword,
            stuck,
            emcy: a.emcy,
            waited,
        }
    }

    /// Waits until `deadline`, taking in every frame that arrives.
    pub(crate) fn wait_until<B: TimedBus + ?Sized>(
        &mut self,
        bus: &mut B,
        deadline: Instant,
    ) -> Result<(), BusError> {
        while let Some(f) = bus.recv_until(deadline)? {
            let now = bus.now();
            self.absorb(&f, now);
        }
        Ok(())
    }

    fn start_enabling(&mut self) {
        self.phase = Phase::Enabling;
        for a in self.axes[..self.n_axes].iter_mut() {
            a.sequencer = EnableSequencer::new(Goal::OperationEnabled);
            a.controlword_sent = None;
            a.quick_stop = false;
            a.tpdo_missing = 0;
            a.tpdo_this_cycle = false;
            // The steady lateness is learnt again from this enable phase's TPDOs.
            a.late_base = u32::MAX;
            a.ambiguous_cycles = 0;
            a.window_tpdos = 0;
            a.age = 0;
            a.fe_beyond = 0;
            a.fe_comparable = true;
            a.expected = a.actual;
        }
        self.sync_sent = false;
    }

    /// One enable cycle: the cycle's send phase steps each drive's sequencer; returns each
    /// drive's progress towards OPERATION ENABLED.
    fn enable_step<B: TimedBus + ?Sized>(
        &mut self,
        bus: &mut B,
        now: Instant,
        hold: &[f64],
    ) -> Result<[Progress; cnc402_config::MAX_AXES], BootError> {
        self.cycle(bus, now, hold).map_err(BootError::Stopped)?;
        Ok(core::array::from_fn(|i| {
            if self.axes.get(i).is_some_and(|a| a.node.is_some()) {
                self.axes[i].progress
            } else {
                Progress::Reached
            }
        }))
    }

    fn start_running(&mut self, now: Instant) {
        self.phase = Phase::Running;
        self.cycles = 0;
        for a in self.axes[..self.n_axes].iter_mut() {
            a.history = [a.actual; COMMAND_HISTORY];
            a.expected = a.actual;
            a.last_command = a.actual;
            a.emcy = None;
            a.tpdo_missing = 0;
            a.following_error = 0.0;
            a.max_following_error = 0.0;
            if a.node.is_some() && a.last_heartbeat.is_none() {
                a.last_heartbeat = Some(now);
            }
            // The statusword's age counts from here (the enable phase may have been long).
            if a.node.is_some() {
                a.statusword_at = Some(now);
            }
        }
    }

    /// Takes every drive to SWITCH ON DISABLED (blocking, cycles at the period with the
    /// last commands held); gives up after the enable timeout naming the drive.
    pub fn disable<B: TimedBus + ?Sized>(&mut self, bus: &mut B) -> Result<(), BootError> {
        if self.phase == Phase::Idle {
            return Err(BootError::WrongPhase(self.phase));
        }
        self.request_disable();
        let t0 = bus.now();
        let deadline = t0 + self.options.enable_timeout;
        let mut next = t0 + self.period;
        let hold: [f64; cnc402_config::MAX_AXES] =
            core::array::from_fn(|i| self.axes[i].last_command);
        loop {
            self.wait_until(bus, next)?;
            let _ = self.cycle(bus, next, &hold[..self.n_axes]);
            if self.is_disabled() {
                return Ok(());
            }
            if next >= deadline {
                let i = (0..self.n_axes)
                    .find(|&i| !self.axes[i].disabled)
                    .unwrap_or(0);
                return Err(self.goal_not_reached(i, None, next.saturating_since(t0)));
            }
            next += self.period;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_period_representations() {
        let p = |us| InterpolationPeriod::from_micros(us).map(|p| (p.value, p.exponent));
        assert_eq!(p(1000), Some((1, -3)));
        assert_eq!(p(2000), Some((2, -3)));
        assert_eq!(p(250), Some((25, -5)));
        assert_eq!(p(125), Some((125, -6)));
        assert_eq!(p(1500), Some((15, -4)));
        assert_eq!(p(255_000), Some((255, -3)));
        assert_eq!(p(256_000), None);
        assert_eq!(p(12345), None);
        assert_eq!(p(0), None);
    }
}
