//! cnc402-drives: CAN frames and CANopen messages (`wire`), the bus abstraction with an
//! in-process simulated bus and a fault injector (`bus`), a small object dictionary (`od`),
//! the simulated CiA 402 drive (`sim`), the CANopen master (`master`) and the rigid-tapping
//! coupling checker (`coupling`). Time is always passed in ([`time::Instant`]).

#![forbid(unsafe_code)]

pub mod bus;
pub mod coupling;
pub mod master;
pub mod od;
pub mod sim;
#[cfg(target_os = "linux")]
pub mod socketcan;
pub mod stats;
pub mod time;
pub mod wire;

pub use time::Instant;
