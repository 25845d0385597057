//! Program stops (M0, and M1 with optional stop on): the policy of a run, the one decision of
//! what a stop does ([`StopPolicy::decide`], used by the dry run, the feeder, the loop and the
//! report), and the gate that the loop holds at. The loop only reads and writes atomics here
//! (no lock, no allocation); the reporting side prompts the operator and records the waits.

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use cnc402_motion::StopKind;

/// What a run does at M0 (and at M1 when optional stop is on).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum AtStop {
    /// Hold there (drives enabled, position held, monitors active) until resumed.
    Wait,
    /// Log the stop and go on (no hold).
    #[default]
    Continue,
    /// End the program there cleanly: settle, disable, report `ok`.
    End,
}

impl AtStop {
    /// The policy of a run: the one asked for (`--at-stop`), otherwise `Wait` when an operator
    /// terminal is attached to press Enter and `Continue` when none is. The flag is true when
    /// `Continue` was chosen only for want of a terminal (each stop passed then says so).
    pub fn for_run(asked: Option<AtStop>, operator_terminal: bool) -> (AtStop, bool) {
        match asked {
            Some(a) => (a, false),
            None if operator_terminal => (AtStop::Wait, false),
            None => (AtStop::Continue, true),
        }
    }
}

/// The program-stop settings of a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct StopPolicy {
    /// What M0 (and M1 with `optional_stop`) does.
    pub at_stop: AtStop,
    /// M1 stops like M0 (off: M1 passes).
    pub optional_stop: bool,
}

/// What one stop of the program does under a run's [`StopPolicy`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopDecision {
    /// Not a program stop of this run: M1 with optional stop off, and M2/M30 (they end the
    /// program on their own).
    Pass,
    /// Log it and go on.
    Continue,
    /// Hold the machine there until the operator resumes or ends the program.
    Hold,
    /// The program ends there: nothing after it may be interpreted, not even by the dry run.
    End,
}

impl StopDecision {
    /// The report's name of what was done ("wait", "continue", "end"; "pass" is never
    /// recorded).
    pub fn action(self) -> &'static str {
        match self {
            StopDecision::Pass => "pass",
            StopDecision::Continue => "continue",
            StopDecision::Hold => "wait",
            StopDecision::End => "end",
        }
    }
}

impl StopPolicy {
    /// What a stop of `kind` does: M0 always stops, M1 only with optional stop on, and a stop
    /// does what the policy says.
    pub fn decide(&self, kind: StopKind) -> StopDecision {
        let stops = match kind {
            StopKind::Program => true,
            StopKind::Optional => self.optional_stop,
            // A channel wait is released by the other channels, never by the operator.
            StopKind::End | StopKind::EndRewind | StopKind::WaitMark { .. } => false,
        };
        match (stops, self.at_stop) {
            (false, _) => StopDecision::Pass,
            (true, AtStop::Continue) => StopDecision::Continue,
            (true, AtStop::Wait) => StopDecision::Hold,
            (true, AtStop::End) => StopDecision::End,
        }
    }
}

/// One program stop as the report shows it.
#[derive(Clone, Debug, PartialEq)]
pub struct StopRecord {
    /// Source line of the M0/M1 block.
    pub line: u32,
    /// "M0" or "M1".
    pub kind: &'static str,
    /// Seconds the machine held there (wall clock; 0 with `continue`, `None` for the stop
    /// the program ended at).
    pub waited_s: Option<f64>,
    /// What was done: "wait", "continue" or "end".
    pub action: &'static str,
}

/// Shared between the loop, the reporting side and the operator's resume.
#[derive(Debug, Default)]
pub struct StopGate {
    policy: StopPolicy,
    /// Holds the loop reached (counted by the loop).
    reached: AtomicU64,
    /// Resumes given (counted by the operator side).
    resumed: AtomicU64,
    /// End the program at the current hold instead of resuming.
    end: AtomicBool,
    /// Wall-clock seconds of each finished wait, in order (never touched by the loop).
    waits: Mutex<Vec<f64>>,
    /// The move number (1-based) of the program stop the feeder inserted for a breakpoint or
    /// single block, 0 for none: it holds whatever the policy. One at a time: the feeder
    /// interprets nothing past it until it is released.
    break_at: AtomicU64,
    /// `tool_change = "manual"`: M6 is a program stop too (the feeder interprets nothing
    /// past it until the operator has changed the tool and resumed).
    manual_tool_change: bool,
}

impl StopGate {
    /// This gate with M6 a program stop (`[machine] tool_change = "manual"`).
    pub fn with_manual_tool_change(mut self, manual: bool) -> StopGate {
        self.manual_tool_change = manual;
        self
    }

    /// Whether M6 is a program stop.
    pub fn manual_tool_change(&self) -> bool {
        self.manual_tool_change
    }

    /// A gate for `policy`; `optional_stop` makes M1 act like M0 (otherwise M1 passes).
    pub fn new(at_stop: AtStop, optional_stop: bool) -> StopGate {
        StopGate {
            policy: StopPolicy {
                at_stop,
                optional_stop,
            },
            ..StopGate::default()
        }
    }

    /// The run's policy.
    pub fn policy(&self) -> AtStop {
        self.policy.at_stop
    }

    /// What a stop of `kind` does in this run ([`StopPolicy::decide`]).
    pub fn decide(&self, kind: StopKind) -> StopDecision {
        self.policy.decide(kind)
    }

    /// Whether a stop of `kind` stops the program (M0 always, M1 with optional stop on;
    /// M2/M30 end the program anyway and are not program stops here).
    pub fn applies(&self, kind: StopKind) -> bool {
        self.decide(kind) != StopDecision::Pass
    }

    /// Whether a stop of `kind` ends the program (policy `End`).
    pub fn ends_at(&self, kind: StopKind) -> bool {
        self.decide(kind) == StopDecision::End
    }

    /// Whether a stop of `kind` holds the machine until the operator decides (policy `Wait`).
    pub fn holds_at(&self, kind: StopKind) -> bool {
        self.decide(kind) == StopDecision::Hold
    }

    /// Loop side: a hold begins.
    pub fn hold(&self) {
        self.reached.fetch_add(1, Ordering::SeqCst);
    }

    /// Holds the loop has begun so far.
    pub fn holds_reached(&self) -> u64 {
        self.reached.load(Ordering::SeqCst)
    }

    /// Loop side: whether the current hold is released (resumed, or ended).
    pub fn released(&self) -> bool {
        self.resumed.load(Ordering::SeqCst) >= self.reached.load(Ordering::SeqCst)
    }

    /// Loop side: whether the program is to end at the current hold.
    pub fn end_requested(&self) -> bool {
        self.end.load(Ordering::SeqCst)
    }

    /// Operator side: go on from the current hold; `waited_s` is recorded for the report.
    pub fn resume(&self, waited_s: f64) {
        if let Ok(mut w) = self.waits.lock() {
            w.push(waited_s);
        }
        self.resumed.fetch_add(1, Ordering::SeqCst);
    }

    /// Operator side: end the program at the current hold (it settles and reports ok).
    pub fn end_here(&self, waited_s: f64) {
        if let Ok(mut w) = self.waits.lock() {
            w.push(waited_s);
        }
        self.end.store(true, Ordering::SeqCst);
    }

    /// Feeder side: move number `index` is a hold of the operator's (breakpoint, step).
    pub fn arm_break(&self, index: u64) {
        self.break_at.store(index, Ordering::SeqCst);
    }

    /// Whether the program stop that is move number `index` is the operator's hold.
    pub fn is_break(&self, index: u64) -> bool {
        index != 0 && self.break_at.load(Ordering::SeqCst) == index
    }

    /// What the program stop of `kind` that is move number `index` does: the operator's
    /// holds always hold, the program's own stops as [`decide`](Self::decide) says.
    pub fn decide_at(&self, kind: StopKind, index: u64) -> StopDecision {
        if self.is_break(index) {
            StopDecision::Hold
        } else {
            self.decide(kind)
        }
    }

    /// The recorded waits so far.
    pub fn waits(&self) -> Vec<f64> {
        self.waits.lock().map(|w| w.clone()).unwrap_or_default()
    }
}

/// The M code of a stop kind.
pub fn kind_name(kind: StopKind) -> &'static str {
    match kind {
        StopKind::Program => "M0",
        StopKind::Optional => "M1",
        StopKind::End => "M2",
        StopKind::EndRewind => "M30",
        StopKind::WaitMark { .. } => "channel wait",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gate_holds_until_resumed_and_m1_needs_optional_stop() {
        let g = StopGate::new(AtStop::Wait, false);
        assert!(g.applies(StopKind::Program));
        assert!(!g.applies(StopKind::Optional));
        assert!(!g.applies(StopKind::End));
        assert!(StopGate::new(AtStop::Wait, true).applies(StopKind::Optional));
        assert!(g.released());
        g.hold();
        assert!(!g.released());
        g.resume(0.25);
        assert!(g.released());
        g.hold();
        assert!(!g.released() && !g.end_requested());
        g.end_here(1.0);
        assert!(g.end_requested());
        assert_eq!(g.waits(), vec![0.25, 1.0]);
    }

    #[test]
    fn one_decision_per_kind_and_policy() {
        use StopDecision::*;
        let kinds = [
            StopKind::Program,
            StopKind::Optional,
            StopKind::End,
            StopKind::EndRewind,
        ];
        let decide = |at_stop, optional_stop| {
            let p = StopPolicy {
                at_stop,
                optional_stop,
            };
            kinds.map(|k| p.decide(k))
        };
        assert_eq!(decide(AtStop::Wait, false), [Hold, Pass, Pass, Pass]);
        assert_eq!(decide(AtStop::Wait, true), [Hold, Hold, Pass, Pass]);
        assert_eq!(
            decide(AtStop::Continue, true),
            [Continue, Continue, Pass, Pass]
        );
        assert_eq!(decide(AtStop::End, false), [End, Pass, Pass, Pass]);
        let g = StopGate::new(AtStop::End, true);
        assert!(g.ends_at(StopKind::Optional) && !g.holds_at(StopKind::Optional));
        assert!(!g.applies(StopKind::EndRewind));
    }

    #[test]
    fn a_run_waits_only_with_an_operator_terminal_unless_told() {
        assert_eq!(AtStop::for_run(None, true), (AtStop::Wait, false));
        assert_eq!(AtStop::for_run(None, false), (AtStop::Continue, true));
        assert_eq!(
            AtStop::for_run(Some(AtStop::End), false),
            (AtStop::End, false)
        );
        assert_eq!(
            AtStop::for_run(Some(AtStop::Continue), true),
            (AtStop::Continue, false)
        );
    }
}
