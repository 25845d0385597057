//! The operator at program stops and breaks: each M0/M1 the loop reached is logged,
//! announced on the terminal ("M0 at file:line — press Enter to continue"), each break or
//! single-block hold announced with where the machine is, and a hold is released from a
//! thread that reads the operator's commands (`operator::CommandInput`: the terminal, a pipe
//! or a command file; Enter continues, end of input ends the program there). What each stop
//! did becomes the report's `stops`; breaks, commands and messages its `breaks`, `commands`
//! and `messages`.

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use cnc402_motion::StopKind;

use crate::operator::{
    BreakHit, BreakRecord, COMMANDS, Command, CommandInput, CommandRecord, MessageRecord,
    OperatorLog, OperatorShared, Panel, Read,
};
use crate::program_stop::{StopDecision, StopGate, StopRecord, kind_name};

/// The program stops of one run as the operator meets them.
pub(super) struct OperatorPrompt {
    gate: Arc<StopGate>,
    /// `Continue` was chosen only because no terminal is attached: each stop says so.
    no_operator_terminal: bool,
    stops: Vec<StopRecord>,
    /// Where commands come from.
    input: Arc<CommandInput>,
    /// The orders the feeder follows and the break it inserted last.
    pub(super) shared: Arc<OperatorShared>,
    /// Breaks, commands, messages (commands are added by the operator's thread).
    log: Arc<Mutex<OperatorLog>>,
    /// Every hold asked for, in order: true for a break (the gate's waits are in this order).
    holds: Vec<bool>,
    /// Feed hold and overrides: panel commands read at a hold act on it at once.
    pub(super) panel: Arc<Panel>,
}

fn lock(log: &Mutex<OperatorLog>) -> MutexGuard<'_, OperatorLog> {
    log.lock().unwrap_or_else(|e| e.into_inner())
}

impl OperatorPrompt {
    pub(super) fn new(
        gate: Arc<StopGate>,
        no_operator_terminal: bool,
        input: Arc<CommandInput>,
        shared: Arc<OperatorShared>,
        panel: Arc<Panel>,
    ) -> OperatorPrompt {
        OperatorPrompt {
            gate,
            no_operator_terminal,
            stops: Vec::new(),
            input,
            shared,
            log: Arc::default(),
            holds: Vec::new(),
            panel,
        }
    }

    /// A message of the program reached: on stderr and in the report.
    pub(super) fn message(&mut self, file: String, line: u32, text: String) {
        eprintln!("{file}:{line}: MSG: {text}");
        lock(&self.log)
            .messages
            .push(MessageRecord { file, line, text });
    }

    /// Notes the block search's range for the report.
    pub(super) fn set_search(&mut self, range: String) {
        lock(&self.log).search = Some(range);
    }

    /// A program stop reached at `tick` that is move number `index`: the operator's hold
    /// (a break, a single-block step) or the program's own M0/M1. `block` gives a line's
    /// text, `position` where the machine stands.
    pub(super) fn hold_reached(
        &mut self,
        (line, tick, index): (u32, u64, u64),
        kind: StopKind,
        file: impl FnOnce() -> String,
        block: impl FnOnce(&str, u32) -> String,
        position: String,
    ) {
        if !self.gate.is_break(index) {
            return self.stop_reached(line, kind, file, tick);
        }
        let Some(hit) = self.shared.hit() else {
            return self.stop_reached(line, kind, file, tick);
        };
        let mut n = hit.n.map(|n| format!(" N{n}")).unwrap_or_default();
        if hit.after_tap {
            n.push_str(" (due inside a rigid tap: held after the tap out)");
        }
        eprintln!(
            "{} at {}:{}{n}: {} | {position} — {COMMANDS}?",
            hit.reason,
            hit.file,
            hit.line,
            block(&hit.file, hit.line).trim()
        );
        lock(&self.log).breaks.push(BreakRecord {
            hit: hit.clone(),
            at_tick: tick,
        });
        self.ask_operator(Some(hit), tick);
    }

    /// The gate the loop holds at and the feeder waits behind.
    pub(super) fn gate(&self) -> &Arc<StopGate> {
        &self.gate
    }

    /// A stop of `kind` at `line` reached by the loop; `file` names the source it came from.
    /// Recorded, and with a hold the operator is asked from a thread of its own.
    fn stop_reached(
        &mut self,
        line: u32,
        kind: StopKind,
        file: impl FnOnce() -> String,
        tick: u64,
    ) {
        self.hold_at(line, kind, kind_name(kind), None, file, tick);
    }

    /// A manual tool change (M6 with `tool_change = "manual"`) reached: held as M0 is
    /// (the loop released the tool clamp), "insert tool T… (file:line), then continue".
    pub(super) fn tool_change(&mut self, line: u32, tool: u32, file: String, tick: u64) {
        self.hold_at(line, StopKind::Program, "M6", Some(tool), || file, tick);
    }

    /// A stop named `name` (M0, M1, a manual M6 for `tool`) as the gate decides a stop of
    /// `kind`.
    fn hold_at(
        &mut self,
        line: u32,
        kind: StopKind,
        name: &'static str,
        tool: Option<u32>,
        file: impl FnOnce() -> String,
        tick: u64,
    ) {
        let decision = self.gate.decide(kind);
        let waited_s = match decision {
            StopDecision::Pass => {
                // M2/M30 end the program on their own and are not program stops.
                if kind == StopKind::Optional {
                    log::info!("line {line}: {name} passed (optional stop off)");
                }
                return;
            }
            StopDecision::Continue => {
                let file = file();
                if self.no_operator_terminal {
                    eprintln!(
                        "{name} at {file}:{line} passed: no operator terminal is attached (stdin \
                         is not a terminal; --at-stop wait or end to stop there)"
                    );
                }
                log::info!("{file}:{line}: {name} (continuing)");
                Some(0.0)
            }
            StopDecision::End => {
                log::info!("{}:{line}: {name}: the program ends here", file());
                None
            }
            StopDecision::Hold => {
                match tool {
                    Some(t) => eprintln!(
                        "insert tool T{t} ({}:{line}), then continue — press Enter or give \
                         `continue`, Ctrl-C to stop",
                        file()
                    ),
                    None => eprintln!(
                        "{name} at {}:{line} — press Enter to continue, Ctrl-C to stop",
                        file()
                    ),
                }
                self.ask_operator(None, tick);
                None
            }
        };
        self.stops.push(StopRecord {
            line,
            kind: name,
            waited_s,
            action: decision.action(),
        });
    }

    /// Waits for the operator on a thread of its own (the loop holds meanwhile): a command
    /// resumes (and orders the feeder) or ends the program here (`stop`), end of input ends
    /// it here; a bad command is asked again, or from a command file ends the run (the CLI
    /// exits 64).
    fn ask_operator(&mut self, hit: Option<BreakHit>, tick: u64) {
        self.holds.push(hit.is_some());
        let (gate, input, shared, log, panel) = (
            self.gate.clone(),
            self.input.clone(),
            self.shared.clone(),
            self.log.clone(),
            self.panel.clone(),
        );
        let t0 = std::time::Instant::now();
        let spawned = std::thread::Builder::new()
            .name("cnc402-operator".into())
            .spawn(move || {
                // Each turn reads one more line of the input: it ends with the input.
                loop {
                    match input.next() {
                        Read::Command(Command::Panel(p), input_line) => {
                            // Acts on the panel and answers no hold: read on.
                            panel.apply(p.action, input_line);
                            eprintln!("{}: {}", p.action.name(), crate::operator::describe(&panel));
                        }
                        Read::Command(c, input_line) => {
                            let mut l = lock(&log);
                            l.commands.push(CommandRecord {
                                command: c.name(),
                                input_line,
                                at_tick: tick,
                            });
                            if c == Command::Stop {
                                l.stopped_by_operator = true;
                                drop(l);
                                eprintln!("stop: the program ends here (controlled stop)");
                                gate.end_here(t0.elapsed().as_secs_f64());
                            } else {
                                drop(l);
                                shared.order(c, hit.as_ref());
                                gate.resume(t0.elapsed().as_secs_f64());
                            }
                            return;
                        }
                        Read::Bad { message, fatal } => {
                            eprintln!("{message} (nothing moves)");
                            if fatal {
                                lock(&log).command_error = Some(message);
                                gate.end_here(t0.elapsed().as_secs_f64());
                                return;
                            }
                        }
                        Read::Eof => {
                            // A Ctrl-C closes a piped input too: let the stop win.
                            std::thread::sleep(Duration::from_millis(50));
                            if crate::rt::sigint_seen() {
                                return;
                            }
                            eprintln!(
                                "no operator input (end of input): the program ends at this stop"
                            );
                            gate.end_here(t0.elapsed().as_secs_f64());
                            return;
                        }
                    }
                }
            });
        if let Err(e) = spawned {
            log::error!("cannot wait for the operator ({e}): the program ends here");
            self.gate.end_here(0.0);
        }
    }

    /// What the operator side recorded, for the report.
    pub(super) fn operator_log(&self) -> OperatorLog {
        lock(&self.log).clone()
    }

    /// The report's stops: each hold with the wait the operator took (the last one `end`
    /// when the operator ended the program there).
    pub(super) fn records(&self) -> Vec<StopRecord> {
        // The gate records a wait for every hold; the breaks' are not program stops.
        let all = self.gate.waits();
        let waits: Vec<f64> = all
            .iter()
            .zip(&self.holds)
            .filter(|(_, is_break)| !**is_break)
            .map(|(w, _)| *w)
            .collect();
        let ended_at_stop = self.holds.get(all.len().wrapping_sub(1)) == Some(&false);
        let mut wi = 0;
        self.stops
            .iter()
            .map(|r| {
                let mut r = r.clone();
                if r.action == StopDecision::Hold.action() {
                    r.waited_s = waits.get(wi).copied();
                    wi += 1;
                    if r.waited_s.is_some()
                        && self.gate.end_requested()
                        && ended_at_stop
                        && wi == waits.len()
                    {
                        r.action = StopDecision::End.action();
                    }
                }
                r
            })
            .collect()
    }
}
