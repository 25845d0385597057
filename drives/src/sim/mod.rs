//! The simulated CiA 402 servo drive: the same model in-process (attached to
//! [`crate::bus::SimBus`]) and in the `simdrive` process on a real socket. It is driven only
//! by CAN frames and the time passed in.

mod drive;
mod machine;
mod motion;
mod objects;
mod pdo;
mod sdo_server;

pub use drive::{FaultKind, FaultKindError, NmtStatus, SimDrive, SimDriveOptions, SimDriveStats};
pub use machine::{device_of, simulated_machine, simulated_machine_with};
pub use motion::AxisModel;
pub use objects::{PRODUCT_CODE, REVISION, VENDOR_ID, interpolation_period, interpolation_seconds};
pub use sdo_server::{ObjectAccess, SdoServer};
