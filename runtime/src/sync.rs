//! The feeder thread and motion sync: the interpreter and planner run on a thread of their own,
//! pushing planned moves into the move ring, so that a read of an actual position (`#5021`,
//! `@ITPPATH`) can block until the machine has executed every move before it — the
//! [`MotionSync`] the interpreter calls — while the loop and the reporting side go on. The
//! reporting side publishes what the loop did into [`SyncShared`] after each drained batch.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration;

use cnc402_interp::MotionSync;
use cnc402_lang::NcError;
use cnc402_motion::{AxisPos, Lookahead};

use crate::feeder::Feeder;
use crate::program_stop::{StopDecision, StopGate};
use crate::ring::{LoopInput, MoveProducer, Producer};
use crate::status::{Phase, Status, within_one_count};

/// Idle ticks after which the machine counts as settled even if a drive has not come within
/// one count of its setpoint.
pub const SETTLE_LIMIT_TICKS: u32 = 100;

/// What the loop has done, as last drained.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoopProgress {
    /// Moves the loop has taken from the ring.
    pub moves_started: u64,
    /// The interpolator had nothing to do after the last tick.
    pub idle: bool,
    /// Consecutive idle ticks.
    pub idle_ticks: u32,
    /// Every drive within one count of its setpoint.
    pub settled: bool,
    /// Actual positions of the last tick.
    pub actual: AxisPos,
    /// Commanded path length so far (mm over the linear axes).
    pub path_length: f64,
    /// The loop left the running phase (stop, fault, end).
    pub ended: bool,
}

/// Shared between the feeder thread, the reporting side and the interpreter's motion sync.
#[derive(Default)]
pub struct SyncShared {
    progress: Mutex<LoopProgress>,
    changed: Condvar,
    /// The interpreter waits for motion (so virtual time must keep running).
    pub waiting: AtomicBool,
    /// Moves pushed into the ring by the feeder.
    pub pushed: AtomicU64,
    /// The feeder must give up (the run is over).
    pub abort: AtomicBool,
    /// Operator messages in program order.
    messages: Mutex<VecDeque<String>>,
    /// (first move number, file) wherever the source file of the moves changes (includes,
    /// sub-programs in other files).
    files: Mutex<Vec<(u64, Arc<str>)>>,
}

impl SyncShared {
    fn lock(&self) -> MutexGuard<'_, LoopProgress> {
        self.progress.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Publishes the loop's progress: the last drained status, the consecutive idle ticks up
    /// to it, and the commanded path length.
    pub fn publish(&self, s: &Status, idle_ticks: u32, n_axes: usize, path_length: f64) {
        let mut p = self.lock();
        p.idle_ticks = idle_ticks;
        p.moves_started = s.moves_started;
        p.idle = s.idle;
        p.settled = (0..n_axes).all(|i| within_one_count(s.act_counts[i], s.cmd_counts[i]));
        p.actual = AxisPos(s.act);
        p.path_length = path_length;
        p.ended |= s.phase != Phase::Running;
        drop(p);
        self.changed.notify_all();
    }

    /// Marks the run over (wakes a waiting interpreter with an error).
    pub fn end(&self) {
        self.lock().ended = true;
        self.abort.store(true, Ordering::SeqCst);
        self.changed.notify_all();
    }

    /// The actual positions of the last drained tick.
    pub fn actual(&self) -> AxisPos {
        self.lock().actual
    }

    /// The loop left the running phase (stop, fault, end) or the run is over.
    pub fn has_ended(&self) -> bool {
        self.lock().ended || self.abort.load(Ordering::SeqCst)
    }

    /// True when every move pushed so far has run and the machine has settled.
    pub fn motion_done(&self) -> bool {
        Self::done(&self.lock(), self.pushed.load(Ordering::SeqCst))
    }

    fn done(p: &LoopProgress, pushed: u64) -> bool {
        p.moves_started >= pushed && p.idle && (p.settled || p.idle_ticks >= SETTLE_LIMIT_TICKS)
    }

    /// The file move number `index` (1-based) came from, if the feeder recorded one.
    pub fn file_of(&self, index: u64) -> Option<Arc<str>> {
        let files = self.files.lock().unwrap_or_else(|e| e.into_inner());
        files
            .iter()
            .rev()
            .find(|(i, _)| *i <= index)
            .map(|(_, f)| f.clone())
    }

    /// The next operator message.
    pub fn take_message(&self) -> Option<String> {
        self.messages
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .pop_front()
    }
}

/// The interpreter's [`MotionSync`] for a running machine.
pub struct LoopSync {
    pub shared: Arc<SyncShared>,
    /// The lookahead and the ring: the blocks it holds are planned to rest and sent before
    /// waiting, so the read sees the machine where the program put it.
    pub flush: Option<FlushTarget>,
}

/// The feeder's lookahead and the move ring it fills (see [`LoopSync::flush`]).
pub type FlushTarget = (Arc<Mutex<Lookahead>>, Arc<Mutex<MoveProducer>>);

impl LoopSync {
    /// Plans what the lookahead holds to rest and pushes it into the ring.
    fn flush(&self) -> Result<(), String> {
        let Some((look, ring)) = &self.flush else {
            return Ok(());
        };
        let mut look = crate::feeder::lock(look);
        look.finish().map_err(|e| e.to_string())?;
        while let Some(mv) = look.pop() {
            if !push_waiting(
                &mut ring.lock().unwrap_or_else(|e| e.into_inner()),
                LoopInput::Move(mv),
                &self.shared,
            ) {
                return Err("the machine stopped before the motion finished".to_string());
            }
            self.shared.pushed.fetch_add(1, Ordering::SeqCst);
        }
        Ok(())
    }
}

/// Pushes `item`, waiting for room; false when the run ended meanwhile.
fn push_waiting(ring: &mut MoveProducer, mut item: LoopInput, shared: &SyncShared) -> bool {
    loop {
        match ring.try_push(item) {
            Ok(()) => return true,
            Err(back) => {
                if shared.abort.load(Ordering::SeqCst) || shared.lock().ended {
                    return false;
                }
                item = back;
                std::thread::sleep(Duration::from_micros(200));
            }
        }
    }
}

impl MotionSync for LoopSync {
    fn wait_motion_done(&mut self, _programmed: &AxisPos) -> Result<AxisPos, String> {
        self.flush()?;
        let sh = &self.shared;
        sh.waiting.store(true, Ordering::SeqCst);
        let mut p = sh.lock();
        let r = loop {
            if Self::ready(&p, sh) {
                break Ok(p.actual);
            }
            if p.ended {
                break Err("the machine stopped before the motion finished".to_string());
            }
            p = match sh.changed.wait_timeout(p, Duration::from_millis(20)) {
                Ok((g, _)) => g,
                Err(e) => e.into_inner().0,
            };
        };
        drop(p);
        sh.waiting.store(false, Ordering::SeqCst);
        r
    }

    fn path_length_done(&mut self, _produced: f64) -> f64 {
        self.shared.lock().path_length
    }
}

impl LoopSync {
    fn ready(p: &LoopProgress, sh: &SyncShared) -> bool {
        SyncShared::done(p, sh.pushed.load(Ordering::SeqCst))
    }
}

/// What the feeder does after pushing a program stop (M0, M1 with optional stop on).
#[derive(Debug, PartialEq)]
enum AfterStop {
    /// Not a stop of this run's policy: interpret on.
    GoOn,
    /// Wait: interpret nothing past the stop until the loop has held there and the operator
    /// resumed (a buffer stop, as Fanuc's M00 is: what the operator changes during the stop,
    /// such as a `cnc402 vars set`, is what the program reads after it).
    Hold,
    /// End: the program ends at the stop, so nothing after it may be interpreted (a
    /// non-volatile write or an alarm past the stop must not happen).
    EndHere,
}

fn after_stop_of(d: StopDecision) -> AfterStop {
    match d {
        StopDecision::Hold => AfterStop::Hold,
        StopDecision::End => AfterStop::EndHere,
        StopDecision::Pass | StopDecision::Continue => AfterStop::GoOn,
    }
}

/// What the feeder does after pushing `mv`: a program stop (or a manual M6) the gate holds
/// or ends at is a buffer stop.
fn after_stop(mv: &cnc402_motion::PlannedMove, gate: Option<&StopGate>) -> AfterStop {
    match (mv.kind, gate) {
        (cnc402_motion::MoveKind::ProgramStop { kind }, Some(g)) => after_stop_of(g.decide(kind)),
        (cnc402_motion::MoveKind::ToolChange { .. }, Some(g)) if g.manual_tool_change() => {
            after_stop_of(g.decide(cnc402_motion::StopKind::Program))
        }
        _ => AfterStop::GoOn,
    }
}

/// Starts the feeder thread: it runs `feeder` to the end of the program, pushing every move
/// (and `End`) into `ring`, waiting for room as needed. With a stop `gate`, a program stop
/// that holds or ends the run is also a buffer stop (see [`AfterStop`]). A program error
/// raises `stop` and is the thread's result.
pub fn spawn_feeder(
    mut feeder: Feeder,
    ring: MoveProducer,
    shared: Arc<SyncShared>,
    stop: Arc<AtomicBool>,
    gate: Option<Arc<StopGate>>,
) -> std::io::Result<JoinHandle<Option<NcError>>> {
    let ring = Arc::new(Mutex::new(ring));
    sync_to(&mut feeder, &ring, shared.clone());
    std::thread::Builder::new()
        .name("cnc402-feeder".into())
        .spawn(move || {
            let to = FeedTo {
                ring: &ring,
                shared: &shared,
                stop: &stop,
                gate: gate.as_deref(),
                cancel: None,
            };
            feed(&mut feeder, to, true)
        })
}

/// Where [`feed`] sends a program's moves and what it answers to.
pub struct FeedTo<'a> {
    pub ring: &'a Arc<Mutex<MoveProducer>>,
    pub shared: &'a SyncShared,
    /// Raised on a program error (stops the machine).
    pub stop: &'a AtomicBool,
    pub gate: Option<&'a StopGate>,
    /// Raised to abandon the program (a channel reset).
    pub cancel: Option<&'a AtomicBool>,
}

/// Makes `ring` (shared with the motion sync's flush) the target of `feeder`'s motion sync.
pub fn sync_to(feeder: &mut Feeder, ring: &Arc<Mutex<MoveProducer>>, shared: Arc<SyncShared>) {
    feeder.set_motion_sync(Box::new(LoopSync {
        shared,
        flush: Some((feeder.lookahead(), ring.clone())),
    }));
}

/// Runs `feeder` to the end of its program on the calling thread, pushing every move into
/// the ring (and `End` after the last when `end`), as [`spawn_feeder`] describes.
pub fn feed(feeder: &mut Feeder, to: FeedTo, end: bool) -> Option<NcError> {
    let FeedTo {
        ring,
        shared,
        stop,
        gate,
        cancel,
    } = to;
    let push = |ring: &Mutex<MoveProducer>, item: LoopInput| -> bool {
        push_waiting(
            &mut ring.lock().unwrap_or_else(|e| e.into_inner()),
            item,
            shared,
        )
    };
    let mut holds = 0u64;
    loop {
        let cancelled = cancel.is_some_and(|c| c.load(Ordering::SeqCst));
        if shared.abort.load(Ordering::SeqCst) || cancelled {
            return None;
        }
        let next = feeder.next_move();
        while let Some(t) = feeder.take_message() {
            shared
                .messages
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .push_back(t);
        }
        match next {
            Ok(Some(mv)) => {
                let index = shared.pushed.load(Ordering::SeqCst) + 1;
                let is_break = feeder.take_break().is_some();
                if let (true, Some(g)) = (is_break, gate) {
                    g.arm_break(index);
                }
                if let Some(f) = feeder.last_file() {
                    let mut files = shared.files.lock().unwrap_or_else(|e| e.into_inner());
                    if files.last().is_none_or(|(_, last)| last != f) {
                        files.push((index, f.clone()));
                    }
                }
                if !push(ring, LoopInput::Move(mv)) {
                    return None;
                }
                shared.pushed.fetch_add(1, Ordering::SeqCst);
                let after = if is_break {
                    AfterStop::Hold
                } else {
                    after_stop(&mv, gate)
                };
                match after {
                    AfterStop::GoOn => {}
                    AfterStop::EndHere => return None,
                    AfterStop::Hold => {
                        holds += 1;
                        let Some(g) = gate else {
                            continue;
                        };
                        // Until the loop has reached this hold and it is released.
                        loop {
                            if shared.abort.load(Ordering::SeqCst)
                                || shared.lock().ended
                                || g.end_requested()
                            {
                                return None;
                            }
                            if g.holds_reached() >= holds && g.released() {
                                break;
                            }
                            std::thread::sleep(Duration::from_millis(1));
                        }
                        if let Err(e) = feeder.reload_persistent_vars(mv.line) {
                            stop.store(true, Ordering::SeqCst);
                            return Some(e);
                        }
                    }
                }
            }
            Ok(None) => {
                if end {
                    push(ring, LoopInput::End);
                }
                return None;
            }
            Err(e) => {
                if shared.abort.load(Ordering::SeqCst) || shared.lock().ended {
                    // The machine stopped under a waiting read: not a program error.
                    return None;
                }
                stop.store(true, Ordering::SeqCst);
                return Some(e);
            }
        }
    }
}
