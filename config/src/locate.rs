//! Which machine a command runs on. `--config FILE` names it; without it the first file found
//! of `$CNC402_CONFIG`, `./config/machine.toml`, the user's and the system's config folder is
//! read, and with none of them the built-in machine (the shipped config: simulated drives), so
//! an installed `cnc402` works from any folder as it does from the source tree.

use std::ffi::OsString;
use std::path::{Path, PathBuf};

use crate::{ConfigError, DEFAULT_PATH, MachineConfig};

/// The environment variable naming the config file when `--config` is not given.
pub const CONFIG_ENV: &str = "CNC402_CONFIG";

/// Where a command's machine came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ConfigOrigin {
    /// `--config FILE`.
    Given(PathBuf),
    /// `$CNC402_CONFIG`.
    Environment(PathBuf),
    /// A file found at one of the places searched (see [`search_path`]).
    Found(PathBuf),
    /// No file anywhere: the shipped machine built into the binary.
    BuiltIn,
}

/// The files looked for, in order, when neither `--config` nor `$CNC402_CONFIG` is given:
/// `./config/machine.toml`, `$XDG_CONFIG_HOME/cnc402/machine.toml` (else
/// `$HOME/.config/cnc402/machine.toml`), `/etc/cnc402/machine.toml`. `var` reads the
/// environment (passed in so tests need not change the process's).
pub fn search_path(var: &dyn Fn(&str) -> Option<OsString>) -> Vec<PathBuf> {
    let mut paths = vec![PathBuf::from(DEFAULT_PATH)];
    let user = var("XDG_CONFIG_HOME")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .or_else(|| {
            var("HOME")
                .filter(|v| !v.is_empty())
                .map(|h| Path::new(&h).join(".config"))
        });
    if let Some(dir) = user {
        paths.push(dir.join("cnc402").join("machine.toml"));
    }
    paths.push(PathBuf::from("/etc/cnc402/machine.toml"));
    paths
}

/// Which file to read (`None`: the built-in machine), from `--config`, the environment and
/// which of the [`search_path`] files exist. A named file (`--config`, `$CNC402_CONFIG`) is
/// read even when it is missing, so its error says so; only the searched places are skipped.
pub fn choose(
    given: Option<&Path>,
    var: &dyn Fn(&str) -> Option<OsString>,
    exists: &dyn Fn(&Path) -> bool,
) -> ConfigOrigin {
    if let Some(p) = given {
        return ConfigOrigin::Given(p.to_path_buf());
    }
    if let Some(p) = var(CONFIG_ENV).filter(|v| !v.is_empty()) {
        return ConfigOrigin::Environment(PathBuf::from(p));
    }
    search_path(var)
        .into_iter()
        .find(|p| exists(p))
        .map_or(ConfigOrigin::BuiltIn, ConfigOrigin::Found)
}

impl MachineConfig {
    /// The machine of a command line (see the module doc) and where it came from.
    pub fn locate(given: Option<&Path>) -> Result<(MachineConfig, ConfigOrigin), ConfigError> {
        let origin = choose(given, &|k| std::env::var_os(k), &|p| p.is_file());
        let config = match &origin {
            ConfigOrigin::Given(p) | ConfigOrigin::Environment(p) | ConfigOrigin::Found(p) => {
                MachineConfig::load(p)?
            }
            ConfigOrigin::BuiltIn => MachineConfig::built_in(),
        };
        Ok((config, origin))
    }

    /// The shipped machine as a command runs it when no config file is found: the shipped
    /// file's paths point into the source tree (`../examples`, `../var`), which is not there,
    /// so sub-programs are looked up in the working folder, macro variables `#500–#999` live
    /// in memory for the run and `#use` looks only beside the including file.
    pub fn built_in() -> MachineConfig {
        let mut cfg = MachineConfig::default_machine();
        cfg.interp.program_dir = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
        cfg.interp.variables_file = None;
        cfg.interp.library_dir = None;
        cfg
    }
}

impl ConfigOrigin {
    /// A note for stderr when the machine is the built-in one (`None` otherwise): the user
    /// should know no file of theirs was read.
    pub fn note(&self) -> Option<String> {
        (*self == ConfigOrigin::BuiltIn).then(|| {
            format!(
                "note: no machine config (--config, ${CONFIG_ENV}, ./{DEFAULT_PATH}, \
                 ~/.config/cnc402/machine.toml, /etc/cnc402/machine.toml): running on the \
                 built-in machine (the shipped config: simulated drives; macro variables kept \
                 in memory)"
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(pairs: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<OsString> + 'a {
        move |k| {
            pairs
                .iter()
                .find(|(n, _)| *n == k)
                .map(|(_, v)| OsString::from(v))
        }
    }

    #[test]
    fn a_given_file_wins_even_when_missing_so_its_error_is_reported() {
        let o = choose(
            Some(Path::new("nowhere.toml")),
            &env(&[(CONFIG_ENV, "/x.toml")]),
            &|_| false,
        );
        assert_eq!(o, ConfigOrigin::Given("nowhere.toml".into()));
        let err = MachineConfig::locate(Some(Path::new("/nonexistent/cnc402.toml")));
        assert!(err.is_err());
    }

    #[test]
    fn the_environment_comes_before_the_searched_places() {
        let o = choose(None, &env(&[(CONFIG_ENV, "/m.toml")]), &|_| true);
        assert_eq!(o, ConfigOrigin::Environment("/m.toml".into()));
        // An empty variable is no setting.
        let o = choose(None, &env(&[(CONFIG_ENV, "")]), &|_| true);
        assert_eq!(o, ConfigOrigin::Found(DEFAULT_PATH.into()));
    }

    #[test]
    fn searched_in_order_working_folder_user_system_then_built_in() {
        let vars = [("HOME", "/home/op")];
        let want = [
            DEFAULT_PATH,
            "/home/op/.config/cnc402/machine.toml",
            "/etc/cnc402/machine.toml",
        ];
        assert_eq!(
            search_path(&env(&vars)),
            want.iter().map(PathBuf::from).collect::<Vec<_>>()
        );
        let xdg = [("HOME", "/home/op"), ("XDG_CONFIG_HOME", "/cfg")];
        assert_eq!(
            search_path(&env(&xdg))[1],
            PathBuf::from("/cfg/cnc402/machine.toml")
        );
        for (i, p) in want.iter().enumerate() {
            let only = |q: &Path| q == Path::new(p);
            assert_eq!(
                choose(None, &env(&vars), &only),
                ConfigOrigin::Found(p.into()),
                "{i}"
            );
        }
        assert_eq!(choose(None, &env(&vars), &|_| false), ConfigOrigin::BuiltIn);
    }

    #[test]
    fn the_built_in_machine_writes_nothing_into_the_source_trees_places() {
        let cfg = MachineConfig::built_in();
        assert_eq!(cfg.variables_file(), None);
        assert_eq!(cfg.library_dir(), None);
        assert!(cfg.program_dir().is_absolute() || cfg.program_dir() == Path::new("."));
        // The same machine as the shipped file otherwise.
        let shipped = MachineConfig::default_machine();
        assert_eq!(cfg.axes, shipped.axes);
        assert_eq!(cfg.bus, shipped.bus);
        assert!(ConfigOrigin::BuiltIn.note().is_some());
        assert!(ConfigOrigin::Found("a".into()).note().is_none());
    }
}
