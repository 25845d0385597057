//! The embedded simulated machine: an in-process [`SimBus`] with one [`SimDrive`] per
//! configured drive node, carrying the same frames a real bus would in virtual time, seen by
//! the master through a [`FaultInjector`], plus faults scheduled for tests (a drive fault
//! kind, a bus-off window, a frame rule). [`SimLink`] is the master on it.

use core::time::Duration;

use cnc402_config::{AxisConfig, MAX_AXES, MachineConfig};
use cnc402_drives::Instant;
use cnc402_drives::bus::{FaultInjector, FaultRule, SimBus};

use cnc402_drives::sim::{FaultKind, SimDrive, SimDriveOptions};
use cnc402_drives::wire::NodeId;

use crate::link::FaultPlan;
use crate::master_link::{CycleBus, MasterLink, forward_timed_bus};

/// A fault a test schedules on the simulated machine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SimFault {
    /// Drive `node` (every drive on that node id) takes `kind`.
    Drive {
        /// Node id.
        node: u8,
        /// What happens to it.
        kind: FaultKind,
    },
    /// The master's CAN controller goes bus-off for this long, then recovers.
    BusOff(Duration),
    /// From now on this rule acts on the frames the master sends or receives.
    Frames(FaultRule),
    /// A second device on node id `node`, a copy of the configured drive there (at power-on
    /// only: scheduled later, it is ignored).
    SecondDevice(u8),
}

/// A [`SimFault`] and when: `at` after the first cyclic SYNC, or `None` at power-on (before
/// the master boots the drives).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimFaultPlan {
    /// When, after the first cyclic SYNC; `None`: at power-on.
    pub at: Option<Duration>,
    /// What.
    pub fault: SimFault,
}

/// The simulated bus and drives; see the module doc.
pub struct SimMachine {
    bus: FaultInjector<SimBus<SimDrive>>,
    /// Faults by time since the first cyclic SYNC, and whether each was applied.
    schedule: Vec<(Duration, SimFault, bool)>,
    /// The configured drives (for a second device on a node id) and the period.
    axes: Vec<AxisConfig>,
    period: Duration,
}

/// The CANopen master on the embedded simulated machine.
pub type SimLink = MasterLink<SimMachine>;

impl SimMachine {
    /// Builds the bus and its drives from `cfg`; `initial` are the drives' positions at
    /// power-on (counts, config axis order; `None` = 0).
    pub fn new(
        cfg: &MachineConfig,
        initial: Option<[i32; MAX_AXES]>,
    ) -> Result<SimMachine, String> {
        SimMachine::with_drive_options(cfg, |i, _| SimDriveOptions {
            initial_position: initial.map_or(0, |p| p[i]),
            ..SimDriveOptions::default()
        })
    }

    /// Builds the bus and its drives from `cfg`, each drive with the options `options(axis
    /// index, node id)` gives (a drive that boots late, one in FAULT at power-on).
    pub fn with_drive_options(
        cfg: &MachineConfig,
        options: impl Fn(usize, u8) -> SimDriveOptions,
    ) -> Result<SimMachine, String> {
        let period = Duration::from_micros(cfg.bus.period_us as u64);
        let mut bus: SimBus<SimDrive> = SimBus::new(cfg.bus.bitrate);
        for (i, a) in cfg.axes.iter().enumerate().take(MAX_AXES) {
            let Some(node) = a.node else { continue };
            let id =
                NodeId::new(node).map_err(|e| format!("axis {}: node {node}: {e:?}", a.name))?;
            bus.attach(SimDrive::with_options(a, id, period, options(i, node)));
        }
        Ok(SimMachine {
            bus: FaultInjector::new(bus),
            schedule: Vec::new(),
            axes: cfg.axes.clone(),
            period,
        })
    }

    /// The bus and its drives.
    pub fn bus(&self) -> &SimBus<SimDrive> {
        self.bus.inner()
    }

    /// Puts one more drive on the bus (e.g. a second device on a node id already in use).
    pub fn attach(&mut self, drive: SimDrive) {
        self.bus.inner_mut().attach(drive);
    }

    /// Applies `kind` at once to every drive on node `node` (before boot: a drive that is
    /// silent or of the wrong type from power-on). Returns how many drives took it.
    pub fn inject(&mut self, node: u8, kind: FaultKind) -> usize {
        let now = self.bus.inner().now();
        let bus = self.bus.inner_mut();
        let mut n = 0;
        for i in 0..bus.devices().len() {
            if let Some(d) = bus.device_mut(i)
                && d.node().get() == node
            {
                d.inject(kind, now);
                n += 1;
            }
        }
        n
    }

    /// Schedules `fault` at `at` after the first cyclic SYNC.
    pub fn schedule(&mut self, at: Duration, fault: SimFault) {
        self.schedule.push((at, fault, false));
    }

    /// Arms `plan`: applied now when it is for power-on, else scheduled.
    pub fn arm(&mut self, plan: SimFaultPlan) {
        match plan.at {
            Some(at) => self.schedule(at, plan.fault),
            None => {
                let now = self.bus.inner().now();
                self.apply(plan.fault, now);
            }
        }
    }

    fn apply(&mut self, fault: SimFault, t: Instant) {
        match fault {
            SimFault::SecondDevice(node) => {
                // Allocates: only ever applied at power-on (`arm`), never in a cycle.
                if let Some(a) = self.axes.iter().find(|a| a.node == Some(node))
                    && let Ok(id) = NodeId::new(node)
                {
                    let d = SimDrive::new(a, id, self.period);
                    self.bus.inner_mut().attach(d);
                }
            }
            SimFault::Drive { node, kind } => {
                self.inject(node, kind);
            }
            SimFault::BusOff(d) => self.bus.set_bus_off(t, d),
            SimFault::Frames(rule) => {
                self.bus.add_rule(rule);
            }
        }
    }
}

forward_timed_bus!(SimMachine, bus);

impl CycleBus for SimMachine {
    /// Applies the scheduled faults whose time has come, then runs the bus and the drives
    /// up to `t` (delivering the TPDOs that answer the previous SYNC).
    fn before_cycle(&mut self, t: Instant, since_start: Duration) {
        for k in 0..self.schedule.len() {
            let (at, fault, done) = self.schedule[k];
            if !done && since_start >= at {
                self.schedule[k].2 = true;
                if !matches!(fault, SimFault::SecondDevice(_)) {
                    self.apply(fault, t);
                }
            }
        }
        // Only held frames are sent here, and a failure is the master's to see at its next
        // send.
        let _ = self.bus.set_now(t);
        self.bus.inner_mut().advance(t);
    }

    fn bitrate(&self) -> u32 {
        self.bus.inner().bitrate()
    }
}

impl MasterLink<SimMachine> {
    /// The master on a new simulated machine for `cfg` (see [`SimMachine::new`]).
    pub fn simulated(
        cfg: &MachineConfig,
        initial: Option<[i32; MAX_AXES]>,
    ) -> Result<SimLink, String> {
        let machine = SimMachine::new(cfg, initial)?;
        MasterLink::new(cfg, machine).map_err(|e| e.to_string())
    }

    /// Arms a fault: drive `plan.node` goes to FAULT with EMCY `plan.emcy` at `plan.at` after
    /// the first cyclic SYNC. A node that is not on the bus is ignored.
    pub fn with_fault(self, plan: FaultPlan) -> SimLink {
        self.with_sim_fault(
            plan.at,
            SimFault::Drive {
                node: plan.node,
                kind: FaultKind::Fault(plan.emcy),
            },
        )
    }

    /// Arms `fault` at `at` after the first cyclic SYNC.
    pub fn with_sim_fault(mut self, at: Duration, fault: SimFault) -> SimLink {
        self.bus.schedule(at, fault);
        self
    }

    /// Arms `plan` (see [`SimMachine::arm`]); call before start-up for power-on faults.
    pub fn with_plan(mut self, plan: SimFaultPlan) -> SimLink {
        self.bus.arm(plan);
        self
    }

    /// The simulated bus and its drives.
    pub fn sim_bus(&self) -> &SimBus<SimDrive> {
        self.bus.bus()
    }

    /// The fault injector between the master and the simulated bus (its counters).
    pub fn injector(&self) -> &FaultInjector<SimBus<SimDrive>> {
        &self.bus.bus
    }
}
