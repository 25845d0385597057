//! How the master's blocking helpers (boot, blocking SDO, disable) let time pass: a
//! [`TimedBus`] is a [`CanBus`] that knows the time and can wait for a frame up to a deadline.
//! The simulated bus advances its virtual time; a SocketCAN transport reads `CLOCK_MONOTONIC`
//! at its own edge. The master itself never reads a clock.

use core::time::Duration;

use crate::bus::{BusError, CanBus, CanDevice, FaultInjector, SimBus};
use crate::time::Instant;
use crate::wire::CanFrame;

/// A bus with a clock: used only outside the cyclic path (boot, SDO, disable).
pub trait TimedBus: CanBus {
    /// The current time on this bus's clock.
    fn now(&self) -> Instant;
    /// The next received frame; waits (or lets virtual time pass) no later than `deadline`.
    /// `Ok(None)` means the deadline was reached without a frame; [`now`](Self::now) is then
    /// at or after `deadline`.
    fn recv_until(&mut self, deadline: Instant) -> Result<Option<CanFrame>, BusError>;
}

/// Virtual time advances in steps of this size while a blocking helper waits, so replies
/// arrive at their true bus time (an 8-byte frame takes 135 µs at 1 Mbit/s).
pub const SIM_WAIT_STEP: Duration = Duration::from_micros(50);

impl<D: CanDevice> TimedBus for SimBus<D> {
    fn now(&self) -> Instant {
        SimBus::now(self)
    }
    fn recv_until(&mut self, deadline: Instant) -> Result<Option<CanFrame>, BusError> {
        loop {
            if let Some(f) = self.recv()? {
                return Ok(Some(f));
            }
            let now = SimBus::now(self);
            if now >= deadline {
                return Ok(None);
            }
            self.advance((now + SIM_WAIT_STEP).min(deadline));
        }
    }
}

impl<D: CanDevice> TimedBus for FaultInjector<SimBus<D>> {
    fn now(&self) -> Instant {
        self.inner().now()
    }
    fn recv_until(&mut self, deadline: Instant) -> Result<Option<CanFrame>, BusError> {
        loop {
            if let Some(f) = self.recv()? {
                return Ok(Some(f));
            }
            let now = self.inner().now();
            if now >= deadline {
                return Ok(None);
            }
            let next = (now + SIM_WAIT_STEP).min(deadline);
            self.set_now(next)?;
            self.inner_mut().advance(next);
        }
    }
}

impl<B: TimedBus + ?Sized> TimedBus for &mut B {
    fn now(&self) -> Instant {
        (**self).now()
    }
    fn recv_until(&mut self, deadline: Instant) -> Result<Option<CanFrame>, BusError> {
        (**self).recv_until(deadline)
    }
}
