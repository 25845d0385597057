//! What can end a `cnc402` command, and the exit code each one maps to.

use std::process::ExitCode;

/// Documented exit codes (README.md, "Exit codes").
pub mod exit {
    /// The machine stopped during `run`: a drive fault or safety reaction, or the operator's
    /// SIGINT (Ctrl-C). SIGINT is deliberately 1 and not the shell's 130: it is handled, not
    /// fatal — the path decelerates (a tap stays coupled), every drive gets quick stop, the
    /// drives are disabled and the report is written, exactly as for a fault. Also when the
    /// real-time loop's clock fails ("real-time clock failed: …"; the drives are disabled).
    pub const FAULT: u8 = 1;
    /// Parse, interpreter or planning error.
    pub const PROGRAM: u8 = 2;
    /// The machine config is wrong.
    pub const CONFIG: u8 = 3;
    /// A file cannot be read or written, or the CAN interface cannot be opened (missing
    /// interface; a kernel without AF_CAN, errno 97).
    pub const IO: u8 = 4;
    /// `cnc402 which`: no path passes within `--within` of the point (the message says how
    /// far the nearest is).
    pub const FAR: u8 = 5;
    /// Bad command-line usage.
    pub const USAGE: u8 = 64;
}

#[derive(Debug)]
pub enum CliError {
    /// The NC program is wrong: printed with its location and a caret.
    Program(cnc402_lang::NcError),
    /// The machine config (or `cnc402 pages`' pages file) is wrong.
    Config(cnc402_config::ConfigError),
    /// A file or device could not be used.
    Io(String),
    /// The machine stopped during a run (drive fault, safety reaction, operator stop).
    Fault(String),
    /// A command-line value that clap cannot check by itself.
    Usage(String),
    /// `cnc402 which`: the point is far from every path.
    Far(String),
    /// `cnc402 pages`: a value its field refuses, or the package's alarm with the values
    /// (exit 2, as a wrong program).
    Refused(String),
    /// A block the command line names is not in the program (`--from N…`): exit 2 like a
    /// program error, without a location in it.
    NoSuchBlock(String),
}

impl CliError {
    pub fn report(self) -> ExitCode {
        let (code, report) = match self {
            CliError::Program(e) => (exit::PROGRAM, miette::Report::new(e)),
            CliError::Config(e) => (exit::CONFIG, miette::Report::new(e)),
            CliError::Io(m) => (exit::IO, miette::miette!("{m}")),
            CliError::Fault(m) => (exit::FAULT, miette::miette!("{m}")),
            CliError::Usage(m) => (exit::USAGE, miette::miette!("{m}")),
            CliError::Far(m) => (exit::FAR, miette::miette!("{m}")),
            CliError::Refused(m) => (exit::PROGRAM, miette::miette!("{m}")),
            CliError::NoSuchBlock(m) => (exit::PROGRAM, miette::miette!("{m}")),
        };
        eprintln!("{report:?}");
        ExitCode::from(code)
    }
}
