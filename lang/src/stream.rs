//! Reading a program line by line, for programs too long to hold (CAM output of millions of
//! blocks): [`LineReader`] hands out one line at a time as a [`SourceFile`] window (so errors
//! keep `file:line:col` and the block) and parses it when asked; it can go back to a line
//! whose byte offset was remembered. Memory is one line, whatever the program's length.

// NcError is big (it carries the block for its message); a read returns one at most once per
// run, so boxing it would only make the API clumsier (as in `parse`).
#![allow(clippy::result_large_err)]

use std::io::{self, BufRead, Read, Seek, SeekFrom};
use std::sync::Arc;

use crate::ast::{Line, Program};
use crate::diag::{NcError, SourceFile};
use crate::dialect::Dialect;

/// Anything a program can be read from line by line: a buffered file, or bytes in memory.
pub trait ProgramRead: BufRead + Seek + Send {}
impl<T: BufRead + Seek + Send> ProgramRead for T {}

/// Longest line a streamed program may have (bytes): a longer one is an error at its line,
/// not a read that grows without bound.
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// Where a line starts: its 0-based index (line number − 1) and byte offset in the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct LinePos {
    pub index: usize,
    pub offset: u64,
}

/// What [`LineReader::read`] found.
pub enum ReadLine {
    /// The line's text (as a window) and where it started.
    Text(SourceFile, LinePos),
    /// The end of the file.
    End,
}

/// A program file read one line at a time. Lines end with `\n` (a `\r` before it is
/// dropped); each line is UTF-8 where valid, else Latin-1 (so one line's stray byte does not
/// change how the others read, as it does when a whole file is decoded).
pub struct LineReader {
    name: Arc<str>,
    input: Box<dyn ProgramRead>,
    /// The next line to be read.
    next: LinePos,
    buf: Vec<u8>,
    /// A Heidenhain program (issue 16): its lines are translated as they are read.
    /// (Boxed: most readers have none, and the reader is moved around whole.)
    heidenhain: Option<Box<crate::heidenhain::Translator>>,
    /// The machine's G83 re-entry clearance, for the Heidenhain reader's cycle 205.
    peck_clearance: Option<f64>,
    /// Texts of lines read before, taken again for lines of their length.
    texts: LineTexts,
}

/// Longest line whose text [`LineTexts`] keeps (bytes): CAM blocks are shorter.
const KEPT_TEXT_LEN: usize = 128;

/// The texts of the last lines read, two of each length below [`KEPT_TEXT_LEN`], taken
/// again for a line of the same length once no window holds them any more: a streamed
/// program's lines then do not each allocate and free their text (two, as the window of
/// the line before is still held while the next is read). At most 2 × 128 short texts.
#[derive(Default)]
struct LineTexts {
    by_len: Vec<[Option<Arc<str>>; 2]>,
}

impl LineTexts {
    /// `text` in an `Arc`: a kept one nothing else holds any more, else a new one (kept).
    fn text(&mut self, text: &str) -> Arc<str> {
        if text.len() >= KEPT_TEXT_LEN {
            return text.into();
        }
        if self.by_len.is_empty() {
            self.by_len.resize(KEPT_TEXT_LEN, [None, None]);
        }
        let kept = &mut self.by_len[text.len()];
        for slot in kept.iter_mut() {
            if let Some(t) = slot
                && let Some(free) = Arc::get_mut(t)
            {
                // SAFETY: `free` and `text` have the same length and `text` is UTF-8, so
                // `free` holds valid UTF-8 afterwards (all of its bytes are `text`'s).
                unsafe { free.as_bytes_mut() }.copy_from_slice(text.as_bytes());
                return t.clone();
            }
        }
        let t: Arc<str> = text.into();
        kept[1] = kept[0].replace(t.clone());
        t
    }
}

impl LineReader {
    /// A reader of `input`, named `name` in errors, at its first line.
    pub fn new(name: impl Into<Arc<str>>, input: Box<dyn ProgramRead>) -> LineReader {
        LineReader {
            name: name.into(),
            input,
            next: LinePos::default(),
            buf: Vec::new(),
            heidenhain: None,
            peck_clearance: None,
            texts: LineTexts::default(),
        }
    }

    /// Tells the Heidenhain reader the machine's G83 re-entry clearance (`CYCL DEF 205` is
    /// read as a G83 only with that clearance).
    pub fn set_peck_clearance(&mut self, clearance: f64) {
        self.peck_clearance = Some(clearance);
    }

    /// The program's name (its path).
    pub fn name(&self) -> &Arc<str> {
        &self.name
    }

    /// Where the next line starts.
    pub fn position(&self) -> LinePos {
        self.next
    }

    /// Goes to the line at `pos` (a position this reader gave out).
    pub fn seek(&mut self, pos: LinePos) -> io::Result<()> {
        if pos != self.next {
            self.input.seek(SeekFrom::Start(pos.offset))?;
            self.next = pos;
        }
        Ok(())
    }

    /// Reads the next line's bytes into the buffer; `false` at the end of the file.
    fn fill(&mut self) -> Result<bool, NcError> {
        self.buf.clear();
        let line_no = self.next.index.saturating_add(1);
        // Most lines lie whole in the reader's buffer: take them from there in one piece.
        let whole_line = match self.input.fill_buf() {
            Ok(avail) => {
                // As the general path reads: at most MAX_LINE_BYTES and the `\n`.
                let head = &avail[..avail.len().min(MAX_LINE_BYTES + 1)];
                find_newline(head).map(|p| {
                    self.buf.extend_from_slice(&head[..=p]);
                    p + 1
                })
            }
            Err(_) => None,
        };
        let n = match whole_line {
            Some(n) => {
                self.input.consume(n);
                n
            }
            None => {
                let input: &mut dyn ProgramRead = &mut *self.input;
                io::Read::take(input, MAX_LINE_BYTES as u64 + 1)
                    .read_until(b'\n', &mut self.buf)
                    .map_err(|e| self.io_error(line_no, &e))?
            }
        };
        if n == 0 {
            return Ok(false);
        }
        if self.buf.last() != Some(&b'\n') && n > MAX_LINE_BYTES {
            return Err(NcError::new(
                &SourceFile::window(self.name.clone(), "", line_no as u32),
                crate::ast::Span::new(0, 0),
                format!("line longer than {MAX_LINE_BYTES} bytes"),
            ));
        }
        self.next.index += 1;
        self.next.offset += n as u64;
        Ok(true)
    }

    /// An error reading line `line_no` (the file changed or went away under the run).
    fn io_error(&self, line_no: usize, e: &io::Error) -> NcError {
        NcError::new(
            &SourceFile::window(self.name.clone(), "", line_no as u32),
            crate::ast::Span::new(0, 0),
            format!("cannot read the program: {e}"),
        )
    }

    /// Passes over the next line without decoding it; `false` at the end of the file.
    pub fn skip(&mut self) -> Result<bool, NcError> {
        self.fill()
    }

    /// The next line, as a window of the program (a Heidenhain program's line as the ISO
    /// block it translates to).
    pub fn read(&mut self) -> Result<ReadLine, NcError> {
        let Some(at) = self.read_raw()? else {
            return Ok(ReadLine::End);
        };
        Ok(ReadLine::Text(self.current_window(at)?, at))
    }

    /// Reads the next line without making a window of it (its bytes are [`Self::body`]);
    /// `None` at the end of the file. For passes that look at most lines only briefly; they
    /// must take [`Self::current_window`] instead of the bytes when [`Self::translates`].
    pub fn read_raw(&mut self) -> Result<Option<LinePos>, NcError> {
        let at = self.next;
        if !self.fill()? {
            return Ok(None);
        }
        if at.index == 0 {
            // The first line decides whether the program is a Heidenhain one.
            let first = String::from_utf8_lossy(self.body());
            self.heidenhain = crate::heidenhain::is_heidenhain(&self.name, &first).then(|| {
                Box::new(crate::heidenhain::Translator::for_machine(
                    self.peck_clearance,
                ))
            });
        }
        Ok(Some(at))
    }

    /// Whether the lines read are translated (a Heidenhain program): their bytes are not
    /// what the interpreter reads.
    pub fn translates(&self) -> bool {
        self.heidenhain.is_some()
    }

    /// The bytes of the line last read, without its `\n` (or `\r\n`).
    pub fn body(&self) -> &[u8] {
        &self.buf[self.body_range()]
    }

    /// Where [`Self::body`] lies in the buffer.
    fn body_range(&self) -> std::ops::Range<usize> {
        let mut end = self.buf.len();
        if end > 0 && self.buf[end - 1] == b'\n' {
            end -= 1;
        }
        if end > 0 && self.buf[end - 1] == b'\r' {
            end -= 1;
        }
        0..end
    }

    /// The line last read (it started at `at`) as a window of the program, untranslated.
    pub fn window(&mut self, at: LinePos) -> SourceFile {
        let body = self.body_range();
        match std::str::from_utf8(&self.buf[body]) {
            // Most lines: the text of a line read before of its length, when free.
            Ok(text) => {
                let text = self.texts.text(text);
                SourceFile::one_line(self.name.clone(), text, line_no(at))
            }
            Err(_) => line_window(self.name.clone(), self.body(), at),
        }
    }

    /// The line last read (it started at `at`) as the interpreter reads it: translated to
    /// ISO in a Heidenhain program ([`crate::heidenhain::is_heidenhain`]), else its window.
    pub fn current_window(&mut self, at: LinePos) -> Result<SourceFile, NcError> {
        let window = self.window(at);
        let Some(t) = &mut self.heidenhain else {
            return Ok(window);
        };
        let line_no = window.first_line();
        let text = window.line_text(line_no);
        // An `L` ends where an `RND`/`CHF` after it begins: it sees the lines ahead.
        let ahead = if crate::heidenhain::looks_ahead(text) {
            crate::heidenhain::peek_lines(&mut *self.input, self.next.offset, MAX_LINE_BYTES)
                .map_err(|e| NcError::new(&window, crate::ast::Span::new(0, 0), e.to_string()))?
        } else {
            Vec::new()
        };
        match t.line_ahead(at.index, text, &ahead) {
            Ok(iso) => Ok(SourceFile::window(self.name.clone(), iso, line_no)),
            Err(m) => Err(NcError::new(
                &window,
                crate::ast::Span::new(0, text.len()),
                m,
            )),
        }
    }

    /// The head of the program (its first [`crate::HEADER_LINES`] lines) as one text, for the
    /// dialect header; the reader is back at the first line afterwards.
    pub fn head(&mut self) -> Result<SourceFile, NcError> {
        self.seek(LinePos::default())
            .map_err(|e| self.io_error(1, &e))?;
        let mut text = String::new();
        for _ in 0..crate::HEADER_LINES {
            match self.read()? {
                ReadLine::Text(w, _) => {
                    text.push_str(w.line_text(w.first_line()));
                    text.push('\n');
                }
                ReadLine::End => break,
            }
        }
        self.seek(LinePos::default())
            .map_err(|e| self.io_error(1, &e))?;
        Ok(SourceFile::new(self.name.clone(), text))
    }

    /// The whole program as one text (for a program that must be held whole: the C-like
    /// language is compiled whole).
    pub fn whole(&mut self) -> Result<SourceFile, NcError> {
        self.seek(LinePos::default())
            .map_err(|e| self.io_error(1, &e))?;
        let mut bytes = Vec::new();
        self.input
            .read_to_end(&mut bytes)
            .map_err(|e| self.io_error(1, &e))?;
        self.input
            .seek(SeekFrom::Start(0))
            .map_err(|e| self.io_error(1, &e))?;
        Ok(SourceFile::from_bytes(self.name.clone(), bytes))
    }

    /// The window of line `line_no` (1-based), read from the start; an empty window past the
    /// end. For messages about a line that is no longer held (a planner error).
    pub fn line_window(&mut self, line_no: u32) -> Result<SourceFile, NcError> {
        self.seek(LinePos::default())
            .map_err(|e| self.io_error(1, &e))?;
        for _ in 1..line_no {
            if !self.skip()? {
                break;
            }
        }
        match self.read()? {
            ReadLine::Text(w, _) => Ok(w),
            ReadLine::End => Ok(SourceFile::window(self.name.clone(), "", line_no)),
        }
    }
}

/// Index of the first `\n` in `b`, eight bytes at a time: every line of a program is
/// searched for its end twice (load pass and run), and a byte loop was a tenth of a block's
/// instructions.
fn find_newline(b: &[u8]) -> Option<usize> {
    const ONES: u64 = 0x0101_0101_0101_0101;
    const HIGHS: u64 = 0x8080_8080_8080_8080;
    let (words, rest) = b.as_chunks::<8>();
    for (k, w) in words.iter().enumerate() {
        // A byte of `x` is 0 where `w` has a `\n`; the lowest flagged byte is always a
        // true one (a borrow only flags bytes above a zero byte).
        let x = u64::from_le_bytes(*w) ^ (ONES * u64::from(b'\n'));
        let zero = x.wrapping_sub(ONES) & !x & HIGHS;
        if zero != 0 {
            return Some(8 * k + (zero.trailing_zeros() / 8) as usize);
        }
    }
    let tail = 8 * words.len();
    rest.iter().position(|&c| c == b'\n').map(|p| tail + p)
}

/// The window of a line read from `name` (its bytes without the terminator, starting at
/// `at`): UTF-8 where valid, else Latin-1 (see [`LineReader`]).
pub fn line_window(name: Arc<str>, body: &[u8], at: LinePos) -> SourceFile {
    let text: Arc<str> = match std::str::from_utf8(body) {
        Ok(t) => t.into(),
        Err(_) => body
            .iter()
            .map(|&b| char::from(b))
            .collect::<String>()
            .into(),
    };
    // A body is one line: the reader splits at the first `\n` and strips it.
    SourceFile::one_line(name, text, line_no(at))
}

/// The 1-based line number of the line at `at`.
fn line_no(at: LinePos) -> u32 {
    u32::try_from(at.index + 1).unwrap_or(u32::MAX)
}

/// Whether `text` (one line as read) is a plain block — an optional `N` number and words
/// of an address letter and a literal number, with ASCII comments — and so no flow line, no
/// statement and no error; `Some(true)` when it holds a word or an `N` number, `Some(false)`
/// when it is empty. `None`: it may be anything, [`parse_line`] tells.
///
/// ```
/// use cnc402_lang::stream::plain_block;
/// assert_eq!(plain_block("N10 G1 X1.5 Y-2"), Some(true));
/// assert_eq!(plain_block("  "), Some(false));
/// assert_eq!(plain_block("G1 X1 (cut)"), Some(true));
/// assert_eq!(plain_block("(only a comment) ;and another"), Some(false));
/// assert_eq!(plain_block("G1 X1 (unclosed"), None);
/// assert_eq!(plain_block("WHILE[#1LT3]DO1"), None);
/// ```
pub fn plain_block(text: &str) -> Option<bool> {
    plain_block_bytes(text.as_bytes())
}

/// [`plain_block`] of a line's bytes as read (a plain block is ASCII, so bytes that are no
/// UTF-8 are simply no plain block): the load pass asks it of every line before decoding.
pub fn plain_block_bytes(body: &[u8]) -> Option<bool> {
    crate::parse::simple::classify(body)
}

/// [`plain_block_bytes`] by the plain-block parser itself, without its class table (for
/// tests that hold the two equal).
#[doc(hidden)]
pub fn plain_block_bytes_by_scan(body: &[u8]) -> Option<bool> {
    crate::parse::simple::classify_by_scan(body)
}

/// Whether a line (as read) is a statement of the C-like language: a program with one is
/// parsed whole ([`crate::parse_in`] decides how it reads), never line by line.
pub fn is_statement_line(text: &str) -> bool {
    crate::parse::is_statement_line(text)
}

/// Parses one line of a G-code program (ISO, Fanuc, Haas or LinuxCNC, not C-like) given as
/// a window: the [`Line`] with spans into the window and its line number.
///
/// ```
/// use cnc402_lang::{SourceFile, Dialect, stream::parse_line};
/// let l = parse_line(&SourceFile::window("p.nc", "N40 G1 X2", 7), Dialect::Fanuc).unwrap();
/// assert_eq!((l.line_no, l.n.unwrap().value), (7, 40));
/// let e = parse_line(&SourceFile::window("p.nc", "G1 X", 9), Dialect::Fanuc).unwrap_err();
/// assert_eq!((e.line, e.col), (9, 4));
/// ```
pub fn parse_line(window: &SourceFile, dialect: Dialect) -> Result<Line, NcError> {
    // Most lines of a long program are plain blocks: read those without the general parser.
    let text: &str = &window.text;
    if window.is_one_line()
        && let Some(line) = crate::parse::simple::line(text, window.first_line())
    {
        return Ok(line);
    }
    parse_general_line(window, dialect)
}

/// [`parse_line`] into `line`, whose vectors a plain block reuses (a streamed program's
/// blocks are read one after another into the same line). On an error `line` is left
/// half made and must not be read.
pub fn parse_line_into(
    window: &SourceFile,
    dialect: Dialect,
    line: &mut Line,
) -> Result<(), NcError> {
    let text: &str = &window.text;
    if window.is_one_line() && crate::parse::simple::line_into(text, window.first_line(), line) {
        return Ok(());
    }
    *line = parse_general_line(window, dialect)?;
    Ok(())
}

/// The one line of `window` read by the general parser.
fn parse_general_line(window: &SourceFile, dialect: Dialect) -> Result<Line, NcError> {
    let Program { mut lines, .. } = crate::parse::parse_gcode(window, dialect)?;
    match lines.pop() {
        Some(l) if lines.is_empty() => Ok(l),
        _ => Err(NcError::new(
            window,
            crate::ast::Span::new(0, 0),
            "one line expected",
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::{LineReader, ReadLine, find_newline, parse_line};
    use crate::{Dialect, SourceFile};
    use proptest::prelude::*;
    use std::io::Cursor;

    fn reader(text: &str) -> LineReader {
        LineReader::new("p.nc", Box::new(Cursor::new(text.as_bytes().to_vec())))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(500))]

        /// Windows of lines of few lengths (texts taken again), some held across later
        /// reads and dropped at random: each holds its own line's text to the end, whichever
        /// text it was given (a text written while a window held it fails this).
        #[test]
        fn windows_keep_their_line_while_texts_are_taken_again(
            lines in prop::collection::vec(("[GXY0-9. ]{0,3}", 0usize..3), 1..60),
            latin1 in any::<bool>(),
        ) {
            let mut text: Vec<u8> = Vec::new();
            for (k, (l, _)) in lines.iter().enumerate() {
                text.extend_from_slice(l.as_bytes());
                if latin1 && k % 7 == 3 {
                    text.push(0xe9);
                }
                text.extend_from_slice(if k % 5 == 0 { b"\r\n" } else { b"\n" });
            }
            let mut r = LineReader::new("p.nc", Box::new(Cursor::new(text.clone())));
            let want: Vec<String> = text
                .split(|&b| b == b'\n')
                .map(|l| l.strip_suffix(b"\r").unwrap_or(l).iter().map(|&b| char::from(b)).collect())
                .collect();
            let mut held: Vec<(usize, SourceFile)> = Vec::new();
            let mut k = 0;
            while let ReadLine::Text(w, at) = r.read().unwrap() {
                prop_assert_eq!(at.index, k);
                prop_assert_eq!(w.first_line() as usize, k + 1);
                held.push((k, w));
                // Drop some of the windows held, the oldest first.
                held.drain(..lines[k].1.min(held.len()));
                for (i, w) in &held {
                    prop_assert_eq!(w.line_text(w.first_line()), want[*i].as_str(), "line {}", i);
                }
                k += 1;
            }
            prop_assert_eq!(k, lines.len());
        }
    }

    /// An error on a line whose text was taken again (lines of one length before it) keeps
    /// its file, line, column and block.
    #[test]
    fn an_error_on_a_line_in_a_text_taken_again_keeps_its_place() {
        let mut r = reader("G1X1\nG1X2\nG1X3\nG1 X\nG1X5\n");
        let mut last = None;
        while let ReadLine::Text(w, _) = r.read().unwrap() {
            if let Err(e) = parse_line(&w, Dialect::Fanuc) {
                last = Some(e);
                break;
            }
        }
        let e = last.expect("line 4 is an error");
        assert_eq!((&*e.file, e.line, e.col), ("p.nc", 4, 4));
        assert_eq!(e.block, "G1 X");
    }

    /// The word-at-a-time search finds the first `\n` wherever a byte loop finds it, with
    /// the bytes a borrow or a sign bit could confuse around it.
    #[test]
    fn find_newline_finds_the_first_newline_as_a_byte_loop_does() {
        let bytes = [
            b'\n',
            b'\n' ^ 0x80,
            b'\n' + 1,
            b'\n' - 1,
            0,
            0xff,
            b'G',
            b'1',
            0x80,
        ];
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        for _ in 0..100_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let len = (x % 40) as usize;
            let text: Vec<u8> = (0..len)
                .map(|i| {
                    let r = x.rotate_left(7 * i as u32) ^ (i as u64).wrapping_mul(0x2545_f491);
                    // Mostly not `\n`, so that most texts have it late or not at all.
                    if r.is_multiple_of(23) {
                        b'\n'
                    } else {
                        bytes[1 + (r % 8) as usize]
                    }
                })
                .collect();
            let want = text.iter().position(|&c| c == b'\n');
            assert_eq!(find_newline(&text), want, "{text:?}");
        }
    }
}
