//! The main program read line by line ([`Stream`]), so that a program of any length runs in
//! bounded memory: one pass at load parses every line (syntax errors are found before the
//! first block runs, as for a whole program) and keeps only where the flow may go — the
//! units (`O` numbers), WHILE/END pairs, LinuxCNC O-word constructs and their byte offsets;
//! then each line is read and parsed again when the interpreter reaches it. Backward jumps
//! (`GOTO`, `END m`, `M99`, O-word loops, subroutine calls) seek to a remembered offset; a
//! `GOTO n` searches forward, then from the unit's start, as Fanuc does, and remembers what
//! it found in a bounded cache. Memory grows with the flow lines, never with the blocks.

use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;

use cnc402_lang::ast::{LineKind, Program};
use cnc402_lang::stream::{
    LinePos, LineReader, ReadLine, is_statement_line, line_window, parse_line, parse_line_into,
    plain_block_bytes,
};
use cnc402_lang::{Dialect, NcError, SourceFile};

use super::units::{Unit, UnitScan};

/// Most sequence numbers a stream remembers where it found (`GOTO`, `M99 P`): past it the
/// cache starts over, and the next jumps search again.
pub const LABEL_CACHE: usize = 4096;

/// The main program's reader and what the load pass found.
pub(crate) struct Stream {
    reader: LineReader,
    dialect: Dialect,
    /// Positions of the lines the flow jumps to that the load pass knows: unit starts,
    /// WHILE/END and O-word lines (bounded by those lines, not by the blocks).
    anchors: BTreeMap<usize, u64>,
    /// (unit start, N) → the line found by a search, and positions of lines found so.
    labels: HashMap<(usize, u32), LinePos>,
    found: BTreeMap<usize, u64>,
    /// The window of the last line read for the flow (errors at the program's end; see
    /// [`Stream::last_window`]).
    last: Arc<SourceFile>,
    /// The last view given out, reused for the next line once nothing else holds it.
    spare: Option<Arc<Unit>>,
    /// Where the last line read started when the plain-block lane read it (no window made):
    /// `last` is then made again from it when it is asked for.
    plain_last: Option<LinePos>,
}

/// What the load pass made of a file.
// Made once a program and taken apart at once: the size of its variants does not matter.
#[allow(clippy::large_enum_variant)]
pub(crate) enum Loaded {
    /// Read line by line: the stream and its units (the first runs first).
    Streamed(Stream, Vec<Arc<Unit>>),
    /// The file has C-like statements: compiled whole (the language has functions and
    /// `#use` files, checked before the program starts). The whole text.
    CLike(SourceFile),
}

/// Reads the whole of `reader` once in `dialect`: parses every line (the first syntax error
/// ends the load), splits the units as [`super::units::split_units`] does, and remembers the
/// flow lines' positions. `checked`: every line of the file parsed before (a run after its
/// dry run), so only lines that may be flow lines are parsed now.
pub(crate) fn load(
    mut reader: LineReader,
    dialect: Dialect,
    checked: bool,
) -> Result<Loaded, NcError> {
    let linuxcnc = dialect == Dialect::LinuxCnc;
    let mut anchors = BTreeMap::new();
    anchors.insert(0, 0);
    let mut units: Vec<(usize, UnitScan)> = Vec::new();
    let mut scan = UnitScan::new(0, false, linuxcnc);
    let mut scan_start = 0;
    let mut seen_o = false;
    let mut prefix_has_code = false;
    let name = reader.name().clone();
    // Where the last line started: its window is made once, at the end (read again), as
    // most lines are read without one.
    let mut last = None;
    while let Some(at) = reader.read_raw()? {
        let i = at.index;
        last = Some(at);
        // A plain block is ASCII and no C-like statement (its letters each stand alone, see
        // lang's tests/plain_fast_path.rs), so it is classified on its bytes; any other line
        // is decoded and asked below.
        let plain = if reader.translates() {
            None
        } else {
            let body = reader.body();
            // Once the prefix question is settled, a checked line with none of the letters
            // of `O`, `WHILE`, `END`, an O-word, `:` or `%` is a plain block.
            if checked && (seen_o || prefix_has_code) && !may_be_flow(body) {
                match std::str::from_utf8(body) {
                    Ok(text) if !linuxcnc && is_statement_line(text) => {
                        return Ok(Loaded::CLike(reader.whole()?));
                    }
                    Ok(_) => Some(true),
                    Err(_) => None,
                }
            } else {
                plain_block_bytes(body)
            }
        };
        if let Some(has_code) = plain {
            // What `scan.line` and the match below make of a plain block, without its Line.
            prefix_has_code |= has_code && !seen_o;
            scan.plain_line(i);
            continue;
        }
        let window = reader.current_window(at)?;
        if !linuxcnc && is_statement_line(window.line_text(window.first_line())) {
            return Ok(Loaded::CLike(reader.whole()?));
        }
        let line = parse_line(&window, dialect)?;
        match line.kind {
            LineKind::ProgramNumber { .. } => {
                // A prefix of `%`, comments and empty lines belongs to the first program.
                if seen_o || prefix_has_code {
                    let done = std::mem::replace(&mut scan, UnitScan::new(i, false, linuxcnc));
                    units.push((std::mem::replace(&mut scan_start, i), done));
                }
                seen_o = true;
                anchors.insert(i, at.offset);
            }
            LineKind::While { .. } | LineKind::End { .. } | LineKind::OWord(_) => {
                anchors.insert(i, at.offset);
            }
            LineKind::Empty | LineKind::Percent if line.n.is_none() => {}
            _ => prefix_has_code |= !seen_o,
        }
        scan.line(i, &line);
    }
    let n = reader.position().index;
    units.push((scan_start, scan));
    // Each unit ends where the next begins; the last at the file's end.
    let ends: Vec<usize> = units.iter().skip(1).map(|u| u.0).chain([n]).collect();
    let units = units
        .into_iter()
        .zip(ends)
        .map(|((start, scan), end)| {
            let (number, ix) = scan.finish(end);
            Arc::new(Unit {
                src: Arc::new(SourceFile::window(name.clone(), "", start as u32 + 1)),
                program: Arc::new(Program {
                    lines: Vec::new(),
                    dialect,
                }),
                base: 0,
                number,
                start,
                end,
                ix: Arc::new(ix),
                streamed: true,
            })
        })
        .collect();
    let last_window = match last {
        Some(at) => {
            reader
                .seek(at)
                .map_err(|e| read_error(&name, at.index, &e))?;
            reader.read_raw()?;
            reader.window(at)
        }
        None => line_window(name, b"", LinePos::default()),
    };
    let stream = Stream {
        reader,
        dialect,
        anchors,
        labels: HashMap::new(),
        found: BTreeMap::new(),
        last: Arc::new(last_window),
        spare: None,
        plain_last: None,
    };
    Ok(Loaded::Streamed(stream, units))
}

impl Stream {
    /// Line `i` of `unit` (a streamed unit): a view holding it, `None` past the file's end.
    pub(crate) fn view(&mut self, unit: &Unit, i: usize) -> Result<Option<Arc<Unit>>, NcError> {
        self.go_to(i)?;
        let ReadLine::Text(window, _) = self.reader.read()? else {
            return Ok(None);
        };
        self.view_window(unit, i, window)
    }

    /// The view of line `i` of `unit` whose window (read just now) is `window`.
    fn view_window(
        &mut self,
        unit: &Unit,
        i: usize,
        window: SourceFile,
    ) -> Result<Option<Arc<Unit>>, NcError> {
        let window = self.reuse_window(unit, window);
        // The last view, once the interpreter has let go of it, takes this line in place.
        let reused = self.spare.as_mut().and_then(Arc::get_mut);
        match reused.and_then(|v| v.reuse_view(unit, &window, i)) {
            Some(line) => parse_line_into(&window, self.dialect, line)?,
            None => {
                let line = parse_line(&window, self.dialect)?;
                self.spare = Some(Arc::new(unit.view_of(window, line, i)));
            }
        }
        Ok(self.spare.clone())
    }

    /// `window` (of line `i` of `unit`) in the last line's allocation when nothing else holds
    /// that any more (the spare view lets go of it first), so that a long program's lines do
    /// not each allocate one; it is the last window read from then on.
    fn reuse_window(&mut self, unit: &Unit, window: SourceFile) -> Arc<SourceFile> {
        self.plain_last = None;
        if let Some(v) = self.spare.as_mut().and_then(Arc::get_mut) {
            v.src = unit.src.clone();
        }
        match Arc::get_mut(&mut self.last) {
            Some(last) => *last = window,
            None => self.last = Arc::new(window),
        }
        self.last.clone()
    }

    /// Puts the reader at line `i`: from where it is when that is on the way, else from the
    /// nearest known position before it.
    fn go_to(&mut self, i: usize) -> Result<(), NcError> {
        let here = self.reader.position();
        if here.index == i {
            return Ok(());
        }
        let known = |m: &BTreeMap<usize, u64>| {
            m.range(..=i)
                .next_back()
                .map(|(&index, &offset)| LinePos { index, offset })
        };
        let best = known(&self.anchors)
            .into_iter()
            .chain(known(&self.found))
            .max()
            .unwrap_or_default();
        if here.index > i || best.index > here.index {
            self.reader.seek(best).map_err(|e| self.io_error(i, &e))?;
        }
        while self.reader.position().index < i {
            if !self.reader.skip()? {
                break;
            }
        }
        Ok(())
    }

    fn io_error(&self, i: usize, e: &std::io::Error) -> NcError {
        read_error(self.reader.name(), i, e)
    }

    /// The line of `N n` in `unit` for a jump from line `from`: searched forward to the
    /// unit's end, then from its start (Fanuc's order); `None` when the unit has none.
    pub(crate) fn find_label(
        &mut self,
        unit: &Unit,
        n: u32,
        from: usize,
    ) -> Result<Option<usize>, NcError> {
        if let Some(p) = self.labels.get(&(unit.start, n)) {
            return Ok(Some(p.index));
        }
        let found = match self.search(n, from.max(unit.start), unit.end)? {
            Some(p) => Some(p),
            None => self.search(n, unit.start, from.min(unit.end))?,
        };
        let Some(p) = found else { return Ok(None) };
        if self.labels.len() >= LABEL_CACHE {
            self.labels.clear();
            self.found.clear();
        }
        self.labels.insert((unit.start, n), p);
        self.found.insert(p.index, p.offset);
        Ok(Some(p.index))
    }

    /// The first line in `from..to` numbered `N n`.
    fn search(&mut self, n: u32, from: usize, to: usize) -> Result<Option<LinePos>, NcError> {
        self.go_to(from)?;
        while self.reader.position().index < to {
            let ReadLine::Text(window, at) = self.reader.read()? else {
                return Ok(None);
            };
            if starts_with_n(window.line_text(window.first_line()))
                && parse_line(&window, self.dialect)?
                    .n
                    .is_some_and(|l| l.value == n)
            {
                return Ok(Some(at));
            }
        }
        Ok(None)
    }

    /// The window of line `line_no` (1-based), for an error about a line no longer held.
    pub(crate) fn line_window(&mut self, line_no: u32) -> Result<SourceFile, NcError> {
        let i = (line_no as usize).saturating_sub(1);
        self.go_to(i)?;
        match self.reader.read()? {
            ReadLine::Text(w, _) => Ok(w),
            ReadLine::End => Ok(SourceFile::window(self.reader.name().clone(), "", line_no)),
        }
    }
}

/// An error reading line `i` (0-based) of the program `name`.
fn read_error(name: &Arc<str>, i: usize, e: &std::io::Error) -> NcError {
    let w = SourceFile::window(name.clone(), "", i as u32 + 1);
    NcError::new(
        &w,
        cnc402_lang::ast::Span::default(),
        format!("cannot read the program: {e}"),
    )
}

/// Whether a line may be one the flow indexes: a program number (`O`, `:`), `%`, a WHILE or
/// END (also `WH`, `EN`), or a LinuxCNC O-word; every such line holds one of these letters.
fn may_be_flow(body: &[u8]) -> bool {
    body.iter()
        .any(|b| matches!(b, b'O' | b'o' | b'W' | b'w' | b'E' | b'e' | b'%' | b':'))
}

/// Whether a line may carry a sequence number: `N` (after a block-delete `/`) starts it.
fn starts_with_n(text: &str) -> bool {
    let t = text.trim_start_matches([' ', '\t']);
    let t = t
        .strip_prefix('/')
        .unwrap_or(t)
        .trim_start_matches([' ', '\t']);
    t.starts_with(['N', 'n'])
}

/// The plain-block lane's reading (see `crate::block::plain`): a line's bytes without its
/// window, and the view made of the same line when the lane leaves it to the general path.
impl Stream {
    /// Reads line `i` without making its window, when the reader is there and the bytes are
    /// what the interpreter reads (no translating reader): `Some(Some(at))` with the bytes in
    /// [`body`](Self::body), `Some(None)` past the file's end, `None` when the line is to be
    /// read by [`view`](Self::view).
    pub(crate) fn read_raw_at(&mut self, i: usize) -> Result<Option<Option<LinePos>>, NcError> {
        if self.reader.position().index != i || self.reader.translates() {
            return Ok(None);
        }
        self.reader.read_raw().map(Some)
    }

    /// The bytes of the line [`read_raw_at`](Self::read_raw_at) read.
    pub(crate) fn body(&self) -> &[u8] {
        self.reader.body()
    }

    /// The lane ran the line read at `at`: it is the last line read.
    pub(crate) fn ran_plain(&mut self, at: LinePos) {
        self.plain_last = Some(at);
    }

    /// The view of line `i` of `unit` (read by [`read_raw_at`](Self::read_raw_at) at `at`), as
    /// [`view`](Self::view) would have given it.
    pub(crate) fn view_read(
        &mut self,
        unit: &Unit,
        i: usize,
        at: LinePos,
    ) -> Result<Option<Arc<Unit>>, NcError> {
        let window = self.reader.current_window(at)?;
        self.view_window(unit, i, window)
    }

    /// The window of the last line read (errors at the program's end), made again when the
    /// lane read that line; the reader is where it was afterwards.
    pub(crate) fn last_window(&mut self) -> Result<Arc<SourceFile>, NcError> {
        if let Some(at) = self.plain_last.take() {
            let here = self.reader.position();
            self.reader
                .seek(at)
                .map_err(|e| read_error(self.reader.name(), at.index, &e))?;
            if let ReadLine::Text(w, _) = self.reader.read()? {
                self.last = Arc::new(w);
            }
            self.reader
                .seek(here)
                .map_err(|e| read_error(self.reader.name(), here.index, &e))?;
        }
        Ok(self.last.clone())
    }
}
