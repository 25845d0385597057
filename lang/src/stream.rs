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
    /// Bytes read from `input` and not yet handed out start at `buf[start]` and end at
    /// `buf[end]`: lines are found in place (one search for the `\n` each), not copied out
    /// of the input's buffer one by one. `buf` is [`READ_CHUNK`] bytes, more (up to
    /// [`MAX_LINE_BYTES`] + 1) only while a longer line is read.
    buf: Vec<u8>,
    start: usize,
    end: usize,
    /// Where the last line read lies in `buf`, without its `\n` (or `\r\n`).
    body: std::ops::Range<usize>,
    /// Whether the last line read is ASCII (so UTF-8, without validating it again).
    ascii: bool,
    /// A Heidenhain program (issue 16): its lines are translated as they are read.
    /// (Boxed: most readers have none, and the reader is moved around whole.)
    heidenhain: Option<Box<crate::heidenhain::Translator>>,
    /// The machine's G83 re-entry clearance, for the Heidenhain reader's cycle 205.
    peck_clearance: Option<f64>,
    /// Texts of lines read before, taken again for lines of their length.
    texts: LineTexts,
}

/// How many bytes the reader asks its input for at a time (and keeps: the memory of a
/// streamed program, whatever its length). More than the program file's `BufReader` holds
/// (64 KiB), so that a read goes past that buffer instead of being copied through it.
const READ_CHUNK: usize = 128 << 10;

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
            start: 0,
            end: 0,
            body: 0..0,
            ascii: true,
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
    #[inline]
    pub fn position(&self) -> LinePos {
        self.next
    }

    /// Goes to the line at `pos` (a position this reader gave out).
    pub fn seek(&mut self, pos: LinePos) -> io::Result<()> {
        if pos != self.next {
            self.input.seek(SeekFrom::Start(pos.offset))?;
            self.drop_read_ahead();
            self.next = pos;
        }
        Ok(())
    }

    /// Forgets the bytes read ahead (the input was moved). The line last read stays where
    /// it is ([`Self::body`]) until the next line is read.
    fn drop_read_ahead(&mut self) {
        self.start = 0;
        self.end = 0;
    }

    /// Finds the next line in the buffer (reading more when it is not whole there) and makes
    /// it the line last read; `false` at the end of the file. As `read_until` reads a line:
    /// up to and with its `\n`, or to the end of the file; a line with no `\n` in its first
    /// [`MAX_LINE_BYTES`] + 1 bytes is an error.
    #[inline]
    fn fill(&mut self) -> Result<bool, NcError> {
        // The buffer is never longer than a line may be: a `\n` in it ends a line.
        debug_assert!(self.buf.len() <= MAX_LINE_BYTES + 1);
        match find_newline(&self.buf[self.start..self.end]) {
            Some((p, ascii)) => {
                self.take_line(p + 1, ascii);
                Ok(true)
            }
            None => self.fill_slow(),
        }
    }

    /// [`Self::fill`] when the buffer holds no whole line: reads until it does.
    #[cold]
    #[inline(never)]
    fn fill_slow(&mut self) -> Result<bool, NcError> {
        loop {
            let ahead = &self.buf[self.start..self.end];
            if let Some((p, ascii)) = find_newline(ahead) {
                self.take_line(p + 1, ascii);
                return Ok(true);
            }
            let line_no = self.next.index.saturating_add(1);
            if ahead.len() > MAX_LINE_BYTES {
                return Err(NcError::new(
                    &SourceFile::window(self.name.clone(), "", line_no as u32),
                    crate::ast::Span::new(0, 0),
                    format!("line longer than {MAX_LINE_BYTES} bytes"),
                ));
            }
            if self.read_more().map_err(|e| self.io_error(line_no, &e))? == 0 {
                // The end of the file: what is left is the last line, without a `\n`.
                let rest = self.end - self.start;
                if rest == 0 {
                    return Ok(false);
                }
                let ascii = self.buf[self.start..self.end].is_ascii();
                self.take_line(rest, ascii);
                return Ok(true);
            }
        }
    }

    /// Makes the next `n` bytes in the buffer (a line and its terminator) the line read;
    /// `ascii`: its bytes are all ASCII.
    #[inline]
    fn take_line(&mut self, n: usize, ascii: bool) {
        // Without its `\n`, then without a `\r` before it.
        let len = match &self.buf[self.start..self.start + n] {
            [.., b'\r', b'\n'] => n - 2,
            [.., b'\n' | b'\r'] => n - 1,
            _ => n,
        };
        self.body = self.start..self.start + len;
        self.ascii = ascii;
        self.start += n;
        self.next.index += 1;
        self.next.offset += n as u64;
    }

    /// Reads more of the input after the bytes not yet handed out (moved to the buffer's
    /// start first: they are part of one line); the number of bytes read, 0 at the end.
    #[cold]
    fn read_more(&mut self) -> io::Result<usize> {
        self.buf.copy_within(self.start..self.end, 0);
        self.end -= self.start;
        self.start = 0;
        self.body = 0..0;
        self.ascii = true;
        if self.end == self.buf.len() {
            // A line longer than the buffer: room for the longest line and its `\n`.
            let len = (2 * self.buf.len()).clamp(READ_CHUNK, MAX_LINE_BYTES + 1);
            self.buf.resize(len, 0);
        } else if self.end < READ_CHUNK && self.buf.len() > READ_CHUNK {
            // The long line is gone: back to the usual size.
            self.buf.truncate(READ_CHUNK);
            self.buf.shrink_to_fit();
        }
        loop {
            match self.input.read(&mut self.buf[self.end..]) {
                Ok(n) => {
                    self.end += n;
                    return Ok(n);
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
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
    #[inline]
    pub fn read(&mut self) -> Result<ReadLine, NcError> {
        let Some(at) = self.read_raw()? else {
            return Ok(ReadLine::End);
        };
        Ok(ReadLine::Text(self.current_window(at)?, at))
    }

    /// Reads the next line without making a window of it (its bytes are [`Self::body`]);
    /// `None` at the end of the file. For passes that look at most lines only briefly; they
    /// must take [`Self::current_window`] instead of the bytes when [`Self::translates`].
    #[inline]
    pub fn read_raw(&mut self) -> Result<Option<LinePos>, NcError> {
        let at = self.next;
        if !self.fill()? {
            return Ok(None);
        }
        if at.index == 0 {
            self.read_first_line();
        }
        Ok(Some(at))
    }

    /// The first line decides whether the program is a Heidenhain one.
    #[cold]
    fn read_first_line(&mut self) {
        let first = String::from_utf8_lossy(self.body());
        self.heidenhain = crate::heidenhain::is_heidenhain(&self.name, &first).then(|| {
            Box::new(crate::heidenhain::Translator::for_machine(
                self.peck_clearance,
            ))
        });
    }

    /// Whether the lines read are translated (a Heidenhain program): their bytes are not
    /// what the interpreter reads.
    #[inline]
    pub fn translates(&self) -> bool {
        self.heidenhain.is_some()
    }

    /// The bytes of the line last read, without its `\n` (or `\r\n`).
    #[inline]
    pub fn body(&self) -> &[u8] {
        &self.buf[self.body.clone()]
    }

    /// The line last read (it started at `at`) as a window of the program, untranslated.
    pub fn window(&mut self, at: LinePos) -> SourceFile {
        let body = &self.buf[self.body.clone()];
        let text = if self.ascii {
            // SAFETY: ASCII is UTF-8 (`ascii` was found on these very bytes by `fill`).
            Ok(unsafe { std::str::from_utf8_unchecked(body) })
        } else {
            std::str::from_utf8(body)
        };
        match text {
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
    #[inline]
    pub fn current_window(&mut self, at: LinePos) -> Result<SourceFile, NcError> {
        let window = self.window(at);
        if self.heidenhain.is_none() {
            return Ok(window);
        }
        self.translate(window, at)
    }

    /// The ISO block of the Heidenhain line last read (its window `window`, at `at`).
    #[cold]
    fn translate(&mut self, window: SourceFile, at: LinePos) -> Result<SourceFile, NcError> {
        let Some(t) = &mut self.heidenhain else {
            return Ok(window);
        };
        let line_no = window.first_line();
        let text = window.line_text(line_no);
        // An `L` ends where an `RND`/`CHF` after it begins: it sees the lines ahead.
        let ahead = if crate::heidenhain::looks_ahead(text) {
            let ahead = &self.buf[self.start..self.end];
            let newlines = ahead.iter().filter(|&&b| b == b'\n').count();
            let lines = if newlines >= crate::heidenhain::AHEAD_LINES {
                crate::heidenhain::peek_lines(&mut io::Cursor::new(ahead), 0, MAX_LINE_BYTES)
            } else {
                // Not all read ahead: from the input, at the next line (read again after).
                self.start = self.end;
                let at = self.next.offset;
                self.input.seek(SeekFrom::Start(at)).and_then(|_| {
                    crate::heidenhain::peek_lines(&mut *self.input, at, MAX_LINE_BYTES)
                })
            };
            lines.map_err(|e| NcError::new(&window, crate::ast::Span::new(0, 0), e.to_string()))?
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
        // From the file's start, whatever was read ahead.
        self.input
            .seek(SeekFrom::Start(0))
            .map_err(|e| self.io_error(1, &e))?;
        self.drop_read_ahead();
        self.next = LinePos::default();
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

/// Index of the first `\n` in `b` and whether the bytes before it are all ASCII, sixteen
/// bytes at a time (SSE2, which every x86-64 has): every line of a program is searched for
/// its end twice (load pass and run), and a byte loop was a tenth of a block's
/// instructions; the ASCII test spares validating a line's UTF-8 again for its window.
#[cfg(target_arch = "x86_64")]
#[inline]
fn find_newline(b: &[u8]) -> Option<(usize, bool)> {
    use std::arch::x86_64::{_mm_cmpeq_epi8, _mm_loadu_si128, _mm_movemask_epi8, _mm_set1_epi8};
    let (blocks, rest) = b.as_chunks::<16>();
    // Bit i: byte i of a block is `\n` (`newline`), has its high bit set (`high`).
    let mut high = 0;
    for (k, block) in blocks.iter().enumerate() {
        // SAFETY: SSE2 is in every x86-64 (the baseline `target_feature`); `block` is the
        // 16 bytes the load reads, and it asks no alignment.
        let (newline, h) = unsafe {
            let v = _mm_loadu_si128(block.as_ptr().cast());
            let newline = _mm_movemask_epi8(_mm_cmpeq_epi8(v, _mm_set1_epi8(b'\n' as i8)));
            (newline, _mm_movemask_epi8(v))
        };
        if newline != 0 {
            let at = newline.trailing_zeros();
            // The bytes below the `\n` (fewer than 16: the shift is in range).
            high |= h & ((1 << at) - 1);
            return Some((16 * k + at as usize, high == 0));
        }
        high |= h;
    }
    let (p, ascii) = find_newline_by_words(rest)?;
    Some((16 * blocks.len() + p, ascii && high == 0))
}

/// [`find_newline`] where there is no SSE2.
#[cfg(not(target_arch = "x86_64"))]
fn find_newline(b: &[u8]) -> Option<(usize, bool)> {
    find_newline_by_words(b)
}

/// [`find_newline`] eight bytes at a time, in a `u64`.
fn find_newline_by_words(b: &[u8]) -> Option<(usize, bool)> {
    const ONES: u64 = 0x0101_0101_0101_0101;
    const HIGHS: u64 = 0x8080_8080_8080_8080;
    let (words, rest) = b.as_chunks::<8>();
    // The high bits of every byte before the `\n`.
    let mut high = 0;
    for (k, w) in words.iter().enumerate() {
        // A byte of `x` is 0 where `w` has a `\n`; the lowest flagged byte is always a
        // true one (a borrow only flags bytes above a zero byte).
        let w = u64::from_le_bytes(*w);
        let x = w ^ (ONES * u64::from(b'\n'));
        let zero = x.wrapping_sub(ONES) & !x & HIGHS;
        if zero != 0 {
            let at = zero.trailing_zeros() / 8;
            // The bytes below the `\n` (none when it is the first: a shift by 64 is none).
            let below = u64::MAX.checked_shr(64 - 8 * at).unwrap_or(0);
            high |= w & below;
            return Some((8 * k + at as usize, high & HIGHS == 0));
        }
        high |= w;
    }
    let tail = 8 * words.len();
    let p = rest.iter().position(|&c| c == b'\n')?;
    let ascii = high & HIGHS == 0 && rest[..p].is_ascii();
    Some((tail + p, ascii))
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
mod reference;

#[cfg(test)]
mod tests {
    use super::{LineReader, ReadLine, find_newline, find_newline_by_words, parse_line};
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

    /// The word-at-a-time search finds the first `\n` wherever a byte loop finds it, and
    /// tells whether the bytes before it are ASCII as a byte loop does, with the bytes a
    /// borrow or a sign bit could confuse around it.
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
            let len = (x % 80) as usize;
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
            let want = text
                .iter()
                .position(|&c| c == b'\n')
                .map(|p| (p, text[..p].is_ascii()));
            assert_eq!(find_newline(&text), want, "{text:?}");
            assert_eq!(find_newline_by_words(&text), want, "{text:?}");
        }
    }
}
