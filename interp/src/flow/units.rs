//! The programs of a file and the call stack's pieces: program units (`O` numbers, their
//! sequence numbers and paired `WHILE` loops), call frames, the `G66` modal call, the runaway
//! guard's counter and the Macro B call arguments (specifications I and II). Data only: the
//! interpreter's flow through them is in `macros`.

use std::collections::HashMap;
use std::sync::Arc;

use cnc402_lang::SourceFile;
use cnc402_lang::ast::{Block, Line, LineKind, Program, Span, Value};

use crate::vars::MVal;

/// Deepest call nesting (main program included): Fanuc allows 10 sub-program levels plus
/// 4 macro levels.
pub const MAX_FRAMES: usize = 15;
/// Deepest `G65`/`G66` nesting (local-variable levels besides the main program's).
pub const MAX_MACRO_LEVELS: usize = 4;

/// One program of a file: `O9001` through the line before the next `O` line (or the file's
/// end), with its sequence numbers and paired loops. A unit of a program read line by line
/// (`streamed`) holds no lines: the interpreter reads each as it runs it and makes a
/// [`Unit::view`] of it, so that errors point into that line's window.
#[derive(Debug)]
pub struct Unit {
    /// The whole file, or (a view) the window of the one line in `program`.
    pub src: Arc<SourceFile>,
    /// The whole program, or (a view) the one line read.
    pub program: Arc<Program>,
    /// Index of `program.lines[0]` in the file: 0, or a view's line index.
    pub base: usize,
    /// The `O` number; `None` for a file without one.
    pub number: Option<u32>,
    /// Line indices `start..end` of the file.
    pub start: usize,
    pub end: usize,
    /// Its sequence numbers and paired loops, shared by its views.
    pub ix: Arc<UnitIndex>,
    /// Lines come from the interpreter's line reader (`super::stream`).
    pub streamed: bool,
}

/// What is found once when a unit is loaded: where the flow may go.
#[derive(Debug, Default)]
pub struct UnitIndex {
    /// N number → line index (first occurrence in this unit). Empty for a streamed unit
    /// (a block per line could carry one): its GOTOs search the file.
    pub labels: HashMap<u32, usize>,
    /// WHILE line ↔ its END line (both directions).
    pub loops: HashMap<usize, usize>,
    /// Nesting errors found when the unit was loaded, reported when the line runs.
    pub loop_errors: HashMap<usize, String>,
    /// LinuxCNC O-word pairs and subroutines (empty in the other dialects).
    pub owords: super::oindex::OIndex,
    /// Where an endless main program starts over (`M99`): its first line that is not `%`.
    pub restart: usize,
}

/// Builds a unit's [`UnitIndex`] from its lines given one at a time, in order.
pub(crate) struct UnitScan {
    start: usize,
    number: Option<u32>,
    /// `None`: labels are not kept (a streamed unit).
    labels: Option<HashMap<u32, usize>>,
    loops: HashMap<usize, usize>,
    loop_errors: HashMap<usize, String>,
    open: Vec<(u8, usize)>,
    owords: Option<super::oindex::OIndexBuilder>,
    restart: Option<usize>,
}

impl UnitScan {
    /// A unit starting at line index `start`; `keep_labels` false for a streamed unit;
    /// `linuxcnc`: O-word lines are paired.
    pub(crate) fn new(start: usize, keep_labels: bool, linuxcnc: bool) -> UnitScan {
        UnitScan {
            start,
            number: None,
            labels: keep_labels.then(HashMap::new),
            loops: HashMap::new(),
            loop_errors: HashMap::new(),
            open: Vec::new(),
            owords: linuxcnc.then(Default::default),
            restart: None,
        }
    }

    /// Takes line `i` (0-based, line number `i + 1`).
    pub(crate) fn line(&mut self, i: usize, l: &Line) {
        if let (Some(labels), Some(n)) = (&mut self.labels, l.n) {
            labels.entry(n.value).or_insert(i);
        }
        if self.restart.is_none() && !matches!(l.kind, LineKind::Percent) {
            self.restart = Some(i);
        }
        match &l.kind {
            LineKind::ProgramNumber { number, .. } => {
                self.number.get_or_insert(*number);
            }
            LineKind::While { id, .. } => self.open_loop(i, *id),
            LineKind::End { id } => self.close_loop(i, *id),
            LineKind::OWord(o) => {
                if let Some(b) = &mut self.owords {
                    b.line(i, o);
                }
            }
            _ => {}
        }
    }

    /// Takes line `i`, known to be a plain block (no flow, no `%`; its labels not kept).
    pub(crate) fn plain_line(&mut self, i: usize) {
        self.restart.get_or_insert(i);
    }

    fn open_loop(&mut self, i: usize, id: u8) {
        if !(1..=3).contains(&id) {
            self.loop_errors
                .insert(i, format!("DO {id}: loop numbers are 1, 2 and 3"));
        } else if let Some(&(_, at)) = self.open.iter().find(|o| o.0 == id) {
            self.loop_errors.insert(
                i,
                format!(
                    "DO {id} inside the loop DO {id} of line {}: nested loops need different numbers",
                    at + 1
                ),
            );
        } else if self.open.len() >= 3 {
            self.loop_errors
                .insert(i, "WHILE loops nested more than 3 deep".into());
        }
        // Bounded: a WHILE with an error never pairs, and at most 3 + errors stay open.
        if self.open.len() < 64 {
            self.open.push((id, i));
        }
    }

    fn close_loop(&mut self, i: usize, id: u8) {
        match self.open.last() {
            Some(&(top, w)) if top == id => {
                self.open.pop();
                if !self.loop_errors.contains_key(&w) {
                    self.loops.insert(w, i);
                    self.loops.insert(i, w);
                }
            }
            Some(&(top, w)) => {
                let msg = if let Some(&(_, w2)) = self.open.iter().find(|o| o.0 == id) {
                    let m = format!(
                        "END {id} (line {}) closes DO {id} of line {} while DO {top} of line {} is still open: loops must not cross",
                        i + 1,
                        w2 + 1,
                        w + 1
                    );
                    // The WHILE runs first: it carries the message too.
                    self.loop_errors.insert(w2, m.clone());
                    m
                } else {
                    format!(
                        "END {id} without a WHILE … DO {id} before it (DO {top} of line {} is open)",
                        w + 1
                    )
                };
                self.loop_errors.insert(i, msg);
            }
            None => {
                self.loop_errors
                    .insert(i, format!("END {id} without a WHILE … DO {id} before it"));
            }
        }
    }

    /// The unit's number and index, its lines ending before line index `end`.
    pub(crate) fn finish(mut self, end: usize) -> (Option<u32>, UnitIndex) {
        for (id, w) in std::mem::take(&mut self.open) {
            self.loop_errors
                .entry(w)
                .or_insert_with(|| format!("WHILE … DO {id} has no END {id}"));
        }
        let ix = UnitIndex {
            labels: self.labels.unwrap_or_default(),
            loops: self.loops,
            loop_errors: self.loop_errors,
            owords: self.owords.map(|b| b.finish()).unwrap_or_default(),
            restart: self.restart.unwrap_or(self.start).min(end.max(self.start)),
        };
        (self.number, ix)
    }
}

impl Unit {
    fn new(src: &Arc<SourceFile>, program: &Arc<Program>, start: usize, end: usize) -> Unit {
        let linuxcnc = program.dialect == cnc402_lang::Dialect::LinuxCnc;
        let mut scan = UnitScan::new(start, true, linuxcnc);
        for (i, l) in program.lines[start..end].iter().enumerate() {
            scan.line(start + i, l);
        }
        let (number, ix) = scan.finish(end);
        Unit {
            src: src.clone(),
            program: program.clone(),
            base: 0,
            number,
            start,
            end,
            ix: Arc::new(ix),
            streamed: false,
        }
    }

    /// Line `i` of the file if this unit holds it (a whole program, or a view of line `i`).
    pub fn line(&self, i: usize) -> Option<&Line> {
        self.program.lines.get(i.checked_sub(self.base)?)
    }

    /// A view of this (streamed) unit holding line `i`, read into `src` as `line`.
    pub fn view(&self, src: SourceFile, line: Line, i: usize) -> Unit {
        self.view_of(Arc::new(src), line, i)
    }

    /// [`Self::view`] of a window already shared.
    pub(crate) fn view_of(&self, src: Arc<SourceFile>, line: Line, i: usize) -> Unit {
        Unit {
            src,
            program: Arc::new(Program {
                lines: vec![line],
                dialect: self.program.dialect,
            }),
            base: i,
            number: self.number,
            start: self.start,
            end: self.end,
            ix: self.ix.clone(),
            streamed: self.streamed,
        }
    }

    /// Makes this view (of a streamed unit, held nowhere else) a view of `unit`'s line `i`
    /// in place, so a long program's blocks do not each allocate one: its line, to be read
    /// into; `None` when it cannot (another unit's view, or its program is still held
    /// elsewhere).
    pub(crate) fn reuse_view(
        &mut self,
        unit: &Unit,
        src: &Arc<SourceFile>,
        i: usize,
    ) -> Option<&mut Line> {
        if !Arc::ptr_eq(&self.ix, &unit.ix) || (self.start, self.end) != (unit.start, unit.end) {
            return None;
        }
        let program = Arc::get_mut(&mut self.program)?;
        if program.lines.len() != 1 {
            return None;
        }
        self.src = src.clone();
        self.base = i;
        program.lines.first_mut()
    }

    /// The same unit whatever view of it is at hand (for the runaway guard).
    pub fn id(&self) -> usize {
        Arc::as_ptr(&self.ix) as usize
    }

    pub(crate) fn name(&self) -> String {
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
    /// A LinuxCNC `o… call`: ends at its `endsub`/`return` (own `#1`-`#30` and named locals).
    pub o_call: bool,
    /// LinuxCNC `repeat` loops running in this frame: (repeat line, runs left). At most one
    /// per `repeat` line.
    pub repeat_left: Vec<(usize, u64)>,
}

impl Frame {
    pub fn new(unit: Arc<Unit>, macro_level: bool) -> Frame {
        Frame {
            pc: unit.start,
            unit,
            repeats: 0,
            macro_level,
            o_call: false,
            repeat_left: Vec::new(),
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

/// How many recent blocks [`Runaway`] remembers to name the loop.
const RECENT: usize = 512;

/// Counts blocks since the last motion; remembers recent lines to name the loop.
#[derive(Debug)]
pub struct Runaway {
    pub count: u64,
    /// Blocks executed since the program was loaded (never reset by motion): with the C-like
    /// requests, the block serial of `Interpreter::block_serial`.
    pub total: u64,
    /// The last [`RECENT`] blocks' (unit, line), block `total - 1` at `(total - 1) % RECENT`
    /// (a ring: every block of a long program passes here).
    recent: Box<[(usize, u32); RECENT]>,
}

impl Default for Runaway {
    fn default() -> Self {
        Runaway {
            count: 0,
            total: 0,
            // The ring's unused slots name no unit (`Unit::id` is a pointer, never 0).
            recent: Box::new([(0, 0); RECENT]),
        }
    }
}

impl Runaway {
    pub fn reset(&mut self) {
        self.count = 0;
    }
    pub(crate) fn note(&mut self, unit: &Unit, line: u32) {
        self.recent[(self.total % RECENT as u64) as usize] = (unit.id(), line);
        self.count += 1;
        self.total += 1;
    }
    /// The line range the recent blocks of `unit` ran over.
    pub(crate) fn lines(&self, unit: &Unit) -> (u32, u32) {
        let id = unit.id();
        let ls = self.recent.iter().filter(|r| r.0 == id).map(|r| r.1);
        let lo = ls.clone().min().unwrap_or(0);
        let hi = ls.max().unwrap_or(0);
        (lo, hi)
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
