//! `drivectl store NODE`: the drive's parameters into its non-volatile memory (0x1010:1 =
//! "save") or its factory defaults back (`--restore`, 0x1011:1 = "load"). Both change what
//! the drive does after its next power-on, so they ask first: a yes on the terminal, or
//! `--yes`; in a pipe without `--yes` they refuse.

use std::io::{BufRead, IsTerminal, Read, Write};
use std::time::Duration;

use cnc402_drives::od::{LOAD_SIGNATURE, RESTORE_DEFAULTS, SAVE_SIGNATURE, STORE_PARAMETERS};
use serde_json::json;

use crate::error::{CliError, Result};
use crate::{Ctx, node_id};

/// Drives take a while to write their flash; the SDO answer comes after it.
const STORE_TIMEOUT: Duration = Duration::from_secs(5);

/// Runs the store (or restore) on node `n` once confirmed.
pub fn store(ctx: &mut Ctx, n: u8, yes: bool, restore: bool) -> Result<()> {
    let node = node_id(n)?;
    let (index, signature, what) = if restore {
        (
            RESTORE_DEFAULTS,
            LOAD_SIGNATURE,
            "restore the factory defaults of",
        )
    } else {
        (STORE_PARAMETERS, SAVE_SIGNATURE, "store the parameters of")
    };
    // Bit 0 of sub 1: the device does this on command (CiA 301).
    let support = ctx.with_sdo(|sdo| sdo.read_u32(node, index, 1))?;
    if support & 1 == 0 {
        return Err(CliError::state(format!(
            "{}: {index:#06x}:01 reads {support:#x}: the drive does not {what} itself on \
             command",
            ctx.label(n),
            what = if restore { "restore" } else { "store" }
        )));
    }
    confirm(&format!("{what} {}", ctx.label(n)), yes)?;
    let timeout = ctx.timeout;
    ctx.timeout = ctx.timeout.max(STORE_TIMEOUT);
    let r = ctx.with_sdo(|sdo| sdo.write_u32(node, index, 1, signature));
    ctx.timeout = timeout;
    r?;
    if ctx.json {
        ctx.emit_json(&json!({
            "node": n, "index": index, "sub": 1,
            "command": if restore { "restore" } else { "store" }, "done": true,
        }));
    } else if restore {
        ctx.say(format!(
            "{}: factory defaults restored (0x1011:01 = \"load\"); they take effect at the \
             next reset or power-on",
            ctx.label(n)
        ));
    } else {
        ctx.say(format!(
            "{}: parameters stored (0x1010:01 = \"save\"); the drive keeps them over a power \
             cycle",
            ctx.label(n)
        ));
    }
    Ok(())
}

/// `--yes`, or a "y"/"yes" typed on the terminal; anything else refuses (a usage error).
fn confirm(action: &str, yes: bool) -> Result<()> {
    if yes {
        return Ok(());
    }
    let stdin = std::io::stdin();
    if !stdin.is_terminal() {
        return Err(CliError::usage(format!(
            "refusing to {action} without --yes: standard input is not a terminal to ask on"
        )));
    }
    eprint!("{action}? This changes what the drive does after power-on. [y/N] ");
    let _ = std::io::stderr().flush();
    let mut answer = String::new();
    // One line at most 64 bytes: a confirmation, not a document.
    let _ = stdin.lock().take(64).read_line(&mut answer);
    match answer.trim().to_ascii_lowercase().as_str() {
        "y" | "yes" => Ok(()),
        _ => Err(CliError::usage(format!("not confirmed: did not {action}"))),
    }
}
