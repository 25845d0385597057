//! Why a run could not produce a report: the error every part of a run hands back to
//! `run_program`'s caller.

use cnc402_lang::NcError;

/// Why a run could not produce a report.
#[derive(Debug)]
pub enum RunError {
    /// The program is wrong (found by the dry run, or while running: then the machine was
    /// stopped first).
    Program(NcError),
    /// A file or device could not be used.
    Io(String),
    /// The real-time loop's clock failed (`clock_nanosleep` returned an error other than
    /// EINTR): the run was stopped and the drives disabled. The text says why.
    Clock(String),
}

impl RunError {
    pub(super) fn clock(e: nix::errno::Errno) -> RunError {
        RunError::Clock(format!("real-time clock failed: clock_nanosleep: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::RunError;

    #[test]
    fn a_failing_real_time_clock_says_so() {
        match RunError::clock(nix::errno::Errno::EINVAL) {
            RunError::Clock(m) => {
                assert!(m.starts_with("real-time clock failed: "), "{m}");
                assert!(m.contains("EINVAL"), "{m}");
            }
            other => panic!("{other:?}"),
        }
    }
}
