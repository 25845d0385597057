//! The header comment by which a program names its dialect (`(dialect: linuxcnc)`), and the
//! choice between it, the command line and the config.

use crate::ast::Span;
use crate::diag::{NcError, SourceFile};
use crate::dialect::Dialect;

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
        declared_dialect(&SourceFile::new("t.nc", text))
            .map_err(|e| (e.line, e.col, e.message.clone()))
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
