//! The job's sub-programs as iTNC labels: the blocks each run of a sub-program produced
//! (marked by [`crate::input::calls::mark_subs`]) are collected while emitting; at the end the
//! blocks every run ends with are written once as `LBL n … LBL 0` after the main program and
//! each run becomes its own leading blocks and `CALL LBL n`; calls in a row become a program
//! section repeated with `CALL LBL s REP m`. Only whole blocks move, in the order they run,
//! so the iTNC runs the very blocks the plain program had.

use cnc402_interp::canon::{CanonKind, CanonOp};
use cnc402_motion::segment::SegmentKind;

use crate::assemble::{Block, Program, SubProgram, Word};
use crate::input::calls::{SUB_MARKER, SubBody};

/// The iTNC 530's highest label number.
pub const MAX_LABEL: u32 = 999;

/// The blocks of one run of a sub-program: `start..end` of the main program.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Run {
    number: u32,
    start: usize,
    end: usize,
}

/// The runs found while emitting.
#[derive(Clone, Debug, Default)]
pub struct Runs {
    bodies: Vec<SubBody>,
    open: Option<(SubBody, usize)>,
    runs: Vec<Run>,
}

impl Runs {
    pub fn new(bodies: &[SubBody]) -> Runs {
        Runs {
            bodies: bodies.to_vec(),
            ..Runs::default()
        }
    }

    /// Notes `op`, about to be emitted at block `at`: `true` for a marker (nothing to emit).
    pub fn note(&mut self, op: &CanonOp, at: usize) -> bool {
        let marker = match &op.kind {
            CanonKind::Single(SegmentKind::Message { text }) => text
                .trim()
                .strip_prefix(SUB_MARKER)
                .and_then(|n| n.trim().parse::<u32>().ok()),
            _ => None,
        };
        let outside = self.open.is_some_and(|(b, _)| {
            !(b.first_line..=b.last_line).contains(&op.source.line) || marker.is_some()
        });
        if outside {
            self.close(at);
        }
        let Some(number) = marker else { return false };
        if let Some(b) = self.bodies.iter().find(|b| b.number == number) {
            self.open = Some((*b, at));
        }
        true
    }

    /// Ends the run open at block `at`.
    pub fn close(&mut self, at: usize) {
        if let Some((b, start)) = self.open.take()
            && at > start
        {
            self.runs.push(Run {
                number: b.number,
                start,
                end: at,
            });
        }
    }

    /// Rewrites `program` with labels (a body of at least two blocks; nothing when its main program does not end with
    /// `M2`/`M30`: a label body after it would run on).
    pub fn place(mut self, program: &mut Program) {
        self.close(program.main.len());
        let ends = program
            .main
            .last()
            .is_some_and(|b| matches!(text_of(b).as_str(), "M2" | "M30"));
        if self.runs.is_empty() || !ends {
            return;
        }
        let old = std::mem::take(&mut program.main);
        // Per sub-program (in order of first run): its label and how many blocks every run
        // ends with.
        let mut labels: Vec<(u32, u32, usize)> = Vec::new();
        for r in &self.runs {
            if labels.iter().any(|l| l.0 == r.number) || labels.len() as u32 >= MAX_LABEL {
                continue;
            }
            let runs: Vec<&[Block]> = self
                .runs
                .iter()
                .filter(|q| q.number == r.number)
                .map(|q| &old[q.start..q.end])
                .collect();
            let common = common_tail(&runs);
            if common > 1 {
                let first = &old[r.end - common..r.end];
                program.subs.push(SubProgram {
                    name: format!("O{}", r.number),
                    blocks: first.to_vec(),
                });
                labels.push((r.number, program.subs.len() as u32, common));
            }
        }
        let mut next = 0;
        for r in &self.runs {
            let Some(&(_, label, common)) = labels.iter().find(|l| l.0 == r.number) else {
                continue;
            };
            program.main.extend_from_slice(&old[next..r.end - common]);
            let source = old[r.end - common].source.clone();
            program
                .main
                .push(Block::new(vec![format!("CALL LBL {label}")], source));
            next = r.end;
        }
        program.main.extend_from_slice(&old[next..]);
        repeat_sections(program, program.subs.len() as u32 + 1);
    }
}

/// How many blocks all `runs` end with alike, taken back to a block that starts something
/// (a cycle's Q lines and its `CYCL DEF n.1…` lines stay with their `CYCL DEF`).
fn common_tail(runs: &[&[Block]]) -> usize {
    let shortest = runs.iter().map(|r| r.len()).min().unwrap_or(0);
    let mut n = (0..shortest)
        .take_while(|&k| {
            let b = &runs[0][runs[0].len() - 1 - k];
            runs.iter().all(|r| same(&r[r.len() - 1 - k], b))
        })
        .count();
    let first = runs[0];
    while n > 0 && continues(&text_of(&first[first.len() - n])) {
        n -= 1;
    }
    n
}

/// Whether a block continues the one before: a Q line, or `CYCL DEF 7.1`, `9.1` ….
fn continues(text: &str) -> bool {
    let cycle_line = text
        .strip_prefix("CYCL DEF ")
        .and_then(|t| t.split_whitespace().next())
        .and_then(|n| n.split_once('.'))
        .is_some_and(|(_, k)| k != "0");
    text.starts_with(' ') || cycle_line
}

fn same(a: &Block, b: &Block) -> bool {
    a.words == b.words && a.comment == b.comment
}

fn text_of(b: &Block) -> String {
    b.words
        .iter()
        .map(|w| match w {
            Word::Text(t) => t.as_str(),
            Word::Sub(_) => "",
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// Calls of one label in a row: `LBL s`, the call, `CALL LBL s REP m` (m more times).
fn repeat_sections(program: &mut Program, mut section: u32) {
    let old = std::mem::take(&mut program.main);
    let mut i = 0;
    while i < old.len() {
        let t = text_of(&old[i]);
        let row = if t.starts_with("CALL LBL ") {
            old[i..]
                .iter()
                .take(65_535)
                .take_while(|b| same(b, &old[i]))
                .count()
        } else {
            1
        };
        if row > 1 && section <= MAX_LABEL {
            let source = old[i].source.clone();
            program
                .main
                .push(Block::new(vec![format!("LBL {section}")], source.clone()));
            program.main.push(old[i].clone());
            program.main.push(Block::new(
                vec![format!("CALL LBL {section} REP {}", row - 1)],
                source,
            ));
            section += 1;
        } else {
            program.main.extend_from_slice(&old[i..i + row]);
        }
        i += row;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blocks(texts: &[&str]) -> Vec<Block> {
        texts
            .iter()
            .map(|t| Block::new(vec![t.to_string()], None))
            .collect()
    }

    #[test]
    fn a_body_never_starts_inside_a_cycle_definition() {
        let a = blocks(&[
            "L X+1",
            "CYCL DEF 7.0 DATUM SHIFT",
            "CYCL DEF 7.1 X+5",
            "L Y+1",
            "L Z+1",
        ]);
        let b = blocks(&[
            "L X+2",
            "CYCL DEF 7.0 DATUM SHIFT",
            "CYCL DEF 7.1 X+5",
            "L Y+1",
            "L Z+1",
        ]);
        // The tails agree from 7.0 on; 7.1 alone does not start a body, 7.0 does.
        assert_eq!(common_tail(&[&a, &b]), 4);
        // Alike from a continuation line on: the body starts after it.
        let g = blocks(&[
            "CYCL DEF 9.0 DWELL TIME",
            "CYCL DEF 9.1 DWELL 0.5",
            "L X+1",
            "L Y+1",
        ]);
        let h = blocks(&["L Z+5", "CYCL DEF 9.1 DWELL 0.5", "L X+1", "L Y+1"]);
        assert_eq!(common_tail(&[&g, &h]), 2);
        let c = blocks(&[
            "L X+2",
            "CYCL DEF 7.0 DATUM SHIFT",
            "CYCL DEF 7.1 X+6",
            "L Y+1",
        ]);
        let d = blocks(&[
            "L X+2",
            "CYCL DEF 7.0 DATUM SHIFT",
            "CYCL DEF 7.1 X+5",
            "L Y+1",
        ]);
        assert_eq!(common_tail(&[&c, &d]), 1);
        let e = blocks(&[
            "CYCL DEF 200 DRILLING",
            "  Q200=+0 ;SET-UP CLEARANCE",
            "L X+1 M99",
        ]);
        let f = blocks(&[
            "CYCL DEF 200 DRILLING",
            "  Q200=+1 ;SET-UP CLEARANCE",
            "L X+1 M99",
        ]);
        assert_eq!(common_tail(&[&e, &f]), 1);
        assert!(continues("CYCL DEF 9.1 DWELL 0.5") && !continues("CYCL DEF 9.0 DWELL TIME"));
    }
}
