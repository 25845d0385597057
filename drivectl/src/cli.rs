//! The command line (clap derive): global options, one subcommand per capability, each with
//! an example in its help. [`Cli`] is parsed in `main` and run by [`crate::run`].

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

use crate::link::SimSetup;

const AFTER_HELP: &str = "\
Examples:
  drivectl --iface sim scan                     # try it without hardware
  drivectl --iface can0 info 3
  drivectl sdo read 3 0x6041                     # type from the EDS / standard objects
  drivectl sdo write 3 0x6065 u32 5000
  drivectl move 3 12.5                           # boots, enables in CSP, moves, disables
  drivectl --iface vcan0 monitor --log bus.log

--iface sim runs the embedded simulator in-process: one simulated CiA 402 drive per axis of
the machine config, powered on when drivectl starts (each invocation starts a fresh machine).
One-shot commands have no background loop, so the simulator's virtual time advances while a
command waits for an answer (SDO responses, boot-ups, heartbeats): every command works there,
and waits cost no wall-clock time. --sim-setup prepares a condition first (a drive in FAULT,
a drive that stops answering SDO, a drive already enabled).
";

/// Exit code table and the notes above, shown by `--help`.
fn long_after_help() -> String {
    format!("{AFTER_HELP}\n{}", cnc402_config::exit::help_table())
}

/// drivectl: diagnose and commission CANopen CiA 402 drives.
#[derive(Debug, Parser)]
#[command(
    name = "drivectl",
    version,
    about = "Diagnose and commission CANopen CiA 402 servo drives (SocketCAN or the embedded simulator)",
    after_help = "Example: drivectl --iface sim scan   (see --help for more and the exit codes)",
    after_long_help = long_after_help()
)]
pub struct Cli {
    #[command(flatten)]
    pub global: Global,
    #[command(subcommand)]
    pub command: Command,
}

/// Options of every command.
#[derive(Debug, Args, Clone)]
pub struct Global {
    /// CAN interface (can0, vcan0) or `sim` for the embedded simulator [default: the
    /// config's bus.interface]
    #[arg(long, global = true, value_name = "NAME")]
    pub iface: Option<String>,
    /// Machine config: node ids, axis names, limits for jog/move [default: $CNC402_CONFIG,
    /// else the first of ./config/machine.toml, ~/.config/cnc402/machine.toml,
    /// /etc/cnc402/machine.toml, else the built-in machine]
    #[arg(long, global = true, value_name = "PATH")]
    pub config: Option<PathBuf>,
    /// Machine-readable output (one JSON document; streaming commands: one JSON object per
    /// line)
    #[arg(long, global = true)]
    pub json: bool,
    /// Vendor EDS/DCF (CiA 306): object names and data types in every printout
    #[arg(long, global = true, value_name = "FILE")]
    pub eds: Option<PathBuf>,
    /// SDO response timeout and probe/listen windows, in ms, 1..=60000 [default: the
    /// config's bus.sdo_timeout_ms]
    #[arg(long, global = true, value_name = "MS", value_parser = clap::value_parser!(u64).range(1..=MAX_WAIT_MS))]
    pub timeout_ms: Option<u64>,
    /// Simulator only: prepare a condition before the command (repeatable):
    /// enable:NODE, fault:NODE[:CODE], fault-persistent:NODE[:CODE], sdo:NODE (stops
    /// answering SDO), heartbeat:NODE, tpdo:NODE
    #[arg(long, global = true, value_name = "ACTION:NODE[:CODE]")]
    pub sim_setup: Vec<SimSetup>,
}

/// Longest SDO timeout or listen window (ms), as the config's `bus.sdo_timeout_ms`: a
/// larger one (up to 2^64 ms was taken) waited for ever, or overflowed the clock.
pub const MAX_WAIT_MS: u64 = 60_000;
/// Longest `--for`/`--duration`/`--stats-every` (s): a week; without the option, `jog`,
/// `monitor` and `emcy` run until Ctrl-C.
pub const MAX_SECONDS: f64 = 604_800.0;

/// A node id or `all` (NMT).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NodeOrAll {
    /// One node.
    Node(u8),
    /// Every node (NMT node id 0).
    All,
}

impl core::str::FromStr for NodeOrAll {
    type Err = String;
    fn from_str(s: &str) -> Result<NodeOrAll, String> {
        if s.eq_ignore_ascii_case("all") {
            return Ok(NodeOrAll::All);
        }
        parse_node(s).map(NodeOrAll::Node)
    }
}

/// Parses a node id 1..=127.
pub fn parse_node(s: &str) -> Result<u8, String> {
    let v = crate::values::parse_uint(s).ok_or_else(|| format!("`{s}` is not a node id"))?;
    if (1..=127).contains(&v) {
        Ok(v as u8)
    } else {
        Err(format!("node id {v} outside 1..=127"))
    }
}

/// NMT commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum NmtCmd {
    /// Start remote node (→ OPERATIONAL)
    Start,
    /// Stop remote node (→ STOPPED)
    Stop,
    /// Enter PRE-OPERATIONAL
    Preop,
    /// Reset node (application and communication); waits for the boot-up
    Reset,
    /// Reset communication; waits for the boot-up
    ResetComm,
}

/// CiA 402 modes of operation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ModeArg {
    /// Cyclic synchronous position (8)
    Csp,
    /// Cyclic synchronous velocity (9)
    Csv,
    /// Profile position (1)
    Pp,
    /// Profile velocity (3)
    Pv,
    /// Homing (6)
    Homing,
}

/// Shells for `completions`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ShellArg {
    /// bash
    Bash,
    /// zsh
    Zsh,
    /// fish
    Fish,
    /// elvish
    Elvish,
    /// PowerShell
    Powershell,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Find nodes: listen for boot-ups/heartbeats, then probe 1..127 by SDO (0x1000)
    #[command(after_help = "Example: drivectl --iface can0 scan --json")]
    Scan {
        /// How long to listen for heartbeats before probing, in ms, 0..=60000
        #[arg(long, default_value_t = 300, value_name = "MS", value_parser = clap::value_parser!(u64).range(0..=MAX_WAIT_MS))]
        listen_ms: u64,
        /// Probe only these nodes (default 1..=127)
        #[arg(long, value_delimiter = ',', value_parser = parse_node, value_name = "N,N")]
        nodes: Vec<u8>,
    },
    /// Everything about one drive: identity, modes, state, position, errors, heartbeat, PDOs
    #[command(after_help = "Example: drivectl info 3")]
    Info {
        /// Node id
        #[arg(value_parser = parse_node)]
        node: u8,
    },
    /// Read or write an object by SDO (expedited or segmented)
    #[command(
        subcommand,
        after_help = "Examples:\n  drivectl sdo read 3 0x6041\n  drivectl sdo write 3 0x1017 u16 100"
    )]
    Sdo(SdoCmd),
    /// Send an NMT command to a node or to all
    #[command(after_help = "Examples:\n  drivectl nmt start 3\n  drivectl nmt reset-comm all")]
    Nmt {
        /// The command
        command: NmtCmd,
        /// Node id or `all`
        target: NodeOrAll,
    },
    /// Read the statusword and show the CiA 402 state and its bits
    #[command(after_help = "Example: drivectl state 3")]
    State {
        /// Node id
        #[arg(value_parser = parse_node)]
        node: u8,
    },
    /// Take the drive to OPERATION ENABLED step by step (target = actual first)
    #[command(after_help = "Example: drivectl enable 3 --fault-reset")]
    Enable {
        /// Node id
        #[arg(value_parser = parse_node)]
        node: u8,
        /// Leave FAULT with a fault reset on the way (otherwise a drive in FAULT is an error)
        #[arg(long)]
        fault_reset: bool,
        #[command(flatten)]
        seq: SeqArgs,
    },
    /// Take the drive to SWITCH ON DISABLED (power stage off)
    #[command(after_help = "Example: drivectl disable 3")]
    Disable {
        /// Node id
        #[arg(value_parser = parse_node)]
        node: u8,
        #[command(flatten)]
        seq: SeqArgs,
    },
    /// Quick stop: the drive brakes on its quick stop ramp
    #[command(after_help = "Example: drivectl quick-stop 3")]
    QuickStop {
        /// Node id
        #[arg(value_parser = parse_node)]
        node: u8,
        #[command(flatten)]
        seq: SeqArgs,
    },
    /// Leave FAULT with a fault reset edge (controlword bit 7), showing the error code
    #[command(after_help = "Example: drivectl fault-reset 3")]
    FaultReset {
        /// Node id
        #[arg(value_parser = parse_node)]
        node: u8,
        #[command(flatten)]
        seq: SeqArgs,
    },
    /// Set the mode of operation (0x6060), confirmed by 0x6061; refused when 0x6502 does
    /// not list it
    #[command(after_help = "Example: drivectl mode 3 csp")]
    Mode {
        /// Node id
        #[arg(value_parser = parse_node)]
        node: u8,
        /// The mode
        mode: ModeArg,
        /// Write 0x6060 even if 0x6502 does not list the mode (the drive decides)
        #[arg(long)]
        force: bool,
    },
    /// Jog one axis at a velocity (CSP, jerk-limited ramps from the config); Ctrl-C stops
    /// with a ramp
    #[command(
        allow_negative_numbers = true,
        after_help = "Example: drivectl jog 1 --velocity -5 --for 2   (X at -5 mm/s for 2 s)"
    )]
    Jog {
        /// Node id (must be an axis of the config)
        #[arg(value_parser = parse_node)]
        node: u8,
        /// Velocity in axis units per second (mm/s, deg/s); sign = direction
        #[arg(long, allow_negative_numbers = true)]
        velocity: f64,
        /// Stop (with a ramp) after this many seconds; without it, jog until Ctrl-C
        #[arg(long = "for", value_name = "SECONDS")]
        duration: Option<f64>,
        /// Tests: behave as if Ctrl-C came after this many seconds of motion
        #[arg(long, hide = true, value_name = "SECONDS")]
        interrupt_after: Option<f64>,
    },
    /// Move one axis to an absolute position (CSP, jerk-limited profile from the config);
    /// Ctrl-C stops with a ramp
    #[command(
        allow_negative_numbers = true,
        after_help = "Example: drivectl move 3 -12.5   (Z to -12.5 mm)"
    )]
    Move {
        /// Node id (must be an axis of the config)
        #[arg(value_parser = parse_node)]
        node: u8,
        /// Target in axis units (mm, deg), machine coordinates
        #[arg(allow_negative_numbers = true)]
        position: f64,
        /// Tests: behave as if Ctrl-C came after this many seconds of motion
        #[arg(long, hide = true, value_name = "SECONDS")]
        interrupt_after: Option<f64>,
    },
    /// Measure the drive's dead time and closed position loop bandwidth from a small test
    /// motion in CSP, and print the `dynamics` line for the config. The drive must be
    /// enabled (`drivectl enable NODE`) and not in FAULT; the stroke must stay inside the
    /// soft limits
    #[command(
        allow_negative_numbers = true,
        after_help = "Examples:\n  drivectl enable 3 && drivectl identify 3\n  drivectl --iface sim --sim-setup enable:4 identify 4 --amplitude 5 --json"
    )]
    Identify {
        /// Node id (must be an axis of the config)
        #[arg(value_parser = parse_node)]
        node: u8,
        /// Stroke in axis units (mm, deg) from the actual position and back; sign = direction
        /// [default: the axis's following_error_window]
        #[arg(long, allow_negative_numbers = true, value_name = "UNITS")]
        amplitude: Option<f64>,
        /// Length of the test motion in seconds, 0..=10 (whole out-and-back strokes, at least
        /// one)
        #[arg(long, default_value_t = 1.0, value_name = "SECONDS")]
        duration: f64,
    },
    /// Decode all bus traffic live, with node names, bus load and SYNC period statistics
    #[command(
        after_help = "Example: drivectl --iface vcan0 monitor --log capture.log --duration 10"
    )]
    Monitor {
        /// Write the traffic in candump -l format `(sec.usec) iface ID#DATA`
        #[arg(long, value_name = "FILE")]
        log: Option<PathBuf>,
        /// Stop after this many seconds (default: until Ctrl-C)
        #[arg(long, value_name = "SECONDS")]
        duration: Option<f64>,
        /// Statistics interval in seconds
        #[arg(long, default_value_t = 1.0, value_name = "SECONDS")]
        stats_every: f64,
        /// Print only statistics, not every frame
        #[arg(long)]
        quiet: bool,
        /// Read every configured drive's PDO mappings by SDO first and decode PDOs by them
        /// (otherwise PDO1s are decoded with cnc402's mapping)
        #[arg(long)]
        read_mapping: bool,
        /// Full-screen view: one panel per drive, bus load, SYNC statistics, events (q quits)
        #[arg(long, conflicts_with_all = ["quiet", "json"])]
        tui: bool,
    },
    /// Watch and decode EMCY messages
    #[command(after_help = "Example: drivectl emcy --duration 60")]
    Emcy {
        /// Stop after this many seconds (default: until Ctrl-C)
        #[arg(long, value_name = "SECONDS")]
        duration: Option<f64>,
    },
    /// Store the drive's parameters in its non-volatile memory (0x1010:1 = "save"), or with
    /// --restore bring back its factory defaults (0x1011:1 = "load", effective after a reset).
    /// Asks for confirmation on a terminal; in a pipe or script it needs --yes
    #[command(
        after_help = "Examples:\n  drivectl store 3\n  drivectl store 3 --yes\n  drivectl store 3 --restore --yes"
    )]
    Store {
        /// Node id
        #[arg(value_parser = parse_node)]
        node: u8,
        /// Do it without asking
        #[arg(long)]
        yes: bool,
        /// Restore the factory defaults instead of storing
        #[arg(long)]
        restore: bool,
    },
    /// Read a CiA 306 EDS/DCF and list its objects (names, types, access, defaults)
    #[command(after_help = "Example: drivectl eds vendor.eds --json")]
    Eds {
        /// The file
        file: PathBuf,
    },
    /// Print a shell completion script
    #[command(after_help = "Example: drivectl completions bash > /etc/bash_completion.d/drivectl")]
    Completions {
        /// The shell
        shell: ShellArg,
    },
}

/// Options of the state machine commands.
#[derive(Debug, Args, Clone, Copy)]
pub struct SeqArgs {
    /// Give up (and say where it is stuck and why) after this many ms, 0..=600000
    #[arg(long, default_value_t = 2000, value_name = "MS", value_parser = clap::value_parser!(u64).range(0..=10 * MAX_WAIT_MS))]
    pub within_ms: u64,
    /// Time between steps in ms, 0..=60000
    #[arg(long, default_value_t = 10, value_name = "MS", value_parser = clap::value_parser!(u64).range(0..=MAX_WAIT_MS))]
    pub step_ms: u64,
}

/// `sdo read` / `sdo write`.
#[derive(Debug, Subcommand)]
pub enum SdoCmd {
    /// Read INDEX[:SUB]; TYPE from the command line, the EDS or the standard objects
    #[command(
        after_help = "Examples:\n  drivectl sdo read 3 0x6064 i32\n  drivectl sdo read 3 controlword\n  drivectl sdo read 3 \"Identity object.Vendor ID\"\n  drivectl sdo read 3 1008      # device name, segmented\n  drivectl sdo read 3 1018:1 --json"
    )]
    Read {
        /// Node id
        #[arg(value_parser = parse_node)]
        node: u8,
        /// Object: hex index and sub-index (6041, 0x1018:1) or a name from the EDS/DCF or
        /// the standard objects, any case (controlword, "Store parameters.Save all
        /// parameters")
        object: String,
        /// Data type (u8 u16 u32 u64 i8 i16 i32 i64 f32 f64 bool string bytes)
        r#type: Option<String>,
    },
    /// Write VALUE as TYPE to INDEX[:SUB] (strings/bytes longer than 4 bytes: segmented)
    #[command(
        allow_negative_numbers = true,
        after_help = "Examples:\n  drivectl sdo write 3 0x6060 i8 8\n  drivectl sdo write 3 \"modes of operation\" 8\n  drivectl sdo write 3 0x1017 u16 100\n  drivectl sdo write 3 0x607A i32 -5000"
    )]
    Write {
        /// Node id
        #[arg(value_parser = parse_node)]
        node: u8,
        /// Object: hex index and sub-index (6040, 0x1017:0) or a name (controlword)
        object: String,
        /// Data type (u8 u16 u32 u64 i8 i16 i32 i64 f32 f64 bool string bytes), then the
        /// value; the type may be left out when the EDS/DCF or the standard objects know it
        #[arg(allow_negative_numbers = true, value_name = "[TYPE] VALUE", num_args = 1..=2, required = true)]
        type_and_value: Vec<String>,
    },
}
