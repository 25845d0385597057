//! One physical line: block delete, `%`, program number, `N` number, then the words of a block.
//! Whitespace may stand anywhere between words and between an address letter and its value
//! (`X 10` is `X10`, as Fanuc reads it), but not inside a number (`X1 0` is an error).

use super::lex::{char_len, ws};
use super::{Cx, PResult, fail, fail_exp};
use crate::ast::{Block, Line, LineKind, SeqNo, Value, Word};

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
                let (_, block) = self.block(i, &mut comments)?;
                if block.words.is_empty() {
                    LineKind::Empty
                } else {
                    LineKind::Block(block)
                }
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
    fn block(&self, mut i: &'a str, comments: &mut Vec<crate::ast::Comment>) -> PResult<'a, Block> {
        let mut words = Vec::new();
        loop {
            i = self.trivia(i, comments)?.0;
            if i.is_empty() {
                return Ok((i, Block { words }));
            }
            let (r, w) = self.word(i)?;
            words.push(w);
            i = r;
        }
    }

    /// One word: letter, optional whitespace, then a number, `[expr]` or `=expr`.
    pub(crate) fn word(&self, i: &'a str) -> PResult<'a, Word> {
        let Some(c) = i.chars().next() else {
            return fail(i, 0, "missing word");
        };
        if !c.is_ascii_alphabetic() {
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
                (r, Value::Expr(e))
            }
            Some(b'=') => {
                let after = &v[1..];
                match self.expr(after, 0) {
                    Ok((r, e)) => (r, Value::Expr(e)),
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
            Some(b'+' | b'-' | b'.' | b'0'..=b'9') => {
                let (r, num) = self.number(v)?;
                // `X1.2.3` is a malformed number, not two words.
                if let Some(b'.') = r.as_bytes().first() {
                    return fail(r, 1, "a second decimal point in a number");
                }
                (r, Value::Number(num))
            }
            _ => {
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
