//! simdrive and the vcan hardware-in-the-loop suite (simdrive: filled in by the SocketCAN issue).
//!
//! `latency` summarises wake-up lateness of periodic loops; `rt` holds the real-time process
//! settings (mlockall, SCHED_FIFO) and the absolute-deadline sleep the HIL binaries share.

pub mod latency;
pub mod rt;
