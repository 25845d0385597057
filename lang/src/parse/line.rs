//! One physical line: block delete, `%`, program number, `N` number, then the words of a block.
//! Whitespace may stand anywhere between words and between an address letter and its value
//! (`X 10` is `X10`, as Fanuc reads it), but not inside a number (`X1 0` is an error).

use super::clike::ECx;
use super::lex::{char_len, starts_with_kw, ws};
use super::{Cx, PResult, fail, fail_exp};
use crate::ast::{
    Block, Comment, Expr, ExprKind, Line, LineKind, NamedAxisWord, SeqNo, UnaryOp, Value, Word,
};
use crate::dialect::Dialect;

/// A C expression as a word value: ends at the line end, names must not look like words.
/// Most parameter assignments on one LinuxCNC line (rs274 allows 50 parameter settings a line).
const MAX_ASSIGNS_PER_LINE: usize = 50;

const IN_BLOCK: ECx = ECx {
    nl: false,
    in_block: true,
};
const IN_PARENS: ECx = ECx {
    nl: true,
    in_block: false,
};

/// The length of macro keyword `kw` at the start of `i`, or of its two-letter abbreviation
/// `abbrev` (Fanuc Custom Macro B: "the first two characters can be used as an
/// abbreviation", `WH` for `WHILE`, `GO` for `GOTO`, `EN` for `END`, `TH` for `THEN`) when no
/// letter follows it. Case-insensitive, as the keywords are.
fn macro_kw(i: &str, kw: &str, abbrev: &str) -> Option<usize> {
    if starts_with_kw(i, kw) {
        return Some(kw.len());
    }
    let next = i.as_bytes().get(abbrev.len());
    (starts_with_kw(i, abbrev) && !next.is_some_and(|b| b.is_ascii_alphabetic()))
        .then_some(abbrev.len())
}

impl<'a> Cx<'a> {
    /// Parses `i`, the text of line `line_no` without its `\n`, to the end.
    pub(crate) fn line(&self, line_no: u32, i: &'a str) -> PResult<'a, Line> {
        let body = i.strip_suffix('\r').unwrap_or(i);
        let span = self.span_at(i, body.len());
        let mut comments = Vec::new();
        let (mut i, ()) = self.trivia(i, &mut comments)?;
        let mut block_delete = false;
        if let Some(r) = i.strip_prefix('/') {
            block_delete = true;
            i = self.trivia(r, &mut comments)?.0;
        }
        let mut n = None;
        let kind = match i.as_bytes().first() {
            Some(b'%') => {
                let (r, ()) = self.trivia(&i[1..], &mut comments)?;
                self.expect_end(r, "after `%`")?;
                LineKind::Percent
            }
            Some(b'O' | b'o') if self.dialect == Dialect::LinuxCnc => {
                self.oword(i, &mut comments)?.1
            }
            Some(b'O' | b'o' | b':') => {
                let start = i;
                let after = ws(&i[1..]);
                let (r, number) = self.whole(after, "program number")?;
                let num_span = self.span(start, r);
                let (r, ()) = self.trivia(r, &mut comments)?;
                self.expect_end(r, "after the program number")?;
                LineKind::ProgramNumber {
                    number,
                    span: num_span,
                }
            }
            _ => {
                if let Some(b'N' | b'n') = i.as_bytes().first() {
                    let start = i;
                    let (r, value) = self.whole(ws(&i[1..]), "sequence number")?;
                    n = Some(SeqNo {
                        value,
                        span: self.span(start, r),
                    });
                    i = self.trivia(r, &mut comments)?.0;
                }
                let (_, kind) = self.statement_or_block(i, &mut comments)?;
                kind
            }
        };
        Ok((
            &i[i.len()..],
            Line {
                line_no,
                span,
                block_delete,
                n,
                kind,
                comments,
            },
        ))
    }

    /// What follows the N number: a Custom Macro B statement or a block of words, to the end
    /// of the line.
    ///
    /// Statements are told from words by their first characters: `#` starts an assignment, and
    /// the keywords `IF`, `WHILE`, `GOTO` and `END` cannot start a word (an address letter
    /// must be followed by a value, and `F`, `H`, `O`, `N` are not values).
    fn statement_or_block(&self, i: &'a str, comments: &mut Vec<Comment>) -> PResult<'a, LineKind> {
        let (rest, kind) = match i.as_bytes().first() {
            // `N20 o100 if […]` (LinuxCNC takes a line number before an O-word).
            Some(b'O' | b'o') if self.dialect == Dialect::LinuxCnc => {
                return self.oword(i, comments);
            }
            Some(b'#') if self.dialect == Dialect::LinuxCnc => self.assignments(i)?,
            Some(b'#') => self.assignment(i)?,
            Some(b'I' | b'i') if starts_with_kw(i, "IF") => self.if_statement(i, comments)?,
            Some(b'W' | b'w') if macro_kw(i, "WHILE", "WH").is_some() => {
                let (r, cond) = self.keyword_condition(i, "WHILE", "WH")?;
                let r = ws(r);
                if !starts_with_kw(r, "DO") {
                    return fail_exp(
                        r,
                        char_len(r),
                        "missing DO after WHILE[…]",
                        "DO and a loop number 1-3",
                    );
                }
                let (r, id) = self.loop_id(&r[2..], "DO")?;
                (
                    r,
                    LineKind::While {
                        cond: Box::new(cond),
                        id,
                    },
                )
            }
            Some(b'G' | b'g') if let Some(n) = macro_kw(i, "GOTO", "GO") => {
                let (r, target) = self.goto_target(&i[n..])?;
                (
                    r,
                    LineKind::Goto {
                        target: Box::new(target),
                    },
                )
            }
            Some(b'E' | b'e') if let Some(n) = macro_kw(i, "END", "EN") => {
                let (r, id) = self.loop_id(&i[n..], "END")?;
                (r, LineKind::End { id })
            }
            _ => {
                let (r, block) = self.block(i, comments)?;
                let kind = if block.words.is_empty() {
                    LineKind::Empty
                } else {
                    LineKind::Block(block)
                };
                return Ok((r, kind));
            }
        };
        let (rest, ()) = self.trivia(rest, comments)?;
        self.expect_end(rest, "after the statement")?;
        Ok((rest, kind))
    }

    /// LinuxCNC: one or more assignments on a line, `#1=0 #2=[#1+1]` (at most
    /// [`MAX_ASSIGNS_PER_LINE`]); one is a [`LineKind::Assign`].
    fn assignments(&self, i: &'a str) -> PResult<'a, LineKind> {
        let (mut r, first) = self.assignment(i)?;
        let mut all = Vec::new();
        while ws(r).starts_with('#') {
            if all.len() == MAX_ASSIGNS_PER_LINE {
                let at = ws(r);
                return fail(
                    at,
                    char_len(at),
                    "too many parameter assignments on one line",
                );
            }
            let (rest, next) = self.assignment(ws(r))?;
            all.push(next);
            r = rest;
        }
        if all.is_empty() {
            return Ok((r, first));
        }
        let pairs = std::iter::once(first)
            .chain(all)
            .filter_map(|k| match k {
                LineKind::Assign { target, value } => Some((*target, *value)),
                _ => None,
            })
            .collect();
        Ok((r, LineKind::Assigns(pairs)))
    }

    /// `#n = expr` or `#[expr] = expr`; `i` starts with `#`.
    fn assignment(&self, i: &'a str) -> PResult<'a, LineKind> {
        let (r, target) = self.var(i, 0)?;
        let r = ws(r);
        let Some(after) = r.strip_prefix('=') else {
            return fail_exp(
                r,
                char_len(r),
                "missing `=` after the variable",
                "`=` and an expression",
            );
        };
        match self.expr(after, 0) {
            Ok((r, value)) => Ok((
                r,
                LineKind::Assign {
                    target: Box::new(target),
                    value: Box::new(value),
                },
            )),
            Err(nom::Err::Error(_)) => {
                let at = ws(after);
                fail_exp(
                    at,
                    char_len(at),
                    "missing expression after `=`",
                    "an expression",
                )
            }
            Err(e) => Err(e),
        }
    }

    /// `KW [cond]` (`IF`, `WHILE`); returns the condition.
    fn keyword_condition(&self, i: &'a str, kw: &'static str, abbrev: &str) -> PResult<'a, Expr> {
        let open = ws(&i[macro_kw(i, kw, abbrev).unwrap_or(kw.len())..]);
        if !open.starts_with('[') {
            return fail_exp(
                open,
                char_len(open),
                format!("missing `[` after {kw}"),
                "a condition in `[ ]`",
            );
        }
        let (r, mut cond) = self.bracketed(open, 1)?;
        cond.span = self.span(open, r);
        Ok((r, cond))
    }

    /// `IF[cond]GOTO n` or `IF[cond]THEN statement`.
    fn if_statement(&self, i: &'a str, comments: &mut Vec<Comment>) -> PResult<'a, LineKind> {
        let (r, cond) = self.keyword_condition(i, "IF", "IF")?;
        let r = ws(r);
        if let Some(n) = macro_kw(r, "GOTO", "GO") {
            let (r, target) = self.goto_target(&r[n..])?;
            return Ok((
                r,
                LineKind::IfGoto {
                    cond: Box::new(cond),
                    target: Box::new(target),
                },
            ));
        }
        let Some(n) = macro_kw(r, "THEN", "TH") else {
            return fail_exp(
                r,
                char_len(r),
                "missing GOTO or THEN after IF[…]",
                "GOTO n or THEN and a statement",
            );
        };
        let (r, ()) = self.trivia(&r[n..], comments)?;
        let then = match r.as_bytes().first() {
            Some(b'#') => {
                let (r, a) = self.assignment(r)?;
                (r, a)
            }
            None => {
                return fail_exp(
                    r,
                    0,
                    "missing statement after THEN",
                    "an assignment or a block",
                );
            }
            _ => {
                for kw in ["IF", "WHILE", "GOTO", "END"] {
                    if starts_with_kw(r, kw) {
                        return fail_exp(
                            r,
                            kw.len(),
                            format!("THEN takes an assignment or a block, not {kw}"),
                            "an assignment or a block",
                        );
                    }
                }
                let (r, block) = self.block(r, comments)?;
                (r, LineKind::Block(block))
            }
        };
        Ok((
            then.0,
            LineKind::IfThen {
                cond: Box::new(cond),
                then: Box::new(then.1),
            },
        ))
    }

    /// The target of `GOTO`: a sequence number, `#v` or `[expr]`.
    fn goto_target(&self, i: &'a str) -> PResult<'a, Expr> {
        let i = ws(i);
        match i.as_bytes().first() {
            Some(b'0'..=b'9') => {
                let (r, n) = self.whole(i, "sequence number")?;
                Ok((
                    r,
                    Expr {
                        kind: ExprKind::Number(f64::from(n)),
                        span: self.span(i, r),
                    },
                ))
            }
            Some(b'#') => self.var(i, 0),
            Some(b'[') => {
                let (r, mut e) = self.bracketed(i, 1)?;
                e.span = self.span(i, r);
                Ok((r, e))
            }
            _ => fail_exp(
                i,
                char_len(i),
                "missing sequence number after GOTO",
                "a sequence number, `#variable` or `[expression]`",
            ),
        }
    }

    /// The loop number after `DO` or `END`: 1, 2 or 3.
    fn loop_id(&self, i: &'a str, kw: &'static str) -> PResult<'a, u8> {
        let i = ws(i);
        if !i.as_bytes().first().is_some_and(u8::is_ascii_digit) {
            return fail_exp(
                i,
                char_len(i),
                format!("missing loop number after {kw}"),
                "a loop number 1, 2 or 3",
            );
        }
        let (r, n) = self.whole(i, "loop number")?;
        match u8::try_from(n) {
            Ok(id @ 1..=3) => Ok((r, id)),
            _ => fail_exp(
                i,
                self.off(r) - self.off(i),
                format!("loop number {n} after {kw} is out of range"),
                "a loop number 1, 2 or 3",
            ),
        }
    }

    /// An error unless only the end of the line is left.
    fn expect_end(&self, r: &'a str, what: &str) -> PResult<'a, ()> {
        if r.is_empty() {
            Ok((r, ()))
        } else {
            fail_exp(
                r,
                char_len(r),
                format!("unexpected text {what}"),
                "a comment or the end of the line",
            )
        }
    }

    /// Words (with comments between them) to the end of the line.
    fn block(&self, mut i: &'a str, comments: &mut Vec<Comment>) -> PResult<'a, Block> {
        // One allocation for a typical block: words are rarely shorter than 4 bytes.
        let mut words = Vec::with_capacity((i.len() / 4 + 1).min(16));
        let mut named_axes = Vec::new();
        loop {
            i = self.trivia(i, comments)?.0;
            if i.is_empty() {
                return Ok((i, Block { words, named_axes }));
            }
            if self.c_like && starts_with_kw(i, "AXSTR") && ws(&i[5..]).starts_with('(') {
                let (r, w) = self.named_axis_word(i)?;
                named_axes.push(w);
                i = r;
                continue;
            }
            let (r, w) = match i.strip_prefix(',') {
                Some(after) => self.comma_word(i, after)?,
                None => self.word(i)?,
            };
            words.push(w);
            i = r;
        }
    }

    /// `,R` (corner rounding) or `,C` (chamfer), Fanuc's comma addresses: a word whose
    /// letter is the lower-case `r` or `c` ([`Word::comma_letter`]); `i` starts at the comma.
    ///
    /// ```
    /// let src = cnc402_lang::SourceFile::new("p.nc", "G1 X10 ,R2\n");
    /// let p = cnc402_lang::parse(&src).unwrap();
    /// let cnc402_lang::ast::LineKind::Block(b) = &p.lines[0].kind else { panic!() };
    /// assert_eq!(b.words[2].comma_letter(), Some('R'));
    /// ```
    fn comma_word(&self, i: &'a str, after: &'a str) -> PResult<'a, Word> {
        let after = ws(after);
        if !matches!(after.as_bytes().first(), Some(b'R' | b'r' | b'C' | b'c')) {
            return fail_exp(
                i,
                1,
                "a comma must be followed by R (corner rounding) or C (chamfer)",
                "`,R` or `,C` and a value",
            );
        }
        let (rest, mut w) = self.word(after)?;
        w.letter = w.letter.to_ascii_lowercase();
        w.span = self.span(i, rest);
        Ok((rest, w))
    }

    /// `AXSTR(name)=value` (C-like programs).
    fn named_axis_word(&self, i: &'a str) -> PResult<'a, NamedAxisWord> {
        let open = ws(&i[5..]);
        let inner = &open[1..];
        let (r, axis) = self.c_expr_req(inner, IN_PARENS, "naming the axis")?;
        let r = ws(r);
        let Some(r) = r.strip_prefix(')') else {
            return fail_exp(
                open,
                1,
                "unbalanced bracket: `(` is not closed",
                "`)` after the axis name",
            );
        };
        let r = ws(r);
        let Some(v) = r.strip_prefix('=') else {
            return fail_exp(
                r,
                char_len(r),
                "missing `=` after AXSTR(…)",
                "`=` and the axis value",
            );
        };
        let (rest, value) = self.c_expr_req(v, IN_BLOCK, "after `AXSTR(…)=`")?;
        Ok((
            rest,
            NamedAxisWord {
                axis,
                value,
                span: self.span(i, rest),
            },
        ))
    }

    /// One word: letter, optional whitespace, then a number, `[expr]` or `=expr`.
    pub(crate) fn word(&self, i: &'a str) -> PResult<'a, Word> {
        let Some(c) = i.chars().next() else {
            return fail(i, 0, "missing word");
        };
        // LinuxCNC's polar words (`@` radius, `^` angle) and spindle selection `$`.
        let polar = self.dialect == Dialect::LinuxCnc && matches!(c, '@' | '^' | '$');
        if !c.is_ascii_alphabetic() && !polar {
            return self.not_a_word(i, c);
        }
        let letter = c.to_ascii_uppercase();
        match letter {
            'N' => {
                return fail_exp(
                    i,
                    1,
                    "a sequence number N must start the block",
                    "an address other than N here",
                );
            }
            'O' => {
                return fail(
                    i,
                    1,
                    "a program number O must stand at the start of its own line",
                );
            }
            _ => {}
        }
        let v = ws(&i[1..]);
        let (rest, value) = match v.as_bytes().first() {
            Some(b'[') => {
                let (r, mut e) = self.bracketed(v, 1)?;
                e.span = self.span(v, r);
                (r, Value::Expr(Box::new(e)))
            }
            Some(b'=') if self.c_like => {
                let (r, e) = self.c_expr_req(&v[1..], IN_BLOCK, &format!("after `{letter}=`"))?;
                (r, Value::Expr(Box::new(e)))
            }
            Some(b'=') => {
                let after = &v[1..];
                match self.expr(after, 0) {
                    Ok((r, e)) => (r, Value::Expr(Box::new(e))),
                    Err(nom::Err::Error(_)) => {
                        let at = ws(after);
                        return fail_exp(
                            at,
                            char_len(at),
                            format!("missing expression after `{letter}=`"),
                            "an expression",
                        );
                    }
                    Err(e) => return Err(e),
                }
            }
            Some(b'#') => {
                let (r, e) = self.var(v, 0)?;
                (r, Value::Expr(Box::new(e)))
            }
            // `X-#1`, `Z-[#1+2]`: a signed variable or bracket is an expression.
            Some(b'+' | b'-') if matches!(ws(&v[1..]).as_bytes().first(), Some(b'#' | b'[')) => {
                let op = if v.starts_with('-') {
                    UnaryOp::Neg
                } else {
                    UnaryOp::Plus
                };
                let inner = ws(&v[1..]);
                let (r, mut e) = if inner.starts_with('#') {
                    self.var(inner, 1)?
                } else {
                    self.bracketed(inner, 1)?
                };
                e.span = self.span(inner, r);
                (
                    r,
                    Value::Expr(Box::new(Expr {
                        kind: ExprKind::Unary(op, Box::new(e)),
                        span: self.span(v, r),
                    })),
                )
            }
            Some(b'+' | b'-' | b'.' | b'0'..=b'9') => {
                let (r, num) = self.number(v)?;
                // `X1.2.3` is a malformed number, not two words.
                if let Some(b'.') = r.as_bytes().first() {
                    return fail(r, 1, "a second decimal point in a number");
                }
                (r, Value::Number(num))
            }
            _ => {
                if letter == 'D' && starts_with_kw(i, "DO") {
                    return fail_exp(i, 2, "DO without WHILE[…]", "WHILE[condition] DO n");
                }
                // Point at the address: it is what lacks a value.
                return fail_exp(
                    i,
                    1,
                    format!("no value after address {letter}"),
                    format!("a number, `[expression]` or `=expression` after {letter}"),
                );
            }
        };
        Ok((
            rest,
            Word {
                letter,
                value,
                span: self.span(i, rest),
            },
        ))
    }

    /// The error for a character that cannot start a word.
    fn not_a_word<T>(&self, i: &'a str, c: char) -> PResult<'a, T> {
        let len = c.len_utf8();
        let expected = "an address letter, a comment or the end of the line";
        match c {
            '0'..='9' | '.' | '+' | '-' => {
                let n = i
                    .bytes()
                    .take_while(|b| b.is_ascii_digit() || matches!(b, b'.' | b'+' | b'-'))
                    .count();
                fail_exp(i, n, "a number without an address letter", expected)
            }
            ']' => fail_exp(i, 1, "unbalanced bracket: `]` without `[`", expected),
            ')' => fail_exp(i, 1, "`)` without `(`", expected),
            '{' | '}' => fail_exp(
                i,
                1,
                format!("`{c}` in a G-code block: a block runs to the end of its line"),
                "`{` and `}` on lines of their own",
            ),
            '[' | '=' => fail_exp(i, 1, format!("`{c}` without an address letter"), expected),
            '/' => fail_exp(i, 1, "block delete `/` must start the block", expected),
            '%' => fail_exp(i, 1, "`%` must stand on its own line", expected),
            c if c.is_alphabetic() => fail_exp(
                i,
                len,
                format!("unknown address letter `{c}`"),
                "an address letter A-Z",
            ),
            c if c.is_control() => fail_exp(
                i,
                len,
                format!("unexpected control character U+{:04X}", c as u32),
                expected,
            ),
            c => fail_exp(i, len, format!("unknown address letter `{c}`"), expected),
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn macro_keywords_and_their_two_letter_abbreviations() {
        assert_eq!(super::macro_kw("WH[#1LT3]DO1", "WHILE", "WH"), Some(2));
        assert_eq!(super::macro_kw("WHILE[1]", "WHILE", "WH"), Some(5));
        assert_eq!(super::macro_kw("WHAT", "WHILE", "WH"), None);
        assert_eq!(super::macro_kw("go10", "GOTO", "GO"), Some(2));
        assert_eq!(super::macro_kw("GOTO10", "GOTO", "GO"), Some(4));
    }

    use crate::ast::*;
    use crate::{SourceFile, parse};

    fn one(s: &str) -> Line {
        let p = parse(&SourceFile::new("t", s)).unwrap_or_else(|e| panic!("{s:?}: {e}"));
        assert_eq!(p.lines.len(), 1, "{s:?}");
        p.lines.into_iter().next().unwrap()
    }

    fn words(s: &str) -> Vec<Word> {
        match one(s).kind {
            LineKind::Block(b) => b.words,
            k => panic!("{s:?}: not a block: {k:?}"),
        }
    }

    fn nums(s: &str) -> Vec<(char, f64, bool)> {
        words(s)
            .into_iter()
            .map(|w| match w.value {
                Value::Number(n) => (w.letter, n.value, n.has_point),
                v => panic!("{s:?}: not a number: {v:?}"),
            })
            .collect()
    }

    fn err(s: &str) -> (u32, u32, String) {
        let e = parse(&SourceFile::new("t", s)).unwrap_err();
        (e.line, e.col, e.message.clone())
    }

    #[test]
    fn percent_and_program_numbers() {
        assert_eq!(one("%").kind, LineKind::Percent);
        assert_eq!(one(" % (end)").kind, LineKind::Percent);
        let l = one("O0001(MAIN)");
        assert_eq!(
            l.kind,
            LineKind::ProgramNumber {
                number: 1,
                span: Span::new(0, 5)
            }
        );
        assert_eq!(l.comments[0].text, "MAIN");
        assert!(matches!(
            one(":1234").kind,
            LineKind::ProgramNumber { number: 1234, .. }
        ));
        assert!(matches!(
            one("o 12").kind,
            LineKind::ProgramNumber { number: 12, .. }
        ));
    }

    #[test]
    fn sequence_numbers() {
        let l = one("N10 G1 X1");
        assert_eq!(
            l.n,
            Some(SeqNo {
                value: 10,
                span: Span::new(0, 3)
            })
        );
        let l = one("N100");
        assert_eq!(l.n.map(|n| n.value), Some(100));
        assert_eq!(l.kind, LineKind::Empty);
        assert_eq!(one("n 5 g0").n.map(|n| n.value), Some(5));
    }

    #[test]
    fn words_with_and_without_point() {
        assert_eq!(
            nums("G01 X10 Y-2.5 Z.5 A+3 B1."),
            vec![
                ('G', 1.0, false),
                ('X', 10.0, false),
                ('Y', -2.5, true),
                ('Z', 0.5, true),
                ('A', 3.0, false),
                ('B', 1.0, true)
            ]
        );
        assert_eq!(nums("X1E2"), vec![('X', 1.0, false), ('E', 2.0, false)]);
        assert_eq!(
            nums("G38.2 Z-5"),
            vec![('G', 38.2, true), ('Z', -5.0, false)]
        );
    }

    #[test]
    fn several_g_words_and_no_spaces() {
        assert_eq!(
            nums("G90G54G0X1Y2"),
            vec![
                ('G', 90.0, false),
                ('G', 54.0, false),
                ('G', 0.0, false),
                ('X', 1.0, false),
                ('Y', 2.0, false)
            ]
        );
    }

    #[test]
    fn lower_case_is_folded_and_space_after_letter_is_allowed() {
        assert_eq!(
            nums("g1 x 10 y\t-2"),
            vec![('G', 1.0, false), ('X', 10.0, false), ('Y', -2.0, false)]
        );
        let w = words("x 10");
        assert_eq!(w[0].span, Span::new(0, 4));
    }

    #[test]
    fn comments_anywhere() {
        let l = one("G1(first)X1 (second) Y2 ; third");
        let texts: Vec<&str> = l.comments.iter().map(|c| c.text.as_str()).collect();
        assert_eq!(texts, ["first", "second", " third"]);
        assert_eq!(l.comments[0].span, Span::new(2, 9));
        let LineKind::Block(b) = l.kind else { panic!() };
        assert_eq!(b.words.len(), 3);
        assert_eq!(one("(only a comment)").kind, LineKind::Empty);
        assert_eq!(one("; G1 X1").kind, LineKind::Empty);
        assert_eq!(one("(全角コメント∕)G0").comments[0].text, "全角コメント∕");
    }

    #[test]
    fn block_delete() {
        let l = one("/N20 G1 X5");
        assert!(l.block_delete);
        assert_eq!(l.n.map(|n| n.value), Some(20));
        assert!(!one("G1 X5").block_delete);
        assert!(one(" / G1").block_delete);
    }

    #[test]
    fn expression_values() {
        let w = words("X[1+2*3] F=100*2 G[FUP[1.2]]");
        assert_eq!(w.len(), 3);
        let Value::Expr(e) = &w[0].value else {
            panic!()
        };
        assert!(matches!(e.kind, ExprKind::Binary(BinaryOp::Add, _, _)));
        assert_eq!(e.span, Span::new(1, 8));
        assert_eq!(w[0].span, Span::new(0, 8));
        let Value::Expr(e) = &w[1].value else {
            panic!()
        };
        assert!(matches!(e.kind, ExprKind::Binary(BinaryOp::Mul, _, _)));
        assert_eq!(w[1].span, Span::new(9, 16));
        let Value::Expr(e) = &w[2].value else {
            panic!()
        };
        assert!(matches!(e.kind, ExprKind::Call(Func::Fup, _)));
        // `=expr` ends where the next word starts.
        let w = words("F = 100 * 2 X-1");
        assert_eq!(w.len(), 2);
        assert_eq!(w[1].letter, 'X');
    }

    #[test]
    fn spans_and_crlf() {
        let p = parse(&SourceFile::new("t", "G0 X1\r\nG1 Y2\r\n")).unwrap();
        assert_eq!(p.lines.len(), 2);
        assert_eq!(p.lines[1].line_no, 2);
        assert_eq!(p.lines[1].span, Span::new(7, 12));
        let LineKind::Block(b) = &p.lines[1].kind else {
            panic!()
        };
        assert_eq!(b.words[1].span, Span::new(10, 12));
    }

    #[test]
    fn blank_lines_are_kept() {
        let p = parse(&SourceFile::new("t", "G0\n\n  \nG1\n")).unwrap();
        assert_eq!(p.lines.len(), 4);
        assert_eq!(p.lines[1].kind, LineKind::Empty);
        assert_eq!(p.lines[2].kind, LineKind::Empty);
        assert_eq!(parse(&SourceFile::new("t", "")).unwrap().lines.len(), 1);
    }

    #[test]
    fn errors_point_at_the_offending_text() {
        assert_eq!(err("G1 X"), (1, 4, "no value after address X".into()));
        assert_eq!(err("G1 (open"), (1, 4, "unclosed comment".into()));
        assert_eq!(err("G1 Ä1"), (1, 4, "unknown address letter `Ä`".into()));
        assert_eq!(
            err("G1 X[1+2"),
            (1, 5, "unbalanced bracket: `[` is not closed".into())
        );
        assert_eq!(
            err("G1 X1.2.3"),
            (1, 8, "a second decimal point in a number".into())
        );
        assert_eq!(
            err("G1 X1 0"),
            (1, 7, "a number without an address letter".into())
        );
        assert_eq!(
            err("G1 N10"),
            (1, 4, "a sequence number N must start the block".into())
        );
        assert_eq!(
            err("N1.5"),
            (1, 2, "a sequence number must be a whole number".into())
        );
        assert_eq!(err("% G1"), (1, 3, "unexpected text after `%`".into()));
        assert_eq!(err("G1\nX-"), (2, 3, "no digits after `-`".into()));
    }

    fn var(n: u32) -> ExprKind {
        ExprKind::Var(n)
    }

    #[test]
    fn macro_variables_as_word_values() {
        let w = words("G#524 X#500 M#520 Z-#1 Y+#2 X [#1] F-[#3+1]");
        let kinds: Vec<&ExprKind> = w
            .iter()
            .map(|w| match &w.value {
                Value::Expr(e) => &e.kind,
                v => panic!("{v:?}"),
            })
            .collect();
        assert_eq!(kinds[0], &var(524));
        assert_eq!(kinds[1], &var(500));
        assert_eq!(kinds[2], &var(520));
        assert!(matches!(kinds[3], ExprKind::Unary(UnaryOp::Neg, e) if e.kind == var(1)));
        assert!(matches!(kinds[4], ExprKind::Unary(UnaryOp::Plus, e) if e.kind == var(2)));
        assert_eq!(kinds[5], &var(1));
        assert!(
            matches!(kinds[6], ExprKind::Unary(UnaryOp::Neg, e) if matches!(e.kind, ExprKind::Binary(..)))
        );
        assert_eq!(w[3].span, Span::new(18, 22));
        let w = words("X#[#1+2]");
        assert!(
            matches!(&w[0].value, Value::Expr(e) if matches!(e.kind, ExprKind::IndirectVar(_)))
        );
    }

    #[test]
    fn assignments() {
        let l = one("#100=#4001(SAVE)");
        let LineKind::Assign { target, value } = &l.kind else {
            panic!("{l:?}")
        };
        assert_eq!(target.kind, var(100));
        assert_eq!(target.span, Span::new(0, 4));
        assert_eq!(value.kind, var(4001));
        assert_eq!(l.comments[0].text, "SAVE");
        let l = one("N10 #[#1+2] = SIN[30]*2");
        assert_eq!(l.n.map(|n| n.value), Some(10));
        let LineKind::Assign { target, value } = &l.kind else {
            panic!("{l:?}")
        };
        assert!(matches!(target.kind, ExprKind::IndirectVar(_)));
        assert!(matches!(value.kind, ExprKind::Binary(BinaryOp::Mul, _, _)));
        let l = one("#3000=12(TOOL NOT FOUND)");
        assert!(
            matches!(&l.kind, LineKind::Assign { value, .. } if value.kind == ExprKind::Number(12.0))
        );
        assert_eq!(l.comments[0].text, "TOOL NOT FOUND");
        assert!(matches!(one("/#1=0").kind, LineKind::Assign { .. }));
    }

    #[test]
    fn gotos() {
        let t = |s: &str| match one(s).kind {
            LineKind::Goto { target } => target.kind,
            k => panic!("{k:?}"),
        };
        assert_eq!(t("GOTO100"), ExprKind::Number(100.0));
        assert_eq!(t("goto 5 (back)"), ExprKind::Number(5.0));
        assert_eq!(t("GOTO#10"), var(10));
        assert!(matches!(
            t("GOTO[#1+10]"),
            ExprKind::Binary(BinaryOp::Add, _, _)
        ));
    }

    #[test]
    fn if_goto_and_if_then() {
        let l = one("IF[[#113 OR#114]NE 1]GOTO101(CHECK)");
        let LineKind::IfGoto { cond, target } = &l.kind else {
            panic!("{l:?}")
        };
        assert!(matches!(cond.kind, ExprKind::Binary(BinaryOp::Ne, _, _)));
        assert_eq!(cond.span, Span::new(2, 21));
        assert_eq!(target.kind, ExprKind::Number(101.0));
        let l = one("IF [#520 EQ 3] THEN #113=1");
        let LineKind::IfThen { cond, then } = &l.kind else {
            panic!("{l:?}")
        };
        assert!(matches!(cond.kind, ExprKind::Binary(BinaryOp::Eq, _, _)));
        assert!(matches!(**then, LineKind::Assign { .. }));
        let l = one("if[#1 gt 0]then g0 x#1 (move)");
        let LineKind::IfThen { then, .. } = &l.kind else {
            panic!("{l:?}")
        };
        let LineKind::Block(b) = &**then else {
            panic!("{then:?}")
        };
        assert_eq!(b.words.len(), 2);
        assert_eq!(l.comments[0].text, "move");
    }

    #[test]
    fn while_do_end() {
        let l = one("WHILE[#1 LT 10]DO1");
        let LineKind::While { cond, id } = &l.kind else {
            panic!("{l:?}")
        };
        assert!(matches!(cond.kind, ExprKind::Binary(BinaryOp::Lt, _, _)));
        assert_eq!(*id, 1);
        assert!(matches!(
            one("N5 while [#2 LE #3] do 3").kind,
            LineKind::While { id: 3, .. }
        ));
        assert_eq!(one("END1").kind, LineKind::End { id: 1 });
        assert_eq!(one("end 2 (loop)").kind, LineKind::End { id: 2 });
    }

    #[test]
    fn g65_stays_a_block() {
        assert_eq!(
            nums("G65 H99 P1"),
            vec![('G', 65.0, false), ('H', 99.0, false), ('P', 1.0, false)]
        );
    }

    #[test]
    fn statement_errors() {
        assert_eq!(err("#1"), (1, 3, "missing `=` after the variable".into()));
        assert_eq!(err("#1="), (1, 4, "missing expression after `=`".into()));
        assert_eq!(err("IF #1 GOTO 5"), (1, 4, "missing `[` after IF".into()));
        assert_eq!(
            err("IF[#1]X1"),
            (1, 7, "missing GOTO or THEN after IF[…]".into())
        );
        assert_eq!(
            err("WHILE[1]DO4"),
            (1, 11, "loop number 4 after DO is out of range".into())
        );
        assert_eq!(err("END"), (1, 4, "missing loop number after END".into()));
        assert_eq!(
            err("GOTO"),
            (1, 5, "missing sequence number after GOTO".into())
        );
        assert_eq!(
            err("GOTO 5 X1"),
            (1, 8, "unexpected text after the statement".into())
        );
        assert_eq!(err("DO1"), (1, 1, "DO without WHILE[…]".into()));
    }
}
