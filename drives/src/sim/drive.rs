//! `SimDrive`: a CiA 402 servo drive on CANopen, driven only by frames and time — NMT slave
//! with boot-up, heartbeat and a heartbeat consumer (0x1016, 0x6007 reaction), SDO server, PDOs with the remap rules, the device state
//! machine, CSP following with configurable dynamics, following-error monitoring, and a
//! fault injection API. Works on [`crate::bus::SimBus`] and on any frame source with a clock.

mod commissioning;

use core::fmt;
use core::str::FromStr;
use core::time::Duration;

use cia402::homing::{HOMING_ATTAINED, HOMING_ERROR, HOMING_START};
use cia402::objects as o;
use cia402::{
    Controlword, DeviceStateMachine, HomingMethod, HomingStatus, OperationMode, QuickStopOption,
    State, Statusword, Transition,
};
use cnc402_config::AxisConfig;

use super::homing::{HomingParams, HomingRun, MachineIo};
use super::motion::{AxisModel, DriveDynamics};
use super::objects::{self, DriveParams};
use super::pdo::{self, RpdoSlot, TpdoSlot};
use super::sdo_server::{ObjectAccess, SdoServer};
use crate::bus::{CanDevice, FrameSink};
use crate::od::{ObjectDictionary, OdError, Slot, Value};
use crate::time::Instant;
use crate::wire::{
    AbortCode, CanFrame, EmcyRepr, HeartbeatRepr, NmtCommand, NmtRepr, NmtState, NodeId,
    SdoRequest, WireError, emcy_code,
};

/// The drive's NMT state, including "not yet on the bus". (canopen-rs's `NmtStateMachine`
/// is not used: the simulated drive needs a timed boot, and reset node and reset
/// communication restore different parts of the dictionary; the state itself is four values.)
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NmtStatus {
    /// Powered but not booted yet (boot delay), silent.
    Booting,
    /// PRE-OPERATIONAL: SDO, no PDO.
    PreOperational,
    /// OPERATIONAL: SDO and PDO.
    Operational,
    /// STOPPED: NMT and heartbeat only.
    Stopped,
}

/// How the simulated drive starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SimDriveOptions {
    /// Time from power-on (the first `poll`/`on_frame`) to the boot-up message.
    pub boot_delay: Duration,
    /// Start in FAULT with this EMCY code right after boot-up.
    pub start_in_fault: Option<u16>,
    /// Motor position at power-on (counts).
    pub initial_position: i32,
}

impl Default for SimDriveOptions {
    fn default() -> Self {
        SimDriveOptions {
            boot_delay: Duration::from_millis(1),
            start_in_fault: None,
            initial_position: 0,
        }
    }
}

/// A fault the tests or `simdrive --fault NODE:KIND@SECONDS` inject.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FaultKind {
    /// Enter FAULT with this EMCY code (`fault` = 0x1000 generic, `fault:0x7300`). The cause
    /// clears on fault reset.
    Fault(u16),
    /// Like `Fault`, but the cause persists: fault resets do not clear it (`fault-persistent`).
    PersistentFault(u16),
    /// Stop sending heartbeats (`heartbeat`).
    HeartbeatSilence,
    /// Stop answering SDO requests (`sdo`).
    SdoSilence,
    /// Stop sending TPDOs (`tpdo`).
    DropTpdos,
    /// The drive resets itself (`reboot`): boot-up message, PRE-OPERATIONAL, its dictionary
    /// (PDO mapping included) back to the power-on defaults — a watchdog or power dip.
    Reboot,
    /// An EMCY with this code after every SYNC from now on, the drive staying enabled
    /// (`emcy-storm`, `emcy-storm:0x5530`; default 0x1000 generic).
    EmcyStorm(u16),
    /// The drive stops acting on SYNC (`stop-sync`): no RPDO applied, no motion step, no
    /// synchronous TPDO; heartbeat and SDO go on.
    StopSync,
    /// 0x1000 reads this device type from now on, surviving resets (`device-type:0x20191`);
    /// injected before boot, the drive looks like something other than a CiA 402 servo.
    DeviceType(u32),
    /// 0x1018 reads this vendor id, product code and revision number from now on, surviving
    /// resets (`identity:VENDOR:PRODUCT[:REVISION]`): another model (or another maker's drive)
    /// on this node.
    Identity {
        vendor: u32,
        product: u32,
        revision: Option<u32>,
    },
    /// The machine's further 0x60FD bits read this from now on (`inputs:0x0`: an E-stop
    /// chain that opens), instead of `sim.inputs`.
    Inputs(u32),
}

/// A `FaultKind` that did not parse.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FaultKindError(pub String);

impl fmt::Display for FaultKindError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "unknown fault kind `{}` (expected fault[:CODE], fault-persistent[:CODE], heartbeat, \
             sdo, tpdo, reboot, emcy-storm[:CODE], stop-sync, device-type:VALUE, \
             identity:VENDOR:PRODUCT[:REVISION], inputs:VALUE)",
            self.0
        )
    }
}

impl std::error::Error for FaultKindError {}

impl FromStr for FaultKind {
    type Err = FaultKindError;
    /// Parses `fault`, `fault:0x7300`, `fault-persistent[:CODE]`, `heartbeat`, `sdo`, `tpdo`,
    /// `reboot`, `emcy-storm[:CODE]`, `stop-sync`, `device-type:VALUE` (codes 16 bit, the
    /// device type 32 bit; hex with `0x` or decimal).
    ///
    /// ```
    /// use cnc402_drives::sim::FaultKind;
    /// assert_eq!("fault:0x8611".parse(), Ok(FaultKind::Fault(0x8611)));
    /// assert_eq!("tpdo".parse(), Ok(FaultKind::DropTpdos));
    /// assert_eq!("emcy-storm:0x5530".parse(), Ok(FaultKind::EmcyStorm(0x5530)));
    /// assert_eq!("device-type:0x20191".parse(), Ok(FaultKind::DeviceType(0x20191)));
    /// assert_eq!(
    ///     "identity:0x9a:0x30924".parse(),
    ///     Ok(FaultKind::Identity { vendor: 0x9a, product: 0x30924, revision: None })
    /// );
    /// ```
    fn from_str(s: &str) -> Result<FaultKind, FaultKindError> {
        let err = || FaultKindError(s.to_string());
        if let Some(values) = s.trim().strip_prefix("identity:") {
            return parse_identity(values).ok_or_else(err);
        }
        let (kind, code) = match s.split_once(':') {
            Some((k, c)) => {
                let c = c.trim();
                let v = match c.strip_prefix("0x").or_else(|| c.strip_prefix("0X")) {
                    Some(h) => u32::from_str_radix(h, 16),
                    None => c.parse(),
                }
                .map_err(|_| err())?;
                (k, Some(v))
            }
            None => (s, None),
        };
        let code16 = |c: Option<u32>| match c {
            None => Ok(emcy_code::GENERIC),
            Some(c) => u16::try_from(c).map_err(|_| err()),
        };
        Ok(match (kind.trim(), code) {
            ("fault", c) => FaultKind::Fault(code16(c)?),
            ("fault-persistent", c) => FaultKind::PersistentFault(code16(c)?),
            ("emcy-storm", c) => FaultKind::EmcyStorm(code16(c)?),
            ("device-type", Some(v)) => FaultKind::DeviceType(v),
            ("inputs", Some(v)) => FaultKind::Inputs(v),
            ("heartbeat", None) => FaultKind::HeartbeatSilence,
            ("sdo", None) => FaultKind::SdoSilence,
            ("tpdo", None) => FaultKind::DropTpdos,
            ("reboot", None) => FaultKind::Reboot,
            ("stop-sync", None) => FaultKind::StopSync,
            _ => return Err(err()),
        })
    }
}

/// `VENDOR:PRODUCT[:REVISION]` of an `identity` fault (32-bit values, hex with 0x or
/// decimal).
fn parse_identity(values: &str) -> Option<FaultKind> {
    let value = |v: &str| {
        let v = v.trim();
        match v.strip_prefix("0x").or_else(|| v.strip_prefix("0X")) {
            Some(h) => u32::from_str_radix(h, 16).ok(),
            None => v.parse().ok(),
        }
    };
    let mut parts = values.split(':');
    let vendor = value(parts.next()?)?;
    let product = value(parts.next()?)?;
    let revision = match parts.next() {
        Some(r) => Some(value(r)?),
        None => None,
    };
    if parts.next().is_some() {
        return None;
    }
    Some(FaultKind::Identity {
        vendor,
        product,
        revision,
    })
}

/// Protocol-level counters of one drive (for `simdrive`'s report and tests).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SimDriveStats {
    /// SYNCs processed (in OPERATIONAL).
    pub syncs: u64,
    /// RPDOs applied.
    pub rpdos_applied: u64,
    /// RPDOs rejected for their length (EMCY 0x8210 / 0x8220 sent).
    pub pdo_length_errors: u64,
    /// TPDOs sent.
    pub tpdos_sent: u64,
    /// TPDOs suppressed by fault injection.
    pub tpdos_dropped: u64,
    /// SDO requests received.
    pub sdo_requests: u64,
    /// SDO aborts sent.
    pub sdo_aborts: u64,
    /// EMCY messages sent.
    pub emcys_sent: u64,
    /// Heartbeats sent (not counting boot-up).
    pub heartbeats_sent: u64,
    /// Boot-up messages sent.
    pub boot_ups: u64,
    /// Frames addressed to this drive that made no sense (bad length, PDO while not
    /// operational, unknown NMT command).
    pub unexpected_frames: u64,
    /// Frames the sink refused.
    pub tx_errors: u64,
    /// Largest |following error| seen while following, counts.
    pub max_following_error: u32,
}

/// Parameters read every SYNC, cached from the dictionary (refreshed after every SDO write,
/// reset and RPDO that maps something else than controlword and target), and the slots of
/// the objects the device writes every cycle.
#[derive(Clone, Copy, Debug)]
struct Hot {
    mode: i8,
    period_s: f64,
    decel_per_cycle: f64,
    window: u32,
    timeout: Duration,
    /// 0x607E bit 7: positions inverted.
    inverted: bool,
    statusword: Option<Slot>,
    digital_inputs: Option<Slot>,
    target: Option<Slot>,
    mode_display: Option<Slot>,
    position_actual: Option<Slot>,
    position_demand: Option<Slot>,
    following_error: Option<Slot>,
    velocity: Option<Slot>,
}

impl Hot {
    fn load(od: &ObjectDictionary, nominal: Duration) -> Hot {
        let v = od.get_u64(o::INTERPOLATION_TIME_PERIOD, 1).unwrap_or(0) as u8;
        let e = od.get_i64(o::INTERPOLATION_TIME_PERIOD, 2).unwrap_or(-3) as i8;
        let s = objects::interpolation_seconds(v, e);
        let period_s = if s > 0.0 { s } else { nominal.as_secs_f64() };
        let decel = od.get_u64(o::QUICK_STOP_DECELERATION, 0).unwrap_or(1) as f64;
        Hot {
            mode: od.get_i64(o::MODES_OF_OPERATION, 0).unwrap_or(0) as i8,
            period_s,
            decel_per_cycle: decel * period_s * period_s,
            window: od.get_u64(o::FOLLOWING_ERROR_WINDOW, 0).unwrap_or(0) as u32,
            timeout: Duration::from_millis(od.get_u64(o::FOLLOWING_ERROR_TIMEOUT, 0).unwrap_or(0)),
            inverted: od.get_u64(o::POLARITY, 0).unwrap_or(0) & 0x80 != 0,
            statusword: od.slot(o::STATUSWORD, 0),
            digital_inputs: od.slot(o::DIGITAL_INPUTS, 0),
            target: od.slot(o::TARGET_POSITION, 0),
            mode_display: od.slot(o::MODES_OF_OPERATION_DISPLAY, 0),
            position_actual: od.slot(o::POSITION_ACTUAL, 0),
            position_demand: od.slot(o::POSITION_DEMAND, 0),
            following_error: od.slot(o::FOLLOWING_ERROR_ACTUAL, 0),
            velocity: od.slot(o::VELOCITY_ACTUAL, 0),
        }
    }
}

fn set_at(od: &mut ObjectDictionary, s: Option<Slot>, raw: u64) {
    if let Some(s) = s {
        let _ = od.set_raw_at(s, raw);
    }
}

/// The simulated CiA 402 drive.
pub struct SimDrive {
    node: NodeId,
    params: DriveParams,
    options: SimDriveOptions,
    defaults: ObjectDictionary,
    od: ObjectDictionary,
    nmt: NmtStatus,
    powered_at: Option<Instant>,
    now: Instant,
    cia: DeviceStateMachine,
    axis: AxisModel,
    sdo: SdoServer,
    rpdo: [RpdoSlot; 4],
    tpdo: [TpdoSlot; 4],
    next_heartbeat: Option<Instant>,
    /// The consumed heartbeat (0x1016:1): its COB-ID and timeout; active from its first beat.
    consumer: Option<(u16, Duration)>,
    master_seen: Option<Instant>,
    master_lost: bool,
    fe_since: Option<Instant>,
    fe_exceeded: bool,
    last_sync: Option<Instant>,
    fault_cause: Option<u16>,
    fault_persistent: bool,
    heartbeat_silent: bool,
    sdo_silent: bool,
    drop_tpdos: bool,
    /// `EmcyStorm`: the code sent after every SYNC.
    emcy_storm: Option<u16>,
    /// `StopSync`: SYNCs are ignored.
    sync_deaf: bool,
    outbox: Vec<CanFrame>,
    stats: SimDriveStats,
    nominal_period: Duration,
    /// 0x1005's identifier, cached: every frame on the bus is compared with it.
    sync_id: u16,
    hot: Hot,
    /// Stores/restores carried out (0x1010/0x1011) and the fixed PDO mappings
    /// (`commissioning`).
    stores: u64,
    fixed: Vec<(u16, Vec<crate::wire::MappingEntry>)>,
    /// The machine around the motor (motor counts).
    io: MachineIo,
    /// The homing run since the last start edge, and what the statusword says of homing.
    homing: Option<HomingRun>,
    homing_status: HomingStatus,
    /// Controlword bit 4 as last applied (homing starts on its rising edge).
    homing_start: bool,
    /// Drive position = direction · motor position + `shift` (wrapping counts): set by
    /// homing so that the home point reads the home offset (0x607C).
    shift: i32,
}

impl fmt::Debug for SimDrive {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SimDrive")
            .field("node", &self.node)
            .field("nmt", &self.nmt)
            .field("state", &self.cia.state())
            .field("position", &self.axis.actual())
            .finish()
    }
}

/// `sim.power_on_position` of `axis` in motor counts.
fn power_on_counts(axis: &AxisConfig) -> i32 {
    let c = (axis.sim.machine.power_on_position * axis.counts_per_unit.abs()).round();
    c.clamp(i32::MIN as f64, i32::MAX as f64) as i32
}

fn error_register_for(code: u16) -> u8 {
    // Bit 0 generic always; the class bits by the code's high nibble / byte.
    let class = match code >> 12 {
        0x2 => 0x02,
        0x3 => 0x04,
        0x4 => 0x08,
        0x8 if code >> 8 == 0x81 => 0x10,
        0x5..=0x8 => 0x20,
        _ => 0x00,
    };
    0x01 | class
}

impl SimDrive {
    /// A drive for `axis` at `node`, with SYNC period `period` (sets 0x60C2), booting 1 ms
    /// after power-on at position 0.
    pub fn new(axis: &AxisConfig, node: NodeId, period: Duration) -> SimDrive {
        SimDrive::with_options(axis, node, period, SimDriveOptions::default())
    }

    /// A drive with explicit start options.
    pub fn with_options(
        axis: &AxisConfig,
        node: NodeId,
        period: Duration,
        options: SimDriveOptions,
    ) -> SimDrive {
        let cpu = axis.counts_per_unit.abs();
        let window = (axis.following_error_window * cpu).round();
        let window = if window.is_finite() && window >= 1.0 {
            window.min(u32::MAX as f64 - 1.0) as u32
        } else {
            1
        };
        let decel = (axis.max_acceleration * cpu * 2.0).round();
        let decel = if decel.is_finite() && decel >= 1.0 {
            decel.min(u32::MAX as f64) as u32
        } else {
            1
        };
        let period_us = u32::try_from(period.as_micros()).unwrap_or(u32::MAX).max(1);
        let params = DriveParams {
            node,
            name: format!("cnc402 simdrive {}", axis.name),
            following_error_window: window,
            following_error_timeout_ms: axis.following_error_timeout_ms.min(u16::MAX as u32) as u16,
            quick_stop_deceleration: decel,
            interpolation_period: objects::interpolation_period(period_us),
        };
        let mut defaults = objects::build(&params);
        commissioning::insert_store_objects(&mut defaults);
        let mut d = SimDrive {
            node,
            options,
            od: defaults.clone(),
            defaults,
            params,
            nmt: NmtStatus::Booting,
            powered_at: None,
            now: Instant::ZERO,
            cia: DeviceStateMachine::new(),
            axis: AxisModel::new(
                DriveDynamics::of_axis(axis),
                options.initial_position.wrapping_add(power_on_counts(axis)),
            ),
            sdo: SdoServer::new(),
            rpdo: [RpdoSlot::default(); 4],
            tpdo: [TpdoSlot::default(); 4],
            next_heartbeat: None,
            consumer: None,
            master_seen: None,
            master_lost: false,
            fe_since: None,
            fe_exceeded: false,
            last_sync: None,
            fault_cause: None,
            fault_persistent: false,
            heartbeat_silent: false,
            sdo_silent: false,
            drop_tpdos: false,
            emcy_storm: None,
            sync_deaf: false,
            outbox: Vec::with_capacity(32),
            stats: SimDriveStats::default(),
            nominal_period: period,
            sync_id: 0x80,
            hot: Hot::load(&ObjectDictionary::new(), period),
            stores: 0,
            fixed: Vec::new(),
            io: MachineIo::of_axis(axis),
            homing: None,
            homing_status: HomingStatus::Idle,
            homing_start: false,
            shift: 0,
        };
        d.hot = Hot::load(&d.od, period);
        d.reload_pdos();
        d.publish();
        d
    }

    // ---- observation ------------------------------------------------------------------

    /// Node id.
    pub fn node(&self) -> NodeId {
        self.node
    }
    /// Device name (0x1008).
    pub fn name(&self) -> &str {
        &self.params.name
    }
    /// NMT state.
    pub fn nmt(&self) -> NmtStatus {
        self.nmt
    }
    /// CiA 402 state.
    pub fn state(&self) -> State {
        self.cia.state()
    }
    /// The statusword as sent (0x6041).
    pub fn statusword(&self) -> Statusword {
        Statusword(self.od.get_u64(o::STATUSWORD, 0).unwrap_or(0) as u16)
    }
    /// Position actual value 0x6064 (counts; after 0x607E and homing).
    pub fn position_actual(&self) -> i32 {
        self.to_drive(self.axis.actual())
    }
    /// The motor's own position (counts, before 0x607E and homing): where the simulated
    /// machine's switches are.
    pub fn motor_position(&self) -> i32 {
        self.axis.actual()
    }
    /// What the statusword says of homing (meaningful in homing mode).
    pub fn homing_status(&self) -> HomingStatus {
        self.homing_status
    }
    /// Digital inputs 0x60FD (limit and home switches at the motor's position).
    pub fn digital_inputs(&self) -> u32 {
        self.directed_io().inputs(self.directed_position())
    }
    /// Position demand 0x6062: the setpoint the loop tracks (after the pure delay).
    pub fn position_demand(&self) -> i32 {
        self.to_drive(self.axis.demand())
    }
    /// Target position 0x607A as last received.
    pub fn target_position(&self) -> i32 {
        self.hot
            .target
            .and_then(|s| self.od.get_u64_at(s))
            .unwrap_or(0) as u32 as i32
    }
    /// Following error 0x60F4 (counts).
    pub fn following_error(&self) -> i32 {
        self.direction().wrapping_mul(self.axis.following_error())
    }
    /// The active fault's EMCY code, if in FAULT / FAULT REACTION ACTIVE.
    pub fn fault_code(&self) -> Option<u16> {
        if self.cia.state().is_fault() {
            self.fault_cause
        } else {
            None
        }
    }
    /// Time of the last SYNC processed.
    pub fn last_sync(&self) -> Option<Instant> {
        self.last_sync
    }
    /// Counters.
    pub fn stats(&self) -> SimDriveStats {
        let mut s = self.stats;
        s.sdo_aborts = self.sdo.aborts_sent();
        s
    }
    /// The object dictionary (read-only view).
    pub fn od(&self) -> &ObjectDictionary {
        &self.od
    }
    /// Simulated dynamics (in counts).
    pub fn dynamics(&self) -> DriveDynamics {
        self.axis.dynamics()
    }

    // ---- fault injection ----------------------------------------------------------------

    /// Applies an injected fault at `now` (frames go out at the next `poll`/`on_frame`).
    pub fn inject(&mut self, kind: FaultKind, now: Instant) {
        self.now = self.now.max(now);
        match kind {
            FaultKind::Fault(code) => {
                self.fault_persistent = false;
                self.raise_fault(code);
            }
            FaultKind::PersistentFault(code) => {
                self.fault_persistent = true;
                self.raise_fault(code);
            }
            FaultKind::HeartbeatSilence => self.heartbeat_silent = true,
            FaultKind::SdoSilence => self.sdo_silent = true,
            FaultKind::DropTpdos => self.drop_tpdos = true,
            FaultKind::Reboot => {
                self.reset_node();
                for r in &mut self.rpdo {
                    r.pending = None;
                }
            }
            FaultKind::EmcyStorm(code) => self.emcy_storm = Some(code),
            FaultKind::StopSync => self.sync_deaf = true,
            FaultKind::Inputs(v) => {
                self.io.static_inputs = v;
                self.publish();
            }
            FaultKind::DeviceType(v) => {
                let _ = self.defaults.set_raw(o::DEVICE_TYPE, 0, v as u64);
                let _ = self.od.set_raw(o::DEVICE_TYPE, 0, v as u64);
            }
            FaultKind::Identity {
                vendor,
                product,
                revision,
            } => {
                let subs = [(1, Some(vendor)), (2, Some(product)), (3, revision)];
                for (sub, v) in subs {
                    if let Some(v) = v {
                        let _ = self.defaults.set_raw(o::IDENTITY, sub, v as u64);
                        let _ = self.od.set_raw(o::IDENTITY, sub, v as u64);
                    }
                }
            }
        }
    }

    /// Clears every injected condition (a persistent fault cause included; the drive stays in
    /// FAULT until reset).
    pub fn clear_injected(&mut self) {
        self.fault_persistent = false;
        self.heartbeat_silent = false;
        self.sdo_silent = false;
        self.drop_tpdos = false;
        self.emcy_storm = None;
        self.sync_deaf = false;
    }

    // ---- internals ----------------------------------------------------------------------

    fn send(&mut self, f: CanFrame) {
        self.outbox.push(f);
    }

    fn flush(&mut self, now: Instant, tx: &mut dyn FrameSink) {
        for f in self.outbox.drain(..) {
            if tx.transmit(&f, now).is_err() {
                self.stats.tx_errors += 1;
            }
        }
    }

    fn mode(&self) -> Option<OperationMode> {
        OperationMode::from_i8(self.hot.mode)
    }

    fn csp_active(&self) -> bool {
        self.cia.state() == State::OperationEnabled
            && self.mode() == Some(OperationMode::CyclicSyncPosition)
    }

    /// Writes the device-produced objects into the dictionary (no allocation, no search).
    fn publish(&mut self) {
        let mut sw = self.cia.statusword().with(Statusword::REMOTE, true);
        if self.csp_active() {
            sw = sw.with(Statusword::FOLLOWS_COMMAND, true);
        }
        sw = sw.with(Statusword::FOLLOWING_ERROR, self.fe_exceeded);
        if self.mode() == Some(OperationMode::Homing) {
            // Bits 10, 12 and 13 mean homing status in homing mode.
            let mask = Statusword::TARGET_REACHED | HOMING_ATTAINED | HOMING_ERROR;
            sw = Statusword((sw.0 & !mask) | self.homing_status.bits());
        }
        let h = self.hot;
        let v = self.axis.velocity() / h.period_s.max(1e-9);
        let v = (v * self.direction() as f64)
            .round()
            .clamp(i32::MIN as f64, i32::MAX as f64) as i32;
        let (actual, demand, fe) = (
            self.position_actual(),
            self.position_demand(),
            self.following_error(),
        );
        let inputs = self.digital_inputs();
        let od = &mut self.od;
        set_at(od, h.statusword, sw.0 as u64);
        set_at(od, h.mode_display, h.mode as u8 as u64);
        set_at(od, h.position_actual, actual as u32 as u64);
        set_at(od, h.position_demand, demand as u32 as u64);
        set_at(od, h.following_error, fe as u32 as u64);
        set_at(od, h.velocity, v as u32 as u64);
        set_at(od, h.digital_inputs, inputs as u64);
    }

    fn period_s(&self) -> f64 {
        self.hot.period_s
    }

    /// −1 when 0x607E inverts positions, else 1.
    fn direction(&self) -> i32 {
        if self.hot.inverted { -1 } else { 1 }
    }

    /// A motor count as the drive reports it (0x607E, then the homing shift).
    fn to_drive(&self, motor: i32) -> i32 {
        self.direction()
            .wrapping_mul(motor)
            .wrapping_add(self.shift)
    }

    /// A drive position (a target) in motor counts.
    fn to_motor(&self, drive: i32) -> i32 {
        self.direction()
            .wrapping_mul(drive.wrapping_sub(self.shift))
    }

    /// The machine in the drive's direction (before the homing shift).
    fn directed_io(&self) -> MachineIo {
        self.io.inverted(self.hot.inverted)
    }

    /// The motor's true position in the drive's direction (before the homing shift).
    fn directed_position(&self) -> f64 {
        self.direction() as f64 * self.axis.true_position()
    }

    /// The homing parameters in the dictionary.
    fn homing_params(&self) -> Option<HomingParams> {
        let method = self.od.get_i64(o::HOMING_METHOD, 0).unwrap_or(0) as i8;
        let u = |i, s| self.od.get_u64(i, s).unwrap_or(0) as f64;
        Some(HomingParams {
            method: HomingMethod::new(method)?,
            // A speed of 0 would search forever; the slowest is a count per second.
            speed_switch: u(o::HOMING_SPEEDS, 1).max(1.0),
            speed_zero: u(o::HOMING_SPEEDS, 2).max(1.0),
            acceleration: u(o::HOMING_ACCELERATION, 0).max(1.0),
        })
    }

    /// Controlword bit 4 in homing mode: a rising edge starts homing (with an unsupported
    /// method: homing error at once); falling while homing interrupts it.
    fn on_homing_bit(&mut self, cw: Controlword) {
        let start = cw.has(HOMING_START);
        let rising = start && !self.homing_start;
        self.homing_start = start;
        if self.mode() != Some(OperationMode::Homing) || self.cia.state() != State::OperationEnabled
        {
            return;
        }
        if rising {
            let run = self
                .homing_params()
                .map(|p| HomingRun::start(p, self.directed_position(), &self.directed_io()));
            self.homing_status = run.map_or(HomingStatus::Error, |r| r.status());
            self.homing = run;
            if let Some(home) = run.and_then(|r| r.home()) {
                self.homed_at(home);
            }
        } else if !start && self.homing.is_some_and(|r| !r.finished()) {
            self.homing = None;
            self.homing_status = HomingStatus::Idle;
        }
    }

    /// One homing cycle (operation enabled in homing mode).
    fn homing_step(&mut self, dt: f64) {
        let Some(mut run) = self.homing else {
            self.axis.hold();
            return;
        };
        let step = run.step(self.directed_position(), dt, &self.directed_io());
        self.axis.drive_by(self.direction() as f64 * step);
        self.homing = Some(run);
        self.homing_status = run.status();
        if let Some(home) = run.home() {
            self.homed_at(home);
            self.homing = None;
        }
    }

    /// Homing attained at `home` (directed counts): the home point now reads 0x607C.
    fn homed_at(&mut self, home: f64) {
        let offset = self.od.get_i64(o::HOME_OFFSET, 0).unwrap_or(0) as i32;
        let home = home.clamp(i32::MIN as f64, i32::MAX as f64) as i32;
        self.shift = offset.wrapping_sub(home);
        self.homing_status = HomingStatus::Completed;
        self.axis.hold();
    }

    /// Re-reads the cached parameters after the dictionary changed.
    fn refresh(&mut self) {
        self.hot = Hot::load(&self.od, self.nominal_period);
    }

    /// Re-reads 0x1016:1; a changed entry waits for its producer's first heartbeat again.
    fn load_consumer(&mut self) {
        let v = self.od.get_u64(o::CONSUMER_HEARTBEAT_TIME, 1).unwrap_or(0) as u32;
        let (node, ms) = ((v >> 16) & 0xFF, v & 0xFFFF);
        let consumer = ((1..=127).contains(&node) && ms > 0)
            .then(|| (0x700 + node as u16, Duration::from_millis(ms as u64)));
        if consumer != self.consumer {
            self.consumer = consumer;
            self.master_seen = None;
            self.master_lost = false;
        }
    }

    /// The consumed heartbeat timed out: EMCY 0x8130 and the 0x6007 reaction.
    fn on_master_lost(&mut self) {
        self.master_lost = true;
        match self.od.get_i64(o::ABORT_CONNECTION_OPTION, 0).unwrap_or(1) {
            1 => self.raise_fault(emcy_code::HEARTBEAT),
            2 => {
                self.emcy(emcy_code::HEARTBEAT);
                self.apply_controlword(Controlword::DISABLE_VOLTAGE);
            }
            3 => {
                self.emcy(emcy_code::HEARTBEAT);
                self.apply_controlword(Controlword::QUICK_STOP_CMD);
            }
            _ => self.emcy(emcy_code::HEARTBEAT),
        }
    }

    fn reload_pdos(&mut self) {
        self.load_consumer();
        self.refresh();
        self.sync_id = (self.od.get_u64(o::SYNC_COB_ID, 0).unwrap_or(0x80) & 0x7FF) as u16;
        for n in 0..4u16 {
            self.rpdo[n as usize] = pdo::load_rpdo(&self.od, n);
            self.tpdo[n as usize] = pdo::load_tpdo(&self.od, n);
        }
    }

    fn emcy(&mut self, code: u16) {
        if matches!(self.nmt, NmtStatus::Booting | NmtStatus::Stopped) {
            return;
        }
        let register = self.od.get_u64(o::ERROR_REGISTER, 0).unwrap_or(0) as u8;
        let f = EmcyRepr {
            node: self.node,
            code,
            register,
            manufacturer: [0; 5],
        }
        .emit();
        self.send(f);
        self.stats.emcys_sent += 1;
    }

    fn raise_fault(&mut self, code: u16) {
        self.fault_cause = Some(code);
        if self.cia.fault().is_none() {
            return;
        }
        let _ = self.od.set_raw(o::ERROR_CODE, 0, code as u64);
        let _ = self
            .od
            .set_raw(o::ERROR_REGISTER, 0, error_register_for(code) as u64);
        // 0x1003: newest at sub 1, at most 8.
        let count = self
            .od
            .get_u64(o::PREDEFINED_ERROR_FIELD, 0)
            .unwrap_or(0)
            .min(8) as u8;
        for sub in (1..count.min(7) + 1).rev() {
            let v = self.od.get_u64(o::PREDEFINED_ERROR_FIELD, sub).unwrap_or(0);
            let _ = self.od.set_raw(o::PREDEFINED_ERROR_FIELD, sub + 1, v);
        }
        let _ = self.od.set_raw(o::PREDEFINED_ERROR_FIELD, 1, code as u64);
        let _ = self
            .od
            .set_raw(o::PREDEFINED_ERROR_FIELD, 0, (count + 1).min(8) as u64);
        self.fe_since = None;
        self.emcy(code);
        self.publish();
    }

    fn apply_controlword(&mut self, cw: Controlword) {
        let before = self.cia.state();
        let t = self.cia.on_controlword(cw);
        if t == Some(Transition::T15) {
            if self.fault_persistent {
                let code = self.fault_cause.unwrap_or(emcy_code::GENERIC);
                self.raise_fault(code);
            } else {
                self.fault_cause = None;
                let _ = self.od.set_raw(o::ERROR_CODE, 0, 0);
                let _ = self.od.set_raw(o::ERROR_REGISTER, 0, 0);
                self.emcy(emcy_code::NO_ERROR);
            }
        }
        let after = self.cia.state();
        self.on_homing_bit(cw);
        if after == State::OperationEnabled && before != State::OperationEnabled {
            // Enabling: the loop starts from where the motor is.
            self.axis.hold();
            self.fe_since = None;
            self.fe_exceeded = false;
        }
        if after == State::QuickStopActive && self.cia.quick_stop_option().coasts() {
            self.axis.hold();
        }
        self.publish();
    }

    fn boot(&mut self) {
        self.boot_comm_only();
        self.cia.init_done();
        if let Some(code) = self.options.start_in_fault.take() {
            self.fault_persistent = false;
            self.raise_fault(code);
        } else if self.fault_persistent {
            let code = self.fault_cause.unwrap_or(emcy_code::GENERIC);
            self.raise_fault(code);
        }
        self.publish();
    }

    fn schedule_heartbeat(&mut self) {
        let ms = self.od.get_u64(o::PRODUCER_HEARTBEAT_TIME, 0).unwrap_or(0);
        self.next_heartbeat = (ms > 0).then(|| self.now + Duration::from_millis(ms));
    }

    fn reset_communication(&mut self) {
        for index in self
            .defaults
            .indices()
            .filter(|i| (0x1000..=0x1FFF).contains(i))
            .collect::<Vec<_>>()
        {
            for sub in self.defaults.subs(index).collect::<Vec<_>>() {
                if let Some(v) = self.defaults.get(index, sub).cloned() {
                    let _ = self.od.set(index, sub, v);
                }
            }
        }
        // The error history survives a communication reset.
        self.sdo.reset();
        self.reload_pdos();
        self.nmt = NmtStatus::Booting;
        self.boot_comm_only();
    }

    fn boot_comm_only(&mut self) {
        self.nmt = NmtStatus::PreOperational;
        let f = HeartbeatRepr {
            node: self.node,
            state: NmtState::BootUp,
        }
        .emit();
        self.send(f);
        self.stats.boot_ups += 1;
        self.schedule_heartbeat();
    }

    fn reset_node(&mut self) {
        let position = self.axis.actual();
        self.od = self.defaults.clone();
        self.cia = DeviceStateMachine::new();
        self.axis = AxisModel::new(self.axis.dynamics(), position);
        // An incremental drive forgets its reference when it resets.
        self.shift = 0;
        self.homing = None;
        self.homing_status = HomingStatus::Idle;
        self.homing_start = false;
        self.sdo.reset();
        self.fe_since = None;
        self.fe_exceeded = false;
        if !self.fault_persistent {
            self.fault_cause = None;
        }
        self.reload_pdos();
        self.nmt = NmtStatus::Booting;
        self.boot();
    }

    fn on_nmt(&mut self, frame: &CanFrame) {
        let Ok(r) = NmtRepr::parse(frame) else {
            self.stats.unexpected_frames += 1;
            return;
        };
        if !r.target.includes(self.node) {
            return;
        }
        match r.command {
            NmtCommand::Start => self.nmt = NmtStatus::Operational,
            NmtCommand::Stop => self.nmt = NmtStatus::Stopped,
            NmtCommand::EnterPreOperational => self.nmt = NmtStatus::PreOperational,
            NmtCommand::ResetNode => self.reset_node(),
            NmtCommand::ResetCommunication => self.reset_communication(),
        }
        if r.command != NmtCommand::Start {
            for r in &mut self.rpdo {
                r.pending = None;
            }
        }
    }

    fn on_sdo(&mut self, frame: &CanFrame) {
        if self.sdo_silent || self.nmt == NmtStatus::Stopped {
            return;
        }
        self.stats.sdo_requests += 1;
        let mut server = std::mem::take(&mut self.sdo);
        let response = match SdoRequest::parse(frame) {
            Ok((_, req)) => server.handle(req, self),
            Err(WireError::UnknownCommand(_)) => server.handle_unparsable(frame.data()),
            Err(_) => {
                self.stats.unexpected_frames += 1;
                None
            }
        };
        self.sdo = server;
        if let Some(r) = response {
            let f = r.emit(self.node);
            self.send(f);
        }
    }

    fn apply_rpdo_data(&mut self, n: usize, data: &[u8]) {
        let map = self.rpdo[n].map;
        let slots = self.rpdo[n].slots;
        let mut cw = None;
        let mut other = false;
        let mut k = 0;
        let od = &mut self.od;
        let res = map.unpack(data, |e, raw| {
            match (e.index, e.sub) {
                (o::CONTROLWORD, 0) => cw = Some(Controlword(raw as u16)),
                (o::TARGET_POSITION, 0) => {}
                _ => other = true,
            }
            match slots[k] {
                Some(s) => {
                    let _ = od.set_raw_at(s, raw);
                }
                None => {
                    let _ = od.set_raw(e.index, e.sub, raw);
                }
            }
            k += 1;
        });
        if res.is_ok() {
            self.stats.rpdos_applied += 1;
            if other {
                self.refresh();
            }
            if let Some(cw) = cw {
                self.apply_controlword(cw);
            }
        }
    }

    fn on_rpdo(&mut self, n: usize, frame: &CanFrame) {
        if self.nmt != NmtStatus::Operational || frame.is_remote() {
            self.stats.unexpected_frames += 1;
            return;
        }
        let slot = self.rpdo[n];
        let expected = slot.map.byte_len();
        let got = frame.dlc();
        if got != expected {
            self.stats.pdo_length_errors += 1;
            let code = if got < expected {
                emcy_code::PDO_LENGTH
            } else {
                emcy_code::PDO_LENGTH_EXCEEDED
            };
            self.emcy(code);
            return;
        }
        if slot.transmission_type <= 240 {
            let mut d = [0u8; 8];
            d[..got].copy_from_slice(frame.data());
            self.rpdo[n].pending = Some((d, got));
        } else {
            self.apply_rpdo_data(n, frame.data());
            self.event_tpdos();
        }
    }

    fn on_sync(&mut self) {
        if self.nmt != NmtStatus::Operational || self.sync_deaf {
            return;
        }
        if let Some(code) = self.emcy_storm {
            self.emcy(code);
        }
        self.stats.syncs += 1;
        self.last_sync = Some(self.now);
        // 1. Synchronous RPDOs received since the last SYNC take effect now.
        for n in 0..4 {
            if let Some((d, len)) = self.rpdo[n].pending.take() {
                self.apply_rpdo_data(n, &d[..len]);
            }
        }
        // 2. The motor moves one cycle.
        let dt = self.hot.period_s;
        let decel = self.hot.decel_per_cycle;
        match self.cia.state() {
            State::OperationEnabled if self.mode() == Some(OperationMode::CyclicSyncPosition) => {
                self.axis.follow(self.to_motor(self.target_position()), dt);
            }
            State::OperationEnabled if self.mode() == Some(OperationMode::Homing) => {
                self.homing_step(dt);
            }
            State::QuickStopActive => {
                if self.axis.brake(decel) {
                    self.cia.quick_stop_done();
                }
            }
            State::FaultReactionActive => {
                if self.axis.brake(decel) {
                    self.cia.fault_reaction_done();
                }
            }
            _ => self.axis.hold(),
        }
        // 3. Following error monitoring (0x6065 window, 0x6066 time-out).
        self.check_following_error();
        self.publish();
        // 4. Synchronous TPDOs.
        for n in 0..4 {
            let t = self.tpdo[n];
            if !t.valid {
                continue;
            }
            match t.transmission_type {
                1..=240 => {
                    let c = t.sync_count + 1;
                    if c >= t.transmission_type as u32 {
                        self.tpdo[n].sync_count = 0;
                        self.send_tpdo(n, false);
                    } else {
                        self.tpdo[n].sync_count = c;
                    }
                }
                0 => self.send_tpdo(n, true),
                _ => {}
            }
        }
        self.event_tpdos();
    }

    fn check_following_error(&mut self) {
        if !self.csp_active() {
            self.fe_since = None;
            self.fe_exceeded = false;
            return;
        }
        let fe = self.axis.following_error().unsigned_abs();
        self.stats.max_following_error = self.stats.max_following_error.max(fe);
        let window = self.hot.window;
        if window == 0 || window == u32::MAX || fe <= window {
            self.fe_since = None;
            self.fe_exceeded = false;
            return;
        }
        self.fe_exceeded = true;
        let since = *self.fe_since.get_or_insert(self.now);
        if self.now - since >= self.hot.timeout {
            self.raise_fault(emcy_code::FOLLOWING_ERROR);
        }
    }

    fn pack_tpdo(&self, n: usize) -> ([u8; 8], usize) {
        let mut d = [0u8; 8];
        let slots = self.tpdo[n].slots;
        let mut k = 0;
        let len = self.tpdo[n].map.pack(&mut d, |e| {
            let v = match slots[k] {
                Some(s) => self.od.get_u64_at(s),
                None => self.od.get_u64(e.index, e.sub),
            };
            k += 1;
            v.unwrap_or(0)
        });
        (d, len)
    }

    /// Sends TPDO `n`; with `only_if_changed`, only when its data differ from the last sent.
    fn send_tpdo(&mut self, n: usize, only_if_changed: bool) {
        let (d, len) = self.pack_tpdo(n);
        if only_if_changed && self.tpdo[n].last_data == Some((d, len)) {
            return;
        }
        if self.drop_tpdos {
            self.stats.tpdos_dropped += 1;
            return;
        }
        let f = CanFrame::from_parts(self.tpdo[n].cob_id, d, len);
        self.send(f);
        self.tpdo[n].last_data = Some((d, len));
        self.tpdo[n].last_tx_ns = Some(self.now.nanos());
        self.stats.tpdos_sent += 1;
    }

    /// Event-driven TPDOs (254/255): on change of their data (respecting the inhibit time)
    /// and on the event timer.
    fn event_tpdos(&mut self) {
        if self.nmt != NmtStatus::Operational {
            return;
        }
        for n in 0..4 {
            let t = self.tpdo[n];
            if !t.valid || t.transmission_type < 254 {
                continue;
            }
            let since = t.last_tx_ns.map(|ns| self.now.nanos().saturating_sub(ns));
            let inhibit_ns = t.inhibit_100us as u64 * 100_000;
            if since.is_some_and(|s| s < inhibit_ns) {
                continue;
            }
            let timer_due = t.event_timer_ms > 0
                && since.is_none_or(|s| s >= t.event_timer_ms as u64 * 1_000_000);
            self.send_tpdo(n, !timer_due);
        }
    }

    fn handle_frame(&mut self, frame: &CanFrame) {
        let id = frame.id();
        let sync_id = self.sync_id;
        if id == 0 {
            self.on_nmt(frame);
            return;
        }
        if self.nmt == NmtStatus::Stopped {
            return;
        }
        if self.consumer.is_some_and(|(cid, _)| cid == id) {
            if frame.dlc() == 1 && !frame.is_remote() {
                self.master_seen = Some(self.now);
                self.master_lost = false;
            }
            return;
        }
        if id == 0x600 + self.node.get() as u16 {
            self.on_sdo(frame);
        } else if id == sync_id {
            // A SYNC with more than one data byte is not a SYNC (CiA 301); count it.
            if frame.dlc() > 1 || frame.is_remote() {
                self.stats.unexpected_frames += 1;
            } else {
                self.on_sync();
            }
        } else if let Some(n) = (0..4).find(|&n| self.rpdo[n].valid && self.rpdo[n].cob_id == id) {
            self.on_rpdo(n, frame);
        }
    }

    fn timers(&mut self) {
        let now = self.now;
        let powered = *self.powered_at.get_or_insert(now);
        if self.nmt == NmtStatus::Booting {
            if now >= powered + self.options.boot_delay {
                self.boot();
            } else {
                return;
            }
        }
        if let Some(next) = self.next_heartbeat
            && now >= next
        {
            if !self.heartbeat_silent {
                let state = match self.nmt {
                    NmtStatus::Operational => NmtState::Operational,
                    NmtStatus::Stopped => NmtState::Stopped,
                    _ => NmtState::PreOperational,
                };
                let f = HeartbeatRepr {
                    node: self.node,
                    state,
                }
                .emit();
                self.send(f);
                self.stats.heartbeats_sent += 1;
            }
            let ms = self.od.get_u64(o::PRODUCER_HEARTBEAT_TIME, 0).unwrap_or(0);
            let period = Duration::from_millis(ms.max(1));
            let mut n = next + period;
            if n <= now {
                n = now + period;
            }
            self.next_heartbeat = Some(n);
        }
        if let (Some((_, timeout)), Some(seen)) = (self.consumer, self.master_seen)
            && !self.master_lost
            && now.saturating_since(seen) > timeout
        {
            self.on_master_lost();
        }
        // Without SYNCs a ramp cannot run: after 10 missed periods the motor is taken as
        // stopped so that a fault reaction / quick stop still ends.
        let state = self.cia.state();
        if matches!(state, State::FaultReactionActive | State::QuickStopActive) {
            let stale = Duration::try_from_secs_f64(self.period_s() * 10.0)
                .unwrap_or(Duration::from_millis(10));
            if self.last_sync.is_none_or(|t| now - t > stale) {
                self.axis.hold();
                if state == State::FaultReactionActive {
                    self.cia.fault_reaction_done();
                } else {
                    self.cia.quick_stop_done();
                }
                self.publish();
            }
        }
        self.event_tpdos();
    }
}

impl ObjectAccess for SimDrive {
    fn upload(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode> {
        if index == o::PREDEFINED_ERROR_FIELD && sub >= 1 {
            let count = self.od.get_u64(index, 0).unwrap_or(0);
            if self.od.entry(index, sub).is_ok() && sub as u64 > count {
                return Err(AbortCode::NoData);
            }
        }
        self.od
            .read(index, sub)
            .map(Value::to_bytes)
            .map_err(OdError::abort_code)
    }

    fn download_check(&mut self, index: u16, sub: u8) -> Result<Option<usize>, AbortCode> {
        let e = self.od.entry(index, sub).map_err(OdError::abort_code)?;
        if !e.access.writable() {
            return Err(AbortCode::WriteReadOnly);
        }
        if pdo::is_pdo_parameter(index) && self.nmt == NmtStatus::Operational {
            return Err(AbortCode::DeviceState);
        }
        Ok(e.value.data_type().size())
    }

    fn download(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        let value = self
            .od
            .check_write(index, sub, data)
            .map_err(OdError::abort_code)?;
        if pdo::is_pdo_parameter(index) {
            let raw = value.as_u64().unwrap_or(0) as u32;
            pdo::check_write(
                &self.od,
                index,
                sub,
                raw,
                self.nmt == NmtStatus::Operational,
            )?;
        }
        match index {
            o::PREDEFINED_ERROR_FIELD if value.as_u64() != Some(0) => {
                return Err(AbortCode::InvalidValue);
            }
            crate::od::STORE_PARAMETERS | crate::od::RESTORE_DEFAULTS if sub >= 1 => {
                return self.store_command(index, value.as_u64().unwrap_or(0) as u32);
            }
            o::MODES_OF_OPERATION => {
                let supported = self.od.get_u64(o::SUPPORTED_DRIVE_MODES, 0).unwrap_or(0) as u32;
                let ok = OperationMode::from_i8(value.as_i64().unwrap_or(0) as i8)
                    .is_some_and(|m| m.is_supported_by(supported));
                if !ok {
                    return Err(AbortCode::InvalidValue);
                }
            }
            o::HOMING_METHOD if HomingMethod::new(value.as_i64().unwrap_or(0) as i8).is_none() => {
                return Err(AbortCode::InvalidValue);
            }
            o::QUICK_STOP_OPTION => {
                let opt = QuickStopOption::from_i16(value.as_i64().unwrap_or(-1) as i16)
                    .ok_or(AbortCode::InvalidValue)?;
                self.cia.set_quick_stop_option(opt);
            }
            o::SYNC_COB_ID => {
                let v = value.as_u64().unwrap_or(0) as u32;
                // This drive consumes SYNC only; it cannot produce it, nor use 29-bit ids.
                if v & (3 << 29) != 0 {
                    return Err(AbortCode::InvalidValue);
                }
            }
            o::INTERPOLATION_TIME_PERIOD if sub == 1 && value.as_u64() == Some(0) => {
                return Err(AbortCode::InvalidValue);
            }
            _ => {}
        }
        let mode_before = self.hot.mode;
        self.od
            .write(index, sub, data)
            .map_err(OdError::abort_code)?;
        self.refresh();
        if self.hot.mode != mode_before {
            // A new mode starts from where the motor is; a homing run does not survive it.
            self.axis.hold();
            self.homing = None;
            self.homing_status = HomingStatus::Idle;
        }
        match index {
            o::CONTROLWORD => {
                let cw = Controlword(value.as_u64().unwrap_or(0) as u16);
                self.apply_controlword(cw);
            }
            o::PRODUCER_HEARTBEAT_TIME => self.schedule_heartbeat(),
            o::CONSUMER_HEARTBEAT_TIME => self.load_consumer(),
            o::PREDEFINED_ERROR_FIELD => {
                for s in 1..=8 {
                    let _ = self.od.set_raw(index, s, 0);
                }
            }
            i if pdo::is_pdo_parameter(i) || i == o::SYNC_COB_ID => self.reload_pdos(),
            _ => {}
        }
        self.publish();
        Ok(())
    }
}

impl CanDevice for SimDrive {
    fn on_frame(&mut self, frame: &CanFrame, now: Instant, tx: &mut dyn FrameSink) {
        self.now = self.now.max(now);
        if self.nmt == NmtStatus::Booting {
            self.timers();
        }
        // Most frames on a busy bus are other nodes' PDOs: filter before any work, as a CAN
        // controller's acceptance filter does. Timers run in `poll`.
        let id = frame.id();
        let mine = id == 0
            || id == self.sync_id
            || id == 0x600 + self.node.get() as u16
            || self.consumer.is_some_and(|(cid, _)| cid == id)
            || self.rpdo.iter().any(|r| r.valid && r.cob_id == id);
        if mine && self.nmt != NmtStatus::Booting {
            self.handle_frame(frame);
        }
        if !self.outbox.is_empty() {
            self.flush(now, tx);
        }
    }

    fn poll(&mut self, now: Instant, tx: &mut dyn FrameSink) {
        self.now = self.now.max(now);
        self.timers();
        self.flush(now, tx);
    }
}
