//! How the O-word lines of a LinuxCNC program unit pair up ([`OIndex`]): each `if`/`while`/
//! `do`/`repeat`/`sub` with its branches and end, the `break`/`continue`/`return` inside it,
//! and the subroutines by label. Data only, found once when the unit is loaded; `oword`
//! executes through it.

use std::collections::HashMap;

use cnc402_lang::Dialect;
use cnc402_lang::ast::{LineKind, OLabel, OWord, OWordKind, Program};

/// How the O-word lines of a unit pair up, found when the unit is loaded.
#[derive(Debug, Default)]
pub struct OIndex {
    /// For each O-word line of a construct: its construct.
    pub links: HashMap<usize, OLink>,
    /// Subroutine label → its `sub` line.
    pub subs: HashMap<OLabel, usize>,
    /// Lines whose construct is broken (no end, crossed, wrong label), with the message.
    pub errors: HashMap<usize, String>,
}

/// The construct an O-word line belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OLink {
    /// Its first line (`sub`, `if`, `while`, `do`, `repeat`).
    pub head: usize,
    /// Its last line (`endsub`, `endif`, `endwhile`, the `while` closing a `do`, `endrepeat`).
    pub end: usize,
    /// `if`/`elseif`/`else`: the next branch line (or `endif`); otherwise `end`.
    pub next: usize,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Open {
    Sub,
    If,
    While,
    Do,
    Repeat,
}

impl Open {
    fn word(self) -> &'static str {
        match self {
            Open::Sub => "sub",
            Open::If => "if",
            Open::While => "while",
            Open::Do => "do",
            Open::Repeat => "repeat",
        }
    }
    fn is_loop(self) -> bool {
        matches!(self, Open::While | Open::Do | Open::Repeat)
    }
}

/// A construct being read: its label, kind, head, branch lines and the lines inside it that
/// refer to it (`break`, `continue`, `return`).
struct Building {
    label: OLabel,
    open: Open,
    head: usize,
    branches: Vec<usize>,
    /// An `else` branch is open (only `endif` may follow).
    after_else: bool,
    members: Vec<usize>,
}

/// Builds an [`OIndex`] from the O-word lines of a unit given one at a time, in order (a
/// program read line by line is paired as it is read). Memory: the O-word lines only.
#[derive(Default)]
pub(crate) struct OIndexBuilder {
    ix: OIndex,
    stack: Vec<Building>,
}

impl OIndexBuilder {
    /// Takes the O-word line `i` (0-based; line number `i + 1`).
    pub(crate) fn line(&mut self, i: usize, o: &OWord) {
        self.ix.line(&mut self.stack, i, o);
    }

    /// The index, with every construct still open reported at its head.
    pub(crate) fn finish(self) -> OIndex {
        let mut ix = self.ix;
        for b in self.stack {
            ix.errors
                .insert(b.head, format!("{} {} has no end", b.label, b.open.word()));
        }
        ix
    }
}

pub(crate) fn oword_of(program: &Program, i: usize) -> Option<&OWord> {
    match &program.lines.get(i)?.kind {
        LineKind::OWord(o) => Some(o),
        _ => None,
    }
}

impl OIndex {
    /// Pairs the O-word lines `start..end` of `program` (empty unless it is in the LinuxCNC
    /// dialect).
    pub fn build(program: &Program, start: usize, end: usize) -> OIndex {
        let mut b = OIndexBuilder::default();
        if program.dialect != Dialect::LinuxCnc {
            return b.finish();
        }
        for i in start..end {
            if let Some(o) = oword_of(program, i) {
                b.line(i, o);
            }
        }
        b.finish()
    }

    fn line(&mut self, stack: &mut Vec<Building>, i: usize, o: &OWord) {
        let label = &o.label;
        let top_is = |stack: &Vec<Building>, open: Open| {
            stack
                .last()
                .is_some_and(|b| b.open == open && b.label == *label)
        };
        let push = |ix: &mut OIndex, stack: &mut Vec<Building>, open: Open| {
            // LinuxCNC: a label names one block; an inner block needs a label of its own (a
            // subroutine may reuse its label for one block inside).
            if let Some(b) = stack
                .iter()
                .find(|b| b.label == *label && b.open != Open::Sub)
            {
                ix.errors.insert(
                    i,
                    format!(
                        "duplicate O-word label {label}: already used by the {} of line {}",
                        b.open.word(),
                        b.head + 1
                    ),
                );
            }
            stack.push(Building {
                label: label.clone(),
                open,
                head: i,
                branches: vec![i],
                after_else: false,
                members: Vec::new(),
            })
        };
        match &o.kind {
            OWordKind::Sub => {
                if let Some(b) = stack.last() {
                    self.errors.insert(
                        i,
                        format!(
                            "{label} sub inside {} {} of line {}: subroutines are defined at the top level",
                            b.label,
                            b.open.word(),
                            b.head + 1
                        ),
                    );
                }
                push(self, stack, Open::Sub);
            }
            OWordKind::If(_) => push(self, stack, Open::If),
            OWordKind::Do => push(self, stack, Open::Do),
            OWordKind::Repeat(_) => push(self, stack, Open::Repeat),
            OWordKind::While(_) if top_is(stack, Open::Do) => self.close(stack, i),
            OWordKind::While(_) => push(self, stack, Open::While),
            OWordKind::ElseIf(_) | OWordKind::Else => {
                if !top_is(stack, Open::If) {
                    self.mismatch(stack, i, o, "if");
                    return;
                }
                let Some(b) = stack.last_mut() else { return };
                if std::mem::replace(&mut b.after_else, o.kind == OWordKind::Else) {
                    self.errors.insert(
                        i,
                        format!("{label}: nothing may follow {label} else but endif"),
                    );
                }
                b.branches.push(i);
            }
            OWordKind::EndSub(_) => self.close_if(stack, i, o, Open::Sub),
            OWordKind::EndIf => self.close_if(stack, i, o, Open::If),
            OWordKind::EndWhile => self.close_if(stack, i, o, Open::While),
            OWordKind::EndRepeat => self.close_if(stack, i, o, Open::Repeat),
            OWordKind::Return(_) => {
                // rs274 also takes the label of an if or loop inside the sub (retval.ngc's
                // `o1010 return` in `o1010 if`): it returns from the innermost sub.
                let Some(sub) = stack.iter().rposition(|b| b.open == Open::Sub) else {
                    self.errors
                        .insert(i, format!("{label}: not inside a sub labelled {label}"));
                    return;
                };
                if stack[sub..].iter().any(|b| b.label == *label) {
                    stack[sub].members.push(i);
                } else {
                    self.errors.insert(
                        i,
                        format!(
                            "{label}: not inside a sub labelled {label} (or an if or loop of it)"
                        ),
                    );
                }
            }
            OWordKind::Break | OWordKind::Continue => {
                let found = stack
                    .iter_mut()
                    .rev()
                    .find(|b| b.label == *label && b.open.is_loop());
                match found {
                    Some(b) => b.members.push(i),
                    None => {
                        self.errors.insert(
                            i,
                            format!(
                                "{label}: not inside a while, do or repeat loop labelled {label}"
                            ),
                        );
                    }
                }
            }
            OWordKind::Call(_) => {}
        }
    }

    /// The end of the construct on top of the stack if it is `open` labelled `label`.
    fn close_if(&mut self, stack: &mut Vec<Building>, i: usize, o: &OWord, open: Open) {
        if stack
            .last()
            .is_some_and(|b| b.open == open && b.label == o.label)
        {
            self.close(stack, i);
        } else {
            self.mismatch(stack, i, o, open.word());
        }
    }

    fn mismatch(&mut self, stack: &[Building], i: usize, o: &OWord, want: &str) {
        let (label, what) = (&o.label, kind_word(&o.kind));
        let msg = match stack.last() {
            Some(b) => format!(
                "{label} {what} does not close {} {} of line {}: O-word blocks must nest, each ended with its own label",
                b.label,
                b.open.word(),
                b.head + 1
            ),
            None => format!("{label} {what} without {label} {want} before it"),
        };
        self.errors.insert(i, msg);
    }

    /// Pops the top construct, ended at line `end`, and links its lines.
    fn close(&mut self, stack: &mut Vec<Building>, end: usize) {
        let Some(b) = stack.pop() else { return };
        let mut branches = b.branches;
        branches.push(end);
        for w in branches.windows(2) {
            self.links.insert(
                w[0],
                OLink {
                    head: b.head,
                    end,
                    next: w[1],
                },
            );
        }
        let link = OLink {
            head: b.head,
            end,
            next: end,
        };
        for m in b.members.into_iter().chain([end]) {
            self.links.insert(m, link);
        }
        if b.open == Open::Sub {
            self.subs.entry(b.label.clone()).or_insert(b.head);
        }
    }
}

pub(crate) fn kind_word(k: &OWordKind) -> &'static str {
    match k {
        OWordKind::Sub => "sub",
        OWordKind::EndSub(_) => "endsub",
        OWordKind::Return(_) => "return",
        OWordKind::Call(_) => "call",
        OWordKind::If(_) => "if",
        OWordKind::ElseIf(_) => "elseif",
        OWordKind::Else => "else",
        OWordKind::EndIf => "endif",
        OWordKind::Do => "do",
        OWordKind::While(_) => "while",
        OWordKind::EndWhile => "endwhile",
        OWordKind::Repeat(_) => "repeat",
        OWordKind::EndRepeat => "endrepeat",
        OWordKind::Break => "break",
        OWordKind::Continue => "continue",
    }
}
