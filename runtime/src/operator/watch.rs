//! The feeder's side of breakpoints, single block and block search: every segment the
//! interpreter makes passes [`BlockWatch::admit`] before the planner, which tells where a new
//! block begins (a new line, or the interpreter's block serial: each pass of a loop is a new
//! block), inserts a program stop (the M0 machinery) before a block that must hold — never
//! inside a rigid tap, from the tap in to the tap out — and, in a block search, keeps back
//! the blocks before the range and ends after it.

use std::collections::VecDeque;
use std::sync::Arc;

use cnc402_motion::{AxisPos, Segment, SegmentEnd, SegmentKind, StopKind};

use super::search::{Phase, Search, SearchSpec};
use super::{BlockSpec, BreakHit, OperatorShared};

/// What the feeder does after [`BlockWatch::admit`].
#[derive(Debug, PartialEq)]
pub enum Admit {
    /// Plan what was handed out and go on.
    Go,
    /// The block search's range is over: the program ends here.
    End,
    /// The block search cannot reach its range (why).
    Unreachable(String),
}

/// Most segments a block search passes over before its range (as many as the dry run checks,
/// `feeder::DRY_RUN_MOVES`): a program looping endlessly before `--from` ends with an error.
pub const SEARCH_LIMIT: u64 = 1_000_000;

/// The lines a `skip` passes: the block's line, and once it came round again, the span of
/// the loop it repeats in.
#[derive(Debug)]
struct Skip {
    file: Arc<str>,
    line: u32,
    span: (u32, u32),
    came_round: bool,
}

/// Breakpoints, single block and block search for one run (see the module doc).
#[derive(Debug)]
pub struct BlockWatch {
    breaks: Vec<BlockSpec>,
    single_block: bool,
    /// Holds are inserted (false in a dry run, which only searches).
    holds: bool,
    shared: Arc<OperatorShared>,
    /// (file, line, serial) of the block the last segment came from.
    last: Option<(Arc<str>, u32, u64)>,
    /// Where the machine stood when the run began.
    start: AxisPos,
    /// Where the program's segments have put the tool (machine coordinates).
    pos: AxisPos,
    /// Where the block's first feed (or tap) began on the tool axis: its repetitions begin
    /// at or above it (`-inf` before the block feeds).
    block_floor: f64,
    /// An open rigid tap: the tool axis and where it began.
    tap: Option<(usize, f64)>,
    /// A hold due at a block that began inside a tap: made once the tap is out.
    pending: Option<BreakHit>,
    skip: Option<Skip>,
    search: Option<Search>,
    /// The tool axis for the search's approach (the axis named Z).
    z: Option<usize>,
    /// The breaks of the program stops planned, in order (`None`: the program's own stop).
    planned_stops: VecDeque<Option<BreakHit>>,
    /// [`SEARCH_LIMIT`], smaller in tests.
    search_limit: u64,
}

impl BlockWatch {
    /// A watch for a machine standing at `start`.
    pub fn new(
        breaks: Vec<BlockSpec>,
        single_block: bool,
        search: Option<SearchSpec>,
        shared: Arc<OperatorShared>,
        start: AxisPos,
        z: Option<usize>,
    ) -> BlockWatch {
        BlockWatch {
            breaks,
            single_block,
            holds: true,
            shared,
            last: None,
            start,
            pos: start,
            block_floor: f64::NEG_INFINITY,
            tap: None,
            pending: None,
            skip: None,
            search: search.map(Search::new),
            z,
            planned_stops: VecDeque::new(),
            search_limit: SEARCH_LIMIT,
        }
    }

    /// The same watch without holds (the dry run: it searches, it does not stop).
    pub fn without_holds(mut self) -> BlockWatch {
        self.holds = false;
        self
    }

    /// Takes in `seg`, made by the block with `serial`, and hands out what to plan in `out`.
    pub fn admit(&mut self, seg: Segment, serial: u64, out: &mut Vec<Segment>) -> Admit {
        let src = &seg.source;
        let new_block = self
            .last
            .as_ref()
            .is_none_or(|(f, l, s)| *l != src.line || *s != serial || **f != *src.file);
        let mut first = self.last.is_none();
        self.last = Some((src.file.clone(), src.line, serial));
        let mut approach = Vec::new();
        if let Some(search) = &mut self.search {
            match search.phase {
                Phase::Before if new_block && search.spec.from.matches(src) => {
                    search.phase = Phase::In;
                    approach = search.approach(self.start, self.pos, self.z, src);
                    // The range's first block follows the approach without a single-block hold.
                    first = true;
                }
                Phase::Before => {
                    if search.skipped >= self.search_limit {
                        return Admit::Unreachable(format!(
                            "block search: {} not reached within the first {} segments",
                            search.spec.from, self.search_limit
                        ));
                    }
                    search.skip(&seg.kind);
                    self.follow(&seg.kind);
                    return Admit::Go;
                }
                Phase::InLast
                    if new_block && !search.spec.to.as_ref().is_some_and(|t| t.matches(src)) =>
                {
                    return Admit::End;
                }
                _ => {}
            }
            if new_block && search.spec.to.as_ref().is_some_and(|t| t.matches(src)) {
                search.phase = Phase::InLast;
            }
        }
        out.append(&mut approach);
        if self.holds {
            let repeat = !new_block && self.repeats_block(&seg);
            if (new_block || repeat)
                && let Some(hit) = self.hold_due(&seg, first, repeat)
                && self.pending.is_none()
            {
                self.pending = Some(hit);
            }
            if self.tap.is_none()
                && let Some(mut hit) = self.pending.take()
            {
                // A hold that fell inside a tap is made here, after the tap out: say where.
                if (hit.line, &hit.file) != (seg.source.line, &seg.source.file) {
                    hit.after_tap = true;
                    (hit.file, hit.line, hit.n) =
                        (seg.source.file.clone(), seg.source.line, seg.source.n);
                }
                self.shared.set_hit(hit.clone());
                self.planned_stops.push_back(Some(hit));
                out.push(Segment {
                    kind: SegmentKind::Stop {
                        kind: StopKind::Program,
                    },
                    source: seg.source.clone(),
                    ends: SegmentEnd::ExactStop,
                });
            }
        }
        if let SegmentKind::Stop { .. } = seg.kind {
            self.planned_stops.push_back(None);
        }
        if new_block {
            self.block_floor = f64::NEG_INFINITY;
        }
        if let (Some(z), true) = (self.z, self.block_floor == f64::NEG_INFINITY)
            && matches!(
                seg.kind,
                SegmentKind::Linear { .. } | SegmentKind::Arc { .. } | SegmentKind::Tap(_)
            )
        {
            self.block_floor = self.pos[z];
        }
        self.follow(&seg.kind);
        out.push(seg);
        Admit::Go
    }

    /// The hold due before the block `seg` begins, if any (and the orders it used up).
    fn hold_due(&mut self, seg: &Segment, first: bool, repeat: bool) -> Option<BreakHit> {
        let src = &seg.source;
        let skipped = if repeat {
            // A skip passes the rest of this block's repetitions.
            self.take_skip_order();
            self.skip
                .as_ref()
                .is_some_and(|s| s.line == src.line && *s.file == *src.file)
        } else {
            self.passes_skip(&src.file, src.line)
        };
        if skipped {
            return None;
        }
        let is_break = !repeat && self.breaks.iter().any(|b| b.matches(src));
        let mut orders = self.shared.orders();
        let reason = if std::mem::take(&mut orders.step) {
            "step"
        } else if is_break {
            orders.to_next_break = false;
            "break"
        } else if self.single_block && !orders.to_next_break && !first {
            "step"
        } else {
            return None;
        };
        Some(BreakHit {
            file: src.file.clone(),
            line: src.line,
            n: src.n,
            reason: if repeat { "repeat" } else { reason },
            after_tap: false,
        })
    }

    /// Whether `seg`, inside the block, begins one more repetition of it (a canned cycle's
    /// next hole or K/L repeat, G28's second leg): a rapid across the plane with the tool
    /// axis at or above where the block began to feed (R or the initial level; a shift at a
    /// hole's bottom, as G76 makes, is none).
    fn repeats_block(&self, seg: &Segment) -> bool {
        let (Some(z), SegmentKind::Rapid { end }) = (self.z, &seg.kind) else {
            return false;
        };
        let across = (0..end.0.len()).any(|i| i != z && end[i] != self.pos[i]);
        across && self.pos[z] >= self.block_floor - 1e-9
    }

    /// Takes a `skip` the operator ordered at the last hold.
    fn take_skip_order(&mut self) {
        let ordered = self.shared.orders().skip.take();
        if let Some((f, l)) = ordered {
            self.skip = Some(Skip {
                file: f,
                line: l,
                span: (l, l),
                came_round: false,
            });
        }
    }

    /// Whether a `skip` passes the block at `file:line`; ends the skip once the program
    /// leaves the loop it repeated in.
    fn passes_skip(&mut self, file: &Arc<str>, line: u32) -> bool {
        self.take_skip_order();
        let Some(s) = &mut self.skip else {
            return false;
        };
        if *s.file != **file {
            return false;
        }
        if line == s.line {
            s.came_round = true;
            return true;
        }
        if s.came_round {
            if line < s.span.0 || line > s.span.1 {
                self.skip = None;
            }
        } else {
            s.span = (s.span.0.min(line), s.span.1.max(line));
        }
        false
    }

    /// Follows the program's position and an open rigid tap through `kind`.
    fn follow(&mut self, kind: &SegmentKind) {
        match kind {
            SegmentKind::Tap(t) => {
                let tool = t.tool as usize;
                let began = self.tap.map_or(self.pos[tool], |(_, z0)| z0);
                self.tap = ((t.end[tool] - began).abs() > 1e-9).then_some((tool, began));
                self.pos = t.end;
            }
            SegmentKind::Rapid { end }
            | SegmentKind::Linear { end, .. }
            | SegmentKind::Arc { end, .. } => {
                self.tap = None;
                self.pos = *end;
            }
            _ => {}
        }
    }

    /// The break of the next program stop the planner gave out (`None`: the program's own).
    pub fn stop_out(&mut self) -> Option<BreakHit> {
        self.planned_stops.pop_front().flatten()
    }

    /// After the program's end: why the search's range was never reached, if it was not.
    pub fn unreached(&self) -> Option<String> {
        self.search
            .as_ref()
            .filter(|s| s.phase == Phase::Before)
            .map(|s| {
                format!(
                    "block search: {} was never reached (the program ended before it)",
                    s.spec.from
                )
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::operator::Command;
    use cnc402_motion::{Source, TapSegment};

    fn at(line: u32, kind: SegmentKind) -> Segment {
        Segment {
            kind,
            source: Source {
                file: "w.nc".into(),
                line,
                n: None,
            },
            ends: SegmentEnd::ExactStop,
        }
    }

    fn line_to(line: u32, x: f64) -> Segment {
        let mut end = AxisPos::default();
        end.0[0] = x;
        at(line, SegmentKind::Linear { end, feed: 100.0 })
    }

    fn tap_to(line: u32, z: f64) -> Segment {
        let mut end = AxisPos::default();
        end.0[2] = z;
        end.0[3] = -z * 360.0;
        at(
            line,
            SegmentKind::Tap(TapSegment {
                end,
                feed: 100.0,
                tool: 2,
                spindle: 3,
                pitch: -1.0,
            }),
        )
    }

    /// Feeds `segs` (line, serial), answering every hold with `answer`; the lines held at.
    fn holds(w: &mut BlockWatch, segs: &[(Segment, u64)], answer: Command) -> Vec<u32> {
        let mut held = Vec::new();
        for (s, serial) in segs {
            let mut out = Vec::new();
            assert_eq!(w.admit(s.clone(), *serial, &mut out), Admit::Go);
            for o in &out {
                if let SegmentKind::Stop { .. } = o.kind
                    && let Some(hit) = w.stop_out()
                {
                    held.push(hit.line);
                    w.shared.order(answer, Some(&hit));
                }
            }
        }
        held
    }

    fn watch(breaks: Vec<BlockSpec>, single: bool) -> BlockWatch {
        let shared = Arc::new(OperatorShared::default());
        BlockWatch::new(breaks, single, None, shared, AxisPos::default(), Some(2))
    }

    #[test]
    fn skip_passes_the_loop_and_ends_when_the_program_leaves_it() {
        // Loop over lines 3..4 three times, then line 6; then the loop again (a second call).
        let mut segs = Vec::new();
        let mut serial = 0;
        for _ in 0..2 {
            for pass in 0..3 {
                for line in [3, 4] {
                    serial += 1;
                    segs.push((line_to(line, f64::from(pass + line)), serial));
                }
            }
            serial += 1;
            segs.push((line_to(6, 0.0), serial));
        }
        let mut w = watch(
            vec![BlockSpec::Line {
                file: "w.nc".into(),
                line: 4,
            }],
            false,
        );
        assert_eq!(holds(&mut w, &segs, Command::Continue), [4, 4, 4, 4, 4, 4]);
        let mut w = watch(
            vec![BlockSpec::Line {
                file: "w.nc".into(),
                line: 4,
            }],
            false,
        );
        // Skip at the first hold: the loop's other passes pass; after line 6, it holds again.
        assert_eq!(holds(&mut w, &segs, Command::Skip), [4, 4]);
    }

    /// Regression: a program looping endlessly before `--from` would have kept the dry run
    /// searching for ever.
    #[test]
    fn an_endless_loop_before_the_search_range_is_an_error_not_a_hang() {
        let shared = Arc::new(OperatorShared::default());
        let search = SearchSpec {
            from: BlockSpec::N(99),
            to: None,
        };
        let mut w = BlockWatch::new(
            Vec::new(),
            false,
            Some(search),
            shared,
            AxisPos::default(),
            Some(2),
        );
        w.search_limit = 50;
        let mut out = Vec::new();
        let admitted = (0..1000u32)
            .map(|i| w.admit(line_to(1 + i % 2, f64::from(i % 2)), u64::from(i), &mut out))
            .position(|a| a != Admit::Go);
        assert_eq!(admitted, Some(50));
        assert!(out.is_empty());
        assert!(matches!(
            w.admit(line_to(1, 0.0), 1001, &mut out),
            Admit::Unreachable(m) if m.contains("N99 not reached within the first 50")
        ));
    }

    #[test]
    fn single_block_never_holds_between_a_tap_in_and_its_tap_out() {
        let segs = [
            (line_to(1, 0.0), 1),
            (tap_to(2, -10.0), 2),
            (at(3, SegmentKind::Dwell { seconds: 0.5 }), 3),
            (tap_to(4, 0.0), 4),
            (line_to(5, 5.0), 5),
        ];
        let mut w = watch(Vec::new(), true);
        assert_eq!(holds(&mut w, &segs, Command::Continue), [2, 5]);
    }
}
