//! drivectl: the diagnostic CLI for CANopen CiA 402 drives, as a library so tests can call
//! it. `main` parses [`cli::Cli`] and calls [`run`]; each command lives in [`commands`],
//! [`motion`] (jog/move), [`identify`] or [`monitor`] (monitor/emcy). The bus is [`link::Link`]: a
//! SocketCAN interface or the embedded simulator.

pub mod cli;
pub mod commands;
pub mod decode;
pub mod dict;
pub mod eds;
pub mod error;
pub mod identify;
pub mod link;
pub mod monitor;
pub mod motion;
pub mod period;
pub mod store;
pub mod tui;
pub mod values;

use core::time::Duration;
use std::io::Write;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use cnc402_config::MachineConfig;
use cnc402_drives::master::{BlockingSdo, TimedBus};
use cnc402_drives::wire::{CanFrame, NodeId};
use serde_json::Value as Json;

use crate::cli::{Cli, Command};
use crate::decode::NodeNames;
use crate::dict::Dictionary;
use crate::error::{CliError, Exit, Result};
use crate::link::Link;

/// Everything a command needs: config, bus, dictionary, output mode.
pub struct Ctx {
    /// The machine config.
    pub cfg: MachineConfig,
    /// The bus.
    pub link: Link,
    /// Object names and types.
    pub dict: Dictionary,
    /// Node names from the config.
    pub names: NodeNames,
    /// `--json`.
    pub json: bool,
    /// SDO response timeout / listen window.
    pub timeout: Duration,
    /// Frames that arrived during SDO transfers and were not theirs (heartbeats, EMCY, PDOs).
    pub other: Vec<CanFrame>,
    /// Set by Ctrl-C.
    pub interrupted: Arc<AtomicBool>,
    /// PDO mappings read from the drives (`monitor --read-mapping`).
    pub pdo_maps: decode::PdoMaps,
}

impl Ctx {
    /// Runs `f` with a blocking SDO client on the link; frames that are not the transfer's go
    /// to [`Ctx::other`].
    pub fn with_sdo<T>(&mut self, f: impl FnOnce(&mut BlockingSdo<'_, Link>) -> T) -> T {
        let other = &mut self.other;
        let mut sink = |fr: &CanFrame| other.push(*fr);
        let mut sdo = BlockingSdo::new(&mut self.link, self.timeout, &mut sink);
        f(&mut sdo)
    }

    /// The current bus time.
    pub fn now(&self) -> cnc402_drives::Instant {
        self.link.now()
    }

    /// Whether Ctrl-C was pressed.
    pub fn interrupted(&self) -> bool {
        self.interrupted.load(Ordering::SeqCst)
    }

    /// Prints a line of human output (nothing in `--json` mode).
    pub fn say(&self, line: impl AsRef<str>) {
        if !self.json {
            let mut out = std::io::stdout().lock();
            let _ = writeln!(out, "{}", line.as_ref());
            let _ = out.flush();
        }
    }

    /// Prints one JSON document (only in `--json` mode).
    pub fn emit_json(&self, v: &Json) {
        if self.json {
            let mut out = std::io::stdout().lock();
            let _ = writeln!(out, "{v}");
            let _ = out.flush();
        }
    }

    /// `node 3 (Z)`.
    pub fn label(&self, node: u8) -> String {
        self.names.label(node)
    }
}

/// A node id as the wire type (the CLI has validated 1..=127).
pub fn node_id(n: u8) -> Result<NodeId> {
    NodeId::new(n).map_err(|e| CliError::usage(e.to_string()))
}

/// Loads the config: `--config`, else the one `cnc402_config::locate` finds, else the built-in
/// machine (so `drivectl --iface sim scan` works from any directory); a named file that
/// cannot be read or is invalid is an error.
pub fn load_config(cli: &Cli) -> Result<MachineConfig> {
    MachineConfig::locate(cli.global.config.as_deref())
        .map(|(cfg, _)| cfg)
        .map_err(|e| CliError::new(Exit::Config, e.to_string()))
}

/// Runs a parsed command line. `interrupted` is set by the caller's Ctrl-C handler.
pub fn run(cli: Cli, interrupted: Arc<AtomicBool>) -> Result<()> {
    // Commands that need no bus.
    match &cli.command {
        Command::Completions { shell } => return commands::completions(*shell),
        Command::Eds { file } => return commands::eds_list(file, cli.global.json),
        _ => {}
    }
    let cfg = load_config(&cli)?;
    let eds = match &cli.global.eds {
        Some(p) => Some(eds::load(p)?),
        None => None,
    };
    let iface = cli
        .global
        .iface
        .clone()
        .unwrap_or_else(|| cfg.bus.interface.clone());
    let timeout = Duration::from_millis(
        cli.global
            .timeout_ms
            .unwrap_or(cfg.bus.sdo_timeout_ms as u64)
            .max(1),
    );
    log::debug!(
        "config {}: {} axes; interface {iface}, SDO timeout {} ms",
        cfg.path.display(),
        cfg.axes.len(),
        timeout.as_millis()
    );
    let link = Link::open(&iface, &cfg, &cli.global.sim_setup)?;
    // With the compact layout, its PDOs are decoded by the mapping cnc402 sets.
    let pdo_maps = decode::PdoMaps::of_config(&cfg);
    let mut ctx = Ctx {
        names: NodeNames::from_config(&cfg),
        cfg,
        link,
        dict: Dictionary::new(eds),
        json: cli.global.json,
        timeout,
        other: Vec::new(),
        interrupted,
        pdo_maps,
    };
    commands::dispatch(&mut ctx, cli.command)
}
