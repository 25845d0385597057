//! The embedded simulated machine: an in-process [`SimBus`] with one [`SimDrive`] per
//! configured drive node, carrying the same frames a real bus would in virtual time, plus a
//! scheduled drive fault for tests. [`SimLink`] is the master on it.

use core::time::Duration;

use cnc402_config::{MAX_AXES, MachineConfig};
use cnc402_drives::Instant;
use cnc402_drives::bus::SimBus;

use cnc402_drives::sim::{FaultKind, SimDrive, SimDriveOptions};
use cnc402_drives::wire::NodeId;

use crate::link::FaultPlan;
use crate::master_link::{CycleBus, MasterLink, forward_timed_bus};

/// The simulated bus and drives; see the module doc.
pub struct SimMachine {
    bus: SimBus<SimDrive>,
    fault: Option<(FaultPlan, usize)>,
    fault_done: bool,
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
            bus,
            fault: None,
            fault_done: false,
        })
    }

    /// The bus and its drives.
    pub fn bus(&self) -> &SimBus<SimDrive> {
        &self.bus
    }
}

forward_timed_bus!(SimMachine, bus);

impl CycleBus for SimMachine {
    /// Injects the scheduled fault when its time has come, then runs the bus and the drives
    /// up to `t` (delivering the TPDOs that answer the previous SYNC).
    fn before_cycle(&mut self, t: Instant, since_start: Duration) {
        if let Some((plan, dev)) = self.fault
            && !self.fault_done
            && since_start >= plan.at
        {
            self.fault_done = true;
            if let Some(d) = self.bus.device_mut(dev) {
                d.inject(FaultKind::Fault(plan.emcy), t);
            }
        }
        self.bus.advance(t);
    }

    fn bitrate(&self) -> u32 {
        self.bus.bitrate()
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
    pub fn with_fault(mut self, plan: FaultPlan) -> SimLink {
        let dev = self
            .bus
            .bus
            .devices()
            .iter()
            .position(|d| d.node().get() == plan.node);
        self.bus.fault = dev.map(|d| (plan, d));
        self
    }

    /// The simulated bus and its drives.
    pub fn sim_bus(&self) -> &SimBus<SimDrive> {
        &self.bus.bus
    }
}
