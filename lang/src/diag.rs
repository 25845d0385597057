//! Program locations and the one error type for anything wrong in an NC program.
//! [`SourceFile`] turns byte offsets into `line:col`; [`NcError`] carries `file:line:col`, the
//! offending block and what was expected, and renders with a caret through `miette`. The
//! parser produces it; the interpreter, motion and drive layers reuse it to point at a block.

use std::fmt;
use std::sync::Arc;

use miette::{LabeledSpan, MietteError, MietteSpanContents, SourceCode, SourceSpan, SpanContents};

use crate::ast::Span;

/// An NC program's text with its name and an index of line starts.
///
/// ```
/// use cnc402_lang::SourceFile;
/// let src = SourceFile::new("a.nc", "G0 X1\nG1 Ä2 F3\n");
/// assert_eq!(src.line_col(6), (2, 1));
/// assert_eq!(src.line_col(12), (2, 6)); // `Ä` is one column, two bytes
/// assert_eq!(src.line_text(2), "G1 Ä2 F3");
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SourceFile {
    pub name: Arc<str>,
    pub text: Arc<str>,
    /// Byte offset of the start of every line; `line_starts[0] == 0`. Empty for a text of
    /// one line (read through [`Self::line_starts`]).
    line_starts: Vec<u32>,
    /// The program's line number of the text's first line: 1 for a whole program, more for
    /// a window of a program read line by line ([`SourceFile::window`]).
    first_line: u32,
}

impl SourceFile {
    /// Wraps `text` (a whole program) named `name` (usually its path).
    pub fn new(name: impl Into<Arc<str>>, text: impl Into<Arc<str>>) -> Self {
        let name = name.into();
        let text: Arc<str> = text.into();
        // One line (a window of a program read line by line): no table, see `line_starts`.
        let mut line_starts = Vec::new();
        if text.contains('\n') {
            line_starts.reserve(text.len() / 16 + 1);
            line_starts.push(0);
            line_starts.extend(
                text.bytes()
                    .enumerate()
                    .filter(|&(_, b)| b == b'\n')
                    .map(|(i, _)| (i + 1) as u32),
            );
        }
        SourceFile {
            name,
            text,
            line_starts,
            first_line: 1,
        }
    }

    /// A window of a longer program: `text` is the program's text from the start of line
    /// `first_line` on (a program read line by line keeps only the block it runs). Spans are
    /// byte offsets into `text`; lines and errors count from `first_line`.
    ///
    /// ```
    /// use cnc402_lang::{SourceFile, NcError, ast::Span};
    /// let w = SourceFile::window("big.nc", "G1 X Y2", 900_000);
    /// assert_eq!(w.line_col(3), (900_000, 4));
    /// assert_eq!(w.line_text(900_000), "G1 X Y2");
    /// let e = NcError::new(&w, Span::new(3, 4), "no value after address X");
    /// assert_eq!(e.to_string(), "big.nc:900000:4: no value after address X\n    G1 X Y2");
    /// ```
    pub fn window(name: impl Into<Arc<str>>, text: impl Into<Arc<str>>, first_line: u32) -> Self {
        let mut s = SourceFile::new(name, text);
        s.first_line = first_line.max(1);
        s
    }

    /// The program's line number of the text's first line (1 unless a [`window`](Self::window)).
    pub fn first_line(&self) -> u32 {
        self.first_line
    }

    /// The program's line number of the text's last line.
    pub fn last_line(&self) -> u32 {
        self.first_line.saturating_add(self.line_count() - 1)
    }

    /// Wraps a program read from a file: UTF-8 where the whole file is valid UTF-8, else
    /// Latin-1 (ISO 8859-1, every byte one character), as older controls and CAM systems
    /// write comments. Whatever is then not acceptable text (a NUL, a control character
    /// outside a comment) is the parser's error at its line and column, never a read error.
    ///
    /// ```
    /// use cnc402_lang::SourceFile;
    /// let src = SourceFile::from_bytes("a.nc", b"(Fr\xe4se)\nG0 X1\n".to_vec());
    /// assert_eq!(src.line_text(1), "(Fräse)");
    /// let utf8 = SourceFile::from_bytes("b.nc", "(Fräse)".as_bytes().to_vec());
    /// assert_eq!(utf8.line_text(1), "(Fräse)");
    /// ```
    pub fn from_bytes(name: impl Into<Arc<str>>, bytes: Vec<u8>) -> Self {
        let text = match String::from_utf8(bytes) {
            Ok(text) => text,
            Err(e) => e.into_bytes().iter().map(|&b| char::from(b)).collect(),
        };
        SourceFile::new(name, text)
    }

    /// A window of line `line_no` whose `text` holds no `\n` (a line as a reader split it),
    /// made without searching the text for line breaks again.
    pub(crate) fn one_line(name: Arc<str>, text: Arc<str>, line_no: u32) -> Self {
        debug_assert!(!text.contains('\n'));
        SourceFile {
            name,
            text,
            line_starts: Vec::new(),
            first_line: line_no.max(1),
        }
    }

    /// Whether the text is one line (holds no `\n`).
    pub(crate) fn is_one_line(&self) -> bool {
        self.line_starts.is_empty()
    }

    /// Byte offsets of line starts (crate-internal, for the parser's line numbers).
    pub(crate) fn line_starts(&self) -> &[u32] {
        // A text without a line break starts one line, at 0 (no table is kept for it).
        if self.line_starts.is_empty() {
            return &[0];
        }
        &self.line_starts
    }

    /// Number of lines (a final line without a terminator counts; a trailing `\n` does not
    /// start a new one).
    pub fn line_count(&self) -> u32 {
        let n = self.line_starts().len();
        if n > 1 && self.line_starts()[n - 1] as usize == self.text.len() {
            (n - 1) as u32
        } else {
            n as u32
        }
    }

    /// 1-based line and column of `byte_offset`; the column counts characters, not bytes.
    /// Offsets past the end are clamped to the end; an offset inside a multi-byte character
    /// counts as that character.
    pub fn line_col(&self, byte_offset: usize) -> (u32, u32) {
        let off = byte_offset.min(self.text.len());
        let idx = match self.line_starts().binary_search(&(off as u32)) {
            Ok(i) => i,
            Err(i) => i - 1, // i >= 1 because line_starts[0] == 0 <= off
        };
        let start = self.line_starts()[idx] as usize;
        let mut end = off;
        while !self.text.is_char_boundary(end) {
            end -= 1;
        }
        let col = self.text[start..end].chars().count() as u32 + 1;
        (self.first_line.saturating_add(idx as u32), col)
    }

    /// The text of 1-based `line`, without its `\n` or `\r\n`; `""` for a line that does not
    /// exist.
    pub fn line_text(&self, line: u32) -> &str {
        let Some(i) = (line as usize).checked_sub(self.first_line as usize) else {
            return "";
        };
        let Some(&start) = self.line_starts().get(i) else {
            return "";
        };
        let start = start as usize;
        let end = self
            .line_starts()
            .get(i + 1)
            .map_or(self.text.len(), |&e| e as usize - 1);
        let s = &self.text[start..end];
        s.strip_suffix('\r').unwrap_or(s)
    }

    /// Byte span of 1-based `line` (without terminator), or an empty span at the end.
    pub fn line_span(&self, line: u32) -> Span {
        let Some(i) = (line as usize).checked_sub(self.first_line as usize) else {
            return Span::new(0, 0);
        };
        match self.line_starts().get(i) {
            Some(&start) => {
                let start = start as usize;
                Span::new(start, start + self.line_text(line).len())
            }
            None => Span::new(self.text.len(), self.text.len()),
        }
    }
}

/// The error for anything wrong in an NC program: where it is, the offending block, what is
/// wrong and what was expected.
///
/// `Display` gives `file:line:col: message (expected …)` and the block on the next line;
/// through [`miette::Diagnostic`] a report shows the block with a caret under the span.
///
/// ```
/// use cnc402_lang::{NcError, SourceFile, ast::Span};
/// let src = SourceFile::new("p.nc", "G0 X1\nG1 X Y2\n");
/// let e = NcError::new(&src, Span::new(9, 10), "missing number after address X")
///     .with_expected("a number");
/// assert_eq!((e.line, e.col), (2, 4));
/// assert_eq!(e.to_string(),
///     "p.nc:2:4: missing number after address X (expected a number)\n    G1 X Y2");
/// ```
#[derive(Clone, PartialEq)]
pub struct NcError {
    /// Boxed: errors are rare, and every `Result<_, NcError>` on the interpreter's hot path
    /// is moved whole, so the error's size is paid on every block that has none.
    at: Box<NcErrorFields>,
}

/// What an [`NcError`] holds; its fields read through the error itself (`e.line`).
#[derive(Clone, PartialEq)]
pub struct NcErrorFields {
    pub file: Arc<str>,
    /// 1-based line of `span.start`.
    pub line: u32,
    /// 1-based column (in characters) of `span.start`.
    pub col: u32,
    /// Byte span of the offending text in the whole program.
    pub span: Span,
    /// The text of the offending line.
    pub block: String,
    pub message: String,
    /// What would have been accepted at this point, if that is known.
    pub expected: Option<String>,
    snippet: Snippet,
}

impl std::ops::Deref for NcError {
    type Target = NcErrorFields;

    fn deref(&self) -> &NcErrorFields {
        &self.at
    }
}

impl std::ops::DerefMut for NcError {
    fn deref_mut(&mut self) -> &mut NcErrorFields {
        &mut self.at
    }
}

impl NcError {
    /// An error at `span` of `src`. `span` is clamped to the text.
    pub fn new(src: &SourceFile, span: Span, message: impl Into<String>) -> Self {
        let len = src.text.len();
        let start = (span.start as usize).min(len);
        let end = (span.end as usize).clamp(start, len);
        let span = Span::new(start, end);
        let (line, col) = src.line_col(start);
        let at = NcErrorFields {
            file: src.name.clone(),
            line,
            col,
            span,
            block: src.line_text(line).to_string(),
            message: message.into(),
            expected: None,
            snippet: Snippet::new(src, line, span),
        };
        NcError { at: Box::new(at) }
    }

    /// Says what would have been accepted where the error is.
    pub fn with_expected(mut self, e: impl Into<String>) -> Self {
        self.expected = Some(e.into());
        self
    }

    /// `file:line:col`, as at the head of the message.
    pub fn location(&self) -> String {
        format!("{}:{}:{}", self.file, self.line, self.col)
    }
}

impl fmt::Display for NcError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.location(), self.message)?;
        if let Some(e) = &self.expected {
            write!(f, " (expected {e})")?;
        }
        // The line as the snippet shows it: cut around the error when it is very long.
        write!(
            f,
            "\n    {}",
            &self.snippet.text[self.snippet.block.clone()]
        )
    }
}

impl fmt::Debug for NcError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("NcError")
            .field("file", &self.file)
            .field("line", &self.line)
            .field("col", &self.col)
            .field("span", &self.span)
            .field("block", &self.block)
            .field("message", &self.message)
            .field("expected", &self.expected)
            .finish()
    }
}

impl std::error::Error for NcError {}

impl miette::Diagnostic for NcError {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        Some(Box::new("cnc402::nc"))
    }

    fn source_code(&self) -> Option<&dyn SourceCode> {
        Some(&self.snippet)
    }

    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        let label = match &self.expected {
            Some(e) => format!("expected {e}"),
            None => "here".to_string(),
        };
        Some(Box::new(std::iter::once(
            LabeledSpan::new_primary_with_span(Some(label), self.snippet.span.clone()),
        )))
    }
}

/// Widest line of a report's snippet, in characters. A longer line is shown as a window of
/// this many characters around the error: the renderer pads to the column with a width
/// that cannot pass 65,535, and a 200,000-character line helps no reader anyway.
const SNIPPET_CHARS: usize = 240;

/// What a report shows of the program: the error's line and the lines on either side,
/// each cut to the same window of characters, with the error's span inside it.
#[derive(Clone, Debug, PartialEq)]
struct Snippet {
    name: Arc<str>,
    text: String,
    /// 0-based number of the first line of `text` in the program.
    first_line: usize,
    /// Bytes cut from the start of the error's line, less the `…` put there instead
    /// (0 when nothing was cut): added back to the columns the renderer counts.
    col_shift: usize,
    /// The error's span in `text`.
    span: std::ops::Range<usize>,
    /// The error's line (as cut) in `text`.
    block: std::ops::Range<usize>,
}

impl Snippet {
    fn new(src: &SourceFile, line: u32, span: Span) -> Self {
        let err_line = src.line_text(line);
        let err_start = src.line_span(line).start as usize;
        let col = err_line
            .get(..(span.start as usize).saturating_sub(err_start))
            .map_or(0, |s| s.chars().count());
        let skip = if err_line.chars().count() <= SNIPPET_CHARS {
            0
        } else {
            col.saturating_sub(SNIPPET_CHARS / 2)
        };
        let first = line.saturating_sub(1).max(src.first_line());
        let last = line.saturating_add(1).min(src.last_line()).max(line);
        let mut text = String::new();
        let mut snippet = Snippet {
            name: src.name.clone(),
            text: String::new(),
            first_line: first as usize - 1,
            col_shift: 0,
            span: 0..0,
            block: 0..0,
        };
        for n in first..=last {
            let full = src.line_text(n);
            let line_start = text.len();
            let cut = full.char_indices().nth(skip).map_or(full.len(), |(b, _)| b);
            if cut > 0 && cut < full.len() {
                text.push('…');
            }
            let prefix = text.len() - line_start;
            let kept: String = full[cut..].chars().take(SNIPPET_CHARS).collect();
            if n == line {
                snippet.col_shift = cut.saturating_sub(prefix);
                let to_here = |at: usize| {
                    (line_start + prefix + at.saturating_sub(err_start + cut))
                        .min(line_start + prefix + kept.len())
                };
                let start = to_here(span.start as usize);
                snippet.span = start..to_here(span.end as usize).max(start);
                snippet.block = line_start..line_start + prefix + kept.len();
            }
            text.push_str(&kept);
            text.push('\n');
        }
        snippet.text = text;
        snippet
    }
}

impl SourceCode for Snippet {
    fn read_span<'a>(
        &'a self,
        span: &SourceSpan,
        before: usize,
        after: usize,
    ) -> Result<Box<dyn SpanContents<'a> + 'a>, MietteError> {
        let inner = self.text.as_str().read_span(span, before, after)?;
        Ok(Box::new(MietteSpanContents::new_named(
            self.name.to_string(),
            inner.data(),
            *inner.span(),
            inner.line() + self.first_line,
            inner.column() + self.col_shift,
            inner.line_count(),
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_col_at_line_starts_and_ends() {
        let s = SourceFile::new("t", "ab\r\ncd\n\nx");
        assert_eq!(s.line_col(0), (1, 1));
        assert_eq!(s.line_col(2), (1, 3));
        assert_eq!(s.line_col(4), (2, 1));
        assert_eq!(s.line_col(7), (3, 1));
        assert_eq!(s.line_col(8), (4, 1));
        assert_eq!(s.line_col(9), (4, 2));
        assert_eq!(s.line_col(1000), (4, 2));
        assert_eq!(s.line_text(1), "ab");
        assert_eq!(s.line_text(3), "");
        assert_eq!(s.line_text(4), "x");
        assert_eq!(s.line_text(5), "");
        assert_eq!(s.line_text(0), "");
        assert_eq!(s.line_count(), 4);
        assert_eq!(SourceFile::new("t", "a\n").line_count(), 1);
        assert_eq!(SourceFile::new("t", "").line_count(), 1);
    }

    #[test]
    fn column_counts_chars_and_survives_mid_char_offsets() {
        let s = SourceFile::new("t", "(全角)X");
        assert_eq!(s.line_col(1 + 6 + 1), (1, 5));
        assert_eq!(s.line_col(2), (1, 2)); // inside `全`
    }

    #[test]
    fn error_span_is_clamped_and_renders_with_miette() {
        let s = SourceFile::new("p.nc", "G1 X\n");
        let e = NcError::new(&s, Span::new(4, 99), "missing number after address X")
            .with_expected("a number");
        assert_eq!(e.span, Span::new(4, 5));
        let mut out = String::new();
        miette::GraphicalReportHandler::new_themed(miette::GraphicalTheme::unicode_nocolor())
            .render_report(&mut out, &e)
            .unwrap();
        assert!(out.contains("p.nc:1:5"), "{out}");
        assert!(out.contains("expected a number"), "{out}");
    }
}
