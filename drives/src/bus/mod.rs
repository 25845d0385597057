//! The bus the master and the devices talk through: the [`CanBus`] trait (non-blocking, object
//! safe, no allocation per call), frame and bit counters for bus load, the in-process
//! [`SimBus`] in virtual time with devices attached, and the [`FaultInjector`] wrapper.
//! A SocketCAN transport implements the same trait (recv with a timeout) elsewhere.

mod fault;
mod sim;

use core::fmt;
use core::time::Duration;

use crate::time::Instant;
use crate::wire::CanFrame;

pub use fault::{Action, Direction, FaultInjector, FaultRule, FrameFilter};
pub use sim::{CanDevice, Origin, SimBus, TraceEntry};

/// Why a frame could not be sent or received.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BusError {
    /// The transmit queue is full (the frame was not queued).
    TxQueueFull,
    /// The controller is bus-off.
    BusOff,
    /// The interface is down or gone.
    Down,
    /// An OS-level I/O error (errno), for real transports.
    Io(i32),
}

impl fmt::Display for BusError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BusError::TxQueueFull => write!(f, "CAN transmit queue full"),
            BusError::BusOff => write!(f, "CAN controller bus-off"),
            BusError::Down => write!(f, "CAN interface down"),
            BusError::Io(e) => write!(f, "CAN I/O error (errno {e})"),
        }
    }
}

impl std::error::Error for BusError {}

/// Frames and bits seen, for bus load.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BusCounters {
    /// Frames sent by this endpoint.
    pub tx_frames: u64,
    /// Frames received by this endpoint.
    pub rx_frames: u64,
    /// Frames on the medium (all senders), where the transport can see them.
    pub bus_frames: u64,
    /// Bits on the medium, worst-case stuffing ([`CanFrame::bits`]).
    pub bus_bits: u64,
    /// Frames dropped by the transport (queue overflow, fault injection).
    pub dropped: u64,
}

impl BusCounters {
    /// Bus load in percent over `elapsed` at `bitrate` bit/s.
    pub fn load_percent(&self, bitrate: u32, elapsed: Duration) -> f64 {
        let capacity = bitrate as f64 * elapsed.as_secs_f64();
        if capacity <= 0.0 {
            0.0
        } else {
            100.0 * self.bus_bits as f64 / capacity
        }
    }
}

/// A CAN endpoint: what the master (and a device host such as `simdrive`) talks through.
///
/// Object safe; no call allocates. `recv` never blocks; a real transport may block up to the
/// given timeout in [`recv_timeout`](Self::recv_timeout).
pub trait CanBus {
    /// Queues a frame for transmission. Never blocks.
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError>;
    /// The next received frame, if any. Never blocks.
    fn recv(&mut self) -> Result<Option<CanFrame>, BusError>;
    /// The next received frame, waiting at most `timeout` on transports with a clock of their
    /// own. Virtual-time transports cannot wait (time belongs to the caller) and return what
    /// [`recv`](Self::recv) returns.
    fn recv_timeout(&mut self, timeout: Duration) -> Result<Option<CanFrame>, BusError> {
        let _ = timeout;
        self.recv()
    }
    /// Counters since creation.
    fn counters(&self) -> BusCounters;
}

/// Forwards every [`CanBus`] method through a pointer type to the bus it points at.
macro_rules! forward_can_bus {
    ($(#[$doc:meta])* $pointer:ty) => {
        $(#[$doc])*
        impl<B: CanBus + ?Sized> CanBus for $pointer {
            fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
                (**self).send(frame)
            }
            fn recv(&mut self) -> Result<Option<CanFrame>, BusError> {
                (**self).recv()
            }
            fn recv_timeout(&mut self, timeout: Duration) -> Result<Option<CanFrame>, BusError> {
                (**self).recv_timeout(timeout)
            }
            fn counters(&self) -> BusCounters {
                (**self).counters()
            }
        }
    };
}

forward_can_bus!(&mut B);
forward_can_bus!(
    /// A boxed transport (e.g. chosen at run time: SocketCAN or simulated) is a bus too, and so
    /// a [`FrameSink`] for devices (`&mut dyn CanBus` itself cannot be turned into one).
    Box<B>
);

/// Where a device puts the frames it transmits: the simulated bus, or a real socket in the
/// `simdrive` process (every [`CanBus`] is one).
pub trait FrameSink {
    /// Transmits a frame at time `now`.
    fn transmit(&mut self, frame: &CanFrame, now: Instant) -> Result<(), BusError>;
}

impl<B: CanBus + ?Sized> FrameSink for B {
    fn transmit(&mut self, frame: &CanFrame, _now: Instant) -> Result<(), BusError> {
        self.send(frame)
    }
}

/// A sink that collects frames into a vector (tests, or a host that batches).
impl FrameSink for Vec<CanFrame> {
    fn transmit(&mut self, frame: &CanFrame, _now: Instant) -> Result<(), BusError> {
        self.push(*frame);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::sim::CanDevice;

    struct Hello;
    impl CanDevice for Hello {
        fn on_frame(&mut self, _: &CanFrame, _: Instant, _: &mut dyn FrameSink) {}
        fn poll(&mut self, now: Instant, tx: &mut dyn FrameSink) {
            tx.transmit(&CanFrame::new(0x123, &[1]).unwrap(), now)
                .unwrap();
        }
    }

    #[test]
    fn boxed_bus_and_vec_are_sinks() {
        let mut boxed: Box<dyn CanBus> = Box::new(SimBus::<Hello>::new(0));
        Hello.poll(Instant::ZERO, &mut boxed);
        assert_eq!(boxed.counters().tx_frames, 1);
        let mut v: Vec<CanFrame> = Vec::new();
        Hello.poll(Instant::ZERO, &mut v);
        assert_eq!(v.len(), 1);
    }
}
