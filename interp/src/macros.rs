//! Fanuc Custom Macro B execution: the program units of a file (`O` numbers), the call stack
//! (`M98`/`M99`, `G65`, `G66`/`G67`), macro variables (local per call level, common, non-volatile,
//! system), control flow (`GOTO`, `IF`, `WHILE … DO m … END m`), the old `G65 H…` macro
//! instructions, alarms (`#3000`, `G65 H99`) and the runaway-loop guard.

use std::collections::{HashMap, VecDeque};
use std::sync::Arc;

use cnc402_lang::ast::{Block, Expr, ExprKind, Line, LineKind, Program, Span, Value};
use cnc402_lang::{NcError, SourceFile};
use cnc402_motion::segment::{Plane, SegmentKind, Source, StopKind};

use crate::eval::{self, VarSource, var_number};
use crate::interp::Interpreter;
use crate::nvfile::{NV_FIRST, NV_LAST};
use crate::offsets::tool_offset_var;
use crate::state::Motion;
use crate::words::{GGroup, Words, fmt_num};

/// A macro value; `None` is vacant.
pub type MVal = Option<f64>;

/// Deepest call nesting (main program included): Fanuc allows 10 sub-program levels plus
/// 4 macro levels.
pub const MAX_FRAMES: usize = 15;
/// Deepest `G65`/`G66` nesting (local-variable levels besides the main program's).
pub const MAX_MACRO_LEVELS: usize = 4;

/// One program of a file: `O9001` through the line before the next `O` line (or the file's
/// end), with its sequence numbers and paired loops.
#[derive(Debug)]
pub struct Unit {
    pub src: Arc<SourceFile>,
    pub program: Arc<Program>,
    /// The `O` number; `None` for a file without one.
    pub number: Option<u32>,
    /// Line indices `start..end` into `program.lines`.
    pub start: usize,
    pub end: usize,
    /// N number → line index (first occurrence in this unit).
    pub labels: HashMap<u32, usize>,
    /// WHILE line ↔ its END line (both directions).
    pub loops: HashMap<usize, usize>,
    /// Nesting errors found when the unit was loaded, reported when the line runs.
    pub loop_errors: HashMap<usize, String>,
}

impl Unit {
    fn new(src: &Arc<SourceFile>, program: &Arc<Program>, start: usize, end: usize) -> Unit {
        let number = match program.lines.get(start).map(|l| &l.kind) {
            Some(LineKind::ProgramNumber { number, .. }) => Some(*number),
            _ => program.lines[start..end].iter().find_map(|l| match l.kind {
                LineKind::ProgramNumber { number, .. } => Some(number),
                _ => None,
            }),
        };
        let mut labels = HashMap::new();
        let mut loops = HashMap::new();
        let mut loop_errors = HashMap::new();
        let mut open: Vec<(u8, usize)> = Vec::new();
        let line_of = |i: usize| program.lines[i].line_no;
        for i in start..end {
            let l = &program.lines[i];
            if let Some(n) = l.n {
                labels.entry(n.value).or_insert(i);
            }
            match l.kind {
                LineKind::While { id, .. } => {
                    if !(1..=3).contains(&id) {
                        loop_errors.insert(i, format!("DO {id}: loop numbers are 1, 2 and 3"));
                    } else if let Some(&(_, at)) = open.iter().find(|o| o.0 == id) {
                        loop_errors.insert(
                            i,
                            format!(
                                "DO {id} inside the loop DO {id} of line {}: nested loops need different numbers",
                                line_of(at)
                            ),
                        );
                    } else if open.len() >= 3 {
                        loop_errors.insert(i, "WHILE loops nested more than 3 deep".into());
                    }
                    open.push((id, i));
                }
                LineKind::End { id } => match open.last() {
                    Some(&(top, w)) if top == id => {
                        open.pop();
                        if !loop_errors.contains_key(&w) {
                            loops.insert(w, i);
                            loops.insert(i, w);
                        }
                    }
                    Some(&(top, w)) => {
                        let msg = if let Some(&(_, w2)) = open.iter().find(|o| o.0 == id) {
                            let m = format!(
                                "END {id} (line {}) closes DO {id} of line {} while DO {top} of line {} is still open: loops must not cross",
                                line_of(i),
                                line_of(w2),
                                line_of(w)
                            );
                            // The WHILE runs first: it carries the message too.
                            loop_errors.insert(w2, m.clone());
                            m
                        } else {
                            format!(
                                "END {id} without a WHILE … DO {id} before it (DO {top} of line {} is open)",
                                line_of(w)
                            )
                        };
                        loop_errors.insert(i, msg);
                    }
                    None => {
                        loop_errors
                            .insert(i, format!("END {id} without a WHILE … DO {id} before it"));
                    }
                },
                _ => {}
            }
        }
        for (id, w) in open {
            loop_errors
                .entry(w)
                .or_insert_with(|| format!("WHILE … DO {id} has no END {id}"));
        }
        Unit {
            src: src.clone(),
            program: program.clone(),
            number,
            start,
            end,
            labels,
            loops,
            loop_errors,
        }
    }

    fn name(&self) -> String {
        match self.number {
            Some(n) => format!("O{n:04}"),
            None => format!("the program {}", self.src.name),
        }
    }
}

/// Splits a file into its programs: one per `O` line; lines before the first `O` line form
/// the main program when they hold anything but `%`, comments and empty lines. Returns the
/// units and the index of the main one.
pub fn split_units(src: &Arc<SourceFile>, program: &Arc<Program>) -> (Vec<Arc<Unit>>, usize) {
    let n = program.lines.len();
    let os: Vec<usize> = program
        .lines
        .iter()
        .enumerate()
        .filter(|(_, l)| matches!(l.kind, LineKind::ProgramNumber { .. }))
        .map(|(i, _)| i)
        .collect();
    if os.is_empty() {
        return (vec![Arc::new(Unit::new(src, program, 0, n))], 0);
    }
    let prefix_has_code = program.lines[..os[0]]
        .iter()
        .any(|l| !matches!(l.kind, LineKind::Empty | LineKind::Percent) || l.n.is_some());
    let mut units = Vec::new();
    let mut bounds: Vec<usize> = os.clone();
    if prefix_has_code {
        bounds.insert(0, 0);
    } else {
        bounds[0] = 0;
    }
    bounds.push(n);
    for w in bounds.windows(2) {
        units.push(Arc::new(Unit::new(src, program, w[0], w[1])));
    }
    (units, 0)
}

/// One level of the call stack.
#[derive(Debug)]
pub struct Frame {
    pub unit: Arc<Unit>,
    /// Index of the next line to execute.
    pub pc: usize,
    /// Runs of the unit still to come after this one (`M98 … L3`, `P3xxxx`).
    pub repeats: u32,
    /// A `G65`/`G66` call: has its own local variables.
    pub macro_level: bool,
}

impl Frame {
    pub fn new(unit: Arc<Unit>, macro_level: bool) -> Frame {
        Frame {
            pc: unit.start,
            unit,
            repeats: 0,
            macro_level,
        }
    }
}

/// A `G66` modal call in force.
#[derive(Clone, Debug)]
pub struct ModalCall {
    pub number: u32,
    pub times: u32,
    pub args: [MVal; 33],
    /// The frame depth that issued it: blocks at this depth trigger the call.
    pub depth: usize,
}

/// Counts blocks since the last motion; remembers recent lines to name the loop.
#[derive(Debug, Default)]
pub struct Runaway {
    pub count: u64,
    recent: VecDeque<(usize, u32)>,
}

impl Runaway {
    pub fn reset(&mut self) {
        self.count = 0;
    }
    fn note(&mut self, unit: &Unit, line: u32) {
        self.count += 1;
        if self.recent.len() == 512 {
            self.recent.pop_front();
        }
        self.recent.push_back((unit as *const Unit as usize, line));
    }
    /// The line range the recent blocks of `unit` ran over.
    fn lines(&self, unit: &Unit) -> (u32, u32) {
        let id = unit as *const Unit as usize;
        let ls = self.recent.iter().filter(|r| r.0 == id).map(|r| r.1);
        let lo = ls.clone().min().unwrap_or(0);
        let hi = ls.max().unwrap_or(0);
        (lo, hi)
    }
}

/// Local, common and non-volatile variables.
#[derive(Debug)]
pub struct VarTable {
    /// One set of `#1–#33` per macro call level; `[0]` is the main program's.
    pub locals: Vec<[MVal; 33]>,
    pub common: [MVal; 100],
    pub nv: Box<[MVal; 500]>,
    /// Reads of `#500–#999` so far (see [`Interpreter::persistent_reads`]).
    pub nv_reads: u64,
}

impl Default for VarTable {
    fn default() -> Self {
        VarTable {
            locals: vec![[None; 33]],
            common: [None; 100],
            nv: Box::new([None; 500]),
            nv_reads: 0,
        }
    }
}

impl VarTable {
    /// Reset: locals and common variables vacant; non-volatile ones kept.
    pub fn reset(&mut self) {
        self.locals = vec![[None; 33]];
        self.common = [None; 100];
    }
}

/// Fanuc argument specification I: address → local variable number.
pub fn arg_var(letter: char) -> Option<usize> {
    Some(match letter {
        'A' => 1,
        'B' => 2,
        'C' => 3,
        'I' => 4,
        'J' => 5,
        'K' => 6,
        'D' => 7,
        'E' => 8,
        'F' => 9,
        'H' => 11,
        'M' => 13,
        'Q' => 17,
        'R' => 18,
        'S' => 19,
        'T' => 20,
        'U' => 21,
        'V' => 22,
        'W' => 23,
        'X' => 24,
        'Y' => 25,
        'Z' => 26,
        _ => return None,
    })
}

/// A `G65` block that is an old-style macro instruction (`G65 H02 P#1 Q#2 R5`): it has an
/// `H` word and no address besides G, H, P, Q and R. With any other address (`G65 P9 H11 A1`)
/// H is argument `#11` of a macro call.
pub fn is_g65_h(b: &Block) -> bool {
    let g65 = b
        .words
        .iter()
        .any(|w| w.letter == 'G' && matches!(&w.value, Value::Number(n) if n.value == 65.0));
    g65 && b.words.iter().any(|w| w.letter == 'H')
        && b.words
            .iter()
            .all(|w| matches!(w.letter, 'G' | 'H' | 'P' | 'Q' | 'R'))
}

/// A `G65` or `G66` block (a literal G65/G66 word): its arguments may use specification II.
pub fn is_macro_call(b: &Block) -> bool {
    b.words.iter().any(|w| {
        w.letter == 'G'
            && matches!(&w.value, Value::Number(n) if n.value == 65.0 || n.value == 66.0)
    })
}

/// Fanuc argument specification II: the I, J, K words of a call, in source order, numbered in
/// sets: a letter that does not come after the previous one in I < J < K order starts the
/// next set (`I1 J1 K1 I2 K2 J3` …), and set n's I, J, K are `#(3n+1)`, `#(3n+2)`, `#(3n+3)`
/// (set 1 is specification I's `#4 #5 #6`). Returns (source offset, variable, value) for
/// each word with a value, or the span of the 11th set's first word.
///
/// ```
/// use cnc402_interp::macros::spec2_vars;
/// use cnc402_lang::ast::Span;
/// let s = |i: u32| Span { start: i, end: i + 1 };
/// let w = [('I', Some(1.0), s(0)), ('K', Some(2.0), s(2)), ('J', Some(3.0), s(4)), ('I', None, s(6))];
/// assert_eq!(spec2_vars(&w), Ok(vec![(0, 4, 1.0), (2, 6, 2.0), (4, 8, 3.0)]));
/// ```
pub fn spec2_vars(ijk: &[(char, MVal, Span)]) -> Result<Vec<(u32, usize, f64)>, Span> {
    let mut out = Vec::new();
    let mut set = 1usize;
    let mut last: Option<char> = None;
    for &(letter, v, span) in ijk {
        if last.is_some_and(|l| letter <= l) {
            set += 1;
        }
        last = Some(letter);
        if set > 10 {
            return Err(span);
        }
        let var = 3 * set + 1 + (letter as usize - 'I' as usize);
        if let Some(v) = v {
            out.push((span.start, var, v));
        }
    }
    Ok(out)
}

/// What a block asks for after its own words have run.
pub enum After {
    Nothing,
    /// `M98 P… L…`.
    Call {
        number: u32,
        times: u32,
        span: Span,
    },
    /// `M99 [P n]`.
    Return {
        seq: Option<u32>,
        span: Span,
    },
}

fn whole(v: f64) -> Option<u32> {
    (v >= 0.0 && v.fract() == 0.0 && v <= 99_999_999.0).then_some(v as u32)
}

impl VarSource for Interpreter {
    fn get(&mut self, n: i64) -> Result<Option<f64>, String> {
        self.read_var(n)
    }
}

/// Where the C-like language runs: a Macro B sub-program may be a C-like file, but the
/// Macro B executor does not run C-like code (a C-like main program runs in `hll`).
pub(crate) const C_LIKE_ONLY: &str = "only in a C-like main program and the files it #uses, not in a sub-program that a Macro B program calls (M98, G65, G66)";

/// `#2401–#2800`: controls differ in whether and how they number the D values (cutter
/// radius) of offsets 1–200 there, so cnc402 maps only `#12001…`/`#13001…` for D; a guessed
/// mapping could write the wrong field. The error says where the D values are.
fn old_d_offset_var(n: i64) -> String {
    format!(
        "#{n} is not a variable of this control: the D (radius) offsets are #13001-#13400 (geometry) and #12001-#12400 (wear); the older #2xxx numbers are H only (#2001-#2200 wear, #2201-#2400 geometry)"
    )
}

impl Interpreter {
    /// How many times the program has read a non-volatile variable (`#500–#999`) so far: the
    /// values an operator can change during a program stop (`cnc402 vars set`). A dry run uses
    /// it to tell an error that depends on them from one that does not.
    pub fn persistent_reads(&self) -> u64 {
        self.vars.nv_reads
    }

    fn cur_unit(&self) -> Arc<Unit> {
        self.frames
            .last()
            .map(|f| f.unit.clone())
            .unwrap_or_else(|| self.units[0].clone())
    }

    /// Reads `#n` (system variables included). A position read (`#5021…`, `#5041…`) first
    /// waits for motion through the [`MotionSync`](crate::host::MotionSync).
    pub(crate) fn read_var(&mut self, n: i64) -> Result<MVal, String> {
        let naxes = self.cfg.axes.len() as i64;
        let unit = self.state.unit();
        let lin = |i: usize, v: f64, cfg: &cnc402_config::MachineConfig| {
            if cfg.axes[i].kind.is_rotary() {
                v
            } else {
                v / unit
            }
        };
        Ok(match n {
            0 => None,
            1..=33 => self.vars.locals.last().and_then(|l| l[(n - 1) as usize]),
            100..=199 => self.vars.common[(n - 100) as usize],
            500..=999 => {
                self.vars.nv_reads += 1;
                self.vars.nv[(n - 500) as usize]
            }
            3000 | 3006 => None,
            4001..=4022 => self.group_code((n - 4000) as u32),
            4102..=4120 => match n - 4100 {
                9 => Some(self.state.feed / unit),
                13 => self.last_m,
                14 => self.last_n,
                15 => self
                    .frames
                    .last()
                    .and_then(|f| f.unit.number)
                    .map(f64::from),
                11 => Some(f64::from(self.state.h)),
                19 => Some(self.state.speed),
                20 => Some(f64::from(self.state.tool_selected)),
                2 | 7 | 8 => None,
                _ => return Err(format!("#{n} is not a modal information variable")),
            },
            // Fanuc: the block end point without the tool length offset.
            5001..=5008 if n - 5001 < naxes => {
                let i = (n - 5001) as usize;
                Some(lin(i, self.state.programmed(i), &self.cfg))
            }
            // The tool length offset vector in force (Z; 0 on the other axes).
            5081..=5088 if n - 5081 < naxes => {
                let i = (n - 5081) as usize;
                Some(lin(i, self.state.tlo_of(i), &self.cfg))
            }
            5021..=5028 | 5041..=5048 if (n - 1) % 20 < naxes => {
                let i = ((n - 1) % 20) as usize;
                let actual = self.sync.wait_motion_done(&self.state.pos)?;
                // #5041: work coordinates with the tool length offset included (Fanuc).
                let v = if n < 5041 {
                    actual[i]
                } else {
                    actual[i] - self.state.work_zero(i)
                };
                Some(lin(i, v, &self.cfg))
            }
            5221..=5328 => {
                let (k, i) = work_offset_var(n, naxes)?;
                Some(lin(i, self.state.work_offsets[k][i], &self.cfg))
            }
            2001..=2400 | 10001..=13999 => match tool_offset_var(n) {
                Some((k, f)) => Some(f.get(&self.state.tool_offsets[k - 1]) / unit),
                None => {
                    return Err(format!(
                        "#{n} is not a tool offset of this control (1..400)"
                    ));
                }
            },
            2401..=2800 => return Err(old_d_offset_var(n)),
            _ => return Err(format!("#{n} is not a variable of this control")),
        })
    }

    /// `#4000+g`: the code of modal group `g` (groups cnc402 lacks read vacant, or the
    /// group's cancel code when cnc402 accepts it).
    fn group_code(&self, g: u32) -> MVal {
        let st = &self.state;
        let v = match g {
            1 => match st.motion {
                Motion::Rapid => 0.0,
                Motion::Linear => 1.0,
                Motion::ArcCw => 2.0,
                Motion::ArcCcw => 3.0,
            },
            2 => match st.plane {
                Plane::XY => 17.0,
                Plane::ZX => 18.0,
                Plane::YZ => 19.0,
            },
            3 => {
                if st.incremental {
                    91.0
                } else {
                    90.0
                }
            }
            5 => {
                if st.feed_per_rev {
                    95.0
                } else {
                    94.0
                }
            }
            6 => {
                if st.inch {
                    20.0
                } else {
                    21.0
                }
            }
            7 => 40.0,
            8 => f64::from(st.tool_length.code()),
            9 => st.cycle.map_or(80.0, |c| f64::from(c.code())),
            10 => {
                if st.return_to_r {
                    99.0
                } else {
                    98.0
                }
            }
            11 => 50.0,
            12 => {
                if self.modal_call.is_some() {
                    66.0
                } else {
                    67.0
                }
            }
            14 => 54.0 + st.work_offset as f64,
            15 => f64::from(st.path_mode),
            16 => 69.0,
            17 => 15.0,
            _ => return None,
        };
        Some(v)
    }

    /// Writes `#n`; system variables with side effects (`#3000`, `#3006`) are handled by the
    /// assignment itself.
    pub(crate) fn write_var(&mut self, n: i64, v: MVal) -> Result<(), String> {
        let naxes = self.cfg.axes.len() as i64;
        match n {
            0 => return Err("#0 is always vacant and cannot be written".into()),
            1..=33 => {
                if let Some(l) = self.vars.locals.last_mut() {
                    l[(n - 1) as usize] = v;
                }
            }
            100..=199 => self.vars.common[(n - 100) as usize] = v,
            500..=999 => {
                self.vars.nv[(n - 500) as usize] = v;
                if let Some(s) = self.nv_store.as_mut() {
                    s.store(&self.vars.nv[..])
                        .map_err(|e| format!("#{n} could not be stored (non-volatile): {e}"))?;
                }
            }
            5221..=5328 => {
                let (k, i) = work_offset_var(n, naxes)?;
                let unit = if self.cfg.axes[i].kind.is_rotary() {
                    1.0
                } else {
                    self.state.unit()
                };
                self.state.work_offsets[k][i] = v.unwrap_or(0.0) * unit;
            }
            2001..=2400 | 10001..=13999 => {
                let Some((k, f)) = tool_offset_var(n) else {
                    return Err(format!(
                        "#{n} is not a tool offset of this control (1..400)"
                    ));
                };
                let v = v.unwrap_or(0.0) * self.state.unit();
                f.set(&mut self.state.tool_offsets[k - 1], v);
            }
            2401..=2800 => return Err(old_d_offset_var(n)),
            _ => {
                return Err(format!(
                    "#{n} cannot be written (locals #1-#33, common #100-#199, non-volatile #{NV_FIRST}-#{NV_LAST}, work offsets #5221-#5326, tool offsets #2001-#2400 and #10001-#13400, #3000, #3006)"
                ));
            }
        }
        Ok(())
    }

    fn eval_at(&mut self, src: &SourceFile, e: &Expr) -> Result<MVal, NcError> {
        eval::eval(src, e, self)
    }

    /// Executes the line at the program counter of the innermost frame.
    pub(crate) fn step(&mut self) -> Result<(), NcError> {
        let Some(frame) = self.frames.last_mut() else {
            self.done = true;
            return Ok(());
        };
        let unit = frame.unit.clone();
        let pc = frame.pc;
        if pc >= unit.end {
            return self.end_of_unit(&unit);
        }
        frame.pc += 1;
        let program = unit.program.clone();
        let line = &program.lines[pc];
        if line.block_delete && self.opts.block_delete {
            return Ok(());
        }
        if let Some(n) = line.n {
            self.last_n = Some(f64::from(n.value));
        }
        if !matches!(
            line.kind,
            LineKind::Empty | LineKind::Continued | LineKind::ProgramNumber { .. }
        ) {
            self.runaway.note(&unit, line.line_no);
            if self.runaway.count > self.cfg.interp.block_limit {
                let (a, b) = self.runaway.lines(&unit);
                return Err(NcError::new(
                    &unit.src,
                    line.span,
                    format!(
                        "runaway program: {} blocks in a row without motion (interp.block_limit); the loop runs over lines {a}-{b} of {}",
                        self.cfg.interp.block_limit, unit.src.name
                    ),
                )
                .with_expected("a loop that ends, or motion inside it"));
            }
        }
        let err = |span: Span, m: String| NcError::new(&unit.src, span, m);
        match &line.kind {
            LineKind::Percent => {
                if self.seen_block {
                    return self.end_of_unit(&unit);
                }
                Ok(())
            }
            LineKind::ProgramNumber { .. } | LineKind::Continued => Ok(()),
            LineKind::Empty => self.exec_block(&unit, line, None),
            LineKind::Block(b) => {
                self.seen_block = true;
                self.exec_block(&unit, line, Some(b))
            }
            LineKind::Stmts(_) => Err(err(
                line.span,
                format!("C-like statements are allowed {C_LIKE_ONLY}"),
            )),
            LineKind::Assign { target, value } => {
                self.seen_block = true;
                self.assign(&unit, line, target, value)
            }
            LineKind::Goto { target } => {
                self.seen_block = true;
                let n = self.seq_target(&unit, target)?;
                self.jump(&unit, n, target.span)
            }
            LineKind::IfGoto { cond, target } => {
                self.seen_block = true;
                if self.truth(&unit, cond)? {
                    let n = self.seq_target(&unit, target)?;
                    self.jump(&unit, n, target.span)?;
                }
                Ok(())
            }
            LineKind::IfThen { cond, then } => {
                self.seen_block = true;
                if !self.truth(&unit, cond)? {
                    return Ok(());
                }
                match &**then {
                    LineKind::Assign { target, value } => self.assign(&unit, line, target, value),
                    LineKind::Block(b) => self.exec_block(&unit, line, Some(b)),
                    _ => Err(err(
                        line.span,
                        "IF … THEN takes an assignment or a block".into(),
                    )),
                }
            }
            LineKind::While { cond, id } => {
                self.seen_block = true;
                if let Some(m) = unit.loop_errors.get(&pc) {
                    return Err(err(line.span, m.clone()));
                }
                let Some(&end) = unit.loops.get(&pc) else {
                    return Err(err(line.span, format!("WHILE … DO {id} has no END {id}")));
                };
                if !self.truth(&unit, cond)? {
                    self.set_pc(end + 1);
                }
                Ok(())
            }
            LineKind::End { id } => {
                if let Some(m) = unit.loop_errors.get(&pc) {
                    return Err(err(line.span, m.clone()));
                }
                let Some(&w) = unit.loops.get(&pc) else {
                    return Err(err(line.span, format!("END {id} without WHILE … DO {id}")));
                };
                self.set_pc(w);
                Ok(())
            }
        }
    }

    fn set_pc(&mut self, pc: usize) {
        if let Some(f) = self.frames.last_mut() {
            f.pc = pc;
        }
    }

    fn truth(&mut self, unit: &Unit, cond: &Expr) -> Result<bool, NcError> {
        Ok(matches!(self.eval_at(&unit.src, cond)?, Some(v) if v != 0.0))
    }

    fn seq_target(&mut self, unit: &Unit, e: &Expr) -> Result<u32, NcError> {
        let v = self.eval_at(&unit.src, e)?;
        match v.and_then(whole) {
            Some(n) if (1..=99_999).contains(&n) => Ok(n),
            _ => Err(NcError::new(
                &unit.src,
                e.span,
                format!(
                    "GOTO target {} is not a sequence number",
                    v.map_or("vacant".into(), fmt_num)
                ),
            )
            .with_expected("a whole number 1..99999")),
        }
    }

    /// Continues at `N n` of `unit` (the current frame's program).
    fn jump(&mut self, unit: &Unit, n: u32, span: Span) -> Result<(), NcError> {
        let Some(&i) = unit.labels.get(&n) else {
            return Err(NcError::new(
                &unit.src,
                span,
                format!("sequence number N{n} not found in {}", unit.name()),
            ));
        };
        self.set_pc(i);
        Ok(())
    }

    fn assign(
        &mut self,
        unit: &Unit,
        line: &Line,
        target: &Expr,
        value: &Expr,
    ) -> Result<(), NcError> {
        let n = match &target.kind {
            ExprKind::Var(n) => i64::from(*n),
            ExprKind::IndirectVar(e) => var_number(self.eval_at(&unit.src, e)?.unwrap_or(0.0)),
            _ => {
                return Err(NcError::new(
                    &unit.src,
                    target.span,
                    "an assignment needs a variable on the left",
                ));
            }
        };
        let v = self.eval_at(&unit.src, value)?;
        let text = line
            .comments
            .first()
            .map(|c| c.text.trim().to_string())
            .unwrap_or_default();
        match n {
            3000 => {
                let num = v.unwrap_or(0.0);
                let alarm = 3000 + num.round().max(0.0) as i64;
                let mut m = format!("alarm {alarm}");
                if !text.is_empty() {
                    m.push_str(&format!(": {text}"));
                }
                Err(NcError::new(&unit.src, line.span, m))
            }
            3006 => {
                let source = Source {
                    file: unit.src.name.clone(),
                    line: line.line_no,
                    n: line.n.map(|n| n.value),
                };
                if !text.is_empty() {
                    let s = self
                        .state
                        .segment(SegmentKind::Message { text }, source.clone());
                    self.queue.push_back(s);
                }
                let stop = SegmentKind::Stop {
                    kind: StopKind::Program,
                };
                self.queue.push_back(self.state.segment(stop, source));
                Ok(())
            }
            _ => self
                .write_var(n, v)
                .map_err(|m| NcError::new(&unit.src, target.span, m)),
        }
    }

    /// End of a program unit (its last line, or `%`): the main program ends; a sub-program
    /// returns as with `M99`.
    fn end_of_unit(&mut self, unit: &Unit) -> Result<(), NcError> {
        if self.frames.len() <= 1 {
            self.done = true;
            return Ok(());
        }
        self.ret(unit, None, Span::default())
    }

    /// `M99 [P seq]`.
    fn ret(&mut self, unit: &Unit, seq: Option<u32>, span: Span) -> Result<(), NcError> {
        let Some(f) = self.frames.last_mut() else {
            return Ok(());
        };
        if f.repeats > 0 {
            f.repeats -= 1;
            f.pc = f.unit.start;
            return Ok(());
        }
        if self.frames.len() == 1 {
            // M99 in the main program: jump to N seq. Without P Fanuc starts the program over,
            // endlessly: a machine run does (`MainM99::Repeat`); a dump or a dry run shows one
            // pass and says where it would repeat.
            return match (seq, self.opts.main_m99) {
                (Some(n), _) => self.jump(unit, n, span),
                (None, crate::interp::MainM99::Repeat) => {
                    // Over the opening `%` (past the first block it would end the program).
                    let start = (unit.start..unit.end)
                        .find(|&i| {
                            !matches!(
                                unit.program.lines.get(i).map(|l| &l.kind),
                                Some(LineKind::Percent)
                            )
                        })
                        .unwrap_or(unit.start);
                    self.set_pc(start);
                    Ok(())
                }
                (None, crate::interp::MainM99::End) => {
                    self.done = true;
                    if span != Span::default() {
                        self.main_m99_line = Some(unit.src.line_col(span.start as usize).0);
                    }
                    Ok(())
                }
            };
        }
        if let Some(f) = self.frames.pop()
            && f.macro_level
        {
            self.vars.locals.pop();
        }
        if let Some(n) = seq {
            let caller = self.cur_unit();
            let Some(&i) = caller.labels.get(&n) else {
                return Err(NcError::new(
                    &unit.src,
                    span,
                    format!(
                        "M99 P{n}: sequence number N{n} not found in the caller {}",
                        caller.name()
                    ),
                ));
            };
            self.set_pc(i);
        }
        Ok(())
    }

    /// Program `O<number>`: in the running file, the main file, or the library.
    fn find_program(
        &mut self,
        number: u32,
        src: &SourceFile,
        span: Span,
    ) -> Result<Arc<Unit>, NcError> {
        let cur = self.cur_unit();
        if let Some(u) = self
            .units
            .iter()
            .find(|u| u.number == Some(number) && Arc::ptr_eq(&u.src, &cur.src))
            .or_else(|| self.units.iter().find(|u| u.number == Some(number)))
        {
            return Ok(u.clone());
        }
        if let Some(u) = self.lib_cache.get(&number) {
            return Ok(u.clone());
        }
        let not_found = |why: String| NcError::new(src, span, why);
        // The injected library only: the interpreter itself reads no files.
        let Some(lib) = self.library.as_mut() else {
            return Err(not_found(format!(
                "program O{number:04} not found: not in this file, and no program directory is configured"
            )));
        };
        let main = self.main_src.name.clone();
        let Some(file) = lib
            .find(number, &main)
            .map_err(|e| not_found(format!("program O{number:04}: {e}")))?
        else {
            return Err(not_found(format!(
                "program O{number:04} not found (not in this file, nor as O{number:04}.nc/.CNC/… {})",
                lib.describe()
            )));
        };
        let program = Arc::new(cnc402_lang::parse(&file)?);
        let file = Arc::new(file);
        let (units, main) = split_units(&file, &program);
        let u = units
            .iter()
            .find(|u| u.number == Some(number))
            .cloned()
            .unwrap_or_else(|| units[main].clone());
        for other in &units {
            if let Some(n) = other.number {
                self.lib_cache.entry(n).or_insert_with(|| other.clone());
            }
        }
        self.lib_cache.insert(number, u.clone());
        Ok(u)
    }

    /// Pushes a call of `O<number>`, `times` runs; `args` gives it its own locals (G65/G66).
    fn call(
        &mut self,
        number: u32,
        times: u32,
        args: Option<[MVal; 33]>,
        src: &SourceFile,
        span: Span,
    ) -> Result<(), NcError> {
        let unit = self.find_program(number, src, span)?;
        if times == 0 {
            return Ok(());
        }
        if self.frames.len() >= MAX_FRAMES {
            return Err(NcError::new(
                src,
                span,
                format!("calls nested deeper than {MAX_FRAMES} programs"),
            ));
        }
        if args.is_some() && self.vars.locals.len() > MAX_MACRO_LEVELS {
            return Err(NcError::new(
                src,
                span,
                format!("macro calls (G65/G66) nested deeper than {MAX_MACRO_LEVELS} levels"),
            ));
        }
        let mut f = Frame::new(unit, args.is_some());
        f.repeats = times - 1;
        if let Some(a) = args {
            self.vars.locals.push(a);
        }
        self.frames.push(f);
        Ok(())
    }

    /// Takes the macro-call words out of a block. `Ok(None)`: the block was a `G65`/`G66`/
    /// `G67` and is done; otherwise what to do after the block's own words ran.
    pub(crate) fn take_calls(
        &mut self,
        unit: &Unit,
        w: &mut Words,
        ijk: &[(char, MVal, Span)],
    ) -> Result<Option<After>, NcError> {
        let err = |span: Span, m: String| NcError::new(&unit.src, span, m);
        if let Some(&(code, _, gspan)) = w.g.iter().find(|g| g.1 == GGroup::MacroCall) {
            if let Some(other) = w.g.iter().find(|g| g.2 != gspan) {
                return Err(err(
                    other.2,
                    format!("G{} cannot share a block with G{code}", other.0),
                ));
            }
            // With G65/G66, M is argument #13 (it is not executed).
            if let Some(m) = w.m.get(1) {
                return Err(err(
                    m.1,
                    format!("address M given twice in a G{code} block"),
                ));
            }
            let m_arg = w.m.first().map(|m| (m.1.start, f64::from(m.0)));
            if code == 67 {
                self.modal_call = None;
                return match w.first_unused() {
                    Some((c, a)) => Err(err(a.span, format!("address {c} is not used with G67"))),
                    None => Ok(None),
                };
            }
            let Some(p) = w.take('P') else {
                return Err(err(gspan, format!("G{code} needs P (the program number)"))
                    .with_expected(format!("G{code} P9001 …")));
            };
            let number = whole(p.v)
                .filter(|&n| n <= 9999)
                .ok_or_else(|| err(p.span, format!("P{} is not a program number", fmt_num(p.v))))?;
            let times = match w.take('L') {
                Some(l) => whole(l.v).ok_or_else(|| {
                    err(l.span, format!("L{} is not a repeat count", fmt_num(l.v)))
                })?,
                None => 1,
            };
            // (source offset, variable, value): a variable given twice (D and the second
            // set's I are both #7) takes the later word, as Fanuc mixes the specifications.
            let mut given = Vec::new();
            for c in 'A'..='Z' {
                if let Some(i) = arg_var(c)
                    && let Some(a) = w.take(c)
                {
                    given.push((a.span.start, i, a.v));
                }
            }
            if let Some((at, m)) = m_arg {
                given.push((at, 13, m));
            }
            given.extend(spec2_vars(ijk).map_err(|s| {
                err(
                    s,
                    format!("G{code}: more than 10 I/J/K sets (argument specification II)"),
                )
                .with_expected("at most I10 J10 K10 (#33)")
            })?);
            given.sort_by_key(|g| g.0);
            let mut args = [None; 33];
            for (_, i, v) in given {
                args[i - 1] = Some(v);
            }
            if let Some((c, a)) = w.first_unused() {
                return Err(
                    err(a.span, format!("address {c} is not an argument of G{code}"))
                        .with_expected(
                            "A-F, H, I-K, M, Q-Z (argument specification I; I J K may repeat: II)",
                        ),
                );
            }
            if code == 65 {
                self.call(number, times, Some(args), &unit.src, gspan)?;
            } else {
                // Check the program exists now, where the G66 is.
                self.find_program(number, &unit.src, gspan)?;
                self.modal_call = Some(ModalCall {
                    number,
                    times,
                    args,
                    depth: self.frames.len(),
                });
            }
            return Ok(None);
        }
        let m98 = w.m.iter().find(|m| m.0 == 98).map(|m| m.1);
        let m99 = w.m.iter().find(|m| m.0 == 99).map(|m| m.1);
        if let (Some(_), Some(s)) = (m98, m99) {
            return Err(err(s, "M98 and M99 in one block".into()));
        }
        w.m.retain(|m| m.0 != 98 && m.0 != 99);
        if let Some(span) = m98 {
            let Some(p) = w.take('P') else {
                return Err(
                    err(span, "M98 needs P (the program number)".into()).with_expected("M98 P9001")
                );
            };
            let pv = whole(p.v)
                .ok_or_else(|| err(p.span, format!("P{} is not a program number", fmt_num(p.v))))?;
            // Fanuc 0: more than four digits = repeat count, then the program number.
            let (mut times, number) = if pv > 9999 {
                (pv / 10000, pv % 10000)
            } else {
                (1, pv)
            };
            if let Some(l) = w.take('L') {
                times = whole(l.v).ok_or_else(|| {
                    err(l.span, format!("L{} is not a repeat count", fmt_num(l.v)))
                })?;
            }
            return Ok(Some(After::Call {
                number,
                times,
                span,
            }));
        }
        if let Some(span) = m99 {
            let seq = match w.take('P') {
                Some(p) => Some(whole(p.v).filter(|&n| n > 0).ok_or_else(|| {
                    err(
                        p.span,
                        format!("P{} is not a sequence number", fmt_num(p.v)),
                    )
                })?),
                None => None,
            };
            return Ok(Some(After::Return { seq, span }));
        }
        Ok(Some(After::Nothing))
    }

    /// After a block's words: `M98` call, `M99` return, or a `G66` modal call.
    pub(crate) fn after_block(
        &mut self,
        unit: &Unit,
        after: After,
        moved: bool,
    ) -> Result<(), NcError> {
        match after {
            After::Call {
                number,
                times,
                span,
            } => self.call(number, times, None, &unit.src, span),
            After::Return { seq, span } => self.ret(unit, seq, span),
            After::Nothing => {
                if moved
                    && let Some(mc) = self.modal_call.clone()
                    && mc.depth == self.frames.len()
                {
                    let span = unit
                        .program
                        .lines
                        .get(self.frames.last().map_or(0, |f| f.pc.saturating_sub(1)))
                        .map_or_else(Span::default, |l| l.span);
                    self.call(mc.number, mc.times, Some(mc.args), &unit.src, span)?;
                }
                Ok(())
            }
        }
    }

    /// `G65 Hm P#i Q#j R#k`: the old macro instructions (Fanuc Custom Macro A).
    pub(crate) fn g65_h(&mut self, unit: &Unit, line: &Line, b: &Block) -> Result<(), NcError> {
        let src = unit.src.clone();
        let err = |span: Span, m: String| NcError::new(&src, span, m);
        let mut h = None;
        let mut p: Option<&cnc402_lang::ast::Word> = None;
        let mut q = None;
        let mut r = None;
        for w in &b.words {
            match w.letter {
                'G' => {}
                'H' => h = Some(w),
                'P' => p = Some(w),
                'Q' => q = Some(w),
                'R' => r = Some(w),
                c => {
                    return Err(err(w.span, format!("address {c} is not used in G65 H…"))
                        .with_expected("G65 Hm P#i Q#j R#k"));
                }
            }
        }
        let Some(hw) = h else { return Ok(()) };
        let hv = eval::value_in(&src, &hw.value, self)?;
        let Some(code) = hv.and_then(whole) else {
            return Err(err(hw.span, "H is not an instruction number".into()));
        };
        let qv = match q {
            Some(w) => eval::value_in(&src, &w.value, self)?.unwrap_or(0.0),
            None => 0.0,
        };
        let rv = match r {
            Some(w) => eval::value_in(&src, &w.value, self)?.unwrap_or(0.0),
            None => 0.0,
        };
        let p_span = p.map_or(hw.span, |w| w.span);
        // P as a destination `#i`.
        let dest = |this: &mut Self| -> Result<i64, NcError> {
            match p.map(|w| &w.value) {
                Some(Value::Expr(e)) => match &e.kind {
                    ExprKind::Var(n) => Ok(i64::from(*n)),
                    ExprKind::IndirectVar(i) => {
                        Ok(var_number(eval::eval(&src, i, this)?.unwrap_or(0.0)))
                    }
                    _ => Err(err(p_span, "P must name the result variable: P#i".into())),
                },
                _ => Err(err(
                    p_span,
                    format!("G65 H{code:02} needs P#i (the result variable)"),
                )),
            }
        };
        // P as a constant (sequence number, alarm number).
        let pconst = |this: &mut Self| -> Result<u32, NcError> {
            let v = match p {
                Some(w) => eval::value_in(&src, &w.value, this)?,
                None => None,
            };
            v.and_then(whole)
                .ok_or_else(|| err(p_span, format!("G65 H{code:02} needs P as a whole number")))
        };
        let int = |v: f64| v.round() as i64;
        let result = match code {
            1 => qv,
            2 => qv + rv,
            3 => qv - rv,
            4 => qv * rv,
            5 => {
                if rv == 0.0 {
                    return Err(err(line.span, "G65 H05: division by zero".into()));
                }
                qv / rv
            }
            11 => (int(qv) | int(rv)) as f64,
            12 => (int(qv) & int(rv)) as f64,
            13 => (int(qv) ^ int(rv)) as f64,
            21 => {
                if qv < 0.0 {
                    return Err(err(
                        line.span,
                        "G65 H21: square root of a negative number".into(),
                    ));
                }
                qv.sqrt()
            }
            22 => qv.abs(),
            23 => {
                if int(rv) == 0 {
                    return Err(err(line.span, "G65 H23: remainder by zero".into()));
                }
                (int(qv) % int(rv)) as f64
            }
            24 | 25 => {
                let f = if code == 24 { "BIN" } else { "BCD" };
                let e = Expr {
                    kind: ExprKind::Call(
                        if code == 24 {
                            cnc402_lang::ast::Func::Bin
                        } else {
                            cnc402_lang::ast::Func::Bcd
                        },
                        vec![Expr {
                            kind: ExprKind::Number(qv),
                            span: line.span,
                        }],
                    ),
                    span: line.span,
                };
                eval::expr(&src, &e)
                    .map_err(|e| err(line.span, format!("G65 H{code}: {f}: {}", e.message)))?
            }
            26 => {
                if rv == 0.0 {
                    return Err(err(line.span, "G65 H26: division by zero".into()));
                }
                let d = dest(self)?;
                let cur = self.read_var(d).map_err(|m| err(p_span, m))?.unwrap_or(0.0);
                cur * qv / rv
            }
            27 => qv.hypot(rv),
            28 => {
                let d = qv * qv - rv * rv;
                if d < 0.0 {
                    return Err(err(
                        line.span,
                        "G65 H28: square root of a negative number".into(),
                    ));
                }
                d.sqrt()
            }
            31 => qv * rv.to_radians().sin(),
            32 => qv * rv.to_radians().cos(),
            33 => qv * rv.to_radians().tan(),
            34 => {
                let a = qv.atan2(rv).to_degrees();
                if a < 0.0 { a + 360.0 } else { a }
            }
            80..=86 => {
                let go = match code {
                    80 => true,
                    81 => qv == rv,
                    82 => qv != rv,
                    83 => qv > rv,
                    84 => qv < rv,
                    85 => qv >= rv,
                    _ => qv <= rv,
                };
                let n = pconst(self)?;
                if go {
                    self.jump(unit, n, p_span)?;
                }
                return Ok(());
            }
            99 => {
                let n = pconst(self)?;
                let mut m = format!("alarm {}", 500 + n);
                if let Some(c) = line.comments.first() {
                    let t = c.text.trim();
                    if !t.is_empty() {
                        m.push_str(&format!(": {t}"));
                    }
                }
                return Err(err(line.span, m));
            }
            _ => {
                return Err(
                    err(hw.span, format!("G65 H{code}: unknown macro instruction"))
                        .with_expected("H01-H05, H11-H13, H21-H28, H31-H34, H80-H86, H99"),
                );
            }
        };
        if !result.is_finite() {
            return Err(err(
                line.span,
                format!("G65 H{code:02}: the result is not a finite number"),
            ));
        }
        let d = dest(self)?;
        self.write_var(d, Some(result)).map_err(|m| err(p_span, m))
    }
}

/// `#n` in 5221..=5328 as (work offset G54.. index, axis index): `#5221 + 20·k + i`, for
/// k < 6 and i < `naxes`; anything else in the range is an error naming `#n`.
fn work_offset_var(n: i64, naxes: i64) -> Result<(usize, usize), String> {
    let (k, i) = ((n - 5221) / 20, (n - 5221) % 20);
    if !(0..=5).contains(&k) || !(0..naxes).contains(&i) {
        return Err(format!(
            "#{n} is not a work offset variable of this machine"
        ));
    }
    Ok((k as usize, i as usize))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn work_offset_vars_name_offset_and_axis() {
        assert_eq!(work_offset_var(5221, 4), Ok((0, 0)));
        assert_eq!(work_offset_var(5243, 4), Ok((1, 2)));
        assert_eq!(work_offset_var(5328, 8), Ok((5, 7)));
        assert!(work_offset_var(5225, 4).unwrap_err().contains("#5225"));
        assert!(work_offset_var(5341, 8).is_err(), "k = 6 is not G54-G59");
    }
}
