//! `cnc402`: the command-line front end. A thin binary over the library crates: arguments are
//! turned into a validated plan (config loaded, program parsed) before anything runs.
//!
//! Exit codes (documented in README.md):
//! 0 success · 1 the machine stopped on a fault or safety reaction during `run`, or a program
//! did not pass `test` ·
//! 2 the program is wrong (parse, interpreter or planning error) · 3 the machine config is wrong ·
//! 4 an I/O error (file unreadable, CAN interface missing) · 5 `which`: no path near the
//! point · 64 bad command-line usage.

// CliError carries an NcError (large); it ends the process, so its size costs nothing.
#![allow(clippy::result_large_err)]

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cli_error;
mod dump;
mod home;
mod inspect;
mod pages;
mod post;
mod run;
mod test_cmd;
mod vars;
use cli_error::{CliError, exit};
use dump::{Dump, dump};

#[derive(Parser, Debug)]
#[command(
    name = "cnc402",
    version,
    about = "CNC motion backend: NC programs to CiA 402 drives over CAN"
)]
struct Cli {
    /// Machine description [default: $CNC402_CONFIG, else the first of
    /// ./config/machine.toml, ~/.config/cnc402/machine.toml, /etc/cnc402/machine.toml, else
    /// the built-in machine (simulated drives)].
    #[arg(long, global = true)]
    config: Option<PathBuf>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print the motion segments of a program as JSON Lines (the interpreter's contract).
    ///
    /// Example: cnc402 segments examples/bolt-circle-drilling.nc
    Segments {
        /// The NC program.
        program: PathBuf,
        /// Read the program in this dialect (fanuc, haas, linuxcnc), whatever its header or
        /// the config's `interp.dialect` says.
        #[arg(long, value_name = "NAME")]
        dialect: Option<cnc402_lang::Dialect>,
    },
    /// Print the canonical operations of a program as JSON Lines: what the interpreter
    /// decided the program does, in work coordinates, each with the modal state it ran under
    /// (a canned cycle stays one operation with its words and holes).
    ///
    /// Example: cnc402 canon examples/bolt-circle-drilling.nc
    Canon {
        /// The NC program.
        program: PathBuf,
        /// Read the program in this dialect (fanuc, haas, linuxcnc), whatever its header or
        /// the config's `interp.dialect` says.
        #[arg(long, value_name = "NAME")]
        dialect: Option<cnc402_lang::Dialect>,
    },
    /// Run a program on the configured machine (the embedded simulated drives when
    /// `bus.interface = "sim"`), print a summary, and exit non-zero on any error.
    ///
    /// Example: cnc402 run examples/m10x1.5-rigid-tap.nc --report run.json
    Run(Box<RunArgs>),
    /// Home the machine: boot the drives, run each axis's homing (CiA 402 homing mode, or
    /// an absolute encoder's stored offset), print where each ended, disable the drives.
    ///
    /// Example: cnc402 home Z X Y
    Home(home::HomeArgs),
    /// Point → block: the blocks whose path passes nearest a point (work coordinates of each
    /// block's offsets), nearest first, with file, line, N and distance.
    ///
    /// Example: cnc402 which examples/contour-arcs.nc 60 20 -2
    Which(inspect::WhichArgs),
    /// Write the toolpath as one self-contained HTML page (3D view; click a point for its
    /// block; breakpoints, the dry run's error and a run's trace marked).
    ///
    /// Example: cnc402 view examples/contour-arcs.nc -o path.html --break N150
    View(inspect::ViewArgs),
    /// List, set or clear the non-volatile macro variables #500-#999
    /// (`interp.variables_file`), e.g. to fill the parameter pages of a macro program.
    ///
    /// Example: cnc402 vars set 520=3 521=800 · cnc402 vars clear 500..530 · cnc402 vars
    Vars {
        /// Use this variables file instead of the config's `interp.variables_file`.
        #[arg(long, value_name = "FILE")]
        file: Option<PathBuf>,
        #[command(subcommand)]
        command: Option<vars::VarsCommand>,
    },
    /// The parameter pages of a macro package (pages.toml next to its programs) as an
    /// operator screen: fields with units, ranges and help, values checked and saved to the
    /// non-volatile variables, a preview of the holes, and start (docs/pages.md).
    ///
    /// Example: cnc402 pages examples/mlt980/pages.toml --set pattern=circle --check
    Pages(Box<pages::PagesArgs>),
    /// Post a job for a target control (fanuc0, fanuc16, fanuc18, fanuc32, arumatik,
    /// itnc530): the program is built whole, assembled, then read back and compared with the
    /// job segment by segment; a job the target cannot express is an error naming the block
    /// (docs/post.md).
    ///
    /// Example: cnc402 post --target fanuc0 examples/fanuc-milling.nc -o O1000.nc
    Post(Box<post::PostArgs>),
    /// Test NC programs: run each as `run` would (the embedded simulator unless the config
    /// names a CAN bus), print PASS or FAIL with the error and its line, and exit 0 only when
    /// all pass (1 otherwise); `--junit FILE` writes JUnit XML for a CI.
    ///
    /// Example: cnc402 test examples/*.nc --junit results.xml
    Test(test_cmd::TestArgs),
}

#[derive(clap::Args, Debug)]
struct RunArgs {
    /// The NC program.
    program: PathBuf,
    /// Read the program in this dialect (fanuc, haas, linuxcnc), whatever its header or the
    /// config's `interp.dialect` says.
    #[arg(long, value_name = "NAME")]
    dialect: Option<cnc402_lang::Dialect>,
    /// Write the JSON report here.
    #[arg(long, value_name = "FILE.json")]
    report: Option<PathBuf>,
    /// Write one CSV row per tick here (t, line, <AXIS>_cmd, <AXIS>_act, <AXIS>_sw, and
    /// panel: the feed hold, resume or override applied on that tick).
    #[arg(long, value_name = "FILE.csv")]
    trace: Option<PathBuf>,
    /// Draw Z and C against time and the coupling error into this SVG file.
    #[arg(long, value_name = "FILE.svg")]
    plot: Option<PathBuf>,
    /// Run against the wall clock at the configured period (always so on a real CAN bus).
    #[arg(long)]
    realtime: bool,
    /// Refuse to run (exit 4, naming the limit to raise) unless the real-time loop gets locked
    /// memory and SCHED_FIFO; without it the run goes on with a warning. Needs a real-time
    /// loop: a CAN interface or --realtime (docs/real-machine.md).
    #[arg(long)]
    require_rt: bool,
    /// On a CAN interface: how long to wait for every drive's boot-up after NMT reset
    /// communication (default 30 s; drives that start late, a slow emulated guest).
    #[arg(long, value_name = "SECONDS")]
    boot_timeout: Option<f64>,
    /// On a CAN interface: how long the enable sequence may take, fault reset included
    /// (default 10 s).
    #[arg(long, value_name = "SECONDS")]
    enable_timeout: Option<f64>,
    /// What M0 (program stop) does: `wait` holds the machine (drives enabled, position held)
    /// until Enter is pressed on the terminal (end of input ends the program there);
    /// `continue` logs it and goes on; `end` ends the program there (exit 0). Default: `wait`
    /// when stdin is a terminal, otherwise `continue` (with a line on stderr at each stop).
    #[arg(long, value_enum, value_name = "wait|continue|end")]
    at_stop: Option<AtStopArg>,
    /// M1 (optional stop) acts like M0; off by default, so M1 passes (the operator panel's
    /// optional-stop switch, off unless turned on).
    #[arg(long)]
    optional_stop: bool,
    /// Every SECONDS of wall clock, print one `stats:` line on stderr: wake-ups, late
    /// wake-ups and deadlines let pass so far, the interval's largest wake-up latency and
    /// largest following error per axis (for long runs: hil-tests/soak.sh).
    #[arg(long, value_name = "SECONDS")]
    stats_every: Option<f64>,
    /// Hold before this block, as M0 does (drives enabled, setpoints held, faults still stop
    /// the machine), and print where: `N1700` (every block numbered 1700, in any file of the
    /// run) or `FILE:LINE` (`part.nc:42`, a sub-program file too). Repeatable. A break on a
    /// block inside a loop holds at every pass; a break on a tap holds before the tap.
    /// At a hold the operator types: continue (or Enter), step (one block), next (to the next
    /// breakpoint), skip (pass this block's further repetitions), stop (end the program there,
    /// exit 0).
    #[arg(long = "break", value_name = "N1700|FILE:LINE")]
    breaks: Vec<String>,
    /// Hold before every block after the first (and before each further hole or K/L repeat
    /// of a canned cycle; never inside a rigid tap); `next` runs to the next breakpoint.
    #[arg(long)]
    single_block: bool,
    /// Read the operator's commands (one a line, `#` comments) from FILE (`-`: stdin) instead
    /// of the terminal. An unknown command in FILE ends the run at that hold (exit 64, with
    /// its line); from the terminal it is refused and asked again. End of input ends the
    /// program at the hold. Makes M0 wait for a command too (unless --at-stop says otherwise).
    #[arg(long, value_name = "FILE")]
    commands: Option<PathBuf>,
    /// Block search: run from this block (`N1700` or `FILE:LINE`) with the modal state the
    /// blocks before it set up (they are interpreted without motion); the machine approaches
    /// the block's start: Z up to the higher of here and there, the other axes at rapid,
    /// spindle and coolant as the state says, Z down. A block that does not exist: exit 2.
    #[arg(long, value_name = "N1700|FILE:LINE")]
    from: Option<String>,
    /// Block search: end after this block (needs --from; before --from: exit 64).
    #[arg(long, value_name = "N2200|FILE:LINE", requires = "from")]
    to: Option<String>,
    /// Testing: make drive NODE fault with EMCY CODE (hex) SECONDS after enable.
    #[arg(long, hide = true, value_name = "NODE:CODE@SECONDS")]
    inject_fault: Option<String>,
    /// Run FILE on channel N (`[[channel]]` in the config) beside PROGRAM on channel 0, in
    /// the same loop; the run ends when every channel has ended. Repeatable.
    #[arg(long = "channel", value_name = "N=FILE")]
    channels: Vec<String>,
}

/// `--at-stop`: what a program stop does.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum AtStopArg {
    Wait,
    Continue,
    End,
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = exit::for_clap(e.use_stderr());
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => e.report(),
    }
}

fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Segments { program, dialect } => {
            let cfg = load_config(cli.config.as_deref())?;
            dump(&cfg, &program, dialect, Dump::Segments)
        }
        Command::Canon { program, dialect } => {
            let cfg = load_config(cli.config.as_deref())?;
            dump(&cfg, &program, dialect, Dump::Canon)
        }
        Command::Run(args) => {
            let cfg = load_config(cli.config.as_deref())?;
            run::run(&cfg, &args)
        }
        Command::Home(args) => home::home(&load_config(cli.config.as_deref())?, args),
        Command::Which(args) => inspect::which(&load_config(cli.config.as_deref())?, args),
        Command::View(args) => inspect::view(&load_config(cli.config.as_deref())?, args),
        Command::Vars { file, command } => {
            let cfg = load_config(cli.config.as_deref())?;
            vars::vars(&cfg, file, command)
        }
        Command::Pages(args) => {
            let cfg = load_config(cli.config.as_deref())?;
            pages::pages(&cfg, *args)
        }
        Command::Post(args) => post::post(&load_config(cli.config.as_deref())?, *args),
        Command::Test(args) => test_cmd::test(&load_config(cli.config.as_deref())?, args),
    }
}

/// The machine of `--config`, or the one found without it (see `cnc402_config::locate`);
/// running on the built-in machine is said on stderr.
fn load_config(given: Option<&std::path::Path>) -> Result<cnc402_config::MachineConfig, CliError> {
    let (cfg, origin) = cnc402_config::MachineConfig::locate(given).map_err(CliError::Config)?;
    if let Some(note) = origin.note() {
        eprintln!("{note}");
    }
    Ok(cfg)
}

/// A program's whole text, for the commands that keep every block (`which`, `view`: a page
/// shows them all; the `pages` preview), unlike `segments` and `run`, which stream.
pub(crate) fn load_program(path: &std::path::Path) -> Result<cnc402_lang::SourceFile, CliError> {
    let bytes =
        std::fs::read(path).map_err(|e| CliError::Io(format!("{}: {e}", path.display())))?;
    Ok(cnc402_lang::SourceFile::from_bytes(
        path.display().to_string(),
        bytes,
    ))
}

/// Opens a program to be read line by line (a missing or unreadable file is exit 4 here,
/// before anything runs).
pub(crate) fn open_program(
    path: &std::path::Path,
) -> Result<std::io::BufReader<std::fs::File>, CliError> {
    let io = |e: std::io::Error| CliError::Io(format!("{}: {e}", path.display()));
    let file = std::fs::File::open(path).map_err(io)?;
    if file.metadata().map_err(io)?.is_dir() {
        return Err(CliError::Io(format!("{}: is a directory", path.display())));
    }
    Ok(std::io::BufReader::with_capacity(1 << 16, file))
}
