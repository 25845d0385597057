//! The toolpath of a program as the verification views need it: every path segment the
//! interpreter lowers (lines, arcs and helices, rigid taps, canned cycles expanded into their
//! moves, sub-programs and macros run) as a [`Piece`] in X Y Z, in work coordinates of the
//! block's own offsets (what the program says) or in machine coordinates, each naming its
//! block (file, line, N). A program error ends the path where it happened and is kept.

use std::collections::HashMap;
use std::sync::Arc;

use cnc402_config::MachineConfig;
use cnc402_interp::Interpreter;
use cnc402_interp::lower::xyz_indices;
use cnc402_lang::NcError;
use cnc402_motion::segment::{AxisPos, SegmentKind};

use crate::geom::{P3, Path3, Shape};

/// The coordinates positions are given in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Frame {
    /// Work coordinates under the offsets active for each block (work offset G54–G59, G92,
    /// tool length): the numbers the program was written with.
    Work,
    /// Absolute machine coordinates (what the drives are sent).
    Machine,
}

impl Frame {
    pub fn name(self) -> &'static str {
        match self {
            Frame::Work => "work",
            Frame::Machine => "machine",
        }
    }
}

/// What a piece of path is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PieceKind {
    /// G0 (and a cycle's rapid moves).
    Rapid,
    /// G1, G2/G3 and a cycle's feed moves.
    Feed,
    /// A rigid-tap stroke (tool axis coupled with the spindle).
    Tap,
}

impl PieceKind {
    pub fn name(self) -> &'static str {
        match self {
            PieceKind::Rapid => "rapid",
            PieceKind::Feed => "feed",
            PieceKind::Tap => "tap",
        }
    }
}

/// A program block that made at least one segment.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Block {
    /// Index into [`Toolpath::files`].
    pub file: usize,
    /// 1-based line.
    pub line: u32,
    pub n: Option<u32>,
}

/// One path segment in X Y Z of the toolpath's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Piece {
    /// Index into [`Toolpath::blocks`].
    pub block: usize,
    pub kind: PieceKind,
    pub path: Path3,
    /// The block's work → machine offset of X Y Z (machine = work + offset).
    pub offset: P3,
}

/// A program's toolpath, up to its end, its first error, or the segment limit.
#[derive(Debug, Default)]
pub struct Toolpath {
    pub frame: Option<Frame>,
    /// Every file a block came from (the main program, sub-programs, `#use` files).
    pub files: Vec<Arc<str>>,
    /// Every block that made a segment (path or not), in the order they first ran.
    pub blocks: Vec<Block>,
    pub pieces: Vec<Piece>,
    /// The error that ended the dry run early, if any: the path is what ran before it.
    pub error: Option<NcError>,
    /// The segment limit ended the path (an endless program).
    pub truncated: bool,
}

/// The X Y Z of `p` (0 for an axis the machine lacks).
fn xyz_of(p: &AxisPos, xyz: [Option<usize>; 3]) -> P3 {
    xyz.map(|i| i.map_or(0.0, |i| p.0[i]))
}

impl Toolpath {
    /// Runs `interp` (loaded, not yet started) to its end, its first error, or `limit`
    /// segments, and keeps the path in `frame`.
    pub fn collect(
        cfg: &MachineConfig,
        interp: &mut Interpreter,
        frame: Frame,
        limit: u64,
    ) -> Self {
        let xyz = xyz_indices(cfg);
        let mut tp = Toolpath {
            frame: Some(frame),
            ..Toolpath::default()
        };
        let mut block_index: HashMap<(Arc<str>, u32), usize> = HashMap::new();
        let mut file_index: HashMap<Arc<str>, usize> = HashMap::new();
        let mut at = interp.state().pos;
        let mut count = 0u64;
        loop {
            if count == limit {
                tp.truncated = true;
                break;
            }
            count += 1;
            let (seg, state) = match interp.next_lowered() {
                Ok(Some(s)) => s,
                Ok(None) => break,
                Err(e) => {
                    tp.error = Some(e);
                    break;
                }
            };
            let src = &seg.source;
            let block = *block_index
                .entry((src.file.clone(), src.line))
                .or_insert_with(|| {
                    let next = file_index.len();
                    let file = *file_index.entry(src.file.clone()).or_insert(next);
                    if file == tp.files.len() {
                        tp.files.push(src.file.clone());
                    }
                    tp.blocks.push(Block {
                        file,
                        line: src.line,
                        n: src.n,
                    });
                    tp.blocks.len() - 1
                });
            let (kind, end) = match &seg.kind {
                SegmentKind::Rapid { end } => (PieceKind::Rapid, *end),
                SegmentKind::Linear { end, .. } | SegmentKind::Arc { end, .. } => {
                    (PieceKind::Feed, *end)
                }
                SegmentKind::Tap(t) => (PieceKind::Tap, t.end),
                _ => continue,
            };
            let (start, shape_kind) = match frame {
                Frame::Machine => (at, seg.kind.clone()),
                Frame::Work => (
                    state.to_work(&at),
                    state.convert(seg.kind.clone(), xyz, false),
                ),
            };
            let shape = match shape_kind {
                SegmentKind::Arc {
                    center,
                    plane,
                    dir,
                    turns,
                    ..
                } => Shape::Arc {
                    center,
                    plane,
                    dir,
                    turns,
                },
                _ => Shape::Line,
            };
            let end_in_frame = match frame {
                Frame::Machine => end,
                Frame::Work => state.to_work(&end),
            };
            tp.pieces.push(Piece {
                block,
                kind,
                path: Path3 {
                    start: xyz_of(&start, xyz),
                    end: xyz_of(&end_in_frame, xyz),
                    shape,
                },
                offset: xyz_of(&state.offset, xyz),
            });
            at = end;
        }
        tp
    }

    /// `file:line` (and ` N…`) of block `b`.
    pub fn block_label(&self, b: usize) -> String {
        let blk = &self.blocks[b];
        let mut s = format!("{}:{}", self.files[blk.file], blk.line);
        if let Some(n) = blk.n {
            s.push_str(&format!(" N{n}"));
        }
        s
    }
}
