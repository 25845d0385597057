//! Which control's habits a program is written for ([`Dialect`]), and the header comment by
//! which a program names it. The dialect is chosen once per program, in this order: the
//! command line (`--dialect`), the program's own header ([`declared_dialect`]), the machine
//! config (`interp.dialect`), else Fanuc.

use std::fmt;
use std::str::FromStr;

use crate::ast::Span;
use crate::diag::{NcError, SourceFile};

/// A control whose programs cnc402 reads as that control does where controls differ.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Dialect {
    /// Fanuc 0/16/18/21/30i M series with Custom Macro B (and the C-like language of
    /// source 000). The default.
    #[default]
    Fanuc,
    /// Haas mills: Fanuc plus Haas habits (a bare `G28` homes every axis, decimal `P` in
    /// seconds for cycle dwells, Haas M codes).
    Haas,
    /// LinuxCNC's rs274ngc: O-word subroutines and flow, named parameters, polar words,
    /// `G92.1`–`G92.3`, dwell `P` in seconds, LinuxCNC's canned-cycle retract.
    LinuxCnc,
}

impl Dialect {
    /// Every dialect, in the order the documentation lists them.
    pub const ALL: [Dialect; 3] = [Dialect::Fanuc, Dialect::Haas, Dialect::LinuxCnc];

    /// The name used in the config, on the command line and in program headers.
    pub fn name(self) -> &'static str {
        match self {
            Dialect::Fanuc => "fanuc",
            Dialect::Haas => "haas",
            Dialect::LinuxCnc => "linuxcnc",
        }
    }

    /// The valid names, for messages: `fanuc, haas or linuxcnc`.
    pub fn expected() -> String {
        let names: Vec<&str> = Self::ALL.iter().map(|d| d.name()).collect();
        format!(
            "{} or {}",
            names[..names.len() - 1].join(", "),
            names[names.len() - 1]
        )
    }
}

impl fmt::Display for Dialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The dialect to read `src` in: `forced` (the command line's `--dialect`) if given, else the
/// one its header names ([`declared_dialect`]), else `default` (the config's
/// `interp.dialect`). A header naming an unknown dialect is an error even when `forced`.
///
/// ```
/// use cnc402_lang::{choose_dialect, Dialect, SourceFile};
/// let src = SourceFile::new("p.nc", "(dialect: haas)\nG28\n");
/// assert_eq!(choose_dialect(&src, None, Dialect::LinuxCnc).unwrap(), Dialect::Haas);
/// assert_eq!(choose_dialect(&src, Some(Dialect::Fanuc), Dialect::LinuxCnc).unwrap(), Dialect::Fanuc);
/// let plain = SourceFile::new("p.nc", "G28\n");
/// assert_eq!(choose_dialect(&plain, None, Dialect::LinuxCnc).unwrap(), Dialect::LinuxCnc);
/// ```
#[allow(clippy::result_large_err)]
pub fn choose_dialect(
    src: &SourceFile,
    forced: Option<Dialect>,
    default: Dialect,
) -> Result<Dialect, NcError> {
    let declared = declared_dialect(src)?;
    Ok(forced.or(declared).unwrap_or(default))
}

/// The name was none of [`Dialect::ALL`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownDialect(pub String);

impl fmt::Display for UnknownDialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "unknown dialect {:?} (expected {})",
            self.0,
            Dialect::expected()
        )
    }
}

impl std::error::Error for UnknownDialect {}

impl FromStr for Dialect {
    type Err = UnknownDialect;

    /// Case-insensitive: `LinuxCNC` is `linuxcnc`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|d| d.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| UnknownDialect(s.trim().to_string()))
    }
}

/// How many lines of a program's head are searched for a dialect comment: a header is at the
/// top, and a program of millions of lines must not be scanned for one.
pub const HEADER_LINES: usize = 20;

/// The dialect a program names in its header, if it names one.
///
/// The header is the program's first lines up to its first block: lines that are empty, `%`,
/// a program number (`O1234` or `:1234`, with comments after it) or only comments. A comment
/// there that reads `dialect: NAME` or `dialect=NAME` (any case, in parentheses or after `;`)
/// names the dialect, e.g. `(dialect: linuxcnc)` or `; DIALECT=HAAS`. Only the first
/// [`HEADER_LINES`] lines are read.
///
/// ```
/// use cnc402_lang::{declared_dialect, Dialect, SourceFile};
/// let src = SourceFile::new("p.ngc", "%\n(dialect: linuxcnc)\nG0 X1\n%\n");
/// assert_eq!(declared_dialect(&src).unwrap(), Some(Dialect::LinuxCnc));
/// // After the first block, a comment is only a comment.
/// let late = SourceFile::new("p.nc", "G0 X1\n(dialect: haas)\n");
/// assert_eq!(declared_dialect(&late).unwrap(), None);
/// let bad = SourceFile::new("p.nc", "O1 (DIALECT: SIEMENS)\n");
/// let e = declared_dialect(&bad).unwrap_err();
/// assert_eq!((e.line, e.col), (1, 14));
/// ```
#[allow(clippy::result_large_err)]
pub fn declared_dialect(src: &SourceFile) -> Result<Option<Dialect>, NcError> {
    let text: &str = &src.text;
    let mut offset = 0usize;
    for line in text.split('\n').take(HEADER_LINES) {
        let start = offset;
        offset += line.len() + 1;
        let Some(comments) = header_comments(line) else {
            return Ok(None);
        };
        for (at, comment) in comments {
            if let Some((name_at, name)) = dialect_name(comment) {
                let span_start = start + at + name_at;
                let span = Span::new(span_start, span_start + name.len());
                return name.parse::<Dialect>().map(Some).map_err(|_| {
                    NcError::new(src, span, format!("unknown dialect {name:?}"))
                        .with_expected(Dialect::expected())
                });
            }
        }
    }
    Ok(None)
}

/// The comments of a header line (offset in the line, text), or `None` when the line holds
/// something else (a block: the header has ended).
fn header_comments(line: &str) -> Option<Vec<(usize, &str)>> {
    let body = line.trim_end_matches('\r');
    let mut rest = body.trim_start();
    // A program number or `%` may precede the comments.
    if let Some(r) = rest.strip_prefix('%') {
        rest = r;
    } else if let Some(r) = rest.strip_prefix(['O', 'o', ':']) {
        let digits = r.len() - r.trim_start_matches(|c: char| c.is_ascii_digit()).len();
        if digits == 0 {
            return None;
        }
        rest = &r[digits..];
    }
    let mut out = Vec::new();
    loop {
        rest = rest.trim_start();
        let at = body.len() - rest.len();
        if rest.is_empty() {
            return Some(out);
        }
        if let Some(r) = rest.strip_prefix(';') {
            out.push((at + 1, r));
            return Some(out);
        }
        let r = rest.strip_prefix('(')?;
        let end = r.find(')').unwrap_or(r.len());
        out.push((at + 1, &r[..end]));
        rest = r.get(end + 1..).unwrap_or("");
    }
}

/// `dialect: NAME` / `dialect = NAME` in a comment's text: the name and its offset.
fn dialect_name(comment: &str) -> Option<(usize, &str)> {
    let lead = comment.len() - comment.trim_start().len();
    let t = &comment[lead..];
    let (head, tail) = (t.get(..7)?, t.get(7..)?);
    if !head.eq_ignore_ascii_case("dialect") {
        return None;
    }
    let after = tail.trim_start();
    let after = after.strip_prefix([':', '='])?.trim_start();
    let name_len = after
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '-'))
        .unwrap_or(after.len());
    if name_len == 0 {
        return None;
    }
    Some((comment.len() - after.len(), &after[..name_len]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn declared(text: &str) -> Result<Option<Dialect>, (u32, u32, String)> {
        declared_dialect(&SourceFile::new("t.nc", text)).map_err(|e| (e.line, e.col, e.message))
    }

    #[test]
    fn names_parse_in_any_case_and_print_lower_case() {
        for d in Dialect::ALL {
            assert_eq!(d.name().to_uppercase().parse::<Dialect>(), Ok(d));
            assert_eq!(d.to_string(), d.name());
        }
        assert_eq!("LinuxCNC".parse::<Dialect>(), Ok(Dialect::LinuxCnc));
        assert_eq!(
            "siemens".parse::<Dialect>().unwrap_err().to_string(),
            "unknown dialect \"siemens\" (expected fanuc, haas or linuxcnc)"
        );
    }

    #[test]
    fn header_forms() {
        assert_eq!(
            declared("(dialect: haas)\nG0 X1\n"),
            Ok(Some(Dialect::Haas))
        );
        assert_eq!(
            declared("%\nO0001 (PART) (DIALECT=HAAS)\n"),
            Ok(Some(Dialect::Haas))
        );
        assert_eq!(
            declared("; dialect = linuxcnc\r\n"),
            Ok(Some(Dialect::LinuxCnc))
        );
        assert_eq!(
            declared("\n\n(made by X)\n(dialect:fanuc)\n"),
            Ok(Some(Dialect::Fanuc))
        );
        assert_eq!(
            declared(":1234 (dialect: linuxcnc)\n"),
            Ok(Some(Dialect::LinuxCnc))
        );
        assert_eq!(declared("(dialects are many)\nG0 X0\n"), Ok(None));
        assert_eq!(declared("(dialect)\n"), Ok(None));
        assert_eq!(declared(""), Ok(None));
    }

    #[test]
    fn header_ends_at_the_first_block() {
        assert_eq!(declared("N10 G0 X1 (dialect: haas)\n"), Ok(None));
        assert_eq!(declared("G0 X1\n(dialect: haas)\n"), Ok(None));
        assert_eq!(declared("O (dialect: haas)\n"), Ok(None));
    }

    #[test]
    fn header_is_only_searched_in_its_first_lines() {
        let text = "(c)\n".repeat(HEADER_LINES) + "(dialect: haas)\n";
        assert_eq!(declared(&text), Ok(None));
    }

    #[test]
    fn unknown_dialect_in_a_header_is_an_error_at_its_name() {
        let (line, col, msg) = declared("%\n(dialect: heidenhain)\n").unwrap_err();
        assert_eq!((line, col), (2, 11));
        assert!(msg.contains("unknown dialect \"heidenhain\""), "{msg}");
    }
}
