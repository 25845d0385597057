//! Program stops (M0, and M1 with optional stop on): the policy of a run and the gate that the
//! loop holds at. The loop only reads and writes atomics here (no lock, no allocation); the
//! reporting side prompts the operator and records how long each stop waited.

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
    policy: AtStop,
    optional_stop: bool,
    /// Holds the loop reached (counted by the loop).
    reached: AtomicU64,
    /// Resumes given (counted by the operator side).
    resumed: AtomicU64,
    /// End the program at the current hold instead of resuming.
    end: AtomicBool,
    /// Wall-clock seconds of each finished wait, in order (never touched by the loop).
    waits: Mutex<Vec<f64>>,
}

impl StopGate {
    /// A gate for `policy`; `optional_stop` makes M1 act like M0 (otherwise M1 passes).
    pub fn new(policy: AtStop, optional_stop: bool) -> StopGate {
        StopGate {
            policy,
            optional_stop,
            ..StopGate::default()
        }
    }

    /// The run's policy.
    pub fn policy(&self) -> AtStop {
        self.policy
    }

    /// Whether a stop of `kind` stops the program (M0 always, M1 with optional stop on;
    /// M2/M30 end the program anyway and are not program stops here).
    pub fn applies(&self, kind: StopKind) -> bool {
        match kind {
            StopKind::Program => true,
            StopKind::Optional => self.optional_stop,
            _ => false,
        }
    }

    /// Whether a stop of `kind` ends the program (policy `End`): nothing after it may be
    /// interpreted, not even by the dry run.
    pub fn ends_at(&self, kind: StopKind) -> bool {
        self.policy == AtStop::End && self.applies(kind)
    }

    /// Whether a stop of `kind` holds the machine until the operator decides (policy `Wait`).
    pub fn holds_at(&self, kind: StopKind) -> bool {
        self.policy == AtStop::Wait && self.applies(kind)
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
}
