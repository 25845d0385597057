//! The operator's run-time controls: breakpoints (`--break N1700`, `--break file.nc:42`),
//! single block, the commands given at a hold (`continue`, `step`, `next`, `skip`, `stop`,
//! from the terminal or a command file), block search (`--from`/`--to`) and what the report
//! keeps of them (breaks hit, commands, messages). The feeder side is [`watch::BlockWatch`];
//! the loop only sees the program stops it inserts (the M0 machinery of `program_stop`).

mod input;
mod panel;
mod search;
mod spec;
mod watch;

use std::sync::{Arc, Mutex, MutexGuard};

pub use input::{CommandInput, Read, describe};
pub use panel::{
    FEED_RANGE, PANEL_COMMANDS, Panel, PanelAction, PanelCommand, PanelEvent, PanelLog, PanelState,
    SPINDLE_RANGE, Schedule, Scheduled, Trigger, apply_at_start,
};
pub use search::SearchSpec;
pub use spec::{BlockSpec, SearchError, check_breaks, file_matches, resolve_search};
pub use watch::{Admit, BlockWatch};

/// The operator's controls asked for a run (`cnc402 run --break … --single-block
/// --commands … --from … --to …`).
#[derive(Debug, Default)]
pub struct OperatorOptions {
    pub breaks: Vec<BlockSpec>,
    pub single_block: bool,
    pub search: Option<SearchSpec>,
    /// Where commands come from (`None`: stdin).
    pub commands: Option<Arc<CommandInput>>,
    /// The command file's triggered panel commands ([`CommandInput::schedule`]).
    pub schedule: Schedule,
    /// Read stdin throughout the run so that panel commands act at once (the terminal, or
    /// `--commands -`); off, stdin is read only at holds.
    pub listen_stdin: bool,
}

impl OperatorOptions {
    /// Whether any segment must pass a [`BlockWatch`].
    pub fn watches(&self) -> bool {
        !self.breaks.is_empty() || self.single_block || self.search.is_some()
    }
}

/// One operator command at a hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    /// Go on (with single block on: through the next block).
    Continue,
    /// Run one block and hold before the next.
    Step,
    /// Run to the next breakpoint (single-block holds passed until then).
    Next,
    /// Go on, and pass the rest of this block's repetitions (in a loop) without holding.
    Skip,
    /// End the program here (a controlled stop: the machine settles and disables).
    Stop,
    /// Feed hold, resume, an override (see [`panel`]): acts on the panel, answers no hold.
    Panel(PanelCommand),
}

/// The commands, for messages and `--help`.
pub const COMMANDS: &str = "continue (or Enter), step, next, skip, stop, hold, resume, feed 0–200, spindle 50–120, \
     rapid 25|50|100";

impl Command {
    /// Parses one command line: the word, or its first letter; an empty line is `continue`
    /// (Enter, as at M0).
    pub fn parse(line: &str) -> Result<Command, String> {
        let w = line.trim().to_ascii_lowercase();
        if let Some(p) = PanelCommand::parse(&w) {
            return p.map(Command::Panel);
        }
        Ok(match w.as_str() {
            "" | "c" | "continue" => Command::Continue,
            "s" | "step" => Command::Step,
            "n" | "next" => Command::Next,
            "k" | "skip" => Command::Skip,
            "q" | "stop" => Command::Stop,
            _ => {
                return Err(format!(
                    "unknown command {:?}: expected one of {COMMANDS}",
                    line.trim()
                ));
            }
        })
    }

    /// The command's name in the report.
    pub fn name(self) -> &'static str {
        match self {
            Command::Continue => "continue",
            Command::Step => "step",
            Command::Next => "next",
            Command::Skip => "skip",
            Command::Stop => "stop",
            Command::Panel(p) => p.action.name(),
        }
    }
}

/// Where the machine holds at a breakpoint or single-block stop: the block about to start.
#[derive(Clone, Debug, PartialEq)]
pub struct BreakHit {
    pub file: Arc<str>,
    pub line: u32,
    pub n: Option<u32>,
    /// Why: "break" (a breakpoint), "step" (single block or `step`).
    pub reason: &'static str,
    /// The hold was due inside a rigid tap (between a tap in and its tap out) and is made at
    /// this block, the first after the tap.
    pub after_tap: bool,
}

/// A hold at a break, as the report shows it.
#[derive(Clone, Debug, PartialEq)]
pub struct BreakRecord {
    pub hit: BreakHit,
    /// The loop's tick at which the machine held.
    pub at_tick: u64,
}

/// A message of the program for the operator (`MSG(...)`, `(MSG, ...)`, `#3006`).
#[derive(Clone, Debug, PartialEq)]
pub struct MessageRecord {
    pub file: String,
    pub line: u32,
    pub text: String,
}

/// A command received, with the hold it answered (index into the breaks, `None` at an M0).
#[derive(Clone, Debug, PartialEq)]
pub struct CommandRecord {
    pub command: &'static str,
    /// Line of the command file (1-based), or of stdin.
    pub input_line: u32,
    pub at_tick: u64,
}

/// What the operator side of a run recorded, for the report.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OperatorLog {
    pub breaks: Vec<BreakRecord>,
    pub commands: Vec<CommandRecord>,
    pub messages: Vec<MessageRecord>,
    /// A bad command in a command file: the run ended at the hold; the CLI exits 64.
    pub command_error: Option<String>,
    /// The operator ended the program with `stop`.
    pub stopped_by_operator: bool,
    /// Block search: the range run (`--from`/`--to` as resolved, `file:line`).
    pub search: Option<String>,
    /// Feed holds, resumes and overrides as the loop applied them, and the period that
    /// turns their ticks into seconds.
    pub panel: Vec<PanelEvent>,
    pub panel_lost: u64,
    pub period_s: f64,
}

impl OperatorLog {
    /// The report's keys (`breaks`, `commands`, `messages`, and `search` when used).
    pub fn to_json(&self) -> serde_json::Value {
        use serde_json::json;
        let breaks: Vec<_> = self
            .breaks
            .iter()
            .map(|b| {
                json!({"file": &*b.hit.file, "line": b.hit.line, "n": b.hit.n,
                       "reason": b.hit.reason, "after_tap": b.hit.after_tap,
                       "at_tick": b.at_tick})
            })
            .collect();
        let commands: Vec<_> = self
            .commands
            .iter()
            .map(
                |c| json!({"command": c.command, "input_line": c.input_line, "at_tick": c.at_tick}),
            )
            .collect();
        let messages: Vec<_> = self
            .messages
            .iter()
            .map(|m| json!({"file": m.file, "line": m.line, "text": m.text}))
            .collect();
        let panel: Vec<_> = self
            .panel
            .iter()
            .map(|e| {
                json!({"action": e.action.name(), "percent": e.action.percent(),
                       "at_s": e.tick as f64 * self.period_s, "at_tick": e.tick,
                       "line": e.line, "n": e.n, "input_line": e.input_line})
            })
            .collect();
        json!({
            "panel": panel,
            "panel_lost": self.panel_lost,
            "breaks": breaks,
            "commands": commands,
            "messages": messages,
            "command_error": self.command_error,
            "stopped_by_operator": self.stopped_by_operator,
            "search": self.search,
        })
    }
}

/// What the operator ordered at the last hold, read by the feeder before it interprets on
/// (never by the loop).
#[derive(Clone, Debug, Default)]
pub struct Orders {
    /// Hold before the next block whatever the breakpoints (`step`).
    pub step: bool,
    /// Pass single-block holds until a breakpoint hits (`next`).
    pub to_next_break: bool,
    /// Pass holds at this block (`skip`).
    pub skip: Option<(Arc<str>, u32)>,
}

/// Shared by the feeder's [`BlockWatch`] and the operator prompt.
#[derive(Debug, Default)]
pub struct OperatorShared {
    orders: Mutex<Orders>,
    /// The hold the feeder inserted last (what the prompt shows).
    hit: Mutex<Option<BreakHit>>,
}

impl OperatorShared {
    fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
        m.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Applies the operator's `command` given at a hold at `hit`.
    pub fn order(&self, command: Command, hit: Option<&BreakHit>) {
        let mut o = Self::lock(&self.orders);
        match command {
            Command::Continue | Command::Stop | Command::Panel(_) => {}
            Command::Step => o.step = true,
            Command::Next => o.to_next_break = true,
            Command::Skip => o.skip = hit.map(|h| (h.file.clone(), h.line)),
        }
    }

    /// The feeder's view of the orders (it clears what it used).
    pub fn orders(&self) -> MutexGuard<'_, Orders> {
        Self::lock(&self.orders)
    }

    /// The feeder inserted a hold at `hit`.
    pub fn set_hit(&self, hit: BreakHit) {
        *Self::lock(&self.hit) = Some(hit);
    }

    /// The last hold the feeder inserted.
    pub fn hit(&self) -> Option<BreakHit> {
        Self::lock(&self.hit).clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_parse_and_bad_ones_say_what_is_expected() {
        assert_eq!(Command::parse(""), Ok(Command::Continue));
        assert_eq!(Command::parse(" STEP \n"), Ok(Command::Step));
        assert_eq!(Command::parse("n"), Ok(Command::Next));
        assert_eq!(Command::parse("skip"), Ok(Command::Skip));
        assert_eq!(Command::parse("stop"), Ok(Command::Stop));
        let e = Command::parse("jump").unwrap_err();
        assert!(e.contains("\"jump\"") && e.contains("step"), "{e}");
    }
}
