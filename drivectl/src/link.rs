//! The bus drivectl talks on: a SocketCAN interface, or the embedded simulator (a
//! [`SimBus`] with one [`SimDrive`] per configured axis) whose virtual time advances while a
//! command waits — one-shot commands have no background loop, so waiting *is* simulating.

use core::time::Duration;

use cia402::Goal;
use cnc402_config::MachineConfig;
use cnc402_drives::Instant;
use cnc402_drives::bus::{BusCounters, BusError, CanBus, SimBus};
use cnc402_drives::master::{BlockingSdo, TimedBus, sequence_over_sdo};
use cnc402_drives::sim::{FaultKind, SimDrive, device_of, simulated_machine};
use cnc402_drives::socketcan::{OpenError, SocketCanBus};
use cnc402_drives::wire::{CanFrame, NodeId};

use crate::error::{CliError, Exit, Result};

/// Time the simulated drives get after power-on before a command starts (they boot 1 ms
/// after power-on and send their boot-up message).
pub const SIM_POWER_ON: Duration = Duration::from_millis(10);

/// A prepared condition of the embedded simulator (`--sim-setup`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SimSetup {
    /// Inject a fault (`fault:NODE[:CODE]`, `fault-persistent:NODE[:CODE]`, `sdo:NODE`,
    /// `heartbeat:NODE`, `tpdo:NODE`).
    Inject(u8, FaultKind),
    /// Take the drive to OPERATION ENABLED before the command (`enable:NODE`).
    Enable(u8),
}

impl core::str::FromStr for SimSetup {
    type Err = String;
    /// `enable:3`, `fault:2`, `fault:2:0x7300`, `fault-persistent:2:0x2310`, `sdo:2`.
    fn from_str(s: &str) -> core::result::Result<SimSetup, String> {
        let mut parts = s.splitn(3, ':');
        let kind = parts.next().unwrap_or("");
        let node: u8 = parts
            .next()
            .and_then(|n| n.trim().parse().ok())
            .filter(|n| (1..=127).contains(n))
            .ok_or_else(|| format!("`{s}`: expected ACTION:NODE[:CODE] with NODE 1..127"))?;
        let code = parts.next();
        if kind == "enable" {
            return Ok(SimSetup::Enable(node));
        }
        let fk = match code {
            Some(c) => format!("{kind}:{c}"),
            None => kind.to_string(),
        };
        let fault: FaultKind = fk.parse().map_err(|e| format!("`{s}`: {e}"))?;
        Ok(SimSetup::Inject(node, fault))
    }
}

/// The bus: a real interface or the simulator.
pub enum Link {
    /// `--iface sim`.
    Sim(Box<SimBus<SimDrive>>),
    /// A SocketCAN interface.
    Socket(SocketCanBus),
}

impl Link {
    /// Opens `iface` (`sim` = the embedded simulator built from `cfg`).
    pub fn open(iface: &str, cfg: &MachineConfig, setup: &[SimSetup]) -> Result<Link> {
        if iface == "sim" {
            let mut bus = Box::new(simulated_machine(cfg));
            // Power on at 0 (the first poll), boot-ups sent 1 ms later and on the wire well
            // before the command starts.
            bus.advance(Instant::ZERO);
            bus.advance(Instant::from_millis(2));
            bus.advance(Instant::ZERO + SIM_POWER_ON);
            let mut link = Link::Sim(bus);
            for s in setup {
                link.apply_setup(*s)?;
            }
            return Ok(link);
        }
        if !setup.is_empty() {
            return Err(CliError::usage(
                "--sim-setup only applies to --iface sim (the embedded simulator)",
            ));
        }
        SocketCanBus::open(iface).map(Link::Socket).map_err(|e| {
            let exit = match e {
                OpenError::NoCanSupport { .. } | OpenError::NoSuchInterface { .. } => Exit::Bus,
                OpenError::Io { .. } => Exit::Bus,
            };
            CliError::new(exit, e.to_string())
        })
    }

    /// The interface name (`sim` for the simulator).
    pub fn name(&self) -> &str {
        match self {
            Link::Sim(_) => "sim",
            Link::Socket(s) => s.iface(),
        }
    }

    /// The simulated bus, if this is the simulator.
    pub fn sim(&mut self) -> Option<&mut SimBus<SimDrive>> {
        match self {
            Link::Sim(b) => Some(b),
            Link::Socket(_) => None,
        }
    }

    /// Lets time pass until `t` without taking frames (they stay queued): the simulator
    /// advances, a real bus sleeps.
    pub fn pass_until(&mut self, t: Instant) {
        match self {
            Link::Sim(b) => b.advance(t),
            Link::Socket(s) => {
                let now = TimedBus::now(s);
                if t > now {
                    std::thread::sleep(t - now);
                }
            }
        }
    }

    fn apply_setup(&mut self, s: SimSetup) -> Result<()> {
        let Link::Sim(bus) = self else {
            return Ok(());
        };
        let node_of = |n: u8| NodeId::new(n).map_err(|e| CliError::usage(e.to_string()));
        match s {
            SimSetup::Inject(n, kind) => {
                let node = node_of(n)?;
                let now = bus.now();
                let dev = device_of(bus, node).ok_or_else(|| {
                    CliError::usage(format!("--sim-setup: no simulated drive has node {n}"))
                })?;
                if let Some(d) = bus.device_mut(dev) {
                    d.inject(kind, now);
                }
                bus.advance(now + Duration::from_millis(5));
            }
            SimSetup::Enable(n) => {
                let node = node_of(n)?;
                let mut sink = |_: &CanFrame| {};
                let mut sdo = BlockingSdo::new(&mut **bus, Duration::from_millis(100), &mut sink);
                sequence_over_sdo(
                    &mut sdo,
                    node,
                    Goal::OperationEnabled,
                    Duration::from_millis(2),
                    Duration::from_secs(1),
                    &mut |_, _| {},
                )
                .map_err(|e| CliError::from(e).context("--sim-setup enable"))?;
            }
        }
        Ok(())
    }
}

impl CanBus for Link {
    fn send(&mut self, frame: &CanFrame) -> core::result::Result<(), BusError> {
        match self {
            Link::Sim(b) => b.send(frame),
            Link::Socket(s) => s.send(frame),
        }
    }
    fn recv(&mut self) -> core::result::Result<Option<CanFrame>, BusError> {
        match self {
            Link::Sim(b) => b.recv(),
            Link::Socket(s) => s.recv(),
        }
    }
    fn recv_timeout(&mut self, t: Duration) -> core::result::Result<Option<CanFrame>, BusError> {
        match self {
            Link::Sim(b) => {
                let deadline = b.now() + t;
                b.recv_until(deadline)
            }
            Link::Socket(s) => s.recv_timeout(t),
        }
    }
    fn counters(&self) -> BusCounters {
        match self {
            Link::Sim(b) => b.counters(),
            Link::Socket(s) => s.counters(),
        }
    }
}

impl TimedBus for Link {
    fn now(&self) -> Instant {
        match self {
            Link::Sim(b) => b.now(),
            Link::Socket(s) => TimedBus::now(s),
        }
    }
    fn recv_until(
        &mut self,
        deadline: Instant,
    ) -> core::result::Result<Option<CanFrame>, BusError> {
        match self {
            Link::Sim(b) => b.recv_until(deadline),
            Link::Socket(s) => s.recv_until(deadline),
        }
    }
}
