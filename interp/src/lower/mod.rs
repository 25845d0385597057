//! Lowering: canonical operations (work coordinates, cycles whole) into motion segments
//! (machine coordinates, cycles expanded, every segment saying what it is and how it ends).
//! The one place where offsets are added and a cycle becomes moves; stateless, so any
//! consumer of the canonical stream (the interpreter's segment API, a verifier, a
//! post-processor's preview) gets the same segments.

use cnc402_config::MachineConfig;
use cnc402_motion::segment::{AxisPos, Segment, SegmentEnd, SegmentKind, TapSegment};

use crate::canon::{CanonKind, CanonOp};

pub mod cycle;

/// The machine indices of X, Y and Z (arc centres are X Y Z).
pub fn xyz_indices(cfg: &MachineConfig) -> [Option<usize>; 3] {
    [cfg.axis_index('X'), cfg.axis_index('Y'), cfg.axis_index('Z')]
}

/// A rigid-tap segment: the tool axis `tool` and spindle axis `spindle` coupled by `pitch`
/// (signed mm of tool travel per spindle turn).
pub fn tap_segment(end: AxisPos, feed: f64, tool: usize, spindle: usize, pitch: f64) -> SegmentKind {
    SegmentKind::Tap(TapSegment {
        end,
        feed,
        tool: tool as u8,
        spindle: spindle as u8,
        pitch,
    })
}

/// Lowers `op` into machine-coordinate segments, appended to `out`.
pub fn lower(op: &CanonOp, xyz: [Option<usize>; 3], out: &mut Vec<Segment>) {
    let st = &op.state;
    let path_end = st.path_mode.segment_end();
    let mut push = |kind: SegmentKind, ends: SegmentEnd| {
        out.push(Segment {
            kind,
            source: op.source.clone(),
            ends,
        })
    };
    match &op.kind {
        CanonKind::Rapid { end } => push(
            SegmentKind::Rapid {
                end: st.to_machine(end),
            },
            path_end,
        ),
        CanonKind::Linear { end, feed } => push(
            SegmentKind::Linear {
                end: st.to_machine(end),
                feed: *feed,
            },
            path_end,
        ),
        CanonKind::Arc {
            end,
            center,
            plane,
            dir,
            turns,
            feed,
        } => push(
            SegmentKind::Arc {
                end: st.to_machine(end),
                center: st.xyz_to_machine(*center, xyz),
                plane: *plane,
                dir: *dir,
                turns: *turns,
                feed: *feed,
            },
            path_end,
        ),
        CanonKind::RigidTap(t) => push(
            tap_segment(
                st.to_machine(&t.end),
                t.feed,
                t.tool as usize,
                t.spindle as usize,
                t.pitch,
            ),
            SegmentEnd::ExactStop,
        ),
        CanonKind::CannedCycle(cc) => {
            // A cycle reaches every level it names (Fanuc checks in-position there).
            for step in cycle::expand(cc, st) {
                push(step.kind, SegmentEnd::ExactStop);
            }
        }
        CanonKind::Dwell { seconds } => push(
            SegmentKind::Dwell { seconds: *seconds },
            SegmentEnd::ExactStop,
        ),
        CanonKind::Spindle { rpm, dir } => push(
            SegmentKind::Spindle {
                rpm: *rpm,
                dir: *dir,
            },
            SegmentEnd::ExactStop,
        ),
        CanonKind::SpindleOrient { angle, program } => push(
            SegmentKind::SpindleOrient {
                angle: *angle,
                program: *program,
            },
            SegmentEnd::ExactStop,
        ),
        CanonKind::ToolChange { tool } => {
            push(SegmentKind::ToolChange { tool: *tool }, SegmentEnd::ExactStop)
        }
        CanonKind::Coolant { mist, flood } => push(
            SegmentKind::Coolant {
                mist: *mist,
                flood: *flood,
            },
            SegmentEnd::ExactStop,
        ),
        CanonKind::ProgramStop { kind } => {
            push(SegmentKind::Stop { kind: *kind }, SegmentEnd::ExactStop)
        }
        CanonKind::Message { text } => push(
            SegmentKind::Message { text: text.clone() },
            SegmentEnd::ExactStop,
        ),
    }
}
