//! The machine on a real CAN interface: [`SocketMachine`] is the drives crate's
//! [`SocketCanBus`] (a kernel CAN_RAW socket, clock CLOCK_MONOTONIC) as a [`CycleBus`], and
//! [`SocketLink`] is the same CANopen master as on the simulator, run over it in real time.
//! Every frame the socket delivers goes to the master: it drains the socket at each cycle, and
//! boot's blocking SDO hands non-SDO frames back to it (`BlockingSdo`'s callback).

use cnc402_config::MachineConfig;

use cnc402_drives::socketcan::{OpenError, SocketCanBus, SocketCanOptions};

use crate::master_link::{CycleBus, LinkTimeouts, MasterLink, forward_timed_bus};

/// A SocketCAN interface with the configured bit rate (the socket cannot tell it: a vcan has
/// none, a real controller's is set with `ip link`).
pub struct SocketMachine {
    bus: SocketCanBus,
    bitrate: u32,
}

/// The CANopen master on a SocketCAN interface.
pub type SocketLink = MasterLink<SocketMachine>;

impl SocketMachine {
    /// Opens `cfg.bus.interface`. A kernel without CAN (errno 97) and a missing interface
    /// are told apart in the error, which says what to do about either.
    pub fn open(cfg: &MachineConfig) -> Result<SocketMachine, OpenError> {
        // Sends during the cyclic phase must not stall the loop: a frame that finds the
        // transmit queue full after 0.5 ms is reported (BusError::TxQueueFull → the master's
        // bus safety stop) rather than waited for.
        let options = SocketCanOptions {
            send_budget: core::time::Duration::from_micros(500),
            ..SocketCanOptions::default()
        };
        let bus = SocketCanBus::open_with(&cfg.bus.interface, options)?;
        Ok(SocketMachine {
            bus,
            bitrate: cfg.bus.bitrate,
        })
    }

    /// The socket.
    pub fn socket(&self) -> &SocketCanBus {
        &self.bus
    }
}

forward_timed_bus!(SocketMachine, bus);

impl CycleBus for SocketMachine {
    /// Nothing to do before a cycle: the drives run on their own, and the master's cycle
    /// takes in everything the socket has received since the last one.
    fn bitrate(&self) -> u32 {
        self.bitrate
    }
}

impl MasterLink<SocketMachine> {
    /// The master on `cfg.bus.interface` with start-up limits `timeouts` (use
    /// [`LinkTimeouts::real_bus`] unless told otherwise).
    pub fn socket(cfg: &MachineConfig, timeouts: LinkTimeouts) -> Result<SocketLink, String> {
        let machine = SocketMachine::open(cfg).map_err(|e| e.to_string())?;
        MasterLink::with_timeouts(cfg, machine, timeouts).map_err(|e| e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn opening_a_missing_interface_says_why() {
        let mut cfg = MachineConfig::default_machine();
        cfg.bus.interface = "nosuchcan9".into();
        let e = match SocketLink::socket(&cfg, LinkTimeouts::real_bus()) {
            Ok(_) => panic!("opened a CAN interface that cannot exist"),
            Err(e) => e,
        };
        // Kernel without CAN (this project's machines) or with CAN but no such interface.
        assert!(
            e.contains("nosuchcan9")
                && (e.contains("no CAN support (AF_CAN, errno 97)")
                    || e.contains("no such interface")),
            "{e}"
        );
    }
}
