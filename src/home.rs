//! `cnc402 home [AXIS…]`: boots the configured machine (the embedded simulated drives when
//! `bus.interface = "sim"`), homes the named axes in the order given (default: every axis
//! with a `homing` key, in config order), prints where each ended, and disables the drives.

use cnc402_config::MachineConfig;
use cnc402_drives::Instant;
use cnc402_drives::master::HomingReport;
use cnc402_runtime::{CycleBus, DriveLink, LinkTimeouts, MasterLink, SimMachine, Startup};

use crate::cli_error::CliError;

#[derive(clap::Args, Debug)]
pub struct HomeArgs {
    /// Axis letters to home, in this order (e.g. `Z X Y`: Z first, clear of the work);
    /// default every axis with a `homing` key, in config order.
    axes: Vec<String>,
}

/// The config indices of `letters` (each an axis with a `homing` key), or of every axis with
/// one; a letter that names no such axis is a usage error.
fn axes_to_home(cfg: &MachineConfig, letters: &[String]) -> Result<Vec<usize>, CliError> {
    if letters.is_empty() {
        let all: Vec<usize> = (0..cfg.axes.len())
            .filter(|&i| cfg.axes[i].homing.is_some())
            .collect();
        if all.is_empty() {
            return Err(CliError::Usage(format!(
                "{}: no axis has a `homing` key (docs/config.md, \"Homing\")",
                cfg.path.display()
            )));
        }
        return Ok(all);
    }
    let mut axes = Vec::with_capacity(letters.len());
    for l in letters {
        let mut cs = l.chars();
        let letter = match (cs.next(), cs.next()) {
            (Some(c), None) => c.to_ascii_uppercase(),
            _ => return Err(CliError::Usage(format!("{l:?} is not an axis letter"))),
        };
        let Some(i) = cfg.axis_index(letter) else {
            return Err(CliError::Usage(format!("the config has no axis {letter}")));
        };
        if cfg.axes[i].homing.is_none() {
            return Err(CliError::Usage(format!(
                "axis {letter} has no `homing` key in {}",
                cfg.path.display()
            )));
        }
        if !axes.contains(&i) {
            axes.push(i);
        }
    }
    Ok(axes)
}

/// Boots `link`, homes `axes`, disables the drives again (also after a failed homing).
fn home_on<B: CycleBus>(
    link: &mut MasterLink<B>,
    axes: &[usize],
) -> Result<HomingReport, CliError> {
    match link.startup(Instant::ZERO) {
        Startup::Ready(_) => {}
        Startup::Failed(m) => return Err(CliError::Fault(format!("start-up failed: {m}"))),
        Startup::Pending => return Err(CliError::Fault("start-up did not finish".into())),
    }
    let homed = link.home(axes);
    let disabled = link.shutdown();
    let report = homed.map_err(|e| CliError::Fault(e.to_string()))?;
    disabled.map_err(|e| CliError::Fault(format!("after homing: {e}")))?;
    Ok(report)
}

/// See the module doc.
pub fn home(cfg: &MachineConfig, args: HomeArgs) -> Result<(), CliError> {
    let axes = axes_to_home(cfg, &args.axes)?;
    // With `require_homing` the link would home at start-up on its own: here the command
    // line says which axes, so start-up only boots.
    let cfg = MachineConfig {
        machine: cnc402_config::MachineOptions {
            require_homing: false,
            ..cfg.machine
        },
        ..cfg.clone()
    };
    let report = if cfg.bus.is_sim() {
        let machine = SimMachine::new(&cfg, None).map_err(CliError::Io)?;
        let mut link = MasterLink::new(&cfg, machine)
            .map_err(|e| CliError::Io(format!("simulated bus: {e}")))?;
        home_on(&mut link, &axes)?
    } else {
        let mut link = MasterLink::socket(&cfg, LinkTimeouts::real_bus()).map_err(CliError::Io)?;
        home_on(&mut link, &axes)?
    };
    for a in &report.axes {
        let unit = if cfg.axes[cfg.axis_index(a.axis).unwrap_or(0)]
            .kind
            .is_rotary()
        {
            "°"
        } else {
            " mm"
        };
        match a.method {
            Some(m) => println!(
                "{}: homed (node {}, {m}) in {:.3} s: machine position {:.4}{unit}",
                a.axis,
                a.node,
                a.took.as_secs_f64(),
                a.position
            ),
            None => println!(
                "{}: absolute encoder (node {}): machine position {:.4}{unit}",
                a.axis, a.node, a.position
            ),
        }
    }
    Ok(())
}
