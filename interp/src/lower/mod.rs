//! Lowering: canonical operations (work coordinates, cycles whole) into motion segments
//! (machine coordinates, cycles expanded, every segment saying what it is and how it ends).
//! The one place where offsets are added and a cycle becomes moves; stateless, so every
//! consumer of the canonical stream (the interpreter's segment API, a verifier, a
//! post-processor's preview) gets the same segments.

use std::collections::VecDeque;
use std::sync::Arc;

use cnc402_config::MachineConfig;
use cnc402_motion::segment::{Segment, SegmentEnd, SegmentKind, Source};

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
fn ends(state: &CanonState, kind: &SegmentKind) -> SegmentEnd {
    if kind.is_path() && !matches!(kind, SegmentKind::Tap(_)) {
        state.path_mode.segment_end()
    } else {
        SegmentEnd::ExactStop
    }
}

/// The one segment of a single operation's `kind` (work coordinates) made under `state`.
fn single(
    state: &CanonState,
    mut kind: SegmentKind,
    source: Source,
    xyz: [Option<usize>; 3],
) -> Segment {
    state.convert_in_place(&mut kind, xyz, true);
    Segment {
        ends: ends(state, &kind),
        kind,
        source,
    }
}

/// Lowers `op` into machine-coordinate segments, appended to `out` (a `Vec` or a
/// `VecDeque`). `xyz` comes from [`xyz_indices`].
pub fn lower(op: &CanonOp, xyz: [Option<usize>; 3], out: &mut impl Extend<Segment>) {
    match &op.kind {
        CanonKind::Single(kind) => out.extend(std::iter::once(single(
            &op.state,
            kind.clone(),
            op.source.clone(),
            xyz,
        ))),
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

/// As [`lower_with_state`], taking `op` by value: a one-segment operation's kind, source and
/// state move into its segment (no reference counts touched, nothing cloned); a cycle is
/// lowered as there.
pub(crate) fn lower_owned(
    op: CanonOp,
    xyz: [Option<usize>; 3],
    out: &mut VecDeque<(Segment, Arc<CanonState>)>,
) {
    match op.kind {
        CanonKind::Single(kind) => {
            let segment = single(&op.state, kind, op.source, xyz);
            out.push_back((segment, op.state));
        }
        CanonKind::CannedCycle(_) => lower_with_state(&op, xyz, out),
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::canon::{CompSide, CutterComp, FeedMode, PathMode, ProgramUnits};
    use cnc402_motion::segment::{
        ArcDir, AxisPos, MAX_AXES, Plane, Source, SpindleDir, StopKind, TapSegment,
    };
    use proptest::prelude::*;

    /// A value from a byte: small numbers, repeats likely, NaN, −0 and infinity included.
    fn num(b: u8) -> f64 {
        match b % 8 {
            5 => f64::NAN,
            6 => -0.0,
            7 => f64::INFINITY,
            k => f64::from(k) * 1.25 - 2.0,
        }
    }

    fn pos(v: &[u8]) -> AxisPos {
        let mut p = AxisPos::default();
        for (i, b) in v.iter().take(MAX_AXES).enumerate() {
            p.0[i] = num(*b);
        }
        p
    }

    fn state(v: &[u8]) -> CanonState {
        CanonState {
            plane: [Plane::XY, Plane::ZX, Plane::YZ][v[0] as usize % 3],
            units: [ProgramUnits::Mm, ProgramUnits::Inch][v[1] as usize % 2],
            feed_mode: [FeedMode::PerMinute, FeedMode::PerRevolution][v[2] as usize % 2],
            path_mode: match v[3] % 3 {
                0 => PathMode::ExactStop,
                1 => PathMode::Tapping,
                _ => PathMode::Continuous {
                    tolerance: num(v[4]),
                    collinear: num(v[5]),
                },
            },
            work_offset: v[6] as usize % 6,
            offset: pos(&v[7..]),
            tool: v[1].is_multiple_of(3).then_some(u32::from(v[2])),
            tool_length_mode: 49,
            h: 0,
            tool_length: num(v[3]),
            tool_axis: Some(2),
            comp: v[4].is_multiple_of(4).then_some(CutterComp {
                side: CompSide::Left,
                d: 1,
                radius: num(v[5]),
            }),
        }
    }

    /// Every kind of single operation, its values from `v`.
    fn kind(which: u8, v: &[u8]) -> SegmentKind {
        let end = pos(&v[1..]);
        let f = num(v[0]);
        match which % 11 {
            0 => SegmentKind::Rapid { end },
            1 => SegmentKind::Linear { end, feed: f },
            2 => SegmentKind::Tap(TapSegment {
                end,
                feed: f,
                tool: 2,
                spindle: 3,
                pitch: num(v[2]),
            }),
            3 => SegmentKind::Arc {
                end,
                center: [num(v[3]), num(v[4]), num(v[5])],
                plane: [Plane::XY, Plane::ZX, Plane::YZ][v[6] as usize % 3],
                dir: [ArcDir::Cw, ArcDir::Ccw][v[7] as usize % 2],
                turns: u32::from(v[8] % 3),
                feed: f,
            },
            4 => SegmentKind::Dwell { seconds: f },
            5 => SegmentKind::Spindle {
                rpm: f,
                dir: [SpindleDir::Cw, SpindleDir::Ccw, SpindleDir::Stop][v[1] as usize % 3],
                spindle: v[2] % 3,
            },
            6 => SegmentKind::SpindleOrient {
                angle: f,
                program: v[1].is_multiple_of(2).then_some(num(v[2])),
                spindle: 1,
            },
            7 => SegmentKind::ToolChange {
                tool: u32::from(v[1]),
            },
            8 => SegmentKind::Coolant {
                mist: v[1].is_multiple_of(2),
                flood: v[2].is_multiple_of(2),
            },
            9 => SegmentKind::Stop {
                kind: [StopKind::Program, StopKind::Optional, StopKind::End][v[1] as usize % 3],
            },
            _ => SegmentKind::Message {
                text: format!("m{}", v[1]),
            },
        }
    }

    /// What `CanonState::convert` gave before it converted in place (kept as the reference):
    /// positions through `to_machine`/`to_work`, arc centres shifted by ±offset.
    fn convert_reference(
        st: &CanonState,
        kind: SegmentKind,
        xyz: [Option<usize>; 3],
        to_machine: bool,
    ) -> SegmentKind {
        let pos = |p: &AxisPos| {
            if to_machine {
                st.to_machine(p)
            } else {
                st.to_work(p)
            }
        };
        let sign = if to_machine { 1.0 } else { -1.0 };
        match kind {
            SegmentKind::Rapid { end } => SegmentKind::Rapid { end: pos(&end) },
            SegmentKind::Linear { end, feed } => SegmentKind::Linear {
                end: pos(&end),
                feed,
            },
            SegmentKind::Tap(t) => SegmentKind::Tap(TapSegment {
                end: pos(&t.end),
                ..t
            }),
            SegmentKind::Arc {
                end,
                center,
                plane,
                dir,
                turns,
                feed,
            } => {
                let mut c = center;
                for (k, i) in xyz.into_iter().enumerate() {
                    if let Some(i) = i {
                        c[k] = center[k] + sign * st.offset.0[i];
                    }
                }
                SegmentKind::Arc {
                    end: pos(&end),
                    center: c,
                    plane,
                    dir,
                    turns,
                    feed,
                }
            }
            other => other,
        }
    }

    proptest! {
        /// Converting in place gives, bit for bit, what the conversion through `to_machine`
        /// and `to_work` gave, both ways.
        #[test]
        fn convert_in_place_gives_what_the_reference_gives(
            s in proptest::collection::vec(0u8..=255, 16),
            k in proptest::collection::vec(0u8..=255, 16),
            which in 0u8..11,
            xyz in 0usize..3,
            to_machine: bool,
        ) {
            let xyz = [[Some(0), Some(1), Some(2)], [Some(1), None, Some(3)], [None, None, None]][xyz];
            let st = state(&s);
            let kind = kind(which, &k);
            let want = convert_reference(&st, kind.clone(), xyz, to_machine);
            let got = st.convert(kind, xyz, to_machine);
            prop_assert_eq!(format!("{want:?}"), format!("{got:?}"));
        }

        /// Lowering an operation by value gives what lowering it by reference gives, byte for
        /// byte (NaN and −0 compared by their text), with the operation's own state.
        #[test]
        fn lower_owned_gives_what_lower_with_state_gives(
            s in proptest::collection::vec(0u8..=255, 16),
            k in proptest::collection::vec(0u8..=255, 16),
            which in 0u8..11,
            xyz in 0usize..3,
        ) {
            let xyz = [[Some(0), Some(1), Some(2)], [Some(1), None, Some(3)], [None, None, None]][xyz];
            let op = CanonOp {
                kind: CanonKind::Single(kind(which, &k)),
                source: Source { file: Arc::from("p.nc"), line: u32::from(k[0]), n: None },
                state: Arc::new(state(&s)),
            };
            let (mut by_ref, mut by_value) = (VecDeque::new(), VecDeque::new());
            lower_with_state(&op, xyz, &mut by_ref);
            let state = op.state.clone();
            lower_owned(op, xyz, &mut by_value);
            prop_assert_eq!(format!("{by_ref:?}"), format!("{by_value:?}"));
            prop_assert_eq!(by_value.len(), 1);
            prop_assert!(Arc::ptr_eq(&by_value[0].1, &state));
        }
    }
}
