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
        // Boot and shutdown (blocking SDO, NMT) may wait for room in the transmit queue;
        // the cyclic phase switches to `send_budget(true)` (see CycleBus::set_cyclic).
        let options = SocketCanOptions {
            send_budget: send_budget(false),
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

    /// The cyclic phase sends with a zero budget: one attempt, never a sleep, so five frames
    /// a cycle cannot block the 1 ms loop; a full queue is `TxQueueFull`, which the master
    /// turns into the bus safety stop.
    fn set_cyclic(&mut self, cyclic: bool) {
        if let Err(e) = self.bus.set_send_budget(send_budget(cyclic)) {
            log::warn!(
                "{}: cannot change the socket's write timeout: {e:?}",
                self.bus.iface()
            );
        }
    }
}

/// How long one send may wait for room in the transmit queue: the socket layer's default
/// (2 ms) while booting or shutting down, zero in the cyclic phase.
pub fn send_budget(cyclic: bool) -> core::time::Duration {
    if cyclic {
        core::time::Duration::ZERO
    } else {
        SocketCanOptions::default().send_budget
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
    fn blocking_sends_inside_the_loop_cyclic_budget_is_zero() {
        assert_eq!(send_budget(true), core::time::Duration::ZERO);
        assert!(send_budget(false) >= core::time::Duration::from_millis(1));
    }

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
