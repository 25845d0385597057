//! The nom parser from NC text to [`crate::ast::Program`].
//! Lines are parsed one at a time over `&str`; spans are byte offsets into the whole text, and
//! `line:col` is computed only when an error is reported. Submodules: `lex` (whitespace,
//! comments, numbers), `expr` (the Fanuc expression grammar), `line` (blocks and statements).

mod expr;
mod lex;
mod line;

use std::borrow::Cow;

use nom::error::{ErrorKind, ParseError};
use nom::{IResult, Offset, Parser};

use crate::ast::{Expr, Program, Span};
use crate::diag::{NcError, SourceFile};

/// Parses a whole NC program into one [`crate::ast::Line`] per physical line.
///
/// Lines end with `\n` or `\r\n`; a final line without terminator counts, a trailing
/// terminator does not start an empty last line (an empty text is one empty line). The first
/// error ends the parse: the error points at the offending text and says what was expected.
///
/// ```
/// use cnc402_lang::{parse, SourceFile, ast::{LineKind, Value}};
/// let src = SourceFile::new("demo.nc", "%\nO0001 (DEMO)\nN10 G0 X-1.5 Y.5\nN20 G1 Z[1+2*3] F=100*2\n%\n");
/// let prog = parse(&src).unwrap();
/// assert_eq!(prog.lines.len(), 5);
/// let LineKind::Block(b) = &prog.lines[2].kind else { panic!() };
/// assert_eq!(prog.lines[2].n.unwrap().value, 10);
/// assert_eq!(b.words[1].letter, 'X');
/// let Value::Number(x) = &b.words[1].value else { panic!() };
/// assert_eq!((x.value, x.has_point), (-1.5, true));
///
/// let err = parse(&SourceFile::new("bad.nc", "G1 X1\nG1 Y F100\n")).unwrap_err();
/// assert_eq!((err.line, err.col), (2, 4));
/// assert_eq!(err.message, "no value after address Y");
/// ```
pub fn parse(src: &SourceFile) -> Result<Program, NcError> {
    let text: &str = &src.text;
    let cx = Cx { text };
    let mut lines = Vec::with_capacity(text.len() / 24 + 1);
    let mut rest = text;
    let mut line_no: u32 = 1;
    loop {
        let (line_text, after) = match rest.find('\n') {
            Some(i) => (&rest[..i], Some(&rest[i + 1..])),
            None => (rest, None),
        };
        let parsed = (|i| cx.line(line_no, i)).parse_complete(line_text);
        match parsed {
            Ok((_, line)) => lines.push(line),
            Err(nom::Err::Error(e) | nom::Err::Failure(e)) => return Err(cx.error(src, e)),
            // `parse_complete` never yields Incomplete; report it rather than panic.
            Err(nom::Err::Incomplete(_)) => {
                return Err(NcError::new(
                    src,
                    cx.span_at(line_text, line_text.len()),
                    "incomplete input",
                ));
            }
        }
        match after {
            Some(a) if !a.is_empty() => rest = a,
            _ => break,
        }
        line_no = line_no.saturating_add(1);
    }
    Ok(Program { lines })
}

/// Parses one expression in the Fanuc grammar (the text between `[` and `]`, or after `=`),
/// e.g. for an operator typing a value. The whole text must be the expression.
///
/// ```
/// use cnc402_lang::{parse_expr, SourceFile, ast::{BinaryOp, ExprKind}};
/// let e = parse_expr(&SourceFile::new("expr", "1 + 2*3 EQ 7")).unwrap();
/// assert!(matches!(e.kind, ExprKind::Binary(BinaryOp::Eq, _, _)));
/// assert!(parse_expr(&SourceFile::new("expr", "1 +")).is_err());
/// ```
pub fn parse_expr(src: &SourceFile) -> Result<Expr, NcError> {
    let text: &str = &src.text;
    let cx = Cx { text };
    let r = (|i| {
        let (i, e) = cx.expr(i, 0)?;
        let i = lex::ws(i);
        if !i.is_empty() {
            return fail_exp(
                i,
                lex::char_len(i),
                "unexpected text after the expression",
                "an operator or the end of the expression",
            );
        }
        Ok((i, e))
    })
    .parse_complete(text);
    match r {
        Ok((_, e)) => Ok(e),
        Err(nom::Err::Error(e) | nom::Err::Failure(e)) => Err(cx.error(src, e)),
        Err(nom::Err::Incomplete(_)) => Err(NcError::new(
            src,
            Span::new(text.len(), text.len()),
            "incomplete input",
        )),
    }
}

/// A parse error still holding its place in the input; turned into an [`NcError`] at the top.
#[derive(Debug)]
pub(crate) struct PErr<'a> {
    /// The input at the offending text.
    at: &'a str,
    /// Byte length of the offending text.
    len: usize,
    msg: Cow<'static, str>,
    expected: Option<Cow<'static, str>>,
}

impl<'a> ParseError<&'a str> for PErr<'a> {
    fn from_error_kind(input: &'a str, _kind: ErrorKind) -> Self {
        PErr {
            at: input,
            len: lex::char_len(input),
            msg: Cow::Borrowed("syntax error"),
            expected: None,
        }
    }
    fn append(_: &'a str, _: ErrorKind, other: Self) -> Self {
        other
    }
}

pub(crate) type PResult<'a, T> = IResult<&'a str, T, PErr<'a>>;

/// A committed (non-backtracking) error at `at`, `len` bytes long.
pub(crate) fn fail<'a, T>(
    at: &'a str,
    len: usize,
    msg: impl Into<Cow<'static, str>>,
) -> PResult<'a, T> {
    Err(nom::Err::Failure(PErr {
        at,
        len,
        msg: msg.into(),
        expected: None,
    }))
}

/// Like [`fail`], saying what was expected.
pub(crate) fn fail_exp<'a, T>(
    at: &'a str,
    len: usize,
    msg: impl Into<Cow<'static, str>>,
    expected: impl Into<Cow<'static, str>>,
) -> PResult<'a, T> {
    Err(nom::Err::Failure(PErr {
        at,
        len,
        msg: msg.into(),
        expected: Some(expected.into()),
    }))
}

/// The parse context: the whole text, to turn sub-slices into absolute spans.
#[derive(Clone, Copy)]
pub(crate) struct Cx<'a> {
    text: &'a str,
}

impl<'a> Cx<'a> {
    /// Byte offset of the sub-slice `s` in the whole text.
    #[inline]
    fn off(&self, s: &str) -> usize {
        self.text.offset(s)
    }
    /// Span from the start of `from` to the start of `to` (both sub-slices of the text).
    #[inline]
    fn span(&self, from: &str, to: &str) -> Span {
        Span::new(self.off(from), self.off(to))
    }
    /// Span of `len` bytes at the start of `at`.
    #[inline]
    fn span_at(&self, at: &str, len: usize) -> Span {
        let s = self.off(at);
        Span::new(s, s + len)
    }
    fn error(&self, src: &SourceFile, e: PErr<'a>) -> NcError {
        let err = NcError::new(src, self.span_at(e.at, e.len), e.msg);
        match e.expected {
            Some(x) => err.with_expected(x),
            None => err,
        }
    }
}
