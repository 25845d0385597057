//! The nom parser from NC text to [`crate::ast::Program`].
//! Lines are parsed one at a time over `&str`; spans are byte offsets into the whole text, and
//! `line:col` is computed only when an error is reported. Submodules: `lex` (whitespace,
//! comments, numbers), `expr` (the Fanuc expression grammar), `line` (blocks and statements).

mod clike;
mod expr;
mod header;

pub use header::{HEADER_LINES, choose_dialect, declared_dialect};

pub use expr::MAX_HEIGHT;
mod lcexpr;
pub(crate) mod lex;
mod line;
mod oword;
pub(crate) mod simple;

use std::borrow::Cow;

use nom::error::{ErrorKind, ParseError};
use nom::{IResult, Offset, Parser};

use crate::ast::{Expr, Line, LineKind, Program, Span, Stmt};
use crate::diag::{NcError, SourceFile};
use crate::dialect::Dialect;

/// Parses a whole NC program into one [`crate::ast::Line`] per physical line.
///
/// Lines end with `\n` or `\r\n`; a final line without terminator counts, a trailing
/// terminator does not start an empty last line (an empty text is one empty line). The first
/// error ends the parse: the error points at the offending text and says what was expected.
///
/// Choices where controls differ:
/// * Whitespace may stand between words and between an address letter and its value
///   (`X 10` is `X10`, `X - 5` is not a number: the sign belongs to the digits), never inside
///   a number (`X1 0` is an error). Letters and keywords are case-insensitive.
/// * Numbers have no exponent (`X1E2` is `X1 E2`); `has_point` records a decimal point.
///   Only C-like statements (not G-code values) take exponents: `double d = 1e-3;`.
/// * `( … )` comments may nest (`(START(dòng) SPINDLE)` is one comment) and end at the end
///   of their line; `;` comments to the end of the line (so a Fanuc end-of-block `;` is fine).
/// * `N` must start the block; `O`/`:` and `%` stand on their own line with comments only.
/// * `/` (block delete) only at the start; the Fanuc `/2`…`/9` levels are not supported.
/// * Fanuc Custom Macro B: `#n`, `#[e]`, `#n=e`, `GOTO`, `IF[…]GOTO`, `IF[…]THEN`,
///   `WHILE[…]DO m`, `END m` (keywords need no spaces: `IF[#1EQ2]GOTO5`).
/// * The C-like language (source 000): a line is a *statement* when it starts with `{`, `}`,
///   `$`, `@`, `"`, `//`, `/*`, `#use`, `++`/`--`, or with a name whose first two
///   characters are letters or `_` (`int n`, `Tapping(…)`, `if (…)`, `dOst = …`); other
///   lines are G-code. `GOTO`, `IF`/`WHILE` not followed by `(`, `END`, `DO` and
///   `AXSTR(…)=` stay G-code. Lines that read both ways are errors: a single letter followed
///   by `++ -- += -= *= /= %=` or by `[…] =`, a letter and digits (`x1`) followed by an
///   assignment, and `x = …;` ending in `;`. A program with at least one statement is C-like:
///   its G-code lines then take C expressions after `=` (`F=dTapFeed`, `X=(a+b)`),
///   `AXSTR(name)=value` words and `//` comments. A statement may run over several lines
///   (those become [`crate::ast::LineKind::Continued`]); G-code lines inside it must start
///   their own line.
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
// NcError is big (it carries the block text and the source for miette); it is returned once
// per parse, so boxing it would only make the API clumsier.
#[allow(clippy::result_large_err)]
pub fn parse(src: &SourceFile) -> Result<Program, NcError> {
    let dialect = header::declared_dialect(src)?.unwrap_or_default();
    parse_in(src, dialect)
}

/// [`parse`] in `dialect`, whatever the program's header says (the caller has chosen it, see
/// [`choose_dialect`]).
///
/// ```
/// use cnc402_lang::{parse_in, Dialect, SourceFile};
/// let src = SourceFile::new("p.nc", "(dialect: haas)\nG0 X1\n");
/// assert_eq!(parse_in(&src, Dialect::Fanuc).unwrap().dialect, Dialect::Fanuc);
/// assert_eq!(cnc402_lang::parse(&src).unwrap().dialect, Dialect::Haas);
/// ```
#[allow(clippy::result_large_err)]
pub fn parse_in(src: &SourceFile, dialect: Dialect) -> Result<Program, NcError> {
    let text: &str = &src.text;
    let statement_lines = text
        .split('\n')
        .filter(|l| clike::classify(l.trim_start_matches([' ', '\t'])) == clike::Class::Statement)
        .take(2)
        .count();
    // LinuxCNC programs are never C-like: `@` there is a polar word.
    let c_like = statement_lines > 0 && dialect != Dialect::LinuxCnc;
    parse_lines(src, dialect, c_like, statement_lines)
}

/// Whether `line` (one line of a program) is a statement of the C-like language.
pub(crate) fn is_statement_line(line: &str) -> bool {
    clike::classify(line.trim_start_matches([' ', '\t'])) == clike::Class::Statement
}

/// [`parse_in`] for a text known to hold no C-like statement (a line of a program read line
/// by line, see [`crate::stream`]).
#[allow(clippy::result_large_err)]
pub(crate) fn parse_gcode(src: &SourceFile, dialect: Dialect) -> Result<Program, NcError> {
    parse_lines(src, dialect, false, 0)
}

/// The line loop of [`parse_in`]: `c_like` as the whole program decided it, from
/// `statement_lines` (0, 1 or 2: one lone statement may be a G-code typo).
#[allow(clippy::result_large_err)]
fn parse_lines(
    src: &SourceFile,
    dialect: Dialect,
    c_like: bool,
    statement_lines: usize,
) -> Result<Program, NcError> {
    let text: &str = &src.text;
    let cx = Cx {
        text,
        line_starts: src.line_starts(),
        first_line: src.first_line(),
        c_like,
        dialect,
    };
    let mut lines = Vec::with_capacity(text.len() / 24 + 1);
    let mut rest = text;
    let mut line_no: u32 = src.first_line();
    loop {
        let (line_text, after) = match rest.find('\n') {
            Some(i) => (&rest[..i], Some(&rest[i + 1..])),
            None => (rest, None),
        };
        let start = line_text.trim_start_matches([' ', '\t']);
        let class = if c_like {
            clike::classify(start)
        } else {
            clike::Class::Gcode
        };
        if let clike::Class::Ambiguous(msg) = class {
            let len = start.trim_end_matches('\r').len();
            return Err(cx.error(
                src,
                PErr {
                    at: start,
                    len,
                    msg: Cow::Borrowed(msg),
                    expected: Some(Cow::Borrowed("a statement or a G-code block")),
                },
            ));
        }
        if class == clike::Class::Statement {
            // A statement may run over several lines: it ends at the end of a line.
            let parsed = (|i| cx.c_line(i)).parse_complete(rest);
            let (end, stmts) = match parsed {
                Ok(ok) => ok,
                Err(nom::Err::Error(e) | nom::Err::Failure(e)) => {
                    // A lone "statement" without C punctuation in a G-code program is far more
                    // likely a G-code typo (`GG1`, `XY10`): report it as G-code.
                    let c_punct = |b: u8| b"(){}=;\"$@/#".contains(&b);
                    if statement_lines == 1 && !line_text.bytes().any(c_punct) {
                        let g = Cx {
                            c_like: false,
                            ..cx
                        };
                        if let Err(nom::Err::Error(ge) | nom::Err::Failure(ge)) =
                            (|i| g.line(line_no, i)).parse_complete(line_text)
                        {
                            return Err(g.error(src, ge));
                        }
                    }
                    return Err(cx.error(src, e));
                }
                Err(nom::Err::Incomplete(_)) => {
                    return Err(NcError::new(src, cx.span_at(rest, 0), "incomplete input"));
                }
            };
            let consumed = &rest[..rest.len() - end.len()];
            let extra =
                push_statement_lines(&mut lines, &cx, src, line_no, line_text, consumed, stmts);
            line_no = line_no.saturating_add(extra);
            match end.strip_prefix('\n') {
                Some(a) if !a.is_empty() => rest = a,
                _ => break,
            }
            line_no = line_no.saturating_add(1);
            continue;
        }
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
    Ok(Program { lines, dialect })
}

/// Pushes a C-like statement's line (its statements, or empty) and one `Continued` line for
/// each further line the statement ran over (`consumed`); returns how many those are.
fn push_statement_lines(
    lines: &mut Vec<Line>,
    cx: &Cx<'_>,
    src: &SourceFile,
    line_no: u32,
    line_text: &str,
    consumed: &str,
    stmts: Vec<Stmt>,
) -> u32 {
    let extra = consumed.bytes().filter(|&b| b == b'\n').count() as u32;
    let body = line_text.strip_suffix('\r').unwrap_or(line_text);
    lines.push(Line {
        line_no,
        span: cx.span_at(line_text, body.len()),
        block_delete: false,
        n: None,
        kind: if stmts.is_empty() {
            LineKind::Empty
        } else {
            LineKind::Stmts(stmts)
        },
        comments: Vec::new(),
    });
    for k in 1..=extra {
        let no = line_no + k;
        let span = src.line_span(no);
        lines.push(Line {
            line_no: no,
            span,
            block_delete: false,
            n: None,
            kind: LineKind::Continued,
            comments: Vec::new(),
        });
    }
    extra
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
#[allow(clippy::result_large_err)]
pub fn parse_expr(src: &SourceFile) -> Result<Expr, NcError> {
    let text: &str = &src.text;
    let cx = Cx {
        text,
        line_starts: src.line_starts(),
        first_line: src.first_line(),
        c_like: false,
        dialect: Dialect::Fanuc,
    };
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
    /// Line starts of `text` (empty: count newlines instead).
    line_starts: &'a [u32],
    /// The program's line number of `text`'s first line (see [`SourceFile::window`]).
    first_line: u32,
    /// The program uses the C-like language: G-code lines take C expressions after `=`,
    /// `AXSTR(…)=` words and `//` comments.
    c_like: bool,
    /// The dialect the program is read in (LinuxCNC: O-word flow, `#<name>`, polar words).
    dialect: Dialect,
}

impl<'a> Cx<'a> {
    /// A context for ISO/Fanuc text without a line index (unit tests).
    #[cfg(test)]
    pub(crate) fn new(text: &'a str) -> Self {
        Cx {
            text,
            line_starts: &[],
            first_line: 1,
            c_like: false,
            dialect: Dialect::Fanuc,
        }
    }

    /// 1-based line number of byte offset `off`.
    fn line_no_at(&self, off: usize) -> u32 {
        let first = self.first_line - 1;
        if self.line_starts.is_empty() {
            return first
                + 1
                + self.text.as_bytes()[..off.min(self.text.len())]
                    .iter()
                    .filter(|&&b| b == b'\n')
                    .count() as u32;
        }
        match self.line_starts.binary_search(&(off as u32)) {
            Ok(k) => first + k as u32 + 1,
            Err(k) => first + k as u32,
        }
    }

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
