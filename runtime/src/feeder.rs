//! The feeder: runs the interpreter and the planner (with its lookahead, which blends G64
//! blocks) ahead of the loop (outside it) and pushes planned moves into the move ring while
//! there is room. Errors become [`NcError`]s that point at the program line (a planner error
//! has no column: it names the block). A program comes parsed whole or as a file read line
//! by line ([`ProgramInput`]); then the feeder, like the interpreter, holds a bounded window.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};

use cnc402_config::MachineConfig;
use cnc402_interp::host_fs::{self, VarsAccess};
use cnc402_interp::{Interpreter, Options};
use cnc402_lang::ast::Program;
use cnc402_lang::{NcError, SourceFile};
use cnc402_motion::{AxisPos, Lookahead, MotionError, MoveKind, PlannedMove, SegmentKind};

use crate::ring::{LoopInput, MoveProducer, Observer, Producer};

/// Where a run's program comes from.
#[derive(Clone, Debug)]
pub enum ProgramInput {
    /// Parsed whole (a text given in memory; what tests use).
    Parsed { src: SourceFile, program: Program },
    /// A file read line by line when the interpreter reaches each block (memory bounded by
    /// the lookahead, not by the program); `dialect` as `--dialect` forces it.
    File {
        path: std::path::PathBuf,
        dialect: Option<cnc402_lang::Dialect>,
    },
}

impl ProgramInput {
    /// The program's text for messages: the whole text, or (a file read line by line) an
    /// empty window named after it, whose lines [`line_source`] reads again.
    pub fn source(&self) -> SourceFile {
        match self {
            ProgramInput::Parsed { src, .. } => src.clone(),
            ProgramInput::File { path, .. } => {
                SourceFile::window(path.display().to_string(), "", 1)
            }
        }
    }

    /// Loads the program into `interp` (a file: opened and read line by line; `checked`: its
    /// every line parsed before, by the dry run).
    fn load_into(&self, interp: &mut Interpreter, checked: bool) -> Result<(), NcError> {
        match self {
            ProgramInput::Parsed { src, program } => {
                interp.load(src.clone(), program.clone());
                Ok(())
            }
            ProgramInput::File { path, dialect } => {
                let name = path.display().to_string();
                let file = std::fs::File::open(path).map_err(|e| {
                    NcError::new(
                        &SourceFile::window(name.clone(), "", 1),
                        Default::default(),
                        format!("cannot read the program: {e}"),
                    )
                })?;
                let input = Box::new(std::io::BufReader::with_capacity(1 << 16, file));
                if checked {
                    interp.load_stream_checked(name, input, *dialect)
                } else {
                    interp.load_stream(name, input, *dialect)
                }
            }
        }
    }
}

/// An interpreter and a planner in step; see the module doc.
pub struct Feeder {
    interp: Interpreter,
    /// Shared with the motion sync, which brings it to rest before a position read.
    lookahead: Arc<Mutex<Lookahead>>,
    /// The interpreter has no more segments (the lookahead was told).
    interp_done: bool,
    /// Texts of `Message` segments planned, not yet given out as moves.
    planned_messages: VecDeque<String>,
    src: SourceFile,
    /// A move planned but not yet accepted by the ring.
    held: Option<LoopInput>,
    done: bool,
    /// Texts of `Message` moves sent, in order (the loop reports only that one finished).
    messages: VecDeque<String>,
    /// The source file of the last move.
    last_file: Option<std::sync::Arc<str>>,
    /// The non-volatile variables file a live run writes (`None` for a dry run, or when the
    /// config names none).
    vars_file: Option<std::path::PathBuf>,
    /// Breakpoints, single block and block search (`None`: every segment is planned).
    watch: Option<crate::operator::BlockWatch>,
    /// The break of the last program stop given out (`None`: the program's own stop).
    last_break: Option<crate::operator::BreakHit>,
}

/// A planner error as a program error at the block's line (`src` as [`line_source`] gives it).
pub fn motion_error_to_nc(src: &SourceFile, e: &MotionError) -> NcError {
    NcError::new(src, src.line_span(e.line), e.to_string())
}

/// The text holding line `line` of `file` for a message: `main` when it is that file and
/// holds its text, else the line read again from disk (one line: a program read line by
/// line is never read whole for a message); `main` if it cannot be read.
pub fn line_source(file: &str, line: u32, main: &SourceFile) -> SourceFile {
    let holds = main.first_line() <= line && line <= main.last_line() && !main.text.is_empty();
    if &*main.name == file && holds {
        return main.clone();
    }
    let Ok(f) = std::fs::File::open(file) else {
        return main.clone();
    };
    let input = Box::new(std::io::BufReader::new(f));
    cnc402_lang::stream::LineReader::new(file, input)
        .line_window(line)
        .unwrap_or_else(|_| main.clone())
}

/// The text of `file` for messages: `main` itself, or an included / sub-program file read
/// again from disk (outside the loop); `main` if it cannot be read.
pub fn source_for(file: &str, main: &SourceFile) -> SourceFile {
    if &*main.name == file {
        return main.clone();
    }
    match std::fs::read_to_string(file) {
        Ok(text) => SourceFile::new(file, text),
        Err(_) => main.clone(),
    }
}

impl Feeder {
    /// Loads `program` for a machine standing at `start` (machine coordinates). Writes to the
    /// non-volatile variables `#500–#999` go to the config's `variables_file`.
    pub fn new(cfg: &MachineConfig, src: SourceFile, program: Program, start: AxisPos) -> Feeder {
        let mut interp = new_interp(cfg, start, false);
        interp.load(src.clone(), program);
        Feeder::with_interp(cfg, interp, src, start, false)
    }

    /// As [`new`](Self::new), but `#500–#999` start from the variables file and writes stay
    /// in memory: a dry run must not change what the real run will read.
    pub fn dry(cfg: &MachineConfig, src: SourceFile, program: Program, start: AxisPos) -> Feeder {
        let mut interp = new_interp(cfg, start, true);
        interp.load(src.clone(), program);
        Feeder::with_interp(cfg, interp, src, start, true)
    }

    /// A feeder of `input` for a machine at `start`; `dry`: as [`dry`](Self::dry). A file is
    /// opened here; the dry run's load parses its every line (the error of a line that does
    /// not parse), the run's (`dry` false, after its dry run) only its flow lines.
    pub fn from_input(
        cfg: &MachineConfig,
        input: &ProgramInput,
        start: AxisPos,
        dry: bool,
    ) -> Result<Feeder, NcError> {
        Self::from_input_on(cfg, input, start, dry, None)
    }

    /// [`from_input`](Self::from_input) of a program whose interpreter sees the machine's
    /// channels as `channels` answers and shares the run's `$` globals (see
    /// `crate::channels`); given before the program is loaded, since a C-like program takes
    /// its channels and globals when it loads.
    pub fn from_input_on(
        cfg: &MachineConfig,
        input: &ProgramInput,
        start: AxisPos,
        dry: bool,
        channels: Option<(
            Box<dyn cnc402_interp::Channels>,
            cnc402_interp::SharedGlobals,
        )>,
    ) -> Result<Feeder, NcError> {
        let mut interp = new_interp(cfg, start, dry);
        if let Some((host, globals)) = channels {
            interp.set_channels(host);
            interp.set_shared_globals(globals);
        }
        // The run comes after its dry run, which parsed every line.
        input.load_into(&mut interp, !dry)?;
        Ok(Feeder::with_interp(cfg, interp, input.source(), start, dry))
    }

    fn with_interp(
        cfg: &MachineConfig,
        interp: Interpreter,
        src: SourceFile,
        start: AxisPos,
        dry: bool,
    ) -> Feeder {
        let mut lookahead = Lookahead::new(cfg, cfg.planner.lookahead);
        lookahead.planner_mut().set_position(start);
        Feeder {
            interp,
            lookahead: Arc::new(Mutex::new(lookahead)),
            interp_done: false,
            planned_messages: VecDeque::new(),
            src,
            held: None,
            done: false,
            messages: VecDeque::new(),
            last_file: None,
            vars_file: if dry { None } else { cfg.variables_file() },
            watch: None,
            last_break: None,
        }
    }

    /// Watches the segments for breakpoints, single block and block search.
    pub fn with_watch(mut self, watch: crate::operator::BlockWatch) -> Feeder {
        self.watch = Some(watch);
        self
    }

    /// The break of the program stop [`next_move`](Self::next_move) gave out last, once.
    pub fn take_break(&mut self) -> Option<crate::operator::BreakHit> {
        self.last_break.take()
    }

    /// The next planned move, `Ok(None)` at the end. Segments go through the lookahead, so
    /// a G64 block's move comes out once the blocks after it are known.
    pub fn next_move(&mut self) -> Result<Option<PlannedMove>, NcError> {
        loop {
            if let Some(mv) = lock(&self.lookahead).pop() {
                if let MoveKind::Message = mv.kind
                    && let Some(text) = self.planned_messages.pop_front()
                {
                    self.messages.push_back(text);
                }
                if let (MoveKind::ProgramStop { .. }, Some(w)) = (mv.kind, &mut self.watch) {
                    self.last_break = w.stop_out();
                }
                return Ok(Some(mv));
            }
            if self.interp_done {
                return Ok(None);
            }
            // No lock held here: the interpreter's motion sync takes it.
            let next = self.interp.next_segment()?;
            let Some(seg) = self.watched(next)? else {
                self.interp_done = true;
                let finished = lock(&self.lookahead).finish();
                finished
                    .map_err(|e| motion_error_to_nc(&self.src_of(&self.last_file, e.line), &e))?;
                continue;
            };
            lock(&self.lookahead).push(&seg).map_err(|e| {
                motion_error_to_nc(&line_source(&seg.source.file, e.line, &self.src), &e)
            })?;
            if self.last_file.as_ref() != Some(&seg.source.file) {
                self.last_file = Some(seg.source.file.clone());
            }
            if let SegmentKind::Message { text } = seg.kind {
                self.planned_messages.push_back(text);
            }
        }
    }

    /// `next` through the watch: what it adds before a segment (holds, a search's approach)
    /// is planned here and the segment handed back; `None` at the program's end (or the
    /// search's), an error when a search never reached its range.
    fn watched(
        &mut self,
        mut next: Option<cnc402_motion::Segment>,
    ) -> Result<Option<cnc402_motion::Segment>, NcError> {
        // Each turn takes one more segment from the interpreter, which ends or errs on its
        // own limits: the loop is bounded by the program.
        loop {
            let Some(w) = &mut self.watch else {
                return Ok(next);
            };
            let Some(seg) = next else {
                return match w.unreached() {
                    Some(m) => Err(NcError::new(&self.src, self.src.line_span(1), m)),
                    None => Ok(None),
                };
            };
            let mut out = Vec::new();
            match w.admit(seg, self.interp.block_serial(), &mut out) {
                crate::operator::Admit::Go => {}
                crate::operator::Admit::End => return Ok(None),
                crate::operator::Admit::Unreachable(m) => {
                    return Err(NcError::new(&self.src, self.src.line_span(1), m));
                }
            }
            let Some(last) = out.pop() else {
                // Kept back by the search.
                next = self.interp.next_segment()?;
                continue;
            };
            for s in out {
                lock(&self.lookahead)
                    .push(&s)
                    .map_err(|e| motion_error_to_nc(&source_for(&s.source.file, &self.src), &e))?;
            }
            return Ok(Some(last));
        }
    }

    /// The lookahead, for the motion sync to bring to rest before a position read.
    pub fn lookahead(&self) -> Arc<Mutex<Lookahead>> {
        self.lookahead.clone()
    }

    fn src_of(&self, file: &Option<Arc<str>>, line: u32) -> SourceFile {
        let main = self.src.name.clone();
        line_source(file.as_ref().unwrap_or(&main), line, &self.src)
    }

    /// Pushes moves into `ring` until it is full or the program is over (then `End`).
    /// Returns how many entries were pushed.
    pub fn fill(&mut self, ring: &mut MoveProducer) -> Result<usize, NcError> {
        let mut pushed = 0;
        loop {
            if ring.is_full() {
                return Ok(pushed);
            }
            let item = match self.held.take() {
                Some(i) => i,
                None if self.done => return Ok(pushed),
                None => match self.next_move()? {
                    Some(mv) => LoopInput::Move(mv),
                    None => {
                        self.done = true;
                        LoopInput::End
                    }
                },
            };
            if let Err(back) = ring.try_push(item) {
                self.held = Some(back);
                return Ok(pushed);
            }
            pushed += 1;
        }
    }

    /// True once `End` went into the ring.
    pub fn is_done(&self) -> bool {
        self.done && self.held.is_none()
    }

    /// The text of the next message the loop will report.
    pub fn take_message(&mut self) -> Option<String> {
        self.messages.pop_front()
    }

    /// Reads the non-volatile variables file again after the operator resumed from a program
    /// stop, so that what was set during the stop (`cnc402 vars set`, the way an operator
    /// fills a macro program's parameter pages) is what the program reads after it. Nothing
    /// else writes the file while the program holds: the interpreter waits at the stop.
    /// An error is given at `line` (the stop's) of the file of the last move.
    pub fn reload_persistent_vars(&mut self, line: u32) -> Result<(), NcError> {
        let Some(path) = &self.vars_file else {
            return Ok(());
        };
        // A file removed during the stop would read as all vacant: values the program holds
        // would silently vanish (and vacant words are left out of blocks). An error instead.
        let gone = !path.exists()
            && self
                .interp
                .persistent_vars()
                .as_slice()
                .iter()
                .any(Option::is_some);
        let opened = if gone {
            Err(format!("{} was removed during the stop", path.display()))
        } else {
            cnc402_interp::host_fs::FileVarStore::open(path).map_err(|e| e.to_string())
        };
        match opened {
            Ok((store, table)) => {
                self.interp
                    .set_persistent_vars(table, Some(Box::new(store)));
                Ok(())
            }
            Err(e) => {
                let src = self.src_of(&self.last_file.clone(), line);
                let span = src.line_span(line);
                Err(NcError::new(
                    &src,
                    span,
                    format!(
                        "after this program stop the non-volatile variables cannot be read: {e}"
                    ),
                ))
            }
        }
    }

    /// Replaces the interpreter's motion sync (see [`crate::sync`]).
    pub fn set_motion_sync(&mut self, sync: Box<dyn cnc402_interp::MotionSync>) {
        self.interp.set_motion_sync(sync);
    }

    /// The source file of the last move returned by [`next_move`](Self::next_move).
    pub fn last_file(&self) -> Option<&std::sync::Arc<str>> {
        self.last_file.as_ref()
    }

    /// The program text.
    pub fn source(&self) -> &SourceFile {
        &self.src
    }
}

/// An interpreter for a run (`dry`: the dry run) of a machine standing at `start`.
fn new_interp(cfg: &MachineConfig, start: AxisPos, dry: bool) -> Interpreter {
    // A machine run repeats a main program that ends in M99, as a Fanuc control does; the
    // dry run checks one pass (it would never end otherwise).
    let opts = Options {
        start,
        main_m99: if dry {
            cnc402_interp::MainM99::End
        } else {
            cnc402_interp::MainM99::Repeat
        },
        ..Options::default()
    };
    // The interpreter does no I/O itself: the file system (sub-programs, `#use` files,
    // the non-volatile variables file) is injected here. The dry run reads the variables
    // the way the real run will but keeps its writes in memory.
    let access = if dry {
        VarsAccess::ReadOnly
    } else {
        VarsAccess::Write
    };
    host_fs::interpreter(cfg, opts, access)
}

/// The lookahead, whoever held it last (a panic elsewhere does not poison planning).
pub fn lock(l: &Mutex<Lookahead>) -> MutexGuard<'_, Lookahead> {
    l.lock().unwrap_or_else(|e| e.into_inner())
}

/// Most moves the dry run checks before motion (and `cnc402 segments`/`canon` print). An
/// endless program with motion (`GOTO` back to a move) is legal and must start: past this
/// many moves the dry run stops checking and says so ([`DryRun::checked_only`]); the rest
/// is checked as it runs. A million moves plan in a few seconds and cover any program that
/// ends (the largest examples make tens of thousands).
pub const DRY_RUN_MOVES: u64 = 1_000_000;

/// What a dry run of the whole program (interpreter + planner, no motion) found.
#[derive(Clone, Debug, Default)]
pub struct DryRun {
    /// Planned moves.
    pub moves: u64,
    /// Interpolator ticks of all moves (path moves and dwells; spindle ramps and events are
    /// not known in advance and count as 0).
    pub ticks: u64,
    /// The line of the main program's `M99` where the run will start over (the dry run
    /// covers one pass).
    pub repeats_at: Option<u32>,
    /// A program error found after a program stop that holds (M0 with `--at-stop wait`),
    /// after the program read non-volatile variables there: the line of that stop and the
    /// error. It does not stop the run before motion, because the operator may change those
    /// variables during the stop; it is the run's to report if it still happens. (An error
    /// past the stop that reads none of them is refused before motion, as any other.)
    pub after_hold: Option<(u32, NcError)>,
    /// The error the dry run met after the program had called another channel
    /// (`channel_run`, …): the dry run runs nothing there, so what the program reads
    /// afterwards (a shared `$` flag, a channel's state) may differ in the run; it is the
    /// run's to report if it still happens.
    pub after_channel_call: Option<NcError>,
    /// The dry run stopped after this many moves ([`DRY_RUN_MOVES`]) with the program going
    /// on past them: only those were checked.
    pub checked_only: Option<u64>,
}

/// Interprets and plans the whole program without moving anything, so that a program error
/// is reported (exit 2) before a drive is enabled, and the progress bar knows the length.
/// With a `gate` whose policy ends the program at a stop, the dry run ends there too (what
/// follows would never run); past a stop that holds it goes on, as a resume would, but an
/// error there is only noted ([`DryRun::after_hold`]).
pub fn dry_run(
    cfg: &MachineConfig,
    src: &SourceFile,
    program: &Program,
    start: AxisPos,
    gate: Option<&crate::program_stop::StopGate>,
) -> Result<DryRun, NcError> {
    dry_run_bounded(cfg, src, program, start, gate, DRY_RUN_MOVES)
}

/// [`dry_run_input`] through a block search's `watch` (only the range is planned).
pub fn dry_run_watched(
    cfg: &MachineConfig,
    input: &ProgramInput,
    gate: Option<&crate::program_stop::StopGate>,
    watch: Option<crate::operator::BlockWatch>,
) -> Result<DryRun, NcError> {
    let f = Feeder::from_input(cfg, input, AxisPos::default(), true)?;
    let f = match watch {
        Some(w) => f.with_watch(w),
        None => f,
    };
    dry_run_feeder(cfg, f, gate, DRY_RUN_MOVES)
}

/// [`dry_run_watched`] (no watch) of a channel's program, whose interpreter sees the
/// machine's channels as `host` answers (see `crate::channels::DryChannels`).
pub fn dry_run_channel(
    cfg: &MachineConfig,
    input: &ProgramInput,
    gate: Option<&crate::program_stop::StopGate>,
    host: Box<dyn cnc402_interp::Channels>,
    globals: cnc402_interp::SharedGlobals,
    channel_calls: &std::sync::atomic::AtomicU64,
) -> Result<DryRun, NcError> {
    let f = Feeder::from_input_on(cfg, input, AxisPos::default(), true, Some((host, globals)))?;
    match dry_run_feeder(cfg, f, gate, DRY_RUN_MOVES) {
        Err(e) if channel_calls.load(std::sync::atomic::Ordering::SeqCst) > 0 => Ok(DryRun {
            after_channel_call: Some(e),
            ..DryRun::default()
        }),
        r => r,
    }
}

/// [`dry_run`] checking at most `max_moves` moves.
pub fn dry_run_bounded(
    cfg: &MachineConfig,
    src: &SourceFile,
    program: &Program,
    start: AxisPos,
    gate: Option<&crate::program_stop::StopGate>,
    max_moves: u64,
) -> Result<DryRun, NcError> {
    let input = ProgramInput::Parsed {
        src: src.clone(),
        program: program.clone(),
    };
    dry_run_input(cfg, &input, start, gate, max_moves)
}

/// [`dry_run_bounded`] of a program from `input` (a file: read line by line, in bounded
/// memory).
pub fn dry_run_input(
    cfg: &MachineConfig,
    input: &ProgramInput,
    start: AxisPos,
    gate: Option<&crate::program_stop::StopGate>,
    max_moves: u64,
) -> Result<DryRun, NcError> {
    let f = Feeder::from_input(cfg, input, start, true)?;
    dry_run_feeder(cfg, f, gate, max_moves)
}

fn dry_run_feeder(
    cfg: &MachineConfig,
    mut f: Feeder,
    gate: Option<&crate::program_stop::StopGate>,
    max_moves: u64,
) -> Result<DryRun, NcError> {
    let mut d = DryRun::default();
    // The first stop that holds, and the non-volatile reads made before it.
    let mut held_at: Option<(u32, u64)> = None;
    let mut blended = 0.0;
    loop {
        if d.moves >= max_moves {
            d.checked_only = Some(d.moves);
            break;
        }
        let mv = match f.next_move() {
            Ok(Some(mv)) => mv,
            Ok(None) => break,
            Err(e) => match held_at {
                // Only an error that may depend on what the operator can set during the stop
                // (the non-volatile variables, read since) waits for the run; one that cannot
                // change (a target outside the soft limits from constants) is refused now.
                Some((line, reads)) if f.interp.persistent_reads() > reads => {
                    d.after_hold = Some((line, e));
                    break;
                }
                _ => return Err(e),
            },
        };
        if let (MoveKind::ProgramStop { kind }, Some(g)) = (mv.kind, gate) {
            if g.ends_at(kind) {
                d.moves += 1;
                d.ticks += 1;
                break;
            }
            if g.holds_at(kind) && held_at.is_none() {
                held_at = Some((mv.line, f.interp.persistent_reads()));
            }
        }
        d.moves += 1;
        d.ticks += match mv.kind {
            MoveKind::Path(p) if p.t_begin != 0.0 || p.end_speed > 0.0 => {
                // A blended move lasts a fraction of periods: sum the time, count once.
                blended += p.t_end - p.t_begin;
                0
            }
            MoveKind::Path(p) => p.ticks,
            MoveKind::Dwell { ticks, .. } => ticks,
            _ => 1,
        };
        f.messages.clear();
    }
    d.ticks += (blended / cfg.bus.period_s()).round() as u64;
    d.repeats_at = f.interp.main_m99_line();
    Ok(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dry(text: &str, max_moves: u64) -> Result<DryRun, NcError> {
        let mut cfg = MachineConfig::default_machine();
        cfg.interp.variables_file = None;
        let src = SourceFile::new("d.nc", text);
        let program = cnc402_lang::parse(&src).expect("parses");
        dry_run_bounded(&cfg, &src, &program, AxisPos::default(), None, max_moves)
    }

    /// Regression (issue 18): `N1 G91 G0 X1`, `G0 X-1`, `GOTO1` never reached its end, so
    /// `run` never started it.
    #[test]
    fn endless_goto_loop_with_motion_dry_run_is_bounded() {
        let text = include_str!("../../interp/tests/corpus/goto_loop_with_motion_is_endless.nc");
        let d = dry(text, 500).expect("no error");
        assert_eq!(d.checked_only, Some(500));
        assert_eq!(d.moves, 500);
    }

    #[test]
    fn a_program_that_ends_is_checked_whole() {
        let d = dry("G91 G0 X1\nX-1\nM30\n", 500).expect("no error");
        assert_eq!(d.checked_only, None);
        assert_eq!(d.moves, 3);
    }
}
