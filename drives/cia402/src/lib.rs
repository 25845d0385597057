//! The CiA 402 drive profile as plain data and logic: controlword and statusword with named
//! bits, the eight power states, operation modes, object indices, and the state machine seen
//! from both sides — the device ([`DeviceStateMachine`]) and the master ([`EnableSequencer`]).
//! No I/O, no clock, no allocation: time and words are passed in.

#![forbid(unsafe_code)]

pub(crate) mod device;
pub mod homing;
mod mode;
pub mod objects;
mod sequencer;
mod state;
mod words;

pub use device::{DeviceStateMachine, Transition};
pub use homing::{Direction, HomingMethod, HomingStatus, HomingTarget};
pub use mode::{OperationMode, QuickStopOption};
pub use sequencer::{EnableSequencer, Goal, Progress, Step, Stuck, StuckReason};
pub use state::{Command, State};
pub use words::{Controlword, Statusword};
