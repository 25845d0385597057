//! Lowering: canonical operations (work coordinates, cycles whole) into motion segments
//! (machine coordinates, cycles expanded, every segment saying what it is and how it ends).
//! The one place where offsets are added and a cycle becomes moves; stateless, so every
//! consumer of the canonical stream (the interpreter's segment API, a verifier, a
//! post-processor's preview) gets the same segments.

use std::collections::VecDeque;
use std::sync::Arc;

use cnc402_config::MachineConfig;
use cnc402_motion::segment::{Segment, SegmentEnd, SegmentKind};

use crate::canon::{CanonKind, CanonOp, CanonState};

pub mod cycle;

/// The machine indices of X, Y and Z (arc centres are X Y Z).
pub fn xyz_indices(cfg: &MachineConfig) -> [Option<usize>; 3] {
    [
        cfg.axis_index('X'),
        cfg.axis_index('Y'),
        cfg.axis_index('Z'),
    ]
}

/// How a segment of `kind` made under the operation's path mode ends: rapids, feeds and arcs
/// follow G61/G64; a tap, a wait or an event ends in an exact stop.
fn ends(op: &CanonOp, kind: &SegmentKind) -> SegmentEnd {
    if kind.is_path() && !matches!(kind, SegmentKind::Tap(_)) {
        op.state.path_mode.segment_end()
    } else {
        SegmentEnd::ExactStop
    }
}

/// Lowers `op` into machine-coordinate segments, appended to `out` (a `Vec` or a
/// `VecDeque`). `xyz` comes from [`xyz_indices`].
pub fn lower(op: &CanonOp, xyz: [Option<usize>; 3], out: &mut impl Extend<Segment>) {
    match &op.kind {
        CanonKind::Single(kind) => {
            let kind = op.state.convert(kind.clone(), xyz, true);
            out.extend(std::iter::once(Segment {
                ends: ends(op, &kind),
                kind,
                source: op.source.clone(),
            }));
        }
        CanonKind::CannedCycle(cc) => {
            // A cycle reaches every level it names (Fanuc checks in-position there).
            out.extend(
                cycle::expand(cc, &op.state)
                    .into_iter()
                    .map(|step| Segment {
                        kind: step.kind,
                        source: op.source.clone(),
                        ends: SegmentEnd::ExactStop,
                    }),
            );
        }
    }
}

/// Lowers `op` into `out`, each segment with the operation's state (what the interpreter
/// hands out): written in place, without an intermediate vector.
pub(crate) fn lower_with_state(
    op: &CanonOp,
    xyz: [Option<usize>; 3],
    out: &mut VecDeque<(Segment, Arc<CanonState>)>,
) {
    lower(
        op,
        xyz,
        &mut WithState {
            out,
            state: &op.state,
        },
    );
}

/// Appends segments to the interpreter's queue with the state they were lowered under.
struct WithState<'a> {
    out: &'a mut VecDeque<(Segment, Arc<CanonState>)>,
    state: &'a Arc<CanonState>,
}

impl Extend<Segment> for WithState<'_> {
    fn extend<I: IntoIterator<Item = Segment>>(&mut self, segments: I) {
        for s in segments {
            self.out.push_back((s, self.state.clone()));
        }
    }
}
