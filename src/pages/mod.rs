//! `cnc402 pages`: the parameter pages of a macro package (source 001) as an operator screen
//! and as a scriptable check. The pages come from a description file next to the programs
//! (`spec`), values are refused at the field with the reason (`state`), saved to the
//! non-volatile variables file through `nvfile`, previewed by dry-running the package
//! (`preview`), and start runs its main program through `cnc402 run`'s own code path.

mod preview;
mod screen;
pub mod spec;
mod state;

use std::io::IsTerminal;
use std::path::PathBuf;

use cnc402_config::MachineConfig;
use cnc402_interp::nvfile::{self, NvTable};

use crate::cli_error::CliError;
use spec::Spec;
use state::{PagesState, Store};

/// `cnc402 pages`: the run options are `cnc402 run`'s own (flattened, so `--start` takes
/// every option `run` takes); the positional program is the pages file, and run's `--plot`
/// is `--run-plot` because `--plot` here is the preview.
#[derive(clap::Args, Debug)]
#[command(mut_arg("program", |a| a
    .required(false)
    .default_value("pages.toml")
    .value_name("PAGES.toml")
    .help("The macro package's pages file; a bare name not in the working directory is \
           looked up in interp.program_dir")))]
#[command(mut_arg("plot", |a| a
    .long("run-plot")
    .help("With --start or F8: the run's plot (Z and C against time), as `cnc402 run --plot`")))]
pub struct PagesArgs {
    #[command(flatten)]
    pub run: crate::RunArgs,
    /// Set a field by name or variable number (`pattern=circle`, `holes=6`, `530=3`; an
    /// empty value makes it vacant). Without --check or --start: saved, then exit.
    #[arg(long = "set", value_name = "FIELD=VALUE")]
    pub sets: Vec<String>,
    /// Fill every vacant field that has a default with it (before --set).
    #[arg(long)]
    pub defaults: bool,
    /// Validate every shown field and dry-run the package, print the holes; save nothing.
    /// Exit 0 if all is well, 2 naming the field or the package's alarm.
    #[arg(long, conflicts_with = "start")]
    pub check: bool,
    /// Validate and dry-run as --check, save, then run the package's main program exactly
    /// as `cnc402 run` does (same options).
    #[arg(long)]
    pub start: bool,
    /// Write the preview (the holes the values produce) as SVG.
    #[arg(long = "plot", value_name = "FILE.svg")]
    pub preview_plot: Option<PathBuf>,
}

/// The variables file behind `save`: one locked, durable read-modify-write per save
/// (`nvfile::set_vars`, the machinery of `cnc402 vars set`).
struct FileStore {
    path: PathBuf,
    saves: u32,
}

impl FileStore {
    fn save_all(&mut self, sets: &[(u32, Option<f64>)]) -> Result<(), String> {
        if sets.is_empty() {
            return Ok(());
        }
        nvfile::set_vars(&self.path, sets).map_err(|e| e.to_string())?;
        self.saves += 1;
        test_pause_after_save(self.saves);
        Ok(())
    }
}

impl Store for FileStore {
    fn save(&mut self, var: u32, value: Option<f64>) -> Result<(), String> {
        self.save_all(&[(var, value)])
    }
}

/// Test hook for the power-cut test (tests/pages_cli.rs): with
/// `CNC402_TEST_PAGES_PAUSE=FILE`, after the first save the process writes its pid to FILE
/// and sleeps 30 s, so the test can kill it between two saves.
fn test_pause_after_save(saves: u32) {
    let Some(marker) = std::env::var_os("CNC402_TEST_PAGES_PAUSE") else {
        return;
    };
    if saves == 1 && std::fs::write(&marker, std::process::id().to_string()).is_ok() {
        std::thread::sleep(std::time::Duration::from_secs(30));
    }
}

/// Runs `cnc402 pages`.
pub fn pages(cfg: &MachineConfig, mut args: PagesArgs) -> Result<(), CliError> {
    let pages_path = pages_file(cfg, &args.run.program);
    let spec = Spec::load(&pages_path).map_err(CliError::Config)?;
    let vars_path = cfg.variables_file().ok_or_else(|| {
        CliError::Usage("no variables file: set interp.variables_file in the machine config".into())
    })?;
    let file = NvTable::load(&vars_path).map_err(|e| CliError::Io(e.to_string()))?;
    let mut state = PagesState::new(spec, |n| file.get(n));
    let mut store = FileStore {
        path: vars_path,
        saves: 0,
    };
    let sets = assignments(&mut state, &args)?;
    let title = format!("{} ({})", state.spec.name, pages_path.display());
    let main = state.spec.main.clone();
    if !args.check && !args.start && args.sets.is_empty() && !args.defaults {
        if !std::io::stdout().is_terminal() || !std::io::stdin().is_terminal() {
            return Err(CliError::Usage(
                "the pages screen needs a terminal; in scripts use --set, --check or --start"
                    .into(),
            ));
        }
        let started = screen::run_screen(cfg, &mut state, &mut store, &file)?;
        if let Some(p) = &args.preview_plot {
            let preview = preview::of_pages(cfg, &state, &file)?;
            preview::write_svg(p, &preview, &title)?;
        }
        if !started {
            return Ok(());
        }
        args.run.program = main;
        return crate::run::run(cfg, &args.run);
    }
    let preview = preview::of_pages(cfg, &state, &file)?;
    if let Some(p) = &args.preview_plot {
        preview::write_svg(p, &preview, &title)?;
    }
    let problem = state.first_problem().map(|(i, why)| {
        let f = &state.spec.fields[i];
        format!("field `{}` (#{}, {}): {why}", f.name, f.var, f.label)
    });
    if !args.check && !args.start {
        store.save_all(&sets).map_err(CliError::Io)?;
        print!("{}", listing(&state));
        print!("{}", preview::text(&preview));
        for w in problem.iter().chain(preview.alarm.iter()) {
            eprintln!("warning: saved, but {w}");
        }
        return Ok(());
    }
    print!("{}", preview::text(&preview));
    if let Some(p) = problem {
        return Err(CliError::Refused(p));
    }
    if let Some(a) = &preview.alarm {
        return Err(CliError::Refused(format!(
            "the package stops with these values: {a}"
        )));
    }
    if args.check {
        return Ok(());
    }
    store.save_all(&sets).map_err(CliError::Io)?;
    args.run.program = main;
    crate::run::run(cfg, &args.run)
}

/// The pages file: as given, or a bare name not in the working directory from the program
/// folder (as a bare program name's sub-programs are found).
fn pages_file(cfg: &MachineConfig, given: &std::path::Path) -> PathBuf {
    let bare = given.components().count() == 1 && given.is_relative();
    if bare && !given.exists() {
        cfg.program_dir().join(given)
    } else {
        given.to_path_buf()
    }
}

/// `--defaults` and `--set` applied to the state (in memory), each value checked at its
/// field: the variables to save. A bad value is refused naming the field (exit 2); an unknown
/// field or a malformed assignment is a usage error.
fn assignments(
    state: &mut PagesState,
    args: &PagesArgs,
) -> Result<Vec<(u32, Option<f64>)>, CliError> {
    let mut sets: Vec<(u32, Option<f64>)> = Vec::new();
    let mut put = |state: &mut PagesState, i: usize, v: Option<f64>| {
        state.values[i] = v;
        let var = state.spec.fields[i].var;
        sets.retain(|s| s.0 != var);
        sets.push((var, v));
    };
    if args.defaults {
        for i in 0..state.spec.fields.len() {
            if state.values[i].is_none() && state.spec.fields[i].default.is_some() {
                put(state, i, state.spec.fields[i].default);
            }
        }
    }
    for a in &args.sets {
        let Some((name, value)) = a.split_once('=') else {
            return Err(CliError::Usage(format!(
                "--set {a:?}: expected FIELD=VALUE, e.g. holes=6"
            )));
        };
        let Some(i) = state.spec.field_by_name(name) else {
            let names: Vec<&str> = state.spec.fields.iter().map(|f| f.name.as_str()).collect();
            return Err(CliError::Usage(format!(
                "--set {a:?}: no field `{}` in {} (fields: {})",
                name.trim(),
                state.spec.path.display(),
                names.join(", ")
            )));
        };
        let f = &state.spec.fields[i];
        let v = f.parse(value).map_err(|why| {
            CliError::Refused(format!(
                "field `{}` (#{}, {}): {why}",
                f.name, f.var, f.label
            ))
        })?;
        put(state, i, v);
    }
    Ok(sets)
}

/// The shown fields and their values, one `name (#var) = value unit` a line.
fn listing(state: &PagesState) -> String {
    let mut s = String::new();
    for (i, f) in state.spec.fields.iter().enumerate() {
        if state.shown(i) {
            let v = match state.values[i] {
                Some(_) => format!("{} {}", f.show(state.values[i]), f.unit),
                None => "vacant".into(),
            };
            s.push_str(&format!("{} (#{}) = {}\n", f.name, f.var, v.trim_end()));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `pages` flattens `run`'s options and renames two of them: an option added to `run`
    /// under a name `pages` uses too, or a rename of `program`/`plot`, fails here.
    #[test]
    fn the_command_line_of_pages_is_consistent_with_runs() {
        use clap::{CommandFactory, Parser};
        crate::Cli::command().debug_assert();
        let cli = crate::Cli::try_parse_from([
            "cnc402",
            "pages",
            "p.toml",
            "--set",
            "holes=6",
            "--check",
            "--plot",
            "a.svg",
            "--run-plot",
            "b.svg",
            "--report",
            "r.json",
            "--realtime",
        ])
        .unwrap();
        let crate::Command::Pages(a) = cli.command else {
            panic!("not pages")
        };
        assert_eq!(a.run.program, PathBuf::from("p.toml"));
        assert_eq!(a.preview_plot, Some(PathBuf::from("a.svg")));
        assert_eq!(a.run.plot, Some(PathBuf::from("b.svg")));
        assert!(a.run.realtime && a.check && a.run.report.is_some());
        let cli = crate::Cli::try_parse_from(["cnc402", "pages"]).unwrap();
        let crate::Command::Pages(a) = cli.command else {
            panic!("not pages")
        };
        assert_eq!(a.run.program, PathBuf::from("pages.toml"));
        let mut cfg = MachineConfig::default_machine();
        cfg.interp.program_dir = PathBuf::from("/srv/nc");
        assert_eq!(
            pages_file(&cfg, &a.run.program),
            PathBuf::from("/srv/nc/pages.toml")
        );
        let given = PathBuf::from("examples/mlt980/pages.toml");
        assert_eq!(pages_file(&cfg, &given), given);
        assert!(crate::Cli::try_parse_from(["cnc402", "pages", "--check", "--start"]).is_err());
    }

    #[test]
    fn a_field_save_changes_only_its_variable_in_the_file() {
        let dir = std::env::temp_dir().join(format!("cnc402-pages-store-{}", std::process::id()));
        let path = dir.join("v.txt");
        nvfile::set_vars(&path, &[(520, Some(3.0)), (600, Some(1.5))]).unwrap();
        let mut store = FileStore {
            path: path.clone(),
            saves: 0,
        };
        store.save(530, Some(3.0)).unwrap();
        store.save(520, None).unwrap();
        let t = NvTable::load(&path).unwrap();
        assert_eq!(t.iter().collect::<Vec<_>>(), [(530, 3.0), (600, 1.5)]);
        assert_eq!(store.saves, 2);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
