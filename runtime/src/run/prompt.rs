//! The operator at program stops: each M0/M1 the loop reached is logged, announced on the
//! terminal ("M0 at file:line — press Enter to continue") and, when it holds, released from a
//! thread that reads stdin (Enter resumes, end of input ends the program there). What each
//! stop did becomes the report's `stops`.

use std::sync::Arc;
use std::time::Duration;

use cnc402_motion::StopKind;

use crate::program_stop::{StopDecision, StopGate, StopRecord, kind_name};

/// The program stops of one run as the operator meets them.
pub(super) struct OperatorPrompt {
    gate: Arc<StopGate>,
    /// `Continue` was chosen only because no terminal is attached: each stop says so.
    no_operator_terminal: bool,
    stops: Vec<StopRecord>,
}

impl OperatorPrompt {
    pub(super) fn new(gate: Arc<StopGate>, no_operator_terminal: bool) -> OperatorPrompt {
        OperatorPrompt {
            gate,
            no_operator_terminal,
            stops: Vec::new(),
        }
    }

    /// The gate the loop holds at and the feeder waits behind.
    pub(super) fn gate(&self) -> &Arc<StopGate> {
        &self.gate
    }

    /// A stop of `kind` at `line` reached by the loop; `file` names the source it came from.
    /// Recorded, and with a hold the operator is asked from a thread of its own.
    pub(super) fn stop_reached(
        &mut self,
        line: u32,
        kind: StopKind,
        file: impl FnOnce() -> String,
    ) {
        let name = kind_name(kind);
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
                eprintln!(
                    "{name} at {}:{line} — press Enter to continue, Ctrl-C to stop",
                    file()
                );
                self.ask_operator();
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

    /// Waits for the operator on a thread of its own (the loop holds meanwhile): a line on
    /// stdin resumes, end of input ends the program at this stop.
    fn ask_operator(&self) {
        let gate = self.gate.clone();
        let t0 = std::time::Instant::now();
        let spawned = std::thread::Builder::new()
            .name("cnc402-operator".into())
            .spawn(move || {
                let mut buf = String::new();
                match std::io::stdin().read_line(&mut buf) {
                    Ok(n) if n > 0 => gate.resume(t0.elapsed().as_secs_f64()),
                    _ => {
                        // A Ctrl-C closes a piped input too: let the stop win.
                        std::thread::sleep(Duration::from_millis(50));
                        if crate::rt::sigint_seen() {
                            return;
                        }
                        eprintln!(
                            "no operator input (end of input): the program ends at this stop"
                        );
                        gate.end_here(t0.elapsed().as_secs_f64());
                    }
                }
            });
        if let Err(e) = spawned {
            log::error!("cannot wait for the operator ({e}): the program ends here");
            self.gate.end_here(0.0);
        }
    }

    /// The report's stops: each hold with the wait the operator took (the last one `end`
    /// when the operator ended the program there).
    pub(super) fn records(&self) -> Vec<StopRecord> {
        let waits = self.gate.waits();
        let mut wi = 0;
        self.stops
            .iter()
            .map(|r| {
                let mut r = r.clone();
                if r.action == StopDecision::Hold.action() {
                    r.waited_s = waits.get(wi).copied();
                    wi += 1;
                    if r.waited_s.is_some() && self.gate.end_requested() && wi == waits.len() {
                        r.action = StopDecision::End.action();
                    }
                }
                r
            })
            .collect()
    }
}
