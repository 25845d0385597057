//! `cnc402 vars`: list, set and clear the non-volatile macro variables `#500–#999` kept in
//! `interp.variables_file`, so that an operator fills parameter pages (source 001) without a
//! program. Every change is a locked read-modify-write of the file, durable and merged with
//! other writers such as a running program (see `cnc402_interp::nvfile`).

use std::path::{Path, PathBuf};

use cnc402_interp::nvfile::{self, NV_FIRST, NV_LAST, NvTable};

use crate::cli_error::CliError;

/// What `cnc402 vars` does.
#[derive(clap::Subcommand, Debug, Clone)]
pub enum VarsCommand {
    /// Print every set variable, one `#n = value` a line (the default).
    List,
    /// Set variables: `520=3 521=800 #522=150`; `520=` makes #520 vacant.
    Set {
        #[arg(required = true, value_name = "N=VALUE")]
        assignments: Vec<String>,
    },
    /// Make variables vacant: all of them, `N`, or the range `N..M`.
    Clear {
        #[arg(value_name = "N..M")]
        range: Option<String>,
    },
}

/// Runs `cnc402 vars`; `file` overrides the config's `interp.variables_file`.
pub fn vars(
    cfg: &cnc402_config::MachineConfig,
    file: Option<PathBuf>,
    cmd: Option<VarsCommand>,
) -> Result<(), CliError> {
    let path = file.or_else(|| cfg.variables_file()).ok_or_else(|| {
        CliError::Usage(
            "no variables file: set interp.variables_file in the machine config or pass --file"
                .into(),
        )
    })?;
    let io = |e: nvfile::VarFileError| match e {
        nvfile::VarFileError::NotNonVolatile(_) => CliError::Usage(e.to_string()),
        _ => CliError::Io(e.to_string()),
    };
    let table = match cmd.unwrap_or(VarsCommand::List) {
        VarsCommand::List => NvTable::load(&path).map_err(io)?,
        VarsCommand::Set { assignments } => {
            let sets = assignments
                .iter()
                .map(|a| parse_assignment(a))
                .collect::<Result<Vec<_>, _>>()
                .map_err(CliError::Usage)?;
            ensure_dir(&path)?;
            nvfile::set_vars(&path, &sets).map_err(io)?
        }
        VarsCommand::Clear { range } => {
            let (from, to) = match range {
                None => (NV_FIRST, NV_LAST),
                Some(r) => parse_range(&r).map_err(CliError::Usage)?,
            };
            ensure_dir(&path)?;
            nvfile::clear_vars(&path, from, to).map_err(io)?
        }
    };
    print!("{}", listing(&table));
    Ok(())
}

fn ensure_dir(path: &Path) -> Result<(), CliError> {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => {
            std::fs::create_dir_all(d).map_err(|e| CliError::Io(format!("{}: {e}", d.display())))
        }
        _ => Ok(()),
    }
}

/// `#520 = 3` lines of the set variables.
pub fn listing(t: &NvTable) -> String {
    t.iter().map(|(n, v)| format!("#{n} = {v}\n")).collect()
}

/// `520=3`, `#520=3.5`, `520=` (vacant).
pub fn parse_assignment(s: &str) -> Result<(u32, Option<f64>), String> {
    let bad = || format!("{s:?}: expected N=VALUE such as 520=3 (N in {NV_FIRST}..{NV_LAST})");
    let (n, v) = s.split_once('=').ok_or_else(bad)?;
    let n = parse_number(n).ok_or_else(bad)?;
    let v = v.trim();
    let v = if v.is_empty() {
        None
    } else {
        let x: f64 = v.parse().map_err(|_| bad())?;
        if !x.is_finite() {
            return Err(bad());
        }
        Some(x)
    };
    Ok((n, v))
}

fn parse_number(s: &str) -> Option<u32> {
    let s = s.trim();
    let s = s.strip_prefix('#').unwrap_or(s);
    let n: u32 = s.parse().ok()?;
    (NV_FIRST..=NV_LAST).contains(&n).then_some(n)
}

/// `N` or `N..M` (inclusive), both in 500..999.
pub fn parse_range(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("{s:?}: expected N or N..M with {NV_FIRST} <= N <= M <= {NV_LAST}");
    let (a, b) = match s.split_once("..") {
        Some((a, b)) => (a, b),
        None => (s, s),
    };
    let a = parse_number(a).ok_or_else(bad)?;
    let b = parse_number(b).ok_or_else(bad)?;
    if a > b {
        return Err(bad());
    }
    Ok((a, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn assignments_and_ranges() {
        assert_eq!(parse_assignment("520=3"), Ok((520, Some(3.0))));
        assert_eq!(parse_assignment("#521=-0.5"), Ok((521, Some(-0.5))));
        assert_eq!(parse_assignment("522="), Ok((522, None)));
        for bad in ["520", "499=1", "1000=1", "520=x", "520=inf", "=3"] {
            assert!(parse_assignment(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_range("500..510"), Ok((500, 510)));
        assert_eq!(parse_range("#530"), Ok((530, 530)));
        assert!(parse_range("510..500").is_err());
        assert!(parse_range("400..510").is_err());
    }
}
