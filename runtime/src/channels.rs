//! The runtime's side of `channel_load/run/wait/reset` and `@CH[n]`: a [`ChannelBoard`] per
//! run holds each channel's program queue and state; [`ChannelHost`] is the interpreter's
//! `Channels` for one channel; a resident channel's feeder thread ([`spawn_resident`]) takes
//! the programs started on it one after another, holding position in between. Only the
//! interpreter and feeder threads lock the board; the loop reads [`ChannelSignal`] atomics.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration;

use cnc402_config::{ChannelView, MachineConfig, PROGRAM_EXTENSIONS};
use cnc402_interp::{ChannelMode, ChannelState, Channels, SharedGlobals};
use cnc402_lang::NcError;
use cnc402_motion::AxisPos;

use crate::feeder::{Feeder, ProgramInput};
use crate::program_stop::StopGate;
use crate::ring::MoveProducer;
use crate::sync::{FeedTo, SyncShared, feed, sync_to};

/// What the loop and the board share about one channel, lock-free.
#[derive(Debug, Default)]
pub struct ChannelSignal {
    /// A program is queued or running on it.
    pub busy: AtomicBool,
    /// Its interpreter is blocked in a `channel_wait`/`channel_reset` (virtual time must run).
    pub blocked: AtomicBool,
    /// Asked to stop its motion (`channel_reset`); the loop stops it along its path.
    pub reset: AtomicBool,
    /// The loop ended it for good (a fault or stop): it takes no more programs.
    pub dead: AtomicBool,
    /// At a wait mark (for `@CH[n].STATE` = waiting).
    pub at_mark: AtomicBool,
    /// The line it executes (for messages).
    pub line: AtomicU32,
}

/// One channel's queue and state, behind the board's lock.
#[derive(Debug, Default)]
struct Slot {
    loaded: Option<PathBuf>,
    queued: Option<ProgramInput>,
    /// The last program ended in an error (its text).
    error: Option<String>,
    resetting: bool,
    /// The channel whose end this channel's interpreter waits for.
    waiting_for: Option<usize>,
    /// The program it runs (for messages).
    program: String,
    /// Each program it ran and how it ended, oldest first (at most [`HISTORY`]).
    ran: Vec<String>,
}

/// Most programs a channel's history keeps (a program that starts programs in an endless
/// loop must not grow it without bound).
const HISTORY: usize = 1000;

/// See the module doc.
pub struct ChannelBoard {
    views: Vec<ChannelView>,
    program_dir: PathBuf,
    slots: Mutex<Vec<Slot>>,
    changed: Condvar,
    signals: Vec<Arc<ChannelSignal>>,
    globals: SharedGlobals,
    /// The run is over: no program starts, no wait blocks.
    closed: AtomicBool,
}

/// How long a `channel_wait` or `channel_reset` may block at most (wall clock) before it is
/// an error: a bound, not a timing (a program waits for another channel's whole program).
const WAIT_LIMIT: Duration = Duration::from_secs(24 * 3600);

impl ChannelBoard {
    /// The board of `cfg`'s channels for one run.
    pub fn new(cfg: &MachineConfig) -> Arc<ChannelBoard> {
        let views: Vec<ChannelView> = (0..cfg.channel_count())
            .filter_map(|k| cfg.channel(k))
            .collect();
        let n = views.len();
        Arc::new(ChannelBoard {
            views,
            program_dir: cfg.program_dir(),
            slots: Mutex::new((0..n).map(|_| Slot::default()).collect()),
            changed: Condvar::new(),
            signals: (0..n).map(|_| Arc::default()).collect(),
            globals: SharedGlobals::default(),
            closed: AtomicBool::new(false),
        })
    }

    /// The run is over: waits return (false), starts fail.
    pub fn close(&self) {
        self.closed.store(true, Ordering::SeqCst);
        self.changed.notify_all();
    }

    /// Channel `k`'s signal (the loop's side).
    pub fn signal(&self, k: usize) -> Arc<ChannelSignal> {
        self.signals[k].clone()
    }

    /// The interpreter's `Channels` for a program on channel `k`, and the run's globals.
    pub fn host(self: &Arc<Self>, k: usize) -> (Box<dyn Channels>, SharedGlobals) {
        let host = ChannelHost {
            board: self.clone(),
            this: k,
        };
        (Box::new(host), self.globals.clone())
    }

    /// Queues `input` (given on the command line) as channel `k`'s first program.
    pub fn queue_first(&self, k: usize, input: ProgramInput) {
        let mut slots = self.lock();
        slots[k].program = input.source().name.to_string();
        slots[k].queued = Some(input);
        self.signals[k].busy.store(true, Ordering::SeqCst);
    }

    /// The programs channel `k` ran and how each ended (`program: ok` or `program: error`).
    pub fn history(&self, k: usize) -> Vec<String> {
        self.lock()
            .get(k)
            .map(|s| s.ran.clone())
            .unwrap_or_default()
    }

    fn lock(&self) -> MutexGuard<'_, Vec<Slot>> {
        self.slots.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Waits for the next program queued on channel `k`; `None` once `shared` says the run
    /// is over.
    fn next_program(&self, k: usize, shared: &SyncShared) -> Option<ProgramInput> {
        let mut slots = self.lock();
        loop {
            if shared.abort.load(Ordering::SeqCst) || self.signals[k].dead.load(Ordering::SeqCst) {
                return None;
            }
            if let Some(p) = slots[k].queued.take() {
                return Some(p);
            }
            slots = match self.changed.wait_timeout(slots, Duration::from_millis(20)) {
                Ok((g, _)) => g,
                Err(e) => e.into_inner().0,
            };
        }
    }

    /// Channel `k`'s program ended (`error`: how it failed).
    fn finished(&self, k: usize, error: Option<String>) {
        let mut slots = self.lock();
        let s = &mut slots[k];
        if s.ran.len() < HISTORY {
            let how = error.as_deref().unwrap_or("ok");
            let entry = format!("{}: {how}", s.program);
            s.ran.push(entry);
        }
        s.error = error;
        self.signals[k].busy.store(false, Ordering::SeqCst);
        drop(slots);
        self.changed.notify_all();
    }

    /// The file `program` names, found as `M98` finds programs: next to `main` (the
    /// calling program), then in `program_dir`; without an extension, each program
    /// extension is tried.
    fn find(&self, program: &str, main: &str) -> Option<PathBuf> {
        let p = Path::new(program);
        if p.is_absolute() {
            return p.is_file().then(|| p.to_path_buf());
        }
        let dirs = [
            Path::new(main).parent().map(Path::to_path_buf),
            Some(self.program_dir.clone()),
        ];
        let names: Vec<PathBuf> = if p.extension().is_some() {
            vec![p.to_path_buf()]
        } else {
            let mut v = vec![p.to_path_buf()];
            v.extend(PROGRAM_EXTENSIONS.iter().map(|e| p.with_extension(e)));
            v
        };
        dirs.iter()
            .flatten()
            .flat_map(|d| names.iter().map(move |n| d.join(n)))
            .find(|c| c.is_file())
    }

    /// Whether channel `k` can take a program now: Auto, not running, not in error, alive.
    fn ready(&self, k: usize, slot: &Slot) -> bool {
        self.views[k].mode == cnc402_config::ChannelMode::Auto
            && !self.closed.load(Ordering::SeqCst)
            && !self.signals[k].busy.load(Ordering::SeqCst)
            && !self.signals[k].dead.load(Ordering::SeqCst)
            && slot.error.is_none()
            && !slot.resetting
    }

    /// `program` read and parsed (the check `channel_load` makes); the error as text.
    fn check(program: &Path) -> Result<(), String> {
        let text =
            std::fs::read_to_string(program).map_err(|e| format!("{}: {e}", program.display()))?;
        let src = cnc402_lang::SourceFile::new(program.display().to_string(), text);
        cnc402_lang::parse(&src)
            .map(|_| ())
            .map_err(|e| e.to_string())
    }
}

/// One channel's `Channels` (see the module doc).
pub struct ChannelHost {
    board: Arc<ChannelBoard>,
    this: usize,
}

impl ChannelBoard {
    /// `ch` as a channel the program on `this` may drive: one of the machine's, not its own.
    fn other(&self, this: usize, ch: usize) -> Result<(), String> {
        let count = self.views.len();
        if ch >= count {
            return Err(cnc402_interp::host::channels::no_such_channel(ch, count));
        }
        if ch == this {
            return Err(format!(
                "channel {ch} is the channel running this program: a program cannot load, run, \
                 wait for or reset its own channel"
            ));
        }
        Ok(())
    }

    /// `@CH[ch].MODE`.
    fn mode(&self, ch: usize) -> Result<ChannelMode, String> {
        let view = self
            .views
            .get(ch)
            .ok_or_else(|| cnc402_interp::host::channels::no_such_channel(ch, self.views.len()))?;
        Ok(match view.mode {
            cnc402_config::ChannelMode::Auto => ChannelMode::Auto,
            cnc402_config::ChannelMode::Manual => ChannelMode::Manual,
        })
    }

    /// The file `program` names, read and parsed (what `channel_load` checks); `None`
    /// (with a warning) when it is missing or does not parse.
    fn checked(&self, ch: usize, program: &str, main: &str) -> Option<PathBuf> {
        let Some(path) = self.find(program, main) else {
            log::warn!("channel_load({ch}, {program:?}): no such program");
            return None;
        };
        if let Err(e) = ChannelBoard::check(&path) {
            log::warn!("channel_load({ch}, {program:?}): {e}");
            return None;
        }
        Some(path)
    }
}

impl ChannelHost {
    fn other(&self, ch: usize) -> Result<(), String> {
        self.board.other(self.this, ch)
    }

    /// Blocks until `done` holds for the slots (or the run ends), with this channel marked
    /// blocked so that virtual time runs on; false when the run ended first.
    fn block_until(&self, mut done: impl FnMut(&[Slot]) -> bool) -> bool {
        let me = &self.board.signals[self.this];
        me.blocked.store(true, Ordering::SeqCst);
        let t0 = std::time::Instant::now();
        let mut slots = self.board.lock();
        let ok = loop {
            if done(&slots) {
                break true;
            }
            if t0.elapsed() > WAIT_LIMIT || self.board.closed.load(Ordering::SeqCst) {
                break false;
            }
            slots = match self
                .board
                .changed
                .wait_timeout(slots, Duration::from_millis(5))
            {
                Ok((g, _)) => g,
                Err(e) => e.into_inner().0,
            };
        };
        drop(slots);
        me.blocked.store(false, Ordering::SeqCst);
        ok
    }

    /// The deadlock a wait of this channel for `ch` would make: `ch` (or a channel it waits
    /// for, and so on) waits for this one.
    fn wait_cycle(&self, slots: &[Slot], ch: usize) -> Option<String> {
        let mut at = ch;
        for _ in 0..slots.len() {
            let next = slots[at].waiting_for?;
            if next == self.this {
                let line = |k: usize| {
                    format!(
                        "channel {k} ({}:{})",
                        slots[k].program,
                        self.board.signals[k].line.load(Ordering::SeqCst)
                    )
                };
                return Some(format!(
                    "channel_wait({ch}) deadlock: {} waits for channel {ch}, which waits for \
                     it ({} waits for channel {next})",
                    line(self.this),
                    line(at)
                ));
            }
            at = next;
        }
        None
    }
}

impl Channels for ChannelHost {
    fn count(&self) -> usize {
        self.board.views.len()
    }

    fn this(&self) -> usize {
        self.this
    }

    fn mode(&mut self, ch: usize) -> Result<ChannelMode, String> {
        self.board.mode(ch)
    }

    fn state(&mut self, ch: usize) -> Result<ChannelState, String> {
        self.mode(ch)?;
        if ch == self.this {
            return Ok(ChannelState::Running);
        }
        let sig = &self.board.signals[ch];
        let slots = self.board.lock();
        Ok(if slots[ch].resetting {
            ChannelState::Reset
        } else if slots[ch].error.is_some() || sig.dead.load(Ordering::SeqCst) {
            ChannelState::Error
        } else if sig.busy.load(Ordering::SeqCst) && sig.at_mark.load(Ordering::SeqCst) {
            ChannelState::Waiting
        } else if sig.busy.load(Ordering::SeqCst) {
            ChannelState::Running
        } else {
            ChannelState::Ready
        })
    }

    fn load(&mut self, ch: usize, program: &str, main: &str) -> Result<bool, String> {
        self.other(ch)?;
        let mut slots = self.board.lock();
        if !self.board.ready(ch, &slots[ch]) {
            return Ok(false);
        }
        let Some(path) = self.board.checked(ch, program, main) else {
            return Ok(false);
        };
        slots[ch].loaded = Some(path);
        Ok(true)
    }

    fn start(&mut self, ch: usize, program: &str, main: &str) -> Result<bool, String> {
        self.other(ch)?;
        let wanted = self.board.find(program, main);
        let loaded = self.board.lock()[ch].loaded.clone();
        if (wanted.is_none() || wanted != loaded) && !self.load(ch, program, main)? {
            return Ok(false);
        }
        let mut slots = self.board.lock();
        if !self.board.ready(ch, &slots[ch]) {
            return Ok(false);
        }
        let Some(path) = slots[ch].loaded.clone() else {
            return Ok(false);
        };
        slots[ch].program = path.display().to_string();
        slots[ch].queued = Some(ProgramInput::File {
            path,
            dialect: None,
        });
        self.board.signals[ch].busy.store(true, Ordering::SeqCst);
        drop(slots);
        self.board.changed.notify_all();
        Ok(true)
    }

    fn wait(&mut self, ch: usize) -> Result<bool, String> {
        self.other(ch)?;
        {
            let mut slots = self.board.lock();
            if let Some(e) = self.wait_cycle(&slots, ch) {
                return Err(e);
            }
            slots[self.this].waiting_for = Some(ch);
        }
        let sig = self.board.signals[ch].clone();
        let ended = self.block_until(|_| !sig.busy.load(Ordering::SeqCst));
        let mut slots = self.board.lock();
        slots[self.this].waiting_for = None;
        Ok(ended && slots[ch].error.is_none() && !sig.dead.load(Ordering::SeqCst))
    }

    fn reset(&mut self, ch: usize) -> Result<bool, String> {
        self.other(ch)?;
        let sig = self.board.signals[ch].clone();
        let not_started = {
            let mut slots = self.board.lock();
            slots[ch].resetting = true;
            let queued = slots[ch].queued.take().is_some();
            if !queued && sig.busy.load(Ordering::SeqCst) {
                sig.reset.store(true, Ordering::SeqCst);
            }
            queued
        };
        if not_started {
            // Taken off the queue before its feeder saw it: it never ran.
            self.board
                .finished(ch, Some("reset (channel_reset) before it started".into()));
        }
        let ended = self.block_until(|_| !sig.busy.load(Ordering::SeqCst));
        let mut slots = self.board.lock();
        slots[ch].resetting = false;
        slots[ch].loaded = None;
        slots[ch].error = None;
        sig.reset.store(false, Ordering::SeqCst);
        Ok(ended && !sig.dead.load(Ordering::SeqCst))
    }
}

/// A resident channel's feeder thread: channel `k` runs each program queued on the board
/// (the first may come from the command line), from where its axes stand, pushing its moves
/// into `ring` without `End` (the channel holds position between programs); a program has
/// ended when the loop has run every move it pushed. A program error fails that program
/// (`channel_wait` reads false) after the moves planned before it; the thread's result is
/// the error of the first program when it came from the command line.
pub struct Resident {
    pub board: Arc<ChannelBoard>,
    pub k: usize,
    pub ring: MoveProducer,
    pub shared: Arc<SyncShared>,
    pub gate: Option<Arc<StopGate>>,
    pub start: AxisPos,
    /// The first program came from the command line (its error is the run's).
    pub first_from_command_line: bool,
}

/// Starts [`Resident`]'s thread.
pub fn spawn_resident(r: Resident) -> std::io::Result<JoinHandle<Option<NcError>>> {
    std::thread::Builder::new()
        .name(format!("cnc402-channel{}", r.k))
        .spawn(move || run_resident(r))
}

fn run_resident(r: Resident) -> Option<NcError> {
    let Resident {
        board,
        k,
        ring,
        shared,
        gate,
        start,
        first_from_command_line,
    } = r;
    let signal = board.signal(k);
    let ring = Arc::new(Mutex::new(ring));
    let cfg = board.views[k].config.clone();
    // A program error fails the program, not the machine.
    let no_stop = AtomicBool::new(false);
    let mut first_error = None;
    let mut first = true;
    // Each turn runs one program; `next_program` ends the loop with the run.
    while let Some(input) = board.next_program(k, &shared) {
        let at = if first { start } else { shared.actual() };
        let error = match Feeder::from_input_on(&cfg, &input, at, false, Some(board.host(k))) {
            Err(e) => Some(e),
            Ok(mut feeder) => {
                sync_to(&mut feeder, &ring, shared.clone());
                let to = FeedTo {
                    ring: &ring,
                    shared: &shared,
                    stop: &no_stop,
                    gate: gate.as_deref(),
                    cancel: Some(&signal.reset),
                };
                let e = feed(&mut feeder, to, false);
                // Waiting for the motion, as the interpreter's motion sync does: virtual
                // time runs on until it is done.
                shared.waiting.store(true, Ordering::SeqCst);
                while !shared.motion_done() && !shared.has_ended() {
                    std::thread::sleep(Duration::from_millis(1));
                }
                shared.waiting.store(false, Ordering::SeqCst);
                e
            }
        };
        if let Some(e) = &error {
            log::warn!("channel {k}: {}:{}: {}", e.file, e.line, e.message);
        }
        let failed = error.as_ref().map(|e| e.to_string()).or_else(|| {
            if signal.reset.load(Ordering::SeqCst) {
                Some("reset (channel_reset) before its end".to_string())
            } else {
                shared
                    .has_ended()
                    .then(|| "the channel stopped before its program ended".to_string())
            }
        });
        if std::mem::take(&mut first) && first_from_command_line {
            first_error = error;
        }
        board.finished(k, failed);
    }
    first_error
}

/// The channels as a dry run sees them: programs are checked (`channel_load`, `channel_run`
/// of a missing or unparsable file read false, as they will in the run), nothing is started,
/// every wait returns at once as if the program ended well, every other channel reads ready.
pub struct DryChannels {
    board: Arc<ChannelBoard>,
    this: usize,
    /// Calls that would act on another channel (load, start, wait, reset), counted so the
    /// dry run knows its program has gone past one.
    calls: Arc<std::sync::atomic::AtomicU64>,
}

impl DryChannels {
    pub fn new(board: Arc<ChannelBoard>, this: usize) -> DryChannels {
        DryChannels {
            board,
            this,
            calls: Arc::default(),
        }
    }

    /// Counts its calls on `calls`.
    pub fn counting(mut self, calls: Arc<std::sync::atomic::AtomicU64>) -> DryChannels {
        self.calls = calls;
        self
    }

    fn called(&self) {
        self.calls.fetch_add(1, Ordering::SeqCst);
    }
}

impl Channels for DryChannels {
    fn count(&self) -> usize {
        self.board.views.len()
    }
    fn this(&self) -> usize {
        self.this
    }
    fn mode(&mut self, ch: usize) -> Result<ChannelMode, String> {
        self.board.mode(ch)
    }
    fn state(&mut self, ch: usize) -> Result<ChannelState, String> {
        self.board.mode(ch)?;
        Ok(if ch == self.this {
            ChannelState::Running
        } else {
            ChannelState::Ready
        })
    }
    fn load(&mut self, ch: usize, program: &str, main: &str) -> Result<bool, String> {
        self.board.other(self.this, ch)?;
        self.called();
        let auto = self.board.mode(ch)? == ChannelMode::Auto;
        Ok(auto && self.board.checked(ch, program, main).is_some())
    }
    fn start(&mut self, ch: usize, program: &str, main: &str) -> Result<bool, String> {
        self.load(ch, program, main)
    }
    fn wait(&mut self, ch: usize) -> Result<bool, String> {
        self.board.other(self.this, ch)?;
        self.called();
        Ok(true)
    }
    fn reset(&mut self, ch: usize) -> Result<bool, String> {
        self.board.other(self.this, ch)?;
        self.called();
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn board() -> Arc<ChannelBoard> {
        let cfg = MachineConfig::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../examples/axioma/two-channel.toml"
        ))
        .expect("config");
        ChannelBoard::new(&cfg)
    }

    /// Channel 1 waits for channel 0 (its program at line 7); channel 0's wait for channel 1
    /// can never end: an error naming both channels' lines, at once.
    #[test]
    fn a_wait_for_a_channel_that_waits_for_this_one_is_a_deadlock() {
        let b = board();
        {
            let mut slots = b.lock();
            slots[1].waiting_for = Some(0);
            slots[1].program = "sub.nc".into();
            slots[0].program = "main.nc".into();
        }
        b.signal(1).busy.store(true, Ordering::SeqCst);
        b.signal(1).line.store(7, Ordering::SeqCst);
        b.signal(0).line.store(3, Ordering::SeqCst);
        let (mut host, _) = b.host(0);
        let e = host.wait(1).unwrap_err();
        assert!(e.contains("deadlock"), "{e}");
        assert!(e.contains("main.nc:3") && e.contains("sub.nc:7"), "{e}");
    }

    #[test]
    fn a_channel_the_machine_lacks_or_its_own_is_a_program_error() {
        let b = board();
        let (mut host, _) = b.host(0);
        assert!(host.state(9).unwrap_err().contains("2 channels"));
        assert!(host.wait(0).unwrap_err().contains("its own channel"));
        assert!(host.run(2, "x.nc", "m.nc").is_err());
        let mut dry = DryChannels::new(b.clone(), 0);
        assert!(dry.start(0, "x.nc", "m.nc").is_err());
        assert_eq!(dry.start(1, "missing.nc", "m.nc"), Ok(false));
        assert_eq!(dry.wait(1), Ok(true));
    }

    #[test]
    fn a_closed_board_starts_nothing_and_waits_for_nothing() {
        let b = board();
        b.signal(1).busy.store(true, Ordering::SeqCst);
        b.close();
        let (mut host, _) = b.host(0);
        assert_eq!(host.wait(1), Ok(false));
    }
}
