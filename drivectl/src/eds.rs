//! The vendor EDS/DCF given with `--eds`: read with the reader the master uses
//! (`cnc402_config::eds`: `$NODEID`, `CompactSubObj`, `ParameterValue` over `DefaultValue`);
//! here only loading a file with drivectl's errors.

use std::path::Path;

pub use cnc402_config::eds::{Eds, EdsEntry, NameError, find_object};

use crate::error::{CliError, Exit, Result};

/// Reads and parses a file; errors name the file and line (exit: config).
pub fn load(path: &Path) -> Result<Eds> {
    let bytes = std::fs::read(path).map_err(|e| {
        CliError::new(
            Exit::Config,
            format!("cannot read EDS {}: {e}", path.display()),
        )
    })?;
    // EDS files are often Latin-1: decode lossily rather than refuse them.
    let text = String::from_utf8_lossy(&bytes);
    Eds::parse(&text)
        .map_err(|(line, m)| CliError::new(Exit::Config, format!("{}:{line}: {m}", path.display())))
}
