//! The program in memory and its assembly into text at the end: blocks are collected first
//! (main program and sub-programs, words already in the target's format), then numbered,
//! framed, sub-program numbers resolved and line lengths checked, so that nothing is written
//! before the whole program is known.

use cnc402_motion::segment::Source;

use crate::PostError;
use crate::rules::Rules;

/// One word of a block: text in the target's format, or a call of a sub-program whose number
/// is decided at assembly.
#[derive(Clone, Debug, PartialEq)]
pub enum Word {
    Text(String),
    /// `P` of the sub-program with this index in [`Program::subs`].
    Sub(usize),
}

/// One block: its words, an optional comment, and the job block it comes from.
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    pub words: Vec<Word>,
    pub comment: Option<String>,
    pub source: Option<Source>,
}

impl Block {
    pub fn new(words: Vec<String>, source: Option<Source>) -> Block {
        Block {
            words: words.into_iter().map(Word::Text).collect(),
            comment: None,
            source,
        }
    }
}

/// A sub-program: a name for its header comment and its blocks (without `O` and `M99`).
#[derive(Clone, Debug, PartialEq)]
pub struct SubProgram {
    pub name: String,
    pub blocks: Vec<Block>,
}

/// The whole program before assembly.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Program {
    pub title: String,
    pub main: Vec<Block>,
    pub subs: Vec<SubProgram>,
}

/// The text of `program` for an ISO (Fanuc-like) target: `%`, `O` main, numbered blocks,
/// `M30`, the sub-programs (`O` … `M99`) after it, `%`.
pub fn assemble_iso(program: &Program, rules: &Rules) -> Result<String, PostError> {
    let sub_numbers = sub_numbers(program.subs.len(), rules)?;
    let mut out = Lines::new(rules);
    out.raw("%".to_string())?;
    let title = comment_text(&program.title, rules);
    out.raw(format!("O{:04}{title}", rules.main_program))?;
    for b in &program.main {
        out.block(b, &sub_numbers)?;
    }
    for (sub, number) in program.subs.iter().zip(&sub_numbers) {
        let name = comment_text(&sub.name, rules);
        out.raw(format!("O{number:04}{name}"))?;
        for b in &sub.blocks {
            out.block(b, &sub_numbers)?;
        }
        out.block(&Block::new(vec!["M99".into()], None), &sub_numbers)?;
    }
    out.raw("%".to_string())?;
    Ok(out.text)
}

/// The numbers of `count` sub-programs, from the rules' first one up, each within range.
fn sub_numbers(count: usize, rules: &Rules) -> Result<Vec<u32>, PostError> {
    (0..count)
        .map(|i| {
            let n = u64::from(rules.first_subprogram) + i as u64;
            if n > u64::from(rules.max_program) || n == u64::from(rules.main_program) {
                return Err(PostError::target(
                    rules,
                    None,
                    format!(
                        "{count} sub-programs do not fit between O{} and O{}",
                        rules.first_subprogram, rules.max_program
                    ),
                ));
            }
            Ok(n as u32)
        })
        .collect()
}

/// ` (TEXT)` for a comment the target keeps: upper case, parentheses taken out (they would
/// end it early).
pub fn comment_text(text: &str, rules: &Rules) -> String {
    if !rules.comments || text.is_empty() {
        return String::new();
    }
    let clean: String = text
        .chars()
        .filter(|c| !matches!(c, '(' | ')' | '%'))
        .map(|c| c.to_ascii_uppercase())
        .collect();
    format!(" ({clean})")
}

/// The assembled lines, with the sequence counter and the line-length check.
struct Lines<'r> {
    rules: &'r Rules,
    text: String,
    next_n: Option<u32>,
}

impl<'r> Lines<'r> {
    fn new(rules: &'r Rules) -> Self {
        Lines {
            rules,
            text: String::new(),
            next_n: rules.numbering.map(|n| n.start),
        }
    }

    fn raw(&mut self, line: String) -> Result<(), PostError> {
        self.push_line(line, None)
    }

    /// Appends `line`, or refuses it when it is longer than the control takes.
    fn push_line(&mut self, line: String, source: Option<&Source>) -> Result<(), PostError> {
        if line.len() > self.rules.max_line {
            return Err(PostError::target(
                self.rules,
                source,
                format!(
                    "the block is {} characters, longer than the control's {}: {line}",
                    line.len(),
                    self.rules.max_line
                ),
            ));
        }
        self.text.push_str(&line);
        self.text.push('\n');
        Ok(())
    }

    fn block(&mut self, b: &Block, subs: &[u32]) -> Result<(), PostError> {
        let mut words = Vec::with_capacity(b.words.len() + 1);
        if let (Some(n), Some(rule)) = (self.next_n, self.rules.numbering) {
            words.push(format!("N{n}"));
            let next = n + rule.step;
            self.next_n = Some(if next > rule.max { rule.step } else { next });
        }
        for w in &b.words {
            words.push(match w {
                Word::Text(t) => t.clone(),
                Word::Sub(i) => format!("P{}", subs[*i]),
            });
        }
        let mut line = words.join(" ");
        if let Some(c) = &b.comment {
            // A comment is shortened to the control's line, not refused: it moves nothing.
            let room = self.rules.max_line.saturating_sub(line.len() + 3);
            let short: String = c.chars().take(room).collect();
            if !short.is_empty() {
                let text = comment_text(short.trim_end(), self.rules);
                line.push_str(if line.is_empty() {
                    text.trim_start()
                } else {
                    &text
                });
            }
        }
        self.push_line(line, b.source.as_ref())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rules::Target;

    #[test]
    fn blocks_are_numbered_and_subprograms_placed_after_the_main() {
        let rules = Target::Fanuc0.rules();
        let mut p = Program {
            title: "t(x)".into(),
            ..Program::default()
        };
        p.main.push(Block {
            words: vec![Word::Text("M98".into()), Word::Sub(0)],
            comment: None,
            source: None,
        });
        p.main.push(Block::new(vec!["M30".into()], None));
        p.subs.push(SubProgram {
            name: "sub".into(),
            blocks: vec![Block::new(vec!["G0".into(), "X1.".into()], None)],
        });
        let text = assemble_iso(&p, &rules).unwrap();
        assert_eq!(
            text,
            "%\nO1000 (TX)\nN10 M98 P8000\nN20 M30\nO8000 (SUB)\nN30 G0 X1.\nN40 M99\n%\n"
        );
    }

    #[test]
    fn sequence_numbers_wrap_past_the_largest() {
        let mut rules = Target::Fanuc0.rules();
        rules.numbering = Some(Numbering {
            start: 9990,
            step: 10,
            max: 9999,
        });
        let p = Program {
            main: vec![Block::new(vec!["G0".into()], None); 2],
            ..Program::default()
        };
        let text = assemble_iso(&p, &rules).unwrap();
        assert!(text.contains("N9990 G0\nN10 G0\n"), "{text}");
    }

    #[test]
    fn a_block_longer_than_the_control_takes_is_an_error() {
        let mut rules = Target::Arumatik.rules();
        rules.max_line = 10;
        let p = Program {
            main: vec![Block::new(vec!["G1".into(), "X123.456".into()], None)],
            ..Program::default()
        };
        let e = assemble_iso(&p, &rules).unwrap_err().to_string();
        assert!(e.contains("longer than the control's 10"), "{e}");
    }

    use crate::rules::Numbering;

    #[test]
    fn a_comment_is_shortened_to_the_line() {
        let mut rules = Target::Arumatik.rules();
        rules.max_line = 20;
        let mut b = Block::new(vec!["M0".into()], None);
        b.comment = Some("MSG, a very long message for the operator".into());
        let p = Program {
            main: vec![b],
            ..Program::default()
        };
        let text = assemble_iso(&p, &rules).unwrap();
        assert!(text.contains("N1 M0 (MSG, A VERY)\n"), "{text}");
    }
}
