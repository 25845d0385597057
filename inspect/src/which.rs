//! Point → block: the blocks whose path passes nearest a point, nearest first, each with its
//! distance and the nearest point of its path. Exact on lines and on arcs and helices (see
//! [`crate::geom::Path3::nearest`]); every piece is measured, none is skipped.

use crate::geom::P3;
use crate::toolpath::{PieceKind, Toolpath};

/// One block near the point.
#[derive(Clone, Debug, PartialEq)]
pub struct Hit {
    /// Index into [`Toolpath::blocks`].
    pub block: usize,
    /// Distance from the point to the block's path (mm).
    pub distance: f64,
    /// The nearest point of the block's path.
    pub nearest: P3,
    /// The kind of the piece the nearest point lies on.
    pub kind: PieceKind,
}

/// The `count` blocks whose path passes nearest `point` (in the toolpath's frame), nearest
/// first; ties keep program order. Empty when the program has no path.
pub fn nearest_blocks(tp: &Toolpath, point: &P3, count: usize) -> Vec<Hit> {
    let mut best: Vec<Option<Hit>> = vec![None; tp.blocks.len()];
    for piece in &tp.pieces {
        let (d, t) = piece.path.nearest(point);
        let slot = &mut best[piece.block];
        if slot.as_ref().is_none_or(|h| d < h.distance) {
            *slot = Some(Hit {
                block: piece.block,
                distance: d,
                nearest: piece.path.point(t),
                kind: piece.kind,
            });
        }
    }
    let mut hits: Vec<Hit> = best.into_iter().flatten().collect();
    hits.sort_by(|a, b| {
        a.distance
            .total_cmp(&b.distance)
            .then(a.block.cmp(&b.block))
    });
    hits.truncate(count);
    hits
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Path3, Shape};
    use crate::toolpath::{Block, Piece};

    fn line(block: usize, start: P3, end: P3) -> Piece {
        Piece {
            block,
            kind: PieceKind::Feed,
            path: Path3 {
                start,
                end,
                shape: Shape::Line,
            },
            offset: [0.0; 3],
        }
    }

    #[test]
    fn blocks_come_nearest_first_once_each() {
        let tp = Toolpath {
            files: vec!["a.nc".into()],
            blocks: (1..=3)
                .map(|line| Block {
                    file: 0,
                    line,
                    n: Some(line * 10),
                })
                .collect(),
            pieces: vec![
                line(0, [0.0, 0.0, 0.0], [10.0, 0.0, 0.0]),
                line(1, [10.0, 0.0, 0.0], [10.0, 10.0, 0.0]),
                // Block 1 twice (a cycle's moves): counted once, at its nearest piece.
                line(1, [10.0, 10.0, 0.0], [10.0, 10.0, 5.0]),
                line(2, [10.0, 10.0, 5.0], [0.0, 10.0, 5.0]),
            ],
            ..Toolpath::default()
        };
        let hits = nearest_blocks(&tp, &[9.5, 10.0, 4.0], 5);
        let order: Vec<usize> = hits.iter().map(|h| h.block).collect();
        assert_eq!(order, vec![1, 2, 0]);
        assert!((hits[0].distance - 0.5).abs() < 1e-12);
        assert_eq!(hits[0].nearest, [10.0, 10.0, 4.0]);
        assert_eq!(nearest_blocks(&tp, &[0.0; 3], 1).len(), 1);
    }
}
