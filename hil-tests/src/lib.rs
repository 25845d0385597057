//! simdrive and the vcan hardware-in-the-loop suite.
//!
//! `latency` summarises wake-up lateness of periodic loops; `rt` holds the real-time process
//! settings (mlockall, SCHED_FIFO) and the absolute-deadline sleep the HIL binaries share;
//! `simdrive` hosts simulated drives on a bus and reports what it saw (Z+C coupling
//! from drive counts, with `cnc402_drives::coupling::CouplingChecker`, the checker `cnc402 run`
//! uses); `check` evaluates the assertions of `hilcheck` on JSON reports.

pub mod check;
pub mod latency;
pub mod rt;
pub mod simdrive;
