//! The programs of a file and the call stack's pieces: program units (`O` numbers, their
//! sequence numbers and paired `WHILE` loops), call frames, the `G66` modal call, the runaway
//! guard's counter and the Macro B call arguments (specifications I and II). Data only: the
//! interpreter's flow through them is in `macros`.

use std::collections::{HashMap, VecDeque};
use std::sync::Arc;

use cnc402_lang::SourceFile;
use cnc402_lang::ast::{Block, LineKind, Program, Span, Value};

use crate::vars::MVal;

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
    /// LinuxCNC O-word pairs and subroutines (empty in the other dialects).
    pub owords: super::oindex::OIndex,
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
            owords: super::oindex::OIndex::build(program, start, end),
        }
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

/// Counts blocks since the last motion; remembers recent lines to name the loop.
#[derive(Debug, Default)]
pub struct Runaway {
    pub count: u64,
    /// Blocks executed since the program was loaded (never reset by motion): with the C-like
    /// requests, the block serial of `Interpreter::block_serial`.
    pub total: u64,
    recent: VecDeque<(usize, u32)>,
}

impl Runaway {
    pub fn reset(&mut self) {
        self.count = 0;
    }
    pub(crate) fn note(&mut self, unit: &Unit, line: u32) {
        self.count += 1;
        self.total += 1;
        if self.recent.len() == 512 {
            self.recent.pop_front();
        }
        self.recent.push_back((unit as *const Unit as usize, line));
    }
    /// The line range the recent blocks of `unit` ran over.
    pub(crate) fn lines(&self, unit: &Unit) -> (u32, u32) {
        let id = unit as *const Unit as usize;
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
