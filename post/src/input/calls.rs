//! The job's own cycles: a Custom Macro B program in the job file numbered O9000–O9999 (the
//! range Fanuc keeps for a machine's own cycles) and called with `G65 P9xxx` and constant
//! arguments. A target with Macro B gets the call and the program, carried once at the end;
//! others get the moves it makes. The input marks each call with a message block so that the
//! canonical operations say where a call begins; line numbers stay the job's.

use cnc402_interp::canon::{CanonKind, CanonOp};
use cnc402_motion::segment::SegmentKind;

/// The text of the marker message (followed by the call's index).
pub const MARKER: &str = "CNC402-POST-CALL ";

/// One cycle program of the job: its number, header comment, job lines (the `O` line and the
/// `M99` line) and its blocks as written.
#[derive(Clone, Debug, PartialEq)]
pub struct CycleProgram {
    pub number: u32,
    pub name: String,
    pub first_line: u32,
    pub last_line: u32,
    pub body: Vec<String>,
    /// The G codes the body writes (the modal groups it may leave changed).
    pub g_codes: Vec<u32>,
}

/// One `G65` call of a cycle program: its job line, the program's index, the arguments.
#[derive(Clone, Debug, PartialEq)]
pub struct CycleCall {
    pub line: u32,
    pub program: usize,
    pub args: Vec<String>,
}

/// The job's cycle programs and calls, the job text with a marker before each call, and the
/// job line of each line of the marked text.
#[derive(Clone, Debug, Default)]
pub struct Marked {
    pub programs: Vec<CycleProgram>,
    pub calls: Vec<CycleCall>,
    pub text: String,
    pub line_of: Vec<u32>,
}

/// Words that would make a body depend on more than its arguments (other programs, offsets
/// set, a jump back into the caller, a `GOTO` to a sequence number the assembler renumbers): such a program is expanded, not carried.
const NOT_CARRIED: [&str; 7] = ["M98", "G65", "G66", "G10", "G92", "M99P", "GOTO"];

/// The cycle programs and calls of `text`, or `None` when it has no call to carry.
pub fn mark(text: &str) -> Option<Marked> {
    let lines: Vec<&str> = text.lines().collect();
    let programs = cycle_programs(&lines);
    if programs.is_empty() {
        return None;
    }
    let mut m = Marked::default();
    for (i, line) in lines.iter().enumerate() {
        let n = i as u32 + 1;
        let inside = programs
            .iter()
            .any(|p| (p.first_line..=p.last_line).contains(&n));
        if !inside && let Some(call) = call_of(line, n, &programs) {
            m.text
                .push_str(&format!("(MSG,{MARKER}{})\n", m.calls.len()));
            m.line_of.push(n);
            m.calls.push(call);
        }
        m.text.push_str(line);
        m.text.push('\n');
        m.line_of.push(n);
    }
    m.programs = programs;
    (!m.calls.is_empty()).then_some(m)
}

/// The text of the marker message at the start of a sub-program's body (followed by its
/// `O` number): each run of the body begins with one.
pub const SUB_MARKER: &str = "CNC402-POST-SUB ";

/// A sub-program of the job that `M98` calls in the same file: its `O` number and the job
/// lines from its `O` line to its `M99`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubBody {
    pub number: u32,
    pub first_line: u32,
    pub last_line: u32,
}

/// The job text with a marker after the `O` line of each sub-program `M98` calls (one that
/// calls no other program itself), the job line of each line, and the bodies.
#[derive(Clone, Debug, Default)]
pub struct SubMarked {
    pub bodies: Vec<SubBody>,
    pub text: String,
    pub line_of: Vec<u32>,
}

/// Words that make a sub-program's runs overlap others' (a call inside it): not marked.
const CALLS: [&str; 4] = ["M98", "G65", "G66", "M99P"];

/// The sub-programs of `text` called by `M98 P` in it, marked; `None` when there is none.
pub fn mark_subs(text: &str) -> Option<SubMarked> {
    let lines: Vec<&str> = text.lines().collect();
    let called: Vec<u32> = lines
        .iter()
        .filter_map(|l| {
            let b = bare(l);
            let at = b.find("M98P")?;
            let digits: String = b[at + 4..]
                .chars()
                .take_while(|c| c.is_ascii_digit())
                .collect();
            digits.parse().ok()
        })
        .collect();
    let mut m = SubMarked::default();
    let mut i = 0;
    while i < lines.len() {
        let n = i as u32 + 1;
        m.text.push_str(lines[i]);
        m.text.push('\n');
        m.line_of.push(n);
        let number = bare(lines[i])
            .strip_prefix('O')
            .and_then(|d| d.parse::<u32>().ok())
            .filter(|d| called.contains(d));
        let end = (i + 1..lines.len()).find(|&k| bare(lines[k]).ends_with("M99"));
        if let (Some(number), Some(end)) = (number, end) {
            let calls_others = lines[i + 1..=end]
                .iter()
                .any(|l| CALLS.iter().any(|w| bare(l).contains(w)));
            if !calls_others {
                m.text.push_str(&format!("(MSG,{SUB_MARKER}{number})\n"));
                m.line_of.push(n);
                m.bodies.push(SubBody {
                    number,
                    first_line: n,
                    last_line: end as u32 + 1,
                });
            }
        }
        i += 1;
    }
    (!m.bodies.is_empty()).then_some(m)
}

/// `ops` without the call markers (for an emitter that writes messages).
pub fn without_markers(ops: &[CanonOp]) -> Vec<CanonOp> {
    ops.iter()
        .filter(|op| {
            !matches!(&op.kind, CanonKind::Single(SegmentKind::Message { text })
                if text.trim().starts_with(MARKER))
        })
        .cloned()
        .collect()
}

/// A block without its sequence number (the assembler numbers the carried blocks).
fn without_number(line: &str) -> &str {
    match line.strip_prefix(['N', 'n']) {
        Some(rest) if rest.starts_with(|c: char| c.is_ascii_digit()) => rest
            .trim_start_matches(|c: char| c.is_ascii_digit())
            .trim_start(),
        _ => line,
    }
}

/// `line` without its comments, upper case, without blanks.
fn bare(line: &str) -> String {
    let mut out = String::new();
    let mut depth = 0u32;
    for c in line.chars() {
        match c {
            '(' => depth += 1,
            ')' => depth = depth.saturating_sub(1),
            ';' if depth == 0 => break,
            c if depth == 0 && !c.is_whitespace() => out.push(c.to_ascii_uppercase()),
            _ => {}
        }
    }
    out
}

/// The letter-and-number words of a bare block, or `None` if one is not a plain number.
fn words(bare: &str) -> Option<Vec<(char, String)>> {
    let mut out: Vec<(char, String)> = Vec::new();
    for c in bare.chars() {
        if c.is_ascii_alphabetic() {
            out.push((c, String::new()));
        } else if c.is_ascii_digit() || matches!(c, '.' | '-' | '+') {
            out.last_mut()?.1.push(c);
        } else {
            return None;
        }
    }
    out.iter()
        .all(|(_, v)| v.parse::<f64>().is_ok())
        .then_some(out)
}

/// The whole G codes of a bare block (`G17`, `G43`; not `G[#1]`).
fn g_codes(bare: &str) -> Vec<u32> {
    bare.match_indices('G')
        .filter_map(|(i, _)| {
            let digits: String = bare[i + 1..]
                .chars()
                .take_while(|c| c.is_ascii_digit())
                .collect();
            digits.parse().ok()
        })
        .collect()
}

/// The programs O9000–O9999 of the file that can be carried, each to its `M99`.
fn cycle_programs(lines: &[&str]) -> Vec<CycleProgram> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let b = bare(lines[i]);
        let number = b
            .strip_prefix('O')
            .and_then(|n| n.parse::<u32>().ok())
            .filter(|n| (9000..=9999).contains(n));
        let Some(number) = number else {
            i += 1;
            continue;
        };
        let end = (i + 1..lines.len()).find(|&k| bare(lines[k]).ends_with("M99"));
        let Some(end) = end else { break };
        let body: Vec<String> = lines[i + 1..end]
            .iter()
            .map(|l| without_number(l.trim()).to_string())
            .filter(|l| !l.is_empty())
            .collect();
        let ends_plain =
            bare(lines[end]).trim_start_matches(|c: char| c == 'N' || c.is_ascii_digit()) == "M99";
        let carried = ends_plain
            && body.iter().all(|l| {
                let b = bare(l);
                !NOT_CARRIED.iter().any(|w| b.contains(w))
            });
        if carried {
            let name = lines[i]
                .split_once('(')
                .map(|(_, c)| c.trim_end().trim_end_matches(')').to_string())
                .unwrap_or_default();
            let g_codes = body.iter().flat_map(|l| g_codes(&bare(l))).collect();
            out.push(CycleProgram {
                number,
                name,
                first_line: i as u32 + 1,
                last_line: end as u32 + 1,
                body,
                g_codes,
            });
        }
        i = end + 1;
    }
    out
}

/// The call on `line` (job line `n`) of one of `programs`: `[Nn] G65 P9xxx` and plain
/// numbers after it.
fn call_of(line: &str, n: u32, programs: &[CycleProgram]) -> Option<CycleCall> {
    let w = words(&bare(line))?;
    let mut w = w.as_slice();
    if let [('N', _), rest @ ..] = w {
        w = rest;
    }
    let [('G', g), ('P', p), args @ ..] = w else {
        return None;
    };
    if g.parse::<f64>().ok()? != 65.0 {
        return None;
    }
    let number: u32 = p.parse().ok()?;
    let program = programs.iter().position(|q| q.number == number)?;
    if args
        .iter()
        .any(|(l, _)| matches!(l, 'G' | 'P' | 'L' | 'N' | 'O'))
    {
        return None;
    }
    Some(CycleCall {
        line: n,
        program,
        args: args.iter().map(|(l, v)| format!("{l}{v}")).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn calls_with_plain_arguments_are_marked_and_lines_kept() {
        let job = "O1\nG0 X0\nN20 G65 P9253 X10. Y5. Q2.\nG65 P9253 X[#1]\n\
                   G65 P100 X1.\nM30\nO9253 (SLOT)\nG1 X#24\nM99\n";
        let m = mark(job).unwrap();
        assert_eq!(m.calls.len(), 1);
        assert_eq!(m.calls[0].args, ["X10.", "Y5.", "Q2."]);
        assert_eq!(m.calls[0].line, 3);
        assert_eq!(m.programs[0].name, "SLOT");
        assert_eq!(m.programs[0].body, ["G1 X#24"]);
        assert_eq!((m.programs[0].first_line, m.programs[0].last_line), (7, 9));
        assert!(m.text.contains("(MSG,CNC402-POST-CALL 0)\nN20 G65"));
        assert_eq!(&m.line_of[..4], &[1, 2, 3, 3]);
    }

    #[test]
    fn sub_programs_called_by_m98_are_marked_after_their_o_line() {
        let job = "O1\nM98 P20 L2\nM98 P30\nM30\nO20\nG1 X1.\nM99\nO30\nM98 P20\nM99\n";
        let m = mark_subs(job).unwrap();
        assert_eq!(
            m.bodies,
            [SubBody {
                number: 20,
                first_line: 5,
                last_line: 7
            }]
        );
        assert!(m.text.contains("O20\n(MSG,CNC402-POST-SUB 20)\nG1 X1."));
        assert_eq!(&m.line_of[4..7], &[5, 5, 6]);
        assert!(mark_subs("G1 X1.\nM30\n").is_none());
    }

    #[test]
    fn a_program_calling_others_is_not_carried() {
        assert!(mark("G65 P9001 X1.\nM30\nO9001\nM98 P5\nM99\n").is_none());
    }
}
