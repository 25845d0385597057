//! Config errors: file, line, column, key path and message, rendered as text
//! (`file:line:col: key: message`) or by miette with a caret under the offending text.

use std::fmt;
use std::ops::Range;
use std::path::Path;

/// A config error: where, which key, what is wrong. Renders as
/// `config/machine.toml:12:3: axis[2].max_velocity: must be > 0`.
#[derive(Clone, Debug, PartialEq)]
pub struct ConfigError {
    pub file: String,
    /// 1-based; 0 when unknown.
    pub line: usize,
    pub col: usize,
    /// Dotted key path, e.g. `axis[2].max_velocity`; empty when the error is not at a key.
    pub key: String,
    pub message: String,
    /// The config text and the span of the offending text, for the caret rendering (boxed:
    /// errors travel through every `Result` of the loaders and should stay small).
    located: Option<Box<(String, Range<usize>)>>,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if self.line > 0 {
            write!(f, ":{}:{}", self.line, self.col)?;
        }
        if !self.key.is_empty() {
            write!(f, ": {}", self.key)?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for ConfigError {}

impl miette::Diagnostic for ConfigError {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        Some(Box::new("cnc402::config"))
    }
    fn source_code(&self) -> Option<&dyn miette::SourceCode> {
        self.located
            .as_ref()
            .map(|l| &l.0 as &dyn miette::SourceCode)
    }
    fn labels(&self) -> Option<Box<dyn Iterator<Item = miette::LabeledSpan> + '_>> {
        let span = self.located.as_ref()?.1.clone();
        let label = if self.key.is_empty() {
            self.message.clone()
        } else {
            self.key.clone()
        };
        Some(Box::new(std::iter::once(
            miette::LabeledSpan::new_with_span(Some(label), span),
        )))
    }
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let col = before
        .rfind('\n')
        .map(|i| before[i + 1..].chars().count())
        .unwrap_or(before.chars().count())
        + 1;
    (line, col)
}

impl ConfigError {
    /// An error at `span` of `text` (no position when `None`), read from `path`. Public for
    /// other description files read the same way (`cnc402 pages`' pages file).
    pub fn at(
        text: &str,
        path: &Path,
        span: Option<Range<usize>>,
        key: String,
        message: String,
    ) -> ConfigError {
        let (line, col) = span
            .as_ref()
            .map(|s| line_col(text, s.start))
            .unwrap_or((0, 0));
        ConfigError {
            file: path.display().to_string(),
            line,
            col,
            key,
            message,
            located: span.map(|span| Box::new((text.to_string(), span))),
        }
    }

    /// The file could not be read.
    pub(crate) fn unreadable(path: &Path, e: &std::io::Error) -> ConfigError {
        ConfigError {
            file: path.display().to_string(),
            line: 0,
            col: 0,
            key: String::new(),
            message: format!("cannot read: {e}"),
            located: None,
        }
    }
}
