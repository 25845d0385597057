//! Shared rig for the master tests: the shipped machine's drives as `SimDrive`s on a
//! `SimBus` in virtual time, and a `Master` for the same config.
#![allow(dead_code)]

use std::time::Duration;

use cnc402_config::MachineConfig;
use cnc402_drives::Instant;
use cnc402_drives::bus::{CanBus, SimBus};
use cnc402_drives::master::{BootReport, Feedback, Master, MasterOptions, SafetyStop};
use cnc402_drives::sim::{FaultKind, SimDrive, SimDriveOptions};
use cnc402_drives::wire::NodeId;

pub struct Rig {
    pub config: MachineConfig,
    pub bus: SimBus<SimDrive>,
    pub master: Master,
    /// Time of the next cycle.
    pub next: Instant,
}

impl Rig {
    /// The shipped machine; `options(axis_index)` sets each drive's start options.
    pub fn new(options: impl Fn(usize) -> SimDriveOptions) -> Rig {
        Rig::with_config(
            MachineConfig::default_machine(),
            options,
            MasterOptions::default(),
        )
    }

    pub fn with_config(
        config: MachineConfig,
        options: impl Fn(usize) -> SimDriveOptions,
        master_options: MasterOptions,
    ) -> Rig {
        let period = Duration::from_micros(config.bus.period_us as u64);
        let mut bus = SimBus::new(config.bus.bitrate);
        for (i, a) in config.axes.iter().enumerate() {
            if let Some(n) = a.node {
                let node = NodeId::new(n).unwrap();
                bus.attach(SimDrive::with_options(a, node, period, options(i)));
            }
        }
        let master = Master::with_options(&config, master_options).unwrap();
        Rig {
            config,
            bus,
            master,
            next: Instant::ZERO,
        }
    }

    pub fn boot(&mut self) -> BootReport {
        let r = self
            .master
            .boot(&mut self.bus)
            .unwrap_or_else(|e| panic!("boot: {e}"));
        self.next = r.enabled_at + self.master.period();
        r
    }

    /// The SimDrive of axis `i` (drives are attached in config order).
    pub fn drive(&self, i: usize) -> &SimDrive {
        let n = self.config.axes[i].node.unwrap();
        self.bus
            .devices()
            .iter()
            .find(|d| d.node().get() == n)
            .unwrap()
    }

    pub fn inject(&mut self, axis: usize, kind: FaultKind) {
        let n = self.config.axes[axis].node.unwrap();
        let now = self.bus.now();
        let d = (0..self.bus.devices().len())
            .find(|&k| self.bus.device(k).unwrap().node().get() == n)
            .unwrap();
        self.bus.device_mut(d).unwrap().inject(kind, now);
    }

    /// Clears every condition injected into axis `axis`'s drive.
    pub fn clear_injected(&mut self, axis: usize) {
        let n = self.config.axes[axis].node.unwrap();
        let d = (0..self.bus.devices().len())
            .find(|&k| self.bus.device(k).unwrap().node().get() == n)
            .unwrap();
        self.bus.device_mut(d).unwrap().clear_injected();
    }

    /// Advances the bus to the next cycle time and runs one master cycle there.
    pub fn cycle(&mut self, commands: &[f64]) -> Result<Feedback, SafetyStop> {
        self.bus.advance(self.next);
        let r = self.master.cycle(&mut self.bus, self.next, commands);
        self.next += self.master.period();
        r
    }

    /// Lets the drives power on and boot (10 ms of bus time in 1 ms steps).
    pub fn power_on(&mut self) {
        for ms in 0..=10 {
            self.bus.advance(Instant::from_millis(ms));
        }
        while self.bus.recv().unwrap().is_some() {}
    }

    pub fn axes(&self) -> usize {
        self.config.axes.len()
    }
}
