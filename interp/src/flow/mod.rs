//! Program flow: the [`Interpreter`] and its public API, a program counter over the lines of
//! a program (parsed whole, or read line by line by `stream`), the call stack (`M98`/`M99`,
//! `G65`, `G66`: [`units`] and `macros`) and the macro variables as the program reads and
//! writes them ([`sysvars`]). Blocks run in the block layer
//! ([`Machine`]); a C-like program runs in `hll`. Segments are produced on demand
//! ([`Interpreter::next_segment`]) so that the interpreter can run ahead of motion and, with
//! Macro B, stop at sync points (reading a position variable waits for queued motion).

mod block_serial;
mod lcblock;
mod macros;
mod oindex;
mod oword;
mod stream;
mod sysvars;
pub mod units;

use std::collections::{HashMap, VecDeque};
use std::sync::Arc;

use cnc402_config::MachineConfig;
use cnc402_lang::ast::{Block, Line, Program, Span};
use cnc402_lang::{NcError, SourceFile};
use cnc402_motion::segment::Segment;

use crate::block::Machine;
use crate::block::plain::PlainLane;
use crate::block::state::ModalState;
use crate::block::words::Words;
pub use crate::block::{MainM99, Options};
use crate::canon::{self, CanonOp, CanonState};
use crate::comp;
use crate::expr::{self, C_LIKE_ONLY};
use crate::hll::Hll;
use crate::host::{ExactStop, MotionSync, PersistentVars, ProgramLibrary};
use crate::lower::{self, xyz_indices};
use crate::vars::{NvTable, VarTable};
use units::{Frame, ModalCall, Runaway, Unit};

/// Runs one program: `load` it, then pull segments with [`next_segment`](Self::next_segment)
/// (or iterate). The first error ends the run; segments of the block that failed are never
/// produced (a canned cycle is checked whole before any of it is given out).
///
/// Custom Macro B (see [`crate::macros`]): variables, GOTO/IF/WHILE, sub-programs (`M98`,
/// `M99`, `G65`, `G66`/`G67`) looked up in the running file and then in the injected
/// [`ProgramLibrary`] (default: none), non-volatile `#500–#999` kept by an injected
/// [`PersistentVars`] (default: memory only), and position reads synchronised through a
/// [`MotionSync`] (default: [`ExactStop`]). The defaults do no I/O; the file system comes in
/// through [`crate::host_fs`].
pub struct Interpreter {
    /// Block execution: configuration, switches, modal state, motion sync, path length.
    m: Machine,
    /// Where the program is: its programs, the call stack, what it has handed out.
    flow: Flow,
    /// Macro variables and where the non-volatile ones are stored.
    vars: Vars,
    /// The C-like language (`$` globals, the running C-like program).
    hll: Hll,
}

/// The program flow's state.
struct Flow {
    /// The main program's file (for errors that belong to no line).
    main_src: Arc<SourceFile>,
    /// The programs of the main file; the first runs first.
    units: Vec<Arc<Unit>>,
    /// The main file when it is read line by line ([`Interpreter::load_stream`]).
    stream: Option<stream::Stream>,
    /// Programs found in the library, by number.
    lib_cache: HashMap<u32, Arc<Unit>>,
    /// LinuxCNC subroutine files (`o<name> call` of `name.ngc`) read so far, by name.
    o_files: HashMap<String, Arc<Unit>>,
    /// The call stack; `frames[0]` is the main program. Empty before `load`.
    frames: Vec<Frame>,
    library: Option<Box<dyn ProgramLibrary>>,
    /// An error found at `load` (damaged variables file), given out by the first
    /// `next_segment`.
    load_error: Option<String>,
    modal_call: Option<ModalCall>,
    runaway: Runaway,
    /// Last M code, N number (for `#4113`, `#4114`).
    last_m: Option<f64>,
    last_n: Option<f64>,
    /// Operations of executed blocks not given out yet.
    queue: VecDeque<CanonOp>,
    /// Segments of the last operation not given out yet, each with the state of the
    /// operation it was lowered from (its work → machine offset).
    lowered: VecDeque<(Segment, Arc<CanonState>)>,
    /// The last block's words (emptied), reused by the next block so that a long program
    /// does not allocate them per block (boxed: moved in and out per block).
    spare_words: Option<Box<Words>>,
    /// Cutter radius compensation between the canonical operations and lowering.
    comp: comp::Stage,
    /// A `%` after the first block, M2/M30, an error, or the end of the text.
    done: bool,
    seen_block: bool,
    /// The line of the main program's `M99` that ended it ([`MainM99::End`]).
    main_m99_line: Option<u32>,
    /// LinuxCNC: the G92 shift as the last G92 set it (what G92.3 restores).
    g92_kept: [f64; cnc402_config::MAX_AXES],
    /// LinuxCNC's `#5599`, the switch of `(debug,…)` output (1 at start, as LinuxCNC): kept
    /// so that programs can set and read it; `(debug,…)` comments are comments here.
    lc_debug_switch: f64,
    /// LinuxCNC's global parameters `#31`-`#5000` that have no Fanuc meaning here (`#61`),
    /// by number: at most 4970 entries.
    lc_globals: std::collections::BTreeMap<i64, f64>,
    /// The plain-block lane (`crate::block::plain`); `None` when switched off (tests hold
    /// the general path against it so).
    lane: Option<PlainLane>,
    /// Blocks the lane ran (tests check it is taken).
    lane_blocks: u64,
}

/// The macro variables and their storage.
#[derive(Default)]
struct Vars {
    table: VarTable,
    /// LinuxCNC named parameters `#<name>`.
    named: crate::vars::NamedVars,
    store: Option<Box<dyn PersistentVars>>,
    /// The injected variables could not be read (`set_persistent_vars_error`): every `load`
    /// fails with this at the first `next_segment`.
    error: Option<String>,
}

impl Interpreter {
    /// The line of the `M99` (without `P`) that ended the main program after one pass, with
    /// [`MainM99::End`]; `None` when it ended otherwise (or has not ended).
    pub fn main_m99_line(&self) -> Option<u32> {
        self.flow.main_m99_line
    }

    /// An interpreter for the machine `cfg`, default [`Options`], no program loaded.
    pub fn new(cfg: &MachineConfig) -> Self {
        Self::with_options(cfg, Options::default())
    }

    /// An interpreter with explicit operator switches.
    pub fn with_options(cfg: &MachineConfig, opts: Options) -> Self {
        let mut it = Self::one_channel(cfg, opts);
        // Without a runtime (segments, canon, which, view, post) a program of a multi-channel
        // machine is checked against that machine's channels, as channel 0, every call to
        // another channel succeeding at once; a run attaches the real channels instead.
        if cfg.channels.len() > 1 {
            it.hll
                .set_channels(Box::new(crate::host::channels::DryChannels {
                    count: cfg.channels.len(),
                    this: 0,
                }));
        }
        it
    }

    fn one_channel(cfg: &MachineConfig, opts: Options) -> Self {
        Interpreter {
            m: Machine::new(cfg, opts),
            flow: Flow {
                main_src: Arc::new(SourceFile::new("", "")),
                units: Vec::new(),
                stream: None,
                lib_cache: HashMap::new(),
                o_files: HashMap::new(),
                frames: Vec::new(),
                library: None,
                load_error: None,
                modal_call: None,
                runaway: Runaway::default(),
                last_m: None,
                last_n: None,
                queue: VecDeque::new(),
                lowered: VecDeque::new(),
                spare_words: None,
                comp: comp::Stage::new(cfg.interp.cutter_comp, xyz_indices(cfg)),
                done: true,
                seen_block: false,
                main_m99_line: None,
                g92_kept: Default::default(),
                lc_debug_switch: 1.0,
                lc_globals: Default::default(),
                lane: Some(PlainLane::new(cfg)),
                lane_blocks: 0,
            },
            vars: Vars::default(),
            hll: Hll::default(),
        }
    }

    /// Replaces the motion sync used when a position variable is read (the runtime's feeder
    /// gives one that waits until the loop is idle).
    pub fn set_motion_sync(&mut self, sync: Box<dyn MotionSync>) {
        self.m.sync = sync;
    }

    /// Sets the machine's channels as this interpreter's programs see them (default: one
    /// channel, [`SingleChannel`](crate::host::channels::SingleChannel)): the C-like `channel_*` built-ins and
    /// `@CH[n]` call them, and wait marks (`wait_mark`, the wait M codes' `P`) are checked
    /// against their number. Takes effect at the next `load`.
    pub fn set_channels(&mut self, channels: Box<dyn crate::host::channels::Channels>) {
        self.hll.set_channels(channels);
    }

    /// Makes the `$` globals of this interpreter's C-like programs the table `shared` (all
    /// channels of one run share one: a flag one channel sets is what the others read).
    /// Without it each interpreter keeps its own. Takes effect at the next `load`.
    pub fn set_shared_globals(&mut self, shared: crate::host::channels::SharedGlobals) {
        self.hll.set_shared_globals(shared);
    }

    /// Sets where sub-programs not in the running file and `#use` files are looked up
    /// (default and `None`: nowhere, so such a call or `#use` is a not-found error).
    pub fn set_program_library(&mut self, lib: Option<Box<dyn ProgramLibrary>>) {
        self.flow.library = lib;
    }

    /// Sets the non-volatile variables `#500–#999` and where writes go (`None`: memory only,
    /// the default). They keep their values across `load`s of this interpreter.
    pub fn set_persistent_vars(&mut self, table: NvTable, store: Option<Box<dyn PersistentVars>>) {
        self.vars.table.nv = table;
        self.vars.store = store;
        self.vars.error = None;
    }

    /// The non-volatile variables could not be read (e.g. a damaged file): every program
    /// loaded from now on ends with `why` at its first `next_segment`, at the main file.
    pub fn set_persistent_vars_error(&mut self, why: String) {
        self.vars.store = None;
        self.vars.error = Some(why);
    }

    /// The non-volatile variables as they are now.
    pub fn persistent_vars(&self) -> NvTable {
        self.vars.table.nv.clone()
    }

    /// Macro variable `#n` as the program would read it (no motion sync: the programmed
    /// position stands for the actual one). `None`: vacant or no such variable.
    pub fn var(&mut self, n: u32) -> Option<f64> {
        let saved = std::mem::replace(&mut self.m.sync, Box::new(ExactStop));
        let v = self.read_var(i64::from(n)).ok().flatten();
        self.m.sync = saved;
        v
    }

    /// Path length (mm) of all segments produced so far: linear axes, arcs along the arc.
    pub fn path_length(&self) -> f64 {
        self.m.path_len
    }

    /// Starts `program` (parsed from `src`) from its first line with the modal state of a fresh
    /// start. Common variables `#100–#199` are cleared (reset); locals start vacant;
    /// non-volatile ones keep their values (see [`set_persistent_vars`](Self::set_persistent_vars)).
    /// A C-like program is checked here (its `#use` files come from the program library).
    pub fn load(&mut self, src: SourceFile, program: Program) {
        let library: Option<&mut dyn ProgramLibrary> = match &mut self.flow.library {
            Some(l) => Some(l.as_mut()),
            None => None,
        };
        self.hll.load(&self.m.cfg, &src, &program, library);
        let src = Arc::new(src);
        let program = Arc::new(program);
        let (units, main) = units::split_units(&src, &program);
        self.flow.stream = None;
        self.start(src, units, main, program.dialect);
    }

    /// Starts the program read line by line from `input` (named `name` in errors, usually its
    /// path), in bounded memory: the dialect is `forced` (`--dialect`), else its header's
    /// (read from its first lines), else the config's. Every line is parsed once here (a
    /// syntax error anywhere is this error), then read and parsed again when it runs; see
    /// `flow/stream.rs`. A C-like program is read and compiled whole, as [`load`](Self::load)
    /// does. Programs called from other files are read whole.
    ///
    /// ```
    /// use cnc402_config::MachineConfig;
    /// let mut it = cnc402_interp::Interpreter::new(&MachineConfig::default_machine());
    /// let text = "N1 #1=0\nN2 G91 G1 X1 F100\n#1=#1+1\nIF[#1LT3]GOTO2\nM30\n";
    /// it.load_stream("p.nc", Box::new(std::io::Cursor::new(text)), None).unwrap();
    /// assert_eq!(it.filter(|s| s.is_ok()).count(), 4); // three moves and the end
    /// ```
    pub fn load_stream(
        &mut self,
        name: impl Into<Arc<str>>,
        input: Box<dyn cnc402_lang::stream::ProgramRead>,
        forced: Option<cnc402_lang::Dialect>,
    ) -> Result<(), NcError> {
        self.load_stream_with(name, input, forced, false)
    }

    /// [`load_stream`](Self::load_stream) of a file whose every line parsed before (the run
    /// after its dry run): the load pass parses only the lines that may be flow lines. Should
    /// the file have changed since, a line that no longer parses is the error when it runs.
    pub fn load_stream_checked(
        &mut self,
        name: impl Into<Arc<str>>,
        input: Box<dyn cnc402_lang::stream::ProgramRead>,
        forced: Option<cnc402_lang::Dialect>,
    ) -> Result<(), NcError> {
        self.load_stream_with(name, input, forced, true)
    }

    fn load_stream_with(
        &mut self,
        name: impl Into<Arc<str>>,
        input: Box<dyn cnc402_lang::stream::ProgramRead>,
        forced: Option<cnc402_lang::Dialect>,
        checked: bool,
    ) -> Result<(), NcError> {
        let mut reader = cnc402_lang::stream::LineReader::new(name, input);
        reader.set_peck_clearance(self.m.cfg.interp.peck_clearance);
        let head = reader.head()?;
        let dialect = cnc402_lang::choose_dialect(&head, forced, self.m.cfg.interp.dialect)?;
        let main_src = Arc::new(SourceFile::window(reader.name().clone(), "", 1));
        match stream::load(reader, dialect, checked)? {
            stream::Loaded::CLike(src) => {
                let program = cnc402_lang::parse_in(&src, dialect)?;
                self.load(src, program);
            }
            stream::Loaded::Streamed(s, units) => {
                let empty = Program {
                    lines: Vec::new(),
                    dialect,
                };
                // Not C-like: this only ends a C-like program loaded before.
                self.hll.load(&self.m.cfg, &main_src, &empty, None);
                self.flow.stream = Some(s);
                self.start(main_src, units, 0, dialect);
            }
        }
        Ok(())
    }

    /// Resets everything for a fresh start of `units[main]` of the file `src`.
    fn start(
        &mut self,
        src: Arc<SourceFile>,
        units: Vec<Arc<Unit>>,
        main: usize,
        dialect: cnc402_lang::Dialect,
    ) {
        self.m.reset();
        self.m.dialect = dialect;
        self.flow.main_src = src;
        self.flow.units = units;
        self.flow.lib_cache.clear();
        self.flow.o_files.clear();
        self.flow.frames = vec![Frame::new(self.flow.units[main].clone(), false)];
        self.vars.table.reset();
        self.vars.named.reset();
        self.flow.modal_call = None;
        self.flow.runaway = Runaway::default();
        self.flow.last_m = None;
        self.flow.last_n = None;
        self.flow.load_error = self.vars.error.clone();
        self.flow.queue.clear();
        self.flow.lowered.clear();
        self.flow.comp.reset(self.m.state.pos);
        self.flow.done = false;
        self.flow.seen_block = false;
        self.flow.main_m99_line = None;
        self.flow.g92_kept = Default::default();
        self.flow.lc_debug_switch = 1.0;
        self.flow.lc_globals.clear();
    }

    /// The next segment, `Ok(None)` at the end of the program, or the error that ends it:
    /// the canonical operations ([`next_canon`](Self::next_canon)) lowered to machine
    /// coordinates. Use one of the two per run: the segments of an operation taken with
    /// `next_canon` are not given out here.
    pub fn next_segment(&mut self) -> Result<Option<Segment>, NcError> {
        Ok(self.next_lowered()?.map(|(s, _)| s))
    }

    /// As [`next_segment`](Self::next_segment), with the state of the (compensated)
    /// operation the segment was lowered from: `state.to_work` gives its positions in the
    /// work coordinates the program was written in (what `cnc402 which` and `view` show).
    pub fn next_lowered(&mut self) -> Result<Option<(Segment, Arc<CanonState>)>, NcError> {
        self.lower_some()?;
        Ok(self.flow.lowered.pop_front())
    }

    /// [`next_segment`](Self::next_segment) handed to `f` (the dump's loop: a segment is 160
    /// bytes, moved out of the queue into `f` once rather than through the return values).
    pub fn with_next_segment<R>(
        &mut self,
        f: impl FnOnce(Segment) -> R,
    ) -> Result<Option<R>, NcError> {
        self.lower_some()?;
        Ok(self.flow.lowered.pop_front().map(|(s, _)| f(s)))
    }

    /// Runs the program until a lowered segment waits or it ends.
    #[inline]
    fn lower_some(&mut self) -> Result<(), NcError> {
        while self.flow.lowered.is_empty() {
            if matches!(self.next_op(true)?, Pulled::End) {
                break;
            }
        }
        Ok(())
    }

    /// The next canonical operation (work coordinates, canned cycles whole, with the state
    /// each ran under), `Ok(None)` at the end of the program, or the error that ends it.
    pub fn next_canon(&mut self) -> Result<Option<CanonOp>, NcError> {
        Ok(match self.next_op(false)? {
            Pulled::Op(op) => Some(*op),
            Pulled::Kept | Pulled::End => None,
        })
    }

    /// The next operation, lowered: its segments count into the path length here (what
    /// `@ITPPATH` and the motion sync read), whichever of the two APIs hands them out, and
    /// are kept for [`next_segment`](Self::next_segment) when `keep`.
    /// The programmed operation goes through cutter compensation ([`comp::Stage`]), which may
    /// hold it back until the next element shows how the two meet; what it gives out is
    /// lowered. With `keep` the operation itself is not given back (no copy of it is made).
    fn next_op(&mut self, keep: bool) -> Result<Pulled, NcError> {
        let ready = self.ready_op().inspect_err(|_| {
            // The error is the last item: what compensation holds back is dropped.
            self.flow.comp.reset(self.m.state.pos);
        })?;
        let before = self.flow.lowered.len();
        // X, Y and Z's indices (arc centres) for lowering.
        let xyz = self.m.map.xyz;
        let f = &mut self.flow;
        let (fed, pulled) = match ready {
            Ready::Queued if keep && f.queue.front().is_some_and(|op| f.comp.pass_through(op)) => {
                // Checked where it waits, then taken out and lowered by value: its kind,
                // source and state move into the segment.
                if let Some(op) = f.queue.pop_front() {
                    lower::lower_owned(op, xyz, &mut f.lowered);
                }
                if f.lowered.len() == before + 1
                    && let Some((s, _)) = f.lowered.back()
                {
                    // The usual one segment: counted without ranging over the queue.
                    self.m.account(s);
                    return Ok(Pulled::Kept);
                }
                (Ok(()), Pulled::Kept)
            }
            ready => {
                let op = match ready {
                    Ready::Queued => f.queue.pop_front(),
                    Ready::Op(op) => Some(op),
                    Ready::End => None,
                };
                match op {
                    Some(op) if keep => (f.comp.push(op), Pulled::Kept),
                    Some(op) => (f.comp.push(op.clone()), Pulled::Op(Box::new(op))),
                    None => (f.comp.finish(), Pulled::End),
                }
            }
        };
        if let Err(e) = fed {
            self.flow.done = true;
            self.flow.queue.clear();
            self.flow.comp.reset(self.m.state.pos);
            return Err(self.comp_error(e));
        }
        while let Some(c) = self.flow.comp.pop() {
            lower::lower_with_state(&c, xyz, &mut self.flow.lowered);
        }
        for (s, _) in self.flow.lowered.range(before..) {
            self.m.account(s);
        }
        if !keep {
            self.flow.lowered.truncate(before);
        }
        Ok(pulled)
    }

    /// A compensation error at the line of the block it names.
    fn comp_error(&mut self, e: comp::CompError) -> NcError {
        if let Some(s) = &mut self.flow.stream
            && *self.flow.main_src.name == *e.source.file
        {
            return match s.line_window(e.source.line) {
                Ok(w) => comp_error_at(&w, e),
                Err(read) => read,
            };
        }
        let f = &self.flow;
        let src = std::iter::once(&f.main_src)
            .chain(f.units.iter().map(|u| &u.src))
            .chain(f.lib_cache.values().map(|u| &u.src))
            .find(|s| s.name == e.source.file)
            .unwrap_or(&f.main_src);
        comp_error_at(src, e)
    }

    /// Runs the program until its next operation is ready: at the front of the queue, or
    /// from the C-like program, or none (the end).
    fn ready_op(&mut self) -> Result<Ready, NcError> {
        if let Some(e) = self.flow.load_error.take() {
            self.flow.done = true;
            return Err(NcError::new(&self.flow.main_src, Span::default(), e));
        }
        if self.hll.active() {
            self.m.lane_canon = false;
            return Ok(match self.hll.next_op(&mut self.m)? {
                Some(op) => Ready::Op(op),
                None => Ready::End,
            });
        }
        loop {
            if !self.flow.queue.is_empty() {
                return Ok(Ready::Queued);
            }
            if self.flow.done {
                return Ok(Ready::End);
            }
            if let Err(e) = self.step() {
                self.flow.done = true;
                self.flow.queue.clear();
                return Err(e);
            }
        }
    }

    /// Switches the plain-block lane on (the default) or off: every block then runs
    /// through the general block layer. The outputs are the same either way; tests compare
    /// them.
    #[doc(hidden)]
    pub fn set_plain_lane(&mut self, on: bool) {
        self.flow.lane = on.then(|| PlainLane::new(&self.m.cfg));
    }

    /// How many blocks the plain-block lane has run since this interpreter was made.
    #[doc(hidden)]
    pub fn plain_lane_blocks(&self) -> u64 {
        self.flow.lane_blocks
    }

    /// The modal state after the last executed block.
    pub fn state(&self) -> &ModalState {
        &self.m.state
    }

    /// The 1-based line of the first block numbered `N n` in the main program, if any (a
    /// program read line by line: the one a jump from its start would find).
    pub fn label_line(&mut self, n: u32) -> Option<u32> {
        let u = self.flow.frames.first()?.unit.clone();
        let i = match (&mut self.flow.stream, u.streamed) {
            (Some(s), true) => s.find_label(&u, n, u.start).ok()??,
            _ => *u.ix.labels.get(&n)?,
        };
        Some(i as u32 + 1)
    }

    /// Runs one block of `unit` (the current frame's program), with words evaluated against
    /// the variables (vacant words left out), then whatever the block asks for after its
    /// words: an `M98` call, an `M99` return, or the `G66` modal call after a move.
    pub(crate) fn exec_block(
        &mut self,
        unit: &Arc<Unit>,
        line: &Line,
        block: Option<&Block>,
    ) -> Result<(), NcError> {
        let empty = Block::default();
        let block = block.unwrap_or(&empty);
        let linuxcnc = unit.program.dialect == cnc402_lang::Dialect::LinuxCnc;
        let translated;
        let block = match linuxcnc {
            true => match self.linuxcnc_block(unit, block)? {
                Some(b) => {
                    translated = b;
                    &translated
                }
                None => block,
            },
            false => block,
        };
        if let Some(named) = block.named_axes.first() {
            return Err(NcError::new(
                &unit.src,
                named.span,
                format!("AXSTR axis words are allowed {}", C_LIKE_ONLY),
            ));
        }
        if units::is_g65_h(block) {
            return self.g65_h(unit, line, block);
        }
        // A G65/G66 call may repeat I, J and K (argument specification II): they are taken
        // out of the block here, in source order, and numbered by `take_calls`.
        let mut ijk = Vec::new();
        let filtered;
        let block = if units::is_macro_call(block)
            && block
                .words
                .iter()
                .any(|w| matches!(w.letter, 'I' | 'J' | 'K'))
        {
            for w in &block.words {
                if matches!(w.letter, 'I' | 'J' | 'K') {
                    let v = expr::value_in(&unit.src, &w.value, self)?;
                    ijk.push((w.letter, v, w.span));
                }
            }
            let mut b = block.clone();
            b.words.retain(|w| !matches!(w.letter, 'I' | 'J' | 'K'));
            filtered = b;
            &filtered
        } else {
            block
        };
        let mut words = match self.flow.spare_words.take() {
            Some(mut w) => {
                w.collect_again(&unit.src, block, self)?;
                w
            }
            None => Box::new(Words::collect_with(&unit.src, block, self)?),
        };
        crate::block::mcodes::macro_calls(&self.m.cfg, &unit.src, &mut words)?;
        let seat = self.hll.seat();
        let at = (&*unit.src, self.m.dialect);
        let wait = crate::block::mcodes::wait_mcode(&self.m.cfg, at, &mut words, seat)?;
        let Some(call) = self.take_calls(unit, &mut words, &ijk)? else {
            return Ok(());
        };
        let has_axis = self.m.cfg.axes.iter().any(|a| words.peek(a.name).is_some());
        if let Some(m) = words.m.last() {
            self.flow.last_m = Some(f64::from(m.0));
        }
        let from = self.m.state.pos;
        let sets_g92 = linuxcnc && words.g().iter().any(|g| g.0 == 92);
        let first = self.flow.queue.len();
        let end = (self.m).execute_into(&unit.src, &mut words, line, &mut self.flow.queue)?;
        if let Some(kind) = wait {
            self.flow.queue.push_back(crate::block::mcodes::wait_op(
                &mut self.m,
                kind,
                &unit.src,
                line,
            ));
        }
        self.flow.spare_words = Some(words);
        if sets_g92 {
            self.flow.g92_kept = self.m.state.shift;
        }
        if canon::makes_motion(self.flow.queue.range(first..), &from) {
            self.flow.runaway.reset();
        }
        if end {
            self.flow.done = true;
            return Ok(());
        }
        self.after_block(unit, call, has_axis)
    }
}

/// Where [`Interpreter::next_op`] finds the next operation.
enum Ready {
    /// At the front of the queue.
    Queued,
    /// Handed over by the C-like program.
    Op(CanonOp),
    /// The program has ended.
    End,
}

/// What [`Interpreter::next_op`] did.
#[derive(Debug)]
enum Pulled {
    /// The next operation (not kept; boxed: `next_op` returns a small value on the
    /// segments' path).
    Op(Box<CanonOp>),
    /// The next operation went through, its segments kept for `next_segment`.
    Kept,
    /// The program has ended.
    End,
}

/// A compensation error `e` at its line of `src` (the whole file or the line's window).
fn comp_error_at(src: &SourceFile, e: comp::CompError) -> NcError {
    let line = src.line_span(e.source.line);
    let text = src.line_text(e.source.line);
    let lead = text.len() - text.trim_start().len();
    let at = cnc402_lang::ast::Span::new(line.start as usize + lead, line.end as usize);
    NcError::new(src, at, e.message)
}

impl AsRef<Hll> for Interpreter {
    fn as_ref(&self) -> &Hll {
        &self.hll
    }
}

impl Iterator for Interpreter {
    type Item = Result<Segment, NcError>;
    /// Segments until the end of the program; an error is the last item.
    fn next(&mut self) -> Option<Self::Item> {
        self.next_segment().transpose()
    }
}

/// Parses and runs `src` to its end: every segment, or the first error (parser or interpreter).
///
/// ```
/// use cnc402_config::MachineConfig;
/// use cnc402_lang::SourceFile;
/// let cfg = MachineConfig::default_machine();
/// let segs = cnc402_interp::run_program(&cfg, &SourceFile::new("a.nc", "G1 X10 F100\nM30\n"))
///     .unwrap();
/// assert_eq!(segs.len(), 2);
/// let err = cnc402_interp::run_program(&cfg, &SourceFile::new("b.nc", "G1 X10\n")).unwrap_err();
/// assert_eq!(err.to_string(), "b.nc:1:1: zero feed in a motion block (expected an F word > 0 in this or an earlier block)\n    G1 X10");
/// ```
pub fn run_program(cfg: &MachineConfig, src: &SourceFile) -> Result<Vec<Segment>, NcError> {
    run_program_with(cfg, Options::default(), src)
}

/// Parses `src` in the dialect it is to run in on machine `cfg`: `forced` (the command line's
/// `--dialect`) if given, else its header's ([`cnc402_lang::declared_dialect`]), else the
/// config's `interp.dialect`.
///
/// ```
/// use cnc402_interp::parse_program;
/// use cnc402_lang::{Dialect, SourceFile};
/// let cfg = cnc402_config::MachineConfig::default_machine();
/// let src = SourceFile::new("p.nc", "(dialect: haas)\nG0 X1\n");
/// assert_eq!(parse_program(&cfg, &src, None).unwrap().dialect, Dialect::Haas);
/// assert_eq!(parse_program(&cfg, &src, Some(Dialect::Fanuc)).unwrap().dialect, Dialect::Fanuc);
/// ```
#[allow(clippy::result_large_err)]
pub fn parse_program(
    cfg: &cnc402_config::MachineConfig,
    src: &cnc402_lang::SourceFile,
    forced: Option<cnc402_lang::Dialect>,
) -> Result<cnc402_lang::ast::Program, cnc402_lang::NcError> {
    let dialect = cnc402_lang::choose_dialect(src, forced, cfg.interp.dialect)?;
    cnc402_lang::parse_in(src, dialect)
}

/// [`run_program`] with explicit operator switches.
pub fn run_program_with(
    cfg: &MachineConfig,
    opts: Options,
    src: &SourceFile,
) -> Result<Vec<Segment>, NcError> {
    let program = parse_program(cfg, src, None)?;
    let mut it = Interpreter::with_options(cfg, opts);
    it.load(src.clone(), program);
    it.collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use cnc402_motion::segment::{AxisPos, SegmentKind, SpindleDir};

    fn cfg() -> MachineConfig {
        MachineConfig::default_machine()
    }

    fn load(text: &str, opts: Options) -> Interpreter {
        let src = SourceFile::new("t.nc", text);
        let p = cnc402_lang::parse(&src).expect("parses");
        let mut it = Interpreter::with_options(&cfg(), opts);
        it.load(src, p);
        it
    }

    #[test]
    fn segments_come_one_at_a_time_with_their_source() {
        let mut it = load("N5 G0 X1\n\nN7 G1 Y2 F50\n", Options::default());
        let a = it.next_segment().unwrap().unwrap();
        assert_eq!(
            (a.source.line, a.source.n, &*a.source.file),
            (1, Some(5), "t.nc")
        );
        // The interpreter has run only as far as it had to.
        assert_eq!(it.state().pos[1], 0.0);
        let b = it.next_segment().unwrap().unwrap();
        assert_eq!((b.source.line, b.source.n), (3, Some(7)));
        assert_eq!(it.state().pos[1], 2.0);
        assert_eq!(it.next_segment().unwrap(), None);
        assert_eq!(it.next_segment().unwrap(), None);
        assert_eq!(it.label_line(7), Some(3));
        assert_eq!(it.label_line(6), None);
    }

    #[test]
    fn with_next_segment_hands_out_what_next_segment_gives() {
        // A cycle gives several segments an operation, the rest one each.
        let text = "G0 X1\nG1 Y2 F50\nG2 X3 Y0 R2\nM3 S100\nG4 P1\n\
                    G81 X1 Y1 Z-1 R1 F100\nX2\nG80\nG0 X0\nM2\n";
        let mut a = load(text, Options::default());
        let mut b = load(text, Options::default());
        let mut n = 0;
        loop {
            let seen = a.with_next_segment(|s| s).unwrap();
            assert_eq!(seen, b.next_segment().unwrap());
            assert_eq!(a.state().pos, b.state().pos);
            if seen.is_none() {
                break;
            }
            n += 1;
        }
        assert_eq!(n, 15, "{n} segments");
        assert_eq!(a.with_next_segment(|_| ()).unwrap(), None);
    }

    #[test]
    fn options_switch_m1_block_delete_and_start() {
        let mut start = AxisPos::default();
        start[2] = 30.0;
        let opts = Options {
            block_delete: false,
            optional_stop: false,
            start,
            main_m99: MainM99::End,
            default_spindle: 1,
        };
        let segs: Vec<_> = load("/G0 X5\nM1\nG91 G0 Z-5\n", opts)
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(segs.len(), 2, "M1 is skipped, the / block runs");
        let SegmentKind::Rapid { end } = segs[1].kind else {
            panic!()
        };
        assert_eq!((end[0], end[2]), (5.0, 25.0));
    }

    #[test]
    fn s_change_while_turning_and_g95_feed() {
        let segs: Vec<_> = load(
            "M3 S100\nS200\nG95 G1 X1 F0.5\nM5\nS300\n",
            Options::default(),
        )
        .collect::<Result<_, _>>()
        .unwrap();
        let kinds: Vec<_> = segs.iter().map(|s| s.kind.clone()).collect();
        assert_eq!(
            kinds[1],
            SegmentKind::Spindle {
                rpm: 200.0,
                dir: SpindleDir::Cw,
                spindle: 1,
            }
        );
        assert!(matches!(kinds[2], SegmentKind::Linear { feed, .. } if feed == 100.0));
        assert_eq!(kinds.len(), 4, "S while stopped makes no segment");
    }

    #[test]
    fn messages_percent_end_and_msg_parsing() {
        let segs: Vec<_> = load(
            "%\n(MSG, hello )\nG0 X1 (not a msg)\n%\nG0 X2\n",
            Options::default(),
        )
        .collect::<Result<_, _>>()
        .unwrap();
        assert_eq!(segs.len(), 2);
        assert_eq!(
            segs[0].kind,
            SegmentKind::Message {
                text: "hello".into()
            }
        );
    }

    #[test]
    fn an_error_ends_the_run() {
        let mut it = load("G0 X1\nG7\nG0 X2\n", Options::default());
        assert!(it.next_segment().unwrap().is_some());
        let e = it.next_segment().unwrap_err();
        assert_eq!(e.line, 2);
        assert_eq!(it.next_segment().unwrap(), None);
    }

    /// The quick overflow check of a block of plain moves looks at the move's own feed: in
    /// G95 a finite F times a finite S may overflow (F and S alone are finite).
    #[test]
    fn a_g95_feed_that_overflows_is_an_error_at_f() {
        let text = format!("G95 G1 S6000 F{} X1\n", "9".repeat(306));
        let mut it = load(&text, Options::default());
        let e = it.next_segment().unwrap_err();
        assert!(e.message.contains("the feed overflows"), "{}", e.message);
        assert_eq!(e.col, 14);
    }
}

#[cfg(test)]
mod regressions {
    use super::*;

    /// Found by the proptest: `(MSG…` detection sliced a comment at byte 3, inside `Ä`.
    #[test]
    fn multibyte_comment_does_not_panic_msg_detection() {
        let cfg = MachineConfig::default_machine();
        for t in ["(ÄÖÜ)\n", "(MSÄ, x)\n", "(MS)\n", "(msg,lower)\n"] {
            let segs = run_program(&cfg, &SourceFile::new("t.nc", t)).unwrap();
            assert_eq!(segs.len(), usize::from(t.starts_with("(msg")), "{t}");
        }
    }
}
