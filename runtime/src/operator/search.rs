//! Block search (`--from`/`--to`): the blocks before the range are interpreted without motion
//! (modal state, offsets, tool, spindle, variables and the position they end at), then the
//! machine approaches the range's start the safe way — tool change, Z up to the higher of
//! here and there, the other axes at rapid, spindle and coolant as the state says, Z down —
//! and runs the range, ending once a block after `--to` begins.

use cnc402_config::MAX_SPINDLES;
use cnc402_motion::{AxisPos, Segment, SegmentEnd, SegmentKind, Source};

use super::BlockSpec;

/// The range of a block search, as checked against the program.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SearchSpec {
    pub from: BlockSpec,
    /// Run up to and including this block (`None`: to the program's end).
    pub to: Option<BlockSpec>,
}

impl std::fmt::Display for SearchSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.to {
            Some(t) => write!(f, "{} to {t}", self.from),
            None => write!(f, "{} to the end", self.from),
        }
    }
}

/// Where a search is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Phase {
    /// Before `--from`: segments are taken in, nothing moves.
    Before,
    /// In the range.
    In,
    /// The `--to` block has begun: the first block after it ends the program.
    InLast,
}

/// A block search under way: what the skipped blocks left the machine with.
#[derive(Debug)]
pub(super) struct Search {
    pub(super) spec: SearchSpec,
    pub(super) phase: Phase,
    /// Segments passed over so far.
    pub(super) skipped: u64,
    /// The last tool change, spindle (each spindle's, by number − 1) and coolant state of
    /// the skipped blocks.
    tool: Option<SegmentKind>,
    spindle: [Option<SegmentKind>; MAX_SPINDLES],
    coolant: Option<SegmentKind>,
}

impl Search {
    pub(super) fn new(spec: SearchSpec) -> Search {
        Search {
            spec,
            phase: Phase::Before,
            skipped: 0,
            tool: None,
            spindle: Default::default(),
            coolant: None,
        }
    }

    /// A skipped segment: its state is kept, its motion is not made.
    pub(super) fn skip(&mut self, kind: &SegmentKind) {
        self.skipped += 1;
        match kind {
            SegmentKind::ToolChange { .. } => self.tool = Some(kind.clone()),
            SegmentKind::Spindle { spindle, .. } => {
                if let Some(slot) = self.spindle.get_mut(usize::from(*spindle).wrapping_sub(1)) {
                    *slot = Some(kind.clone());
                }
            }
            SegmentKind::Coolant { .. } => self.coolant = Some(kind.clone()),
            _ => {}
        }
    }

    /// The segments that bring the machine from `here` to `there` (where the skipped blocks
    /// left the program) in the state they set up; `z` is the tool axis, if any.
    pub(super) fn approach(
        &self,
        here: AxisPos,
        there: AxisPos,
        z: Option<usize>,
        source: &Source,
    ) -> Vec<Segment> {
        let seg = |kind: SegmentKind| Segment {
            kind,
            source: source.clone(),
            ends: SegmentEnd::ExactStop,
        };
        let mut out: Vec<Segment> = self.tool.iter().cloned().map(seg).collect();
        let mut at = here;
        let mut rapid = |end: AxisPos, out: &mut Vec<Segment>| {
            if end.0 != at.0 {
                out.push(seg(SegmentKind::Rapid { end }));
                at = end;
            }
        };
        let mut above = there;
        if let Some(z) = z {
            let safe = here[z].max(there[z]);
            let mut up = here;
            up.0[z] = safe;
            rapid(up, &mut out);
            above.0[z] = safe;
        }
        rapid(above, &mut out);
        let spindles = self.spindle.iter().flatten();
        out.extend(spindles.chain(&self.coolant).cloned().map(seg));
        rapid(there, &mut out);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pos(x: f64, y: f64, z: f64) -> AxisPos {
        let mut p = AxisPos::default();
        (p.0[0], p.0[1], p.0[2]) = (x, y, z);
        p
    }

    #[test]
    fn the_approach_lifts_z_first_moves_across_starts_the_spindle_then_plunges() {
        let mut s = Search::new(SearchSpec {
            from: BlockSpec::N(10),
            to: None,
        });
        s.skip(&SegmentKind::Spindle {
            rpm: 1200.0,
            dir: cnc402_motion::SpindleDir::Cw,
            spindle: 1,
        });
        let src = Source {
            file: "p.nc".into(),
            line: 3,
            n: Some(10),
        };
        let kinds: Vec<_> = s
            .approach(pos(0.0, 0.0, 50.0), pos(10.0, 20.0, -5.0), Some(2), &src)
            .into_iter()
            .map(|g| g.kind)
            .collect();
        assert_eq!(kinds.len(), 3);
        assert_eq!(
            kinds[0],
            SegmentKind::Rapid {
                end: pos(10.0, 20.0, 50.0)
            }
        );
        assert!(matches!(kinds[1], SegmentKind::Spindle { .. }));
        assert_eq!(
            kinds[2],
            SegmentKind::Rapid {
                end: pos(10.0, 20.0, -5.0)
            }
        );
        // From below the target: Z rises first.
        let kinds: Vec<_> = s
            .approach(pos(0.0, 0.0, 0.0), pos(10.0, 0.0, 5.0), Some(2), &src)
            .into_iter()
            .map(|g| g.kind)
            .collect();
        assert_eq!(
            kinds[0],
            SegmentKind::Rapid {
                end: pos(0.0, 0.0, 5.0)
            }
        );
        assert_eq!(
            kinds[1],
            SegmentKind::Rapid {
                end: pos(10.0, 0.0, 5.0)
            }
        );
    }

    /// Regression (block_search_restored_only_the_last_spindle): with two spindles, a
    /// search kept one spindle command, so the spindle started first stayed off.
    #[test]
    fn block_search_restores_every_spindle() {
        let mut s = Search::new(SearchSpec {
            from: BlockSpec::N(10),
            to: None,
        });
        let sp = |rpm, spindle| SegmentKind::Spindle {
            rpm,
            dir: cnc402_motion::SpindleDir::Cw,
            spindle,
        };
        for k in [sp(1000.0, 1), sp(2000.0, 2), sp(1500.0, 1), sp(7.0, 9)] {
            s.skip(&k);
        }
        let src = Source {
            file: "p.nc".into(),
            line: 3,
            n: Some(10),
        };
        let kinds: Vec<_> = s
            .approach(pos(0.0, 0.0, 0.0), pos(0.0, 0.0, 0.0), Some(2), &src)
            .into_iter()
            .map(|g| g.kind)
            .collect();
        assert_eq!(kinds, vec![sp(1500.0, 1), sp(2000.0, 2)]);
    }
}
