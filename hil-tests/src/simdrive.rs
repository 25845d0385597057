//! The drive host behind the `simdrive` binary: one [`SimDrive`] per configured node, fed
//! every frame from a bus, plus what it observes on the way — the SYNC period, rigid-tapping
//! coupling of Z and C (setpoints as received in the RPDOs and the simulated actual
//! positions), protocol errors, injected faults — and the JSON report it writes.
//! Independent of the transport: [`DriveHost`] is a [`CanDevice`], so tests attach it to an
//! in-process `SimBus` and the binary feeds it from a SocketCAN socket.

use std::fmt;
use std::str::FromStr;
use std::time::Duration;

use cia402::State;
use cnc402_config::{AxisConfig, AxisKind, MachineConfig};
use cnc402_drives::Instant;
use cnc402_drives::bus::{CanDevice, FrameSink};
use cnc402_drives::coupling::{CountSample, CouplingChecker, TapWindow};
use cnc402_drives::sim::{FaultKind, NmtStatus, SimDrive, SimDriveOptions, SimDriveStats};
use cnc402_drives::wire::{CanFrame, NodeId, SdoRequest, WireError};
use serde_json::{Value, json};

use crate::latency::percentile;

/// CANopen's default SYNC identifier (0x1005).
const SYNC_ID: u16 = 0x80;
/// SYNC intervals kept for the percentiles (about 17 minutes at 1 ms; later ones are
/// counted in max/count only).
const MAX_SYNC_SAMPLES: usize = 1 << 20;
/// State changes kept per drive.
const MAX_STATE_HISTORY: usize = 64;

/// A fault to inject: `NODE:KIND@SECONDS` (see [`FaultKind`] for KIND).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultSpec {
    /// Node id of the drive.
    pub node: u8,
    /// What to inject.
    pub kind: FaultKind,
    /// Seconds after the time reference ([`FaultClock`]).
    pub at_s: f64,
}

/// An error that is its message: `pub struct $name(pub String)`, displayed as the message.
macro_rules! message_error {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(Clone, Debug, PartialEq, Eq)]
        pub struct $name(pub String);

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(&self.0)
            }
        }

        impl std::error::Error for $name {}
    };
}

message_error!(
    /// Errors of the command-line value parsers.
    SpecError
);

fn parse_node(s: &str, whole: &str) -> Result<u8, SpecError> {
    match s.trim().parse::<u8>() {
        Ok(n) if (1..=127).contains(&n) => Ok(n),
        _ => Err(SpecError(format!(
            "`{whole}`: node id `{s}` is not 1..=127"
        ))),
    }
}

fn parse_seconds(s: &str, whole: &str) -> Result<f64, SpecError> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && (0.0..=1.0e6).contains(&v) => Ok(v),
        _ => Err(SpecError(format!(
            "`{whole}`: `{s}` is not a time in seconds (0..1e6)"
        ))),
    }
}

impl FromStr for FaultSpec {
    type Err = SpecError;
    /// Parses `NODE:KIND@SECONDS`, e.g. `3:fault:0x7300@1.5`, `4:heartbeat@2`.
    ///
    /// ```
    /// use cnc402_hil::simdrive::FaultSpec;
    /// use cnc402_drives::sim::FaultKind;
    /// let f: FaultSpec = "3:fault:0x7300@1.5".parse().unwrap();
    /// assert_eq!((f.node, f.kind, f.at_s), (3, FaultKind::Fault(0x7300), 1.5));
    /// assert!("3:fault".parse::<FaultSpec>().is_err());
    /// ```
    fn from_str(s: &str) -> Result<FaultSpec, SpecError> {
        let (spec, at) = s
            .rsplit_once('@')
            .ok_or_else(|| SpecError(format!("`{s}`: expected NODE:KIND@SECONDS")))?;
        let (node, kind) = spec
            .split_once(':')
            .ok_or_else(|| SpecError(format!("`{s}`: expected NODE:KIND@SECONDS")))?;
        Ok(FaultSpec {
            node: parse_node(node, s)?,
            kind: kind.parse().map_err(|e| SpecError(format!("`{s}`: {e}")))?,
            at_s: parse_seconds(at, s)?,
        })
    }
}

/// `NODE:SECONDS` (`--boot-delay`): the drive's boot-up message comes this long after
/// power-on.
///
/// ```
/// assert_eq!(cnc402_hil::simdrive::parse_boot_delay("2:1.5").unwrap(), (2, 1.5));
/// ```
pub fn parse_boot_delay(s: &str) -> Result<(u8, f64), SpecError> {
    let (node, secs) = s
        .split_once(':')
        .ok_or_else(|| SpecError(format!("`{s}`: expected NODE:SECONDS")))?;
    Ok((parse_node(node, s)?, parse_seconds(secs, s)?))
}

/// `NODE[:CODE]` (`--start-in-fault`): the drive is in FAULT with EMCY CODE (default 0x1000,
/// hex with 0x or decimal) right after boot-up.
///
/// ```
/// use cnc402_hil::simdrive::parse_start_in_fault;
/// assert_eq!(parse_start_in_fault("1").unwrap(), (1, 0x1000));
/// assert_eq!(parse_start_in_fault("1:0x5530").unwrap(), (1, 0x5530));
/// ```
pub fn parse_start_in_fault(s: &str) -> Result<(u8, u16), SpecError> {
    let (node, code) = match s.split_once(':') {
        Some((n, c)) => {
            let c = c.trim();
            let code = match c.strip_prefix("0x").or_else(|| c.strip_prefix("0X")) {
                Some(h) => u16::from_str_radix(h, 16),
                None => c.parse(),
            }
            .map_err(|_| SpecError(format!("`{s}`: `{c}` is not an EMCY code")))?;
            (n, code)
        }
        None => (s, 0x1000),
    };
    Ok((parse_node(node, s)?, code))
}

/// When the clock of `--fault …@SECONDS` starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultClock {
    /// At the first SYNC seen (the master's cyclic phase): independent of process start
    /// and boot time, so a fault lands at the same point of the program on a slow machine.
    FirstSync,
    /// At power-on of the drives (host start).
    Start,
    /// At the first SYNC on which the tool axis and the spindle move together (the first
    /// Z+C window of the coupling checker: the first tap): lands a fault inside a tap on any
    /// machine, however slowly the program runs against the wall clock.
    FirstTap,
}

/// Everything the host needs besides the machine config.
#[derive(Clone, Debug)]
pub struct HostOptions {
    pub faults: Vec<FaultSpec>,
    pub fault_clock: FaultClock,
    /// Per node: boot delay.
    pub boot_delays: Vec<(u8, f64)>,
    /// Per node: start in FAULT with this EMCY code.
    pub start_in_fault: Vec<(u8, u16)>,
    /// Host only these nodes of the config (empty: all). A second simdrive with one node of
    /// the first one's config is a second device on that node id (a duplicate node id).
    pub only_nodes: Vec<u8>,
    /// Judge every tap window's actual-position coupling against this (µm); `None`: the
    /// actual figure is reported only.
    pub actual_limit_um: Option<f64>,
}

impl Default for HostOptions {
    fn default() -> Self {
        HostOptions {
            faults: Vec::new(),
            fault_clock: FaultClock::FirstSync,
            boot_delays: Vec::new(),
            start_in_fault: Vec::new(),
            only_nodes: Vec::new(),
            actual_limit_um: None,
        }
    }
}

/// Whether the master's dynamic matching shapes a tap's Z and C setpoints apart: both have
/// a drive model (`dynamics`) and the models differ.
fn tap_pair_is_shaped(cfg: &MachineConfig) -> bool {
    let model = |pick: &dyn Fn(&cnc402_config::AxisConfig) -> bool| {
        cfg.axes.iter().find(|a| pick(a)).and_then(|a| a.dynamics)
    };
    match (
        model(&|a| a.name == 'Z'),
        model(&|a| a.kind == AxisKind::Spindle),
    ) {
        (Some(z), Some(c)) => z != c,
        _ => false,
    }
}

message_error!(
    /// Why a host could not be built.
    HostError
);

/// Unwraps an i32 position that may wrap around (a spindle turning for minutes).
#[derive(Clone, Copy, Debug, Default)]
struct Unwrap {
    last: Option<i32>,
    value: i64,
    wraps: u32,
}

impl Unwrap {
    fn feed(&mut self, raw: i32) -> i64 {
        match self.last {
            None => self.value = raw as i64,
            Some(prev) => {
                self.value += raw.wrapping_sub(prev) as i64;
                if (prev < 0) != (raw < 0) && (prev as i64 - raw as i64).abs() > i32::MAX as i64 {
                    self.wraps += 1;
                }
            }
        }
        self.last = Some(raw);
        self.value
    }
}

struct Hosted {
    drive: SimDrive,
    axis: char,
    counts_per_unit: f64,
    state_history: Vec<State>,
    reached_enabled: bool,
    faults_entered: u32,
    fault_resets: u32,
    actual: Unwrap,
    target: Unwrap,
    last_emcy_code: Option<u16>,
}

impl Hosted {
    /// This drive's entry in the report's `drives` (`s`: its counters).
    fn report(&self, s: &SimDriveStats) -> Value {
        let sw = self.drive.statusword().0;
        let position = if self.actual.last.is_some() {
            self.actual.value
        } else {
            self.drive.position_actual() as i64
        };
        json!({
            "axis": self.axis.to_string(),
            "nmt": format!("{:?}", self.drive.nmt()),
            "state": format!("{:?}", self.drive.state()),
            "statusword": format!("0x{sw:04x}"),
            "position": position as f64 / self.counts_per_unit,
            "position_counts": self.drive.position_actual(),
            "position_wraps": self.actual.wraps,
            "target_wraps": self.target.wraps,
            "fault_code": self.drive.fault_code().map(|c| format!("0x{c:04x}")),
            "last_fault_code": self.last_emcy_code.map(|c| format!("0x{c:04x}")),
            "reached_operation_enabled": self.reached_enabled,
            "faults_entered": self.faults_entered,
            "fault_resets": self.fault_resets,
            "state_history": self.state_history.iter().map(|s| format!("{s:?}")).collect::<Vec<_>>(),
            "max_following_error": s.max_following_error as f64 / self.counts_per_unit,
            "syncs": s.syncs,
            "rpdos": s.rpdos_applied,
            "tpdos_sent": s.tpdos_sent,
            "tpdos_dropped": s.tpdos_dropped,
            "sdo_requests": s.sdo_requests,
            "sdo_aborts": s.sdo_aborts,
            "emcys_sent": s.emcys_sent,
            "heartbeats_sent": s.heartbeats_sent,
            "boot_ups": s.boot_ups,
            "unexpected_frames": s.unexpected_frames,
            "pdo_length_errors": s.pdo_length_errors,
        })
    }

    fn note_state(&mut self) {
        let s = self.drive.state();
        let prev = self.state_history.last().copied();
        if prev == Some(s) {
            return;
        }
        if let Some(p) = prev {
            if !p.is_fault() && s.is_fault() {
                self.faults_entered += 1;
            }
            if p.is_fault() && !s.is_fault() {
                self.fault_resets += 1;
            }
        } else if s.is_fault() {
            self.faults_entered += 1;
        }
        if s == State::OperationEnabled {
            self.reached_enabled = true;
        }
        if let Some(c) = self.drive.fault_code() {
            self.last_emcy_code = Some(c);
        }
        if self.state_history.len() < MAX_STATE_HISTORY {
            self.state_history.push(s);
        }
    }
}

struct ScheduledFault {
    spec: FaultSpec,
    applied_at_s: Option<f64>,
}

/// Host-level protocol counters (the drives' own are added in the report).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HostCounters {
    /// Frames received.
    pub frames: u64,
    /// SYNC frames received.
    pub syncs: u64,
    /// SYNC frames with data (a counter byte is allowed; more is an error).
    pub bad_syncs: u64,
    /// RPDO- or SDO-request frames for nodes this host does not host (a scan probing every
    /// id, other devices on the bus): not a protocol error, reported apart.
    pub unaddressed: u64,
    /// Every frame of or for a node this host does not host (its SDO, PDOs, heartbeat, EMCY,
    /// an NMT command naming it): informational, includes `unaddressed`.
    pub other_nodes: u64,
    /// RPDO- or SDO-request frames on a hosted node's default COB-ID that its drive does not
    /// take (RPDO disabled or remapped, node booting): a protocol error.
    pub unaccepted: u64,
    /// SDO requests to a hosted node with an unknown command specifier (the drive answers
    /// abort 0x05040001): a protocol error. Malformed ones the drive counts itself.
    pub bad_sdo_requests: u64,
}

/// How the host sees one received frame (see [`DriveHost::classify`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameClass {
    /// SYNC, or an NMT command for all nodes or a hosted one, or a frame a hosted drive takes.
    Hosted,
    /// A hosted drive takes it but it is not a valid SDO request (unknown command specifier).
    BadSdoRequest,
    /// A request (RPDO 1-4 or SDO) on a hosted node's default COB-ID that no drive takes.
    Unaccepted,
    /// A request (RPDO 1-4 or SDO) for a node not hosted here.
    OtherNodeRequest,
    /// Any other frame of or for a node not hosted here (responses, TPDOs, heartbeat, EMCY,
    /// NMT naming another node).
    OtherNode,
    /// Not tied to a node (TIME, LSS, ids outside the predefined connection set).
    Unrelated,
}

/// The SYNC intervals of one stretch of a run (`simdrive --stats-every`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SyncWindow {
    pub intervals: u64,
    /// The longest interval, ns (0 without any).
    pub max_ns: u64,
    /// Intervals longer than 1.5 periods (a SYNC late or missing).
    pub long: u64,
}

/// One drive per configured node plus the observers (see the module doc).
pub struct DriveHost {
    drives: Vec<Hosted>,
    z: Option<usize>,
    c: Option<usize>,
    period: Duration,
    powered_at: Option<Instant>,
    first_sync: Option<Instant>,
    /// The first SYNC at which a Z+C window was open ([`FaultClock::FirstTap`]).
    first_tap: Option<Instant>,
    last_sync: Option<Instant>,
    last_now: Instant,
    sync_intervals_ns: Vec<u64>,
    sync_max_ns: u64,
    sync_min_ns: u64,
    /// SYNC intervals since [`DriveHost::take_sync_window`] last took them.
    sync_window: SyncWindow,
    faults: Vec<ScheduledFault>,
    fault_clock: FaultClock,
    coupling: CouplingChecker,
    coupling_samples: u64,
    /// The master shapes Z's and C's setpoints apart (their `dynamics` differ: dynamic
    /// matching), so the setpoints are not coupled by design and only the actual positions
    /// are.
    shaped: bool,
    actual_limit_um: Option<f64>,
    counters: HostCounters,
}

impl fmt::Debug for DriveHost {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("DriveHost")
            .field("nodes", &self.nodes())
            .field("counters", &self.counters)
            .finish()
    }
}

impl DriveHost {
    /// One drive for every axis of `cfg` with a node id; options by node. Errors name a node
    /// that the options mention but the config has not.
    pub fn new(cfg: &MachineConfig, opts: &HostOptions) -> Result<DriveHost, HostError> {
        let period = Duration::from_micros(cfg.bus.period_us as u64);
        let in_config = |n: u8| cfg.axes.iter().any(|a| a.node == Some(n));
        if let Some(n) = opts.only_nodes.iter().find(|&&n| !in_config(n)) {
            return Err(HostError(format!("--nodes: node {n} is not in the config")));
        }
        let mut drives = Vec::new();
        for axis in &cfg.axes {
            let Some(node) = axis.node.and_then(|n| NodeId::new(n).ok()) else {
                continue;
            };
            if !opts.only_nodes.is_empty() && !opts.only_nodes.contains(&node.get()) {
                continue;
            }
            let mut o = SimDriveOptions::default();
            if let Some((_, s)) = opts.boot_delays.iter().find(|(n, _)| *n == node.get()) {
                o.boot_delay = Duration::from_secs_f64(*s);
            }
            if let Some((_, c)) = opts.start_in_fault.iter().find(|(n, _)| *n == node.get()) {
                o.start_in_fault = Some(*c);
            }
            drives.push(hosted(axis, node, period, o));
        }
        if drives.is_empty() {
            return Err(HostError("the config has no axis with a node id".into()));
        }
        let known = |n: u8| drives.iter().any(|d| d.drive.node().get() == n);
        let mentioned = opts
            .faults
            .iter()
            .map(|f| f.node)
            .chain(opts.boot_delays.iter().map(|b| b.0))
            .chain(opts.start_in_fault.iter().map(|b| b.0));
        for n in mentioned {
            if !known(n) {
                return Err(HostError(format!("node {n} is not in the config")));
            }
        }
        let z = drives.iter().position(|d| d.axis == 'Z');
        // By node among the hosted drives (with --nodes they are a subset of the config's).
        let spindle_node = cfg
            .axes
            .iter()
            .find(|a| a.kind == AxisKind::Spindle)
            .and_then(|a| a.node);
        let c = drives.iter().position(|d| d.axis == 'C').or_else(|| {
            drives
                .iter()
                .position(|d| Some(d.drive.node().get()) == spindle_node)
        });
        let z_cpu = z.map(|i| drives[i].counts_per_unit).unwrap_or(1.0);
        let c_cpu = c.map(|i| drives[i].counts_per_unit).unwrap_or(1.0);
        Ok(DriveHost {
            drives,
            z,
            c,
            period,
            powered_at: None,
            first_sync: None,
            first_tap: None,
            last_sync: None,
            last_now: Instant::ZERO,
            // All of it at once: with mlockall the pages are resident from here, so a long run's
            // memory stays flat (hil-tests/soak.sh judges growth) instead of growing to 8 MB.
            sync_intervals_ns: Vec::with_capacity(MAX_SYNC_SAMPLES),
            sync_max_ns: 0,
            sync_min_ns: u64::MAX,
            sync_window: SyncWindow::default(),
            faults: opts
                .faults
                .iter()
                .map(|&spec| ScheduledFault {
                    spec,
                    applied_at_s: None,
                })
                .collect(),
            fault_clock: opts.fault_clock,
            coupling: CouplingChecker::with_capacity(z_cpu, c_cpu, 1 << 14),
            coupling_samples: 0,
            shaped: tap_pair_is_shaped(cfg),
            actual_limit_um: opts.actual_limit_um,
            counters: HostCounters::default(),
        })
    }

    /// Node ids hosted, in config order.
    pub fn nodes(&self) -> Vec<u8> {
        self.drives.iter().map(|d| d.drive.node().get()).collect()
    }

    /// The hosted drive with node id `node`.
    pub fn drive(&self, node: u8) -> Option<&SimDrive> {
        self.drives
            .iter()
            .find(|d| d.drive.node().get() == node)
            .map(|d| &d.drive)
    }

    /// Host-level counters.
    pub fn counters(&self) -> HostCounters {
        self.counters
    }

    /// Coupling windows closed so far.
    pub fn windows(&self) -> &[TapWindow] {
        self.coupling.windows()
    }

    fn power_on(&mut self, now: Instant) {
        if self.powered_at.is_none() {
            self.powered_at = Some(now);
        }
        self.last_now = self.last_now.max(now);
    }

    fn apply_faults(&mut self, now: Instant) {
        let origin = match self.fault_clock {
            FaultClock::FirstSync => self.first_sync,
            FaultClock::Start => self.powered_at,
            FaultClock::FirstTap => self.first_tap,
        };
        let Some(origin) = origin else { return };
        let t = (now - origin).as_secs_f64();
        for f in self.faults.iter_mut() {
            if f.applied_at_s.is_none()
                && t >= f.spec.at_s
                && let Some(h) = self
                    .drives
                    .iter_mut()
                    .find(|d| d.drive.node().get() == f.spec.node)
            {
                h.drive.inject(f.spec.kind, now);
                f.applied_at_s = Some(t);
            }
        }
    }

    fn on_sync(&mut self, frame: &CanFrame, now: Instant) {
        self.counters.syncs += 1;
        if frame.dlc() > 1 {
            self.counters.bad_syncs += 1;
        }
        if self.first_sync.is_none() {
            self.first_sync = Some(now);
        }
        if let Some(prev) = self.last_sync {
            let ns = u64::try_from((now - prev).as_nanos()).unwrap_or(u64::MAX);
            if self.sync_intervals_ns.len() < MAX_SYNC_SAMPLES {
                self.sync_intervals_ns.push(ns);
            }
            self.sync_max_ns = self.sync_max_ns.max(ns);
            self.sync_min_ns = self.sync_min_ns.min(ns);
            let w = &mut self.sync_window;
            w.intervals += 1;
            w.max_ns = w.max_ns.max(ns);
            let period_ns = u64::try_from(self.period.as_nanos()).unwrap_or(u64::MAX);
            if ns > period_ns.saturating_add(period_ns / 2) {
                w.long += 1;
            }
        }
        self.last_sync = Some(now);
    }

    /// The SYNC intervals since the last call (or the start), and a fresh window.
    pub fn take_sync_window(&mut self) -> SyncWindow {
        std::mem::take(&mut self.sync_window)
    }

    /// Feeds the coupling checker with the positions after a SYNC: the targets the drives took
    /// from their RPDOs (scaled back by counts_per_unit) and their actual positions.
    fn sample_coupling(&mut self) {
        let (Some(zi), Some(ci)) = (self.z, self.c) else {
            return;
        };
        let both_running = [zi, ci]
            .iter()
            .all(|&i| self.drives[i].drive.nmt() == NmtStatus::Operational);
        if !both_running {
            // Positions may jump across an NMT reset: do not take that for motion.
            self.coupling.restart();
            return;
        }
        let (z_cmd, z_act) = (self.drives[zi].target.value, self.drives[zi].actual.value);
        let (c_cmd, c_act) = (self.drives[ci].target.value, self.drives[ci].actual.value);
        self.coupling_samples += 1;
        self.coupling.feed_counts(CountSample {
            z_cmd,
            c_cmd,
            z_act,
            c_act,
        });
    }

    /// Whether a hosted drive takes a frame with COB-ID `id` (its SDO server or a valid RPDO).
    fn taken(&self, id: u16) -> bool {
        self.drives.iter().any(|h| {
            let node = h.drive.node().get() as u16;
            if id == 0x600 + node {
                return true;
            }
            (0..4u16).any(|n| {
                h.drive
                    .od()
                    .get_u64(0x1400 + n, 1)
                    .is_some_and(|cob| cob & 0x8000_0000 == 0 && (cob & 0x7FF) as u16 == id)
            })
        })
    }

    fn hosts(&self, node: u8) -> bool {
        self.drives.iter().any(|h| h.drive.node().get() == node)
    }

    /// Classifies a received frame by the node it concerns (CiA 301 predefined connection
    /// set): traffic of other nodes is not a protocol error; requests for a hosted node that
    /// no drive takes, or SDO requests it cannot parse, are.
    pub fn classify(&self, frame: &CanFrame) -> FrameClass {
        let id = frame.id();
        if id == SYNC_ID {
            return FrameClass::Hosted;
        }
        if id == 0 {
            // NMT: a malformed one (DLC != 2) is the drives' to count.
            return match frame.data() {
                [_, target] if *target != 0 && !self.hosts(*target) => FrameClass::OtherNode,
                _ => FrameClass::Hosted,
            };
        }
        if self.taken(id) {
            let is_sdo = self
                .drives
                .iter()
                .any(|h| id == 0x600 + h.drive.node().get() as u16);
            if is_sdo && matches!(SdoRequest::parse(frame), Err(WireError::UnknownCommand(_))) {
                return FrameClass::BadSdoRequest;
            }
            return FrameClass::Hosted;
        }
        let node = (id & 0x7F) as u8;
        let function = id & 0x780;
        if id > 0x7FF || node == 0 || id == 0x100 || !(0x080..=0x700).contains(&function) {
            return FrameClass::Unrelated;
        }
        let request = matches!(function, 0x200 | 0x300 | 0x400 | 0x500 | 0x600);
        match (self.hosts(node), request) {
            (true, true) => FrameClass::Unaccepted,
            (true, false) => FrameClass::Hosted,
            (false, true) => FrameClass::OtherNodeRequest,
            (false, false) => FrameClass::OtherNode,
        }
    }

    /// Closes an open coupling window (call once at the end).
    pub fn finish(&mut self) {
        self.coupling.finish();
    }

    /// The JSON report (see the crate README's "Scenarios" for the keys).
    pub fn report(&self, bus: Option<&BusFigures>) -> Value {
        let mut checks = Vec::new();
        let (taps, others) = self.coupling_checks(&mut checks);
        // Frames of or for other nodes (a scan probing every id, other devices) are counted
        // apart: not a protocol error on a bus that may carry other devices; the scenarios
        // assert them separately. Requests for a hosted node it cannot take are errors.
        let mut unexpected =
            self.counters.bad_syncs + self.counters.unaccepted + self.counters.bad_sdo_requests;
        let mut pdo_len = 0;
        let mut sdo_aborts = 0;
        let mut tx_errors = 0;
        let mut emcys = 0;
        let mut drives = serde_json::Map::new();
        for h in &self.drives {
            let s = h.drive.stats();
            unexpected += s.unexpected_frames;
            pdo_len += s.pdo_length_errors;
            sdo_aborts += s.sdo_aborts;
            tx_errors += s.tx_errors;
            emcys += s.emcys_sent;
            drives.insert(h.drive.node().get().to_string(), h.report(&s));
        }
        checks.push(json!({
            "name": "no unexpected frames", "value": unexpected, "limit": 0,
            "pass": unexpected == 0,
        }));
        checks.push(json!({
            "name": "no PDO length errors", "value": pdo_len, "limit": 0, "pass": pdo_len == 0,
        }));
        checks.push(json!({
            "name": "no transmit errors", "value": tx_errors, "limit": 0, "pass": tx_errors == 0,
        }));
        let ok = checks
            .iter()
            .all(|c| c.get("pass").and_then(Value::as_bool) == Some(true));
        let period_ns = u64::try_from(self.period.as_nanos()).unwrap_or(u64::MAX);
        let faults: Vec<Value> = self
            .faults
            .iter()
            .map(|f| {
                json!({
                    "node": f.spec.node,
                    "kind": format!("{:?}", f.spec.kind),
                    "at_s": f.spec.at_s,
                    "applied_at_s": f.applied_at_s,
                })
            })
            .collect();
        let mut v = json!({
            "ok": ok,
            "checks": checks,
            "period_us": period_ns as f64 / 1000.0,
            "sync_period_us": self.sync_figures(period_ns),
            "coupling_samples": self.coupling_samples,
            "tap_windows": taps,
            "spindle_windows": others,
            "protocol_errors": {
                "unexpected_frames": unexpected,
                "unaddressed_frames": self.counters.unaddressed,
                "other_node_frames": self.counters.other_nodes,
                "unaccepted_requests": self.counters.unaccepted,
                "bad_sdo_requests": self.counters.bad_sdo_requests,
                "bad_syncs": self.counters.bad_syncs,
                "pdo_length_errors": pdo_len,
                "sdo_aborts_sent": sdo_aborts,
                "tx_errors": tx_errors,
            },
            "emcys_sent": emcys,
            "frames_received": self.counters.frames,
            "faults": faults,
            "drives": Value::Object(drives),
        });
        if let Some(b) = bus {
            v["bus"] = json!({
                "iface": b.iface,
                "seconds": b.seconds,
                "rx_frames": b.rx_frames,
                "tx_frames": b.tx_frames,
                "load_percent": b.load_percent,
                "error_frames": b.error_frames,
                "down_events": b.down_events,
            });
        }
        v
    }

    /// The report's checks of every Z+C window (a tap is judged on its setpoints; a window
    /// with the spindle running is reported only), and how many were taps and how many not.
    fn coupling_checks(&self, checks: &mut Vec<Value>) -> (usize, usize) {
        let mut taps = 0;
        let mut others = 0;
        for (i, w) in self.coupling.windows().iter().enumerate() {
            if w.spindle_running {
                // Z moving while the spindle turns (drilling): reported, not judged.
                others += 1;
                checks.push(json!({
                    "name": format!("Z+C window {} (spindle running, not a tap)", i + 1),
                    "value_um": w.max_error_um_cmd,
                    "limit_um": Value::Null,
                    "pitch_mm": w.pitch_mm,
                    "ticks": w.ticks,
                    "pass": true,
                    "informational": true,
                }));
                continue;
            }
            taps += 1;
            let limit_um = self.coupling.limit_um(w) * (1.0 + 1e-9);
            checks.push(json!({
                "name": format!("tap coupling window {} (setpoints)", i + 1),
                "value_um": w.max_error_um_cmd,
                "limit_um": limit_um,
                "pitch_mm": w.pitch_mm,
                "ticks": w.ticks,
                "first_sync": w.first_tick,
                "pass": self.shaped || w.max_error_um_cmd <= limit_um,
                "informational": self.shaped,
            }));
            let act_limit = self.actual_limit_um;
            checks.push(json!({
                "name": format!("tap coupling window {} (actual)", i + 1),
                "value_um": w.max_error_um_act,
                "limit_um": act_limit,
                "pitch_mm": w.pitch_mm,
                "pass": act_limit.is_none_or(|l| w.max_error_um_act <= l),
                "informational": act_limit.is_none(),
            }));
        }
        (taps, others)
    }

    /// The SYNC intervals seen, in µs, against the period (`period_ns`).
    fn sync_figures(&self, period_ns: u64) -> Value {
        let mut sorted = self.sync_intervals_ns.clone();
        sorted.sort_unstable();
        let us = |ns: Option<u64>| ns.map(|v| v as f64 / 1000.0);
        let jitter_ns = if sorted.is_empty() {
            None
        } else {
            Some(
                self.sync_max_ns
                    .saturating_sub(period_ns)
                    .max(period_ns.saturating_sub(self.sync_min_ns)),
            )
        };
        json!({
            "count": self.counters.syncs,
            "intervals": sorted.len(),
            "p50": us(percentile(&sorted, 50)),
            "p99": us(percentile(&sorted, 99)),
            "max": us(sorted.last().copied()),
            "min": us(sorted.first().copied()),
            "max_deviation": us(jitter_ns),
        })
    }
}

/// Transport figures for the report (filled by the binary from the socket's counters).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BusFigures {
    pub iface: String,
    pub seconds: f64,
    pub rx_frames: u64,
    pub tx_frames: u64,
    pub load_percent: f64,
    pub error_frames: u64,
    /// Receives that found the interface down (the drives wait for it to come back).
    pub down_events: u64,
}

fn hosted(axis: &AxisConfig, node: NodeId, period: Duration, o: SimDriveOptions) -> Hosted {
    let cpu = if axis.counts_per_unit.is_finite() && axis.counts_per_unit.abs() > 0.0 {
        axis.counts_per_unit.abs()
    } else {
        1.0
    };
    Hosted {
        drive: SimDrive::with_options(axis, node, period, o),
        axis: axis.name,
        counts_per_unit: cpu,
        state_history: Vec::new(),
        reached_enabled: false,
        faults_entered: 0,
        fault_resets: 0,
        actual: Unwrap::default(),
        target: Unwrap::default(),
        last_emcy_code: None,
    }
}

impl CanDevice for DriveHost {
    /// Hands the frame to every drive (they filter like an acceptance filter), then observes
    /// it: SYNC period, coupling after the SYNC, frames no drive takes.
    fn on_frame(&mut self, frame: &CanFrame, now: Instant, tx: &mut dyn FrameSink) {
        self.power_on(now);
        self.counters.frames += 1;
        let is_sync = frame.id() == SYNC_ID;
        if is_sync {
            self.on_sync(frame, now);
        }
        match self.classify(frame) {
            FrameClass::Hosted | FrameClass::Unrelated => {}
            FrameClass::BadSdoRequest => self.counters.bad_sdo_requests += 1,
            FrameClass::Unaccepted => self.counters.unaccepted += 1,
            FrameClass::OtherNodeRequest => {
                self.counters.unaddressed += 1;
                self.counters.other_nodes += 1;
            }
            FrameClass::OtherNode => self.counters.other_nodes += 1,
        }
        for h in self.drives.iter_mut() {
            h.drive.on_frame(frame, now, tx);
            h.note_state();
        }
        if is_sync {
            for h in self.drives.iter_mut() {
                let t = h.drive.target_position();
                let a = h.drive.position_actual();
                h.target.feed(t);
                h.actual.feed(a);
            }
            self.sample_coupling();
            if self.first_tap.is_none() && self.coupling.open_window().is_some() {
                self.first_tap = Some(now);
            }
        }
        self.apply_faults(now);
    }

    /// Runs the drives' timers (boot, heartbeat, following-error time-out) and due faults.
    fn poll(&mut self, now: Instant, tx: &mut dyn FrameSink) {
        self.power_on(now);
        self.apply_faults(now);
        for h in self.drives.iter_mut() {
            h.drive.poll(now, tx);
            h.note_state();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cnc402_drives::bus::SimBus;
    use cnc402_drives::master::{Master, TimedBus};

    fn boot(host: DriveHost) -> (SimBus<DriveHost>, Master) {
        let cfg = MachineConfig::default_machine();
        let mut bus = SimBus::new(cfg.bus.bitrate);
        bus.attach(host);
        let mut m = Master::new(&cfg).unwrap();
        m.boot(&mut bus).unwrap();
        (bus, m)
    }

    /// Runs `ticks` cycles with Z/C commands from `cmd(tick)` (axis order X Y Z C).
    fn run(
        bus: &mut SimBus<DriveHost>,
        m: &mut Master,
        ticks: u64,
        cmd: impl Fn(u64) -> [f64; 4],
    ) -> Result<(), String> {
        let mut now = TimedBus::now(bus) + m.period();
        for t in 0..ticks {
            bus.advance(now);
            let c = cmd(t);
            m.cycle(bus, now, &c).map_err(|e| format!("{e:?}"))?;
            now += m.period();
        }
        bus.advance(now);
        Ok(())
    }

    fn checks(v: &Value) -> Vec<(String, bool)> {
        v["checks"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| {
                (
                    c["name"].as_str().unwrap().to_string(),
                    c["pass"].as_bool().unwrap(),
                )
            })
            .collect()
    }

    /// C positions of a tap: 3.6°/SYNC with linear ramps in and out, 420 SYNCs.
    fn ramped_c() -> Vec<f64> {
        let speed = |t: u64| -> f64 {
            let t = t as f64;
            if t < 100.0 {
                t / 100.0
            } else if t < 300.0 {
                1.0
            } else {
                (400.0 - t).max(0.0) / 100.0
            }
        };
        let mut c_pos = vec![0.0];
        for t in 0..420 {
            let last = *c_pos.last().unwrap();
            c_pos.push(last + 3.6 * speed(t));
        }
        c_pos
    }

    /// With Z's and C's drive models different the setpoints are shaped apart on purpose:
    /// the setpoint windows are reported only and `--actual-limit-um` judges the tap. Here
    /// the spindle's drive is slow and the setpoints are not matched, so the actual coupling
    /// (tens of µm) fails a 5 µm limit and passes a loose one.
    #[test]
    fn mismatched_models_are_judged_on_the_actual_positions() {
        let mut cfg = MachineConfig::default_machine();
        let sp = cfg.spindle_index().unwrap();
        cfg.axes[sp].sim.delay_cycles = 2;
        cfg.axes[sp].sim.bandwidth_hz = 40.0;
        cfg.axes[sp].dynamics = Some(cnc402_config::DriveModel {
            delay_cycles: 2,
            bandwidth_hz: 40.0,
        });
        assert!(tap_pair_is_shaped(&cfg));
        assert!(!tap_pair_is_shaped(&MachineConfig::default_machine()));
        let c_pos = ramped_c();
        let report = |limit: f64| {
            let opts = HostOptions {
                actual_limit_um: Some(limit),
                ..HostOptions::default()
            };
            let (mut bus, mut m) = boot(DriveHost::new(&cfg, &opts).unwrap());
            run(&mut bus, &mut m, 420, |t| {
                let c = c_pos[t as usize];
                [0.0, 0.0, -c / 360.0 * 1.5, c]
            })
            .unwrap();
            let host = &mut bus.device_mut(0).unwrap();
            host.finish();
            host.report(None)
        };
        let strict = report(5.0);
        let act = strict["checks"][1]["value_um"].as_f64().unwrap();
        assert!(act > 5.0, "{act}");
        assert_eq!(strict["ok"], false, "{strict:#}");
        assert_eq!(strict["checks"][0]["informational"], true);
        assert_eq!(
            checks(&strict)[..2],
            [
                ("tap coupling window 1 (setpoints)".to_string(), true),
                ("tap coupling window 1 (actual)".to_string(), false)
            ]
        );
        assert_eq!(report(act + 1.0)["ok"], true);
    }

    #[test]
    fn coupled_tap_passes_and_sync_period_is_measured() {
        let cfg = MachineConfig::default_machine();
        let host = DriveHost::new(&cfg, &HostOptions::default()).unwrap();
        let (mut bus, mut m) = boot(host);
        // A 1.5 mm pitch tap: C turns 360° per 1.5 mm of Z, ramped in and out.
        let c_pos = ramped_c();
        run(&mut bus, &mut m, 420, |t| {
            let c = c_pos[t as usize];
            [0.0, 0.0, -c / 360.0 * 1.5, c]
        })
        .unwrap();
        let host = &mut bus.device_mut(0).unwrap();
        host.finish();
        let r = host.report(None);
        assert_eq!(r["ok"], true, "{r:#}");
        let w = host.windows();
        assert_eq!(w.len(), 1);
        assert_eq!(r["tap_windows"], 1);
        assert!((w[0].pitch_mm - 1.5).abs() < 1e-3, "{:?}", w[0]);
        assert!(!w[0].same_sense);
        assert!(
            checks(&r)
                .iter()
                .any(|(n, p)| n == "tap coupling window 1 (setpoints)" && *p)
        );
        assert!(
            r["checks"][1]["value_um"].as_f64().unwrap() > 0.0,
            "actual figure reported"
        );
        let s = &r["sync_period_us"];
        assert!(s["count"].as_u64().unwrap() >= 420);
        assert_eq!(s["p50"].as_f64(), Some(1000.0));
        assert_eq!(r["protocol_errors"]["unexpected_frames"], 0, "{r:#}");
        assert_eq!(r["drives"]["4"]["reached_operation_enabled"], true);
    }

    #[test]
    fn decoupled_setpoints_fail_the_check() {
        let cfg = MachineConfig::default_machine();
        let host = DriveHost::new(&cfg, &HostOptions::default()).unwrap();
        let (mut bus, mut m) = boot(host);
        // Z follows C at 1.5 mm/rev but with a 3-count hiccup in the middle.
        let c_pos = ramped_c();
        run(&mut bus, &mut m, 420, |t| {
            let c = c_pos[t as usize];
            let glitch = if t == 200 { 3e-4 } else { 0.0 };
            [0.0, 0.0, -c / 360.0 * 1.5 + glitch, c]
        })
        .unwrap();
        let host = bus.device_mut(0).unwrap();
        host.finish();
        let r = host.report(None);
        assert_eq!(r["ok"], false);
        let c = &r["checks"][0];
        assert_eq!(c["pass"], false);
        assert!(c["value_um"].as_f64().unwrap() > c["limit_um"].as_f64().unwrap());
    }

    #[test]
    fn drilling_with_the_spindle_running_is_reported_not_judged() {
        let cfg = MachineConfig::default_machine();
        let host = DriveHost::new(&cfg, &HostOptions::default()).unwrap();
        let (mut bus, mut m) = boot(host);
        // C turns at 10°/ms from the start; Z feeds down (not coupled) from tick 300 to 400.
        run(&mut bus, &mut m, 500, |t| {
            let z = -((t.clamp(300, 400) - 300) as f64).powi(2) * 1e-4;
            [0.0, 0.0, z, t as f64 * 10.0]
        })
        .unwrap();
        let host = bus.device_mut(0).unwrap();
        host.finish();
        let r = host.report(None);
        assert_eq!(r["ok"], true, "{r:#}");
        assert_eq!(r["tap_windows"], 0);
        assert_eq!(r["spindle_windows"], 1);
        assert!(
            r["checks"][0]["name"]
                .as_str()
                .unwrap()
                .contains("not a tap")
        );
    }

    #[test]
    fn injected_fault_stops_the_master_and_is_reported() {
        let cfg = MachineConfig::default_machine();
        let opts = HostOptions {
            faults: vec!["3:fault:0x7300@0.05".parse().unwrap()],
            ..HostOptions::default()
        };
        let host = DriveHost::new(&cfg, &opts).unwrap();
        let (mut bus, mut m) = boot(host);
        let err = run(&mut bus, &mut m, 200, |_| [0.0; 4]).unwrap_err();
        assert!(err.contains("7300") || err.contains("29440"), "{err}");
        let r = bus.device(0).unwrap().report(None);
        assert_eq!(r["drives"]["3"]["fault_code"], "0x7300");
        assert_eq!(
            r["faults"][0]["applied_at_s"].as_f64().map(|t| t >= 0.05),
            Some(true)
        );
        assert!(r["emcys_sent"].as_u64().unwrap() >= 1);
    }

    #[test]
    fn a_fault_on_the_tap_clock_lands_inside_the_first_tap() {
        let cfg = MachineConfig::default_machine();
        let opts = HostOptions {
            // X (node 1, not part of the tap) faults 50 ms into the first Z+C window.
            faults: vec!["1:fault:0x5530@0.05".parse().unwrap()],
            fault_clock: FaultClock::FirstTap,
            ..HostOptions::default()
        };
        let host = DriveHost::new(&cfg, &opts).unwrap();
        let (mut bus, mut m) = boot(host);
        // 150 cycles at rest, then the ramped tap: the fault must wait for the tap, however
        // long the rest before it.
        let c_pos = ramped_c();
        let err = run(&mut bus, &mut m, 570, |t| {
            let c = c_pos[t.saturating_sub(150).min(420) as usize];
            [0.0, 0.0, -c / 360.0 * 1.5, c]
        })
        .unwrap_err();
        assert!(err.contains("5530") || err.contains("21808"), "{err}");
        let r = bus.device(0).unwrap().report(None);
        let applied = r["faults"][0]["applied_at_s"].as_f64().unwrap();
        assert!((0.05..0.06).contains(&applied), "{applied}");
        // At the fault the tap was under way: Z below its start, C turned.
        let host = bus.device(0).unwrap();
        assert!(host.first_tap.is_some() && host.first_sync < host.first_tap);
        let into_tap = (host.first_tap.unwrap() - host.first_sync.unwrap()).as_secs_f64();
        assert!(
            into_tap >= 0.14,
            "the tap began {into_tap} s after the first SYNC"
        );
    }

    #[test]
    fn start_in_fault_is_reset_by_the_master_and_late_boot_is_awaited() {
        let cfg = MachineConfig::default_machine();
        let opts = HostOptions {
            start_in_fault: vec![(1, 0x5530)],
            boot_delays: vec![(2, 0.5)],
            ..HostOptions::default()
        };
        let host = DriveHost::new(&cfg, &opts).unwrap();
        let (mut bus, mut m) = boot(host);
        // Cyclic operation right after a late boot (heartbeats seen during the wait count).
        run(&mut bus, &mut m, 500, |_| [0.0; 4]).unwrap();
        let r = bus.device(0).unwrap().report(None);
        let d1 = &r["drives"]["1"];
        assert_eq!(d1["faults_entered"], 1, "{d1:#}");
        assert_eq!(d1["fault_resets"], 1);
        assert_eq!(d1["last_fault_code"], "0x5530");
        assert_eq!(d1["state"], "OperationEnabled");
        assert_eq!(r["drives"]["2"]["state"], "OperationEnabled");
        assert!(TimedBus::now(&bus) >= Instant::from_millis(500));
    }

    #[test]
    fn spindle_across_the_int32_wrap_is_unwrapped() {
        let mut u = Unwrap::default();
        let mut raw = i32::MAX - 10;
        let start = u.feed(raw);
        for _ in 0..5 {
            raw = raw.wrapping_add(7);
            u.feed(raw);
        }
        assert_eq!(u.value - start, 35);
        assert_eq!(u.wraps, 1);
        // Backwards across it too.
        for _ in 0..5 {
            raw = raw.wrapping_sub(7);
            u.feed(raw);
        }
        assert_eq!(u.value, start);
        assert_eq!(u.wraps, 2);
    }

    /// A scan and other nodes' traffic are not protocol errors; requests for a hosted node
    /// that it cannot take or parse, and bad PDO lengths, are.
    #[test]
    fn traffic_for_other_nodes_is_counted_apart_from_protocol_errors() {
        let cfg = MachineConfig::default_machine();
        let host = DriveHost::new(&cfg, &HostOptions::default()).unwrap();
        let (mut bus, mut m) = boot(host);
        run(&mut bus, &mut m, 20, |_| [0.0; 4]).unwrap();
        let now = TimedBus::now(&bus);
        let host = bus.device_mut(0).unwrap();
        let before = host.counters();
        let mut tx: Vec<CanFrame> = Vec::new();
        let f = |id: u16, d: &[u8]| CanFrame::new(id, d).unwrap();
        // drivectl's scan: an SDO upload of 0x1000:0 to every node id 1..127.
        for n in 1..=127u16 {
            host.on_frame(
                &f(0x600 + n, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]),
                now,
                &mut tx,
            );
        }
        // Other nodes' traffic: TPDO, heartbeat, EMCY, SDO response, NMT naming node 9, and
        // an RPDO for node 9; TIME (no node).
        for (id, d) in [
            (0x189u16, &[1u8, 2][..]),
            (0x709, &[0x05]),
            (0x089, &[0, 0x73, 0x11, 0, 0, 0, 0, 0]),
            (0x589, &[0x43, 0, 0x10, 0, 0x92, 0x01, 0x02, 0]),
            (0x000, &[0x01, 9]),
            (0x209, &[0x0f, 0]),
            (0x100, &[0, 0, 0, 0, 0, 0]),
        ] {
            host.on_frame(&f(id, d), now, &mut tx);
        }
        let c = host.counters();
        assert_eq!(c.unaddressed - before.unaddressed, 123 + 1, "{c:?}");
        assert_eq!(c.other_nodes - before.other_nodes, 123 + 6, "{c:?}");
        assert_eq!((c.unaccepted, c.bad_sdo_requests), (0, 0));
        // The four hosted drives answered their probe.
        assert_eq!(
            tx.iter()
                .filter(|t| (0x581..=0x584).contains(&t.id()))
                .count(),
            4
        );
        let r = host.report(None);
        assert_eq!(r["protocol_errors"]["unexpected_frames"], 0, "{r:#}");
        assert_eq!(r["ok"], true, "{r:#}");

        // Now errors for hosted nodes: RPDO2 of node 1 (not enabled by the master), an SDO
        // request with an unknown command specifier to node 2, a short RPDO1 to node 3.
        assert_eq!(host.classify(&f(0x301, &[0; 8])), FrameClass::Unaccepted);
        host.on_frame(&f(0x301, &[0; 8]), now, &mut tx);
        assert_eq!(
            host.classify(&f(0x602, &[0xE0, 0, 0, 0, 0, 0, 0, 0])),
            FrameClass::BadSdoRequest
        );
        host.on_frame(&f(0x602, &[0xE0, 0, 0, 0, 0, 0, 0, 0]), now, &mut tx);
        host.on_frame(&f(0x203, &[0x0f]), now, &mut tx);
        let r = host.report(None);
        let p = &r["protocol_errors"];
        assert_eq!(p["unaccepted_requests"], 1, "{p:#}");
        assert_eq!(p["bad_sdo_requests"], 1, "{p:#}");
        assert_eq!(p["pdo_length_errors"], 1, "{p:#}");
        assert_eq!(p["unexpected_frames"], 2, "{p:#}");
        assert_eq!(r["ok"], false);
    }

    #[test]
    fn options_naming_absent_nodes_are_refused() {
        let cfg = MachineConfig::default_machine();
        let opts = HostOptions {
            boot_delays: vec![(9, 1.0)],
            ..HostOptions::default()
        };
        assert!(
            DriveHost::new(&cfg, &opts)
                .unwrap_err()
                .0
                .contains("node 9")
        );
        assert!("0:fault@1".parse::<FaultSpec>().is_err());
        assert!("3:bogus@1".parse::<FaultSpec>().is_err());
        assert!("3:tpdo@-1".parse::<FaultSpec>().is_err());
        assert!(parse_boot_delay("3").is_err());
        assert!(parse_start_in_fault("3:zz").is_err());
    }

    #[test]
    fn only_nodes_hosts_just_those_and_refuses_nodes_not_in_the_config() {
        let cfg = MachineConfig::default_machine();
        let opts = HostOptions {
            only_nodes: vec![2],
            ..HostOptions::default()
        };
        assert_eq!(DriveHost::new(&cfg, &opts).unwrap().nodes(), vec![2]);
        let opts = HostOptions {
            only_nodes: vec![9],
            ..HostOptions::default()
        };
        assert!(
            DriveHost::new(&cfg, &opts)
                .unwrap_err()
                .0
                .contains("--nodes: node 9")
        );
    }
}
