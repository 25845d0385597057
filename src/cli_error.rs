//! What can end a `cnc402` command, and the exit code each one maps to.

use std::process::ExitCode;

/// The exit codes, shared with `drivectl` and `simdrive` (docs/exit-codes.md).
pub use cnc402_config::exit;

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
