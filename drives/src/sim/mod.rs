//! The simulated CiA 402 servo drive: the same model in-process (attached to
//! [`crate::bus::SimBus`]) and in the `simdrive` process on a real socket. It is driven only
//! by CAN frames and the time passed in.
//!
//! Hosting drives on any [`crate::bus::CanBus`] (a SocketCAN transport in `simdrive`): feed
//! every received frame to every drive, poll them for their timers, pass the bus as the sink.
//!
//! ```
//! use std::time::Duration;
//! use cnc402_drives::Instant;
//! use cnc402_drives::bus::{CanBus, CanDevice};
//! use cnc402_drives::sim::SimDrive;
//! use cnc402_drives::wire::NodeId;
//!
//! fn host<B: CanBus>(bus: &mut B, drives: &mut [SimDrive], now: Instant) {
//!     // Real transports block here for at most the timeout; virtual ones return at once.
//!     while let Ok(Some(frame)) = bus.recv_timeout(Duration::from_micros(100)) {
//!         for d in drives.iter_mut() {
//!             d.on_frame(&frame, now, bus);
//!         }
//!     }
//!     for d in drives.iter_mut() {
//!         d.poll(now, bus);
//!     }
//! }
//!
//! let cfg = cnc402_config::MachineConfig::default_machine();
//! let mut drives = vec![SimDrive::new(&cfg.axes[0], NodeId::new(1).unwrap(), Duration::from_millis(1))];
//! // A loopback-free bus that only collects what the drives send:
//! let mut sent = cnc402_drives::bus::SimBus::<SimDrive>::new(0);
//! host(&mut sent, &mut drives, Instant::ZERO); // power on
//! host(&mut sent, &mut drives, Instant::from_millis(5)); // booted 1 ms later
//! sent.advance(Instant::from_millis(5));
//! assert_eq!(sent.counters().tx_frames, 1); // the boot-up message
//! ```

mod drive;
mod homing;
mod machine;
mod motion;
mod objects;
mod pdo;
mod sdo_server;

pub use drive::{FaultKind, FaultKindError, NmtStatus, SimDrive, SimDriveOptions, SimDriveStats};
pub use homing::{HomingParams, HomingRun, MachineIo};
pub use machine::{device_of, simulated_machine, simulated_machine_with};
pub use motion::{AxisModel, DriveDynamics};
pub use objects::{PRODUCT_CODE, REVISION, VENDOR_ID, interpolation_period, interpolation_seconds};
pub use sdo_server::{ObjectAccess, SdoServer};
