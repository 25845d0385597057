//! Shared rigs for the master tests: the shipped machine's drives as `SimDrive`s on a
//! `SimBus` in virtual time and a `Master` for the same config ([`Rig`]), the same behind a
//! `FaultInjector` ([`FaultRig`]), and the small helpers the tests share.
#![allow(dead_code)]

use std::time::Duration;

use cnc402_config::MachineConfig;
use cnc402_drives::Instant;
use cnc402_drives::bus::{CanBus, FaultInjector, FaultRule, FrameFilter, SimBus};
use cnc402_drives::master::{BootReport, Feedback, Master, MasterOptions, SafetyStop};
use cnc402_drives::sim::{FaultKind, SimDrive, SimDriveOptions};
use cnc402_drives::wire::{Function, NodeId};

/// The config's drives (axes with a node) on a simulated bus, each started with
/// `options(axis_index)`.
pub fn sim_bus(
    config: &MachineConfig,
    options: impl Fn(usize) -> SimDriveOptions,
) -> SimBus<SimDrive> {
    let period = Duration::from_micros(config.bus.period_us as u64);
    let mut bus = SimBus::new(config.bus.bitrate);
    for (i, a) in config.axes.iter().enumerate() {
        if let Some(n) = a.node {
            let node = NodeId::new(n).unwrap();
            bus.attach(SimDrive::with_options(a, node, period, options(i)));
        }
    }
    bus
}

/// The shipped machine with another cycle period.
pub fn machine_at_period_us(period_us: u32) -> MachineConfig {
    let mut config = MachineConfig::default_machine();
    config.bus.period_us = period_us;
    config
}

pub fn smoothstep(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    u * u * (3.0 - 2.0 * u)
}

/// The TPDO1s of drive `node`.
pub fn tpdo_of(node: u8) -> FrameFilter {
    FrameFilter::function(Function::Tpdo(1, NodeId::new(node).unwrap()))
}

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
        let bus = sim_bus(&config, options);
        let master = Master::with_options(&config, master_options).unwrap();
        Rig {
            config,
            bus,
            master,
            next: Instant::ZERO,
        }
    }

    /// `config` with default drive and master options (not booted).
    pub fn for_machine(config: MachineConfig) -> Rig {
        Rig::with_config(
            config,
            |_| SimDriveOptions::default(),
            MasterOptions::default(),
        )
    }

    /// The shipped machine with default options, booted.
    pub fn booted() -> Rig {
        Rig::booted_for(MachineConfig::default_machine())
    }

    /// `config` with default drive and master options, booted.
    pub fn booted_for(config: MachineConfig) -> Rig {
        let mut rig = Rig::for_machine(config);
        rig.boot();
        rig
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

/// A booted master for `config` whose drives (default options) sit behind a
/// `FaultInjector` with the given rules.
pub struct FaultRig {
    pub bus: FaultInjector<SimBus<SimDrive>>,
    pub master: Master,
    /// Time of the next cycle.
    pub next: Instant,
}

impl FaultRig {
    pub fn booted(config: &MachineConfig, rules: &[FaultRule]) -> FaultRig {
        let mut bus = FaultInjector::new(sim_bus(config, |_| SimDriveOptions::default()));
        for r in rules {
            bus.add_rule(*r);
        }
        let mut master = Master::new(config).unwrap();
        let report = master
            .boot(&mut bus)
            .unwrap_or_else(|e| panic!("boot: {e}"));
        FaultRig {
            bus,
            next: report.enabled_at + master.period(),
            master,
        }
    }

    /// Advances the bus to the next cycle time and runs one master cycle there.
    pub fn cycle(&mut self, commands: &[f64]) -> Result<Feedback, SafetyStop> {
        self.bus.set_now(self.next).unwrap();
        self.bus.inner_mut().advance(self.next);
        let r = self.master.cycle(&mut self.bus, self.next, commands);
        self.next += self.master.period();
        r
    }
}

/// A [`FaultRig`] running a test's motion: the commanded positions (from the boot
/// positions on), the cycles run, and `M`, the motion's own state. The test file gives it
/// its `cycle`.
pub struct MovingRig<M> {
    pub base: FaultRig,
    pub pos: [f64; 4],
    pub k: u64,
    pub motion: M,
}

impl<M> MovingRig<M> {
    pub fn booted_with(config: &MachineConfig, rules: &[FaultRule], motion: M) -> MovingRig<M> {
        let base = FaultRig::booted(config, rules);
        let pos = base.master.positions();
        MovingRig {
            base,
            pos: [pos[0], pos[1], pos[2], pos[3]],
            k: 0,
            motion,
        }
    }
}

impl<M> std::ops::Deref for MovingRig<M> {
    type Target = FaultRig;
    fn deref(&self) -> &FaultRig {
        &self.base
    }
}

impl<M> std::ops::DerefMut for MovingRig<M> {
    fn deref_mut(&mut self) -> &mut FaultRig {
        &mut self.base
    }
}
