//! The line reader as it was before it kept its own buffer (each line copied out of the
//! input's `BufRead` buffer by `read_until`), kept to test the reader against: every line,
//! position, window, translation and error the same, on inputs that hand out their bytes in
//! pieces of any size, with seeks back to lines read before.

use std::io::{self, BufRead, Cursor, Read, Seek, SeekFrom};
use std::sync::Arc;

use proptest::prelude::*;

use super::{LinePos, LineReader, MAX_LINE_BYTES, ProgramRead, ReadLine, line_window};
use crate::diag::{NcError, SourceFile};

/// The reader before (the parts that decide what is read).
struct OldReader {
    name: Arc<str>,
    input: Box<dyn ProgramRead>,
    next: LinePos,
    buf: Vec<u8>,
    heidenhain: Option<crate::heidenhain::Translator>,
}

impl OldReader {
    fn new(input: Box<dyn ProgramRead>) -> OldReader {
        OldReader {
            name: "p.nc".into(),
            input,
            next: LinePos::default(),
            buf: Vec::new(),
            heidenhain: None,
        }
    }

    fn seek(&mut self, pos: LinePos) -> io::Result<()> {
        if pos != self.next {
            self.input.seek(SeekFrom::Start(pos.offset))?;
            self.next = pos;
        }
        Ok(())
    }

    fn fill(&mut self) -> Result<bool, String> {
        self.buf.clear();
        let line_no = self.next.index.saturating_add(1);
        let input: &mut dyn ProgramRead = &mut *self.input;
        let n = io::Read::take(input, MAX_LINE_BYTES as u64 + 1)
            .read_until(b'\n', &mut self.buf)
            .map_err(|e| format!("{line_no}: cannot read the program: {e}"))?;
        if n == 0 {
            return Ok(false);
        }
        if self.buf.last() != Some(&b'\n') && n > MAX_LINE_BYTES {
            return Err(format!(
                "{line_no}: line longer than {MAX_LINE_BYTES} bytes"
            ));
        }
        self.next.index += 1;
        self.next.offset += n as u64;
        Ok(true)
    }

    fn body(&self) -> &[u8] {
        let mut b = &self.buf[..];
        b = b.strip_suffix(b"\n").unwrap_or(b);
        b.strip_suffix(b"\r").unwrap_or(b)
    }

    fn read_raw(&mut self) -> Result<Option<LinePos>, String> {
        let at = self.next;
        if !self.fill()? {
            return Ok(None);
        }
        if at.index == 0 {
            let first = String::from_utf8_lossy(self.body());
            self.heidenhain = crate::heidenhain::is_heidenhain(&self.name, &first)
                .then(|| crate::heidenhain::Translator::for_machine(Some(1.0)));
        }
        Ok(Some(at))
    }

    /// The text the interpreter reads of the line last read (translated or not).
    fn current_text(&mut self, at: LinePos) -> Result<String, String> {
        let window = line_window(self.name.clone(), self.body(), at);
        let text = window.line_text(window.first_line());
        let Some(t) = &mut self.heidenhain else {
            return Ok(text.to_string());
        };
        let ahead = if crate::heidenhain::looks_ahead(text) {
            crate::heidenhain::peek_lines(&mut *self.input, self.next.offset, MAX_LINE_BYTES)
                .map_err(|e| e.to_string())?
        } else {
            Vec::new()
        };
        t.line_ahead(at.index, text, &ahead)
            .map_err(|m| format!("{}: {m}", at.index + 1))
    }
}

/// An input handing out at most `piece` bytes a read, and failing every third read with
/// `Interrupted` when `interrupts` (which a reader must retry).
struct Pieces {
    bytes: Cursor<Vec<u8>>,
    piece: usize,
    interrupts: bool,
    reads: usize,
}

impl Read for Pieces {
    fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
        self.reads += 1;
        if self.interrupts && self.reads.is_multiple_of(3) {
            return Err(io::ErrorKind::Interrupted.into());
        }
        let n = out.len().min(self.piece);
        self.bytes.read(&mut out[..n])
    }
}

impl Seek for Pieces {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.bytes.seek(pos)
    }
}

fn input(bytes: &[u8], capacity: usize, piece: usize, interrupts: bool) -> Box<dyn ProgramRead> {
    let pieces = Pieces {
        bytes: Cursor::new(bytes.to_vec()),
        piece,
        interrupts,
        reads: 0,
    };
    Box::new(io::BufReader::with_capacity(capacity, pieces))
}

/// What a step of reading gave: the line's position, body and text as the interpreter reads
/// it, or the end, or the error (`line: message`).
type Step = Result<Option<(LinePos, Vec<u8>, String)>, String>;

fn old_step(r: &mut OldReader) -> Step {
    let Some(at) = r.read_raw()? else {
        return Ok(None);
    };
    let body = r.body().to_vec();
    Ok(Some((at, body, r.current_text(at)?)))
}

fn message(e: &NcError) -> String {
    format!("{}: {}", e.line, e.message)
}

fn new_step(r: &mut LineReader) -> Step {
    let Some(at) = r.read_raw().map_err(|e| message(&e))? else {
        return Ok(None);
    };
    let body = r.body().to_vec();
    let w = r.current_window(at).map_err(|e| message(&e))?;
    assert_eq!(w.first_line() as usize, at.index + 1);
    Ok(Some((at, body, w.line_text(w.first_line()).to_string())))
}

/// Reads `bytes` with both readers (each line, then back to a line `back[k]` lines before
/// whenever that is not 0), as long as both give lines; the steps must be equal. The number
/// of lines read.
fn same_reading(
    bytes: &[u8],
    capacity: usize,
    piece: usize,
    interrupts: bool,
    back: &[usize],
) -> usize {
    let mut lines = 0;
    let mut old = OldReader::new(input(bytes, capacity, piece, interrupts));
    let mut new = LineReader::new("p.nc", input(bytes, capacity, piece, interrupts));
    new.set_peck_clearance(1.0);
    let mut seen: Vec<LinePos> = Vec::new();
    for k in 0..bytes.len() + 2 * back.len() + 2 {
        let (o, n) = (old_step(&mut old), new_step(&mut new));
        assert_eq!(o, n, "step {k}");
        assert_eq!(old.next, new.position());
        match o {
            Ok(Some((at, ..))) => seen.push(at),
            _ => return lines,
        }
        lines += 1;
        let b = back.get(k % back.len().max(1)).copied().unwrap_or(0);
        if b > 0 && b <= seen.len() {
            let to = seen[seen.len() - b];
            old.seek(to).unwrap();
            new.seek(to).unwrap();
            seen.truncate(seen.len() - b);
        }
    }
    lines
}

/// Bytes a program's lines are made of, with the ones that make readers differ: `\n`,
/// `\r`, bytes that are no UTF-8 alone (Latin-1) or together (UTF-8).
fn program_bytes() -> impl Strategy<Value = Vec<u8>> {
    let byte = prop::sample::select(vec![
        b'G', b'1', b' ', b'X', b'.', b'-', b'\n', b'\n', b'\r', 0xe9, 0xc3, 0xa9, b'(', b'O',
    ]);
    prop::collection::vec(byte, 0..400)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    /// Lines, positions, bodies and windows as the reader gave them before, whatever the
    /// pieces the input hands out, and after seeks back.
    #[test]
    fn the_reader_reads_as_it_did_before(
        bytes in program_bytes(),
        capacity in 1usize..40,
        piece in 1usize..50,
        interrupts in any::<bool>(),
        back in prop::collection::vec(prop::sample::select(vec![0usize, 0, 0, 1, 2, 5]), 0..8),
    ) {
        same_reading(&bytes, capacity, piece, interrupts, &back);
    }
}

/// Lines of the longest length, one byte more and one byte less, with and without their
/// `\n`, at the file's end or not, read as before (the reader's buffer grows for them and
/// shrinks back after).
#[test]
fn the_longest_lines_read_as_before() {
    for len in [
        MAX_LINE_BYTES - 1,
        MAX_LINE_BYTES,
        MAX_LINE_BYTES + 1,
        MAX_LINE_BYTES + 2,
    ] {
        for tail in [&b""[..], b"\n", b"\r\n", b"\nG1 X1\n", b"\nG1 X1"] {
            let mut bytes = b"G0 X0\n".to_vec();
            bytes.resize(6 + len, b'X');
            bytes.extend_from_slice(tail);
            same_reading(&bytes, 8 << 10, 1 << 20, false, &[]);
            same_reading(&bytes, 100, 70_000, true, &[0, 1]);
        }
    }
}

/// An error reading the input is the error at the line being read, with the input's
/// message; the lines before it read whole.
#[test]
fn an_error_reading_the_input_is_an_error_at_the_line_being_read() {
    struct Failing(Cursor<Vec<u8>>);
    impl Read for Failing {
        fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
            match self.0.read(out)? {
                0 => Err(io::Error::other("disk gone")),
                n => Ok(n),
            }
        }
    }
    impl Seek for Failing {
        fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
            self.0.seek(pos)
        }
    }
    let bytes = b"G1 X1\nG1 X2\nG1 X3".to_vec();
    let mut r = LineReader::new(
        "p.nc",
        Box::new(io::BufReader::new(Failing(Cursor::new(bytes)))),
    );
    for want in ["G1 X1", "G1 X2"] {
        let ReadLine::Text(w, _) = r.read().unwrap() else {
            panic!("a line")
        };
        assert_eq!(w.line_text(w.first_line()), want);
    }
    let e = r.read().err().expect("an error at line 3");
    assert_eq!((&*e.file, e.line), ("p.nc", 3));
    assert_eq!(e.message, "cannot read the program: disk gone");
}

/// A Heidenhain program longer than the reader's buffer: each `L` followed by an `RND`
/// sees the lines after it wherever the buffer ends (from the bytes read ahead, or from the
/// input when they run past them), as it did before.
#[test]
fn heidenhain_lines_ahead_across_the_end_of_the_buffer_as_before() {
    for pad in 0..12 {
        let mut text = format!(
            "0 BEGIN PGM T MM\n1 ;{}\n2 L X+0 Y+0 R0 FMAX\n",
            "x".repeat(pad * 7)
        );
        let mut k = 3;
        while text.len() < 3 * super::READ_CHUNK / 2 {
            // A zigzag: the contour turns at every point, where the RND rounds it.
            text.push_str(&format!("{k} L X+{k} Y+{} R0 F500\n", 10 * (k % 4)));
            text.push_str(&format!("{} RND R0.{}\n", k + 1, 1 + k % 9));
            k += 2;
        }
        text.push_str(&format!(
            "{k} L X+{k} Y+5 R0 F500\n{} END PGM T MM\n",
            k + 1
        ));
        assert_eq!(
            same_reading(text.as_bytes(), 8 << 10, 1 << 20, false, &[]),
            k + 2
        );
    }
}

/// The texts handed out are those of [`SourceFile`] windows (the whole program decoded
/// line by line): a check on the reference itself.
#[test]
fn the_reference_reads_windows_as_line_window_makes_them() {
    let mut old = OldReader::new(Box::new(Cursor::new(b"G1\r\n(\xe9)\nG2".to_vec())));
    let mut texts = Vec::new();
    while let Ok(Some(at)) = old.read_raw() {
        texts.push(old.current_text(at).unwrap());
    }
    assert_eq!(texts, ["G1", "(\u{e9})", "G2"]);
    let _ = SourceFile::window("p.nc", "", 1);
    let _ = ReadLine::End;
}
