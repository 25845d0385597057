//! Cutter radius compensation (G41/G42): a stage on the canonical stream, between the block
//! layer (which emits the programmed contour) and lowering (which gets the tool-centre path).
//! It holds one contour element back until the next element in the plane shows how the two
//! meet, with at most `cutter_comp_lookahead` operations without motion in the plane in
//! between; see `joint.rs` for the corners and `docs/config.md` for the rules.

pub mod geom;
mod joint;

use std::collections::VecDeque;

use cnc402_config::{CompGouge, CompStartup, CutterComp as CompConfig};
use cnc402_motion::segment::{ArcDir, AxisPos, Plane, SegmentKind, Source};

use crate::canon::{CanonKind, CanonOp, CompSide, CutterComp};
use geom::{EPS, Elem, P, dist, fmt};
use joint::Piece;

/// A contour the tool cannot follow, or a rule broken: the block and what is wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct CompError {
    pub source: Source,
    pub message: String,
}

/// The compensation stage: push programmed operations, pop compensated ones.
pub struct Stage {
    cfg: CompConfig,
    xyz: [Option<usize>; 3],
    out: VecDeque<CanonOp>,
    /// Where the program is (work coordinates; `None` before the first operation).
    prog: Option<AxisPos>,
    /// Where the tool centre is (work coordinates).
    tool: AxisPos,
    /// The machine position the program starts from (for `prog` at the first operation).
    start: AxisPos,
    run: Option<Run>,
}

/// Compensation while it is on.
struct Run {
    comp: CutterComp,
    plane: Plane,
    /// Axis indices of the plane's first and second axis; their places in an arc centre.
    ax: [usize; 2],
    centre: [usize; 2],
    /// `s·R`: + on the left (G41).
    sr: f64,
    /// The element whose end waits for the next one.
    pending: Option<Pending>,
    /// Operations without motion in the plane after `pending`.
    held: Vec<CanonOp>,
    /// The last element given out when the contour was broken (lookahead exhausted).
    last: Option<Elem>,
}

struct Pending {
    op: CanonOp,
    elem: Elem,
    /// Where the tool centre starts it.
    start: P,
    /// The start-up block (its start is not offset).
    startup: bool,
}

impl Stage {
    pub fn new(cfg: CompConfig, xyz: [Option<usize>; 3]) -> Self {
        Stage {
            cfg,
            xyz,
            out: VecDeque::new(),
            prog: None,
            tool: AxisPos::default(),
            start: AxisPos::default(),
            run: None,
        }
    }

    /// A new program starting at machine position `start`.
    pub fn reset(&mut self, start: AxisPos) {
        self.out.clear();
        self.prog = None;
        self.start = start;
        self.run = None;
    }

    /// The next compensated operation ready to be lowered.
    pub fn pop(&mut self) -> Option<CanonOp> {
        self.out.pop_front()
    }

    /// The end of the program: whatever is held back is given out.
    pub fn finish(&mut self) -> Result<(), CompError> {
        self.end_run()
    }

    /// Takes `op` when it would pass unchanged (compensation off in it and in the stage,
    /// nothing held or waiting): the caller lowers it where it lies instead of moving it
    /// through the stage's queue. `false`: nothing was done, [`push`](Self::push) it.
    #[inline]
    pub fn pass_through(&mut self, op: &CanonOp) -> bool {
        if self.run.is_some() || op.state.comp.is_some() || !self.out.is_empty() {
            return false;
        }
        self.first_op(op);
        self.follow(op);
        true
    }

    /// Where the program is before its first operation.
    fn first_op(&mut self, op: &CanonOp) {
        if self.prog.is_none() {
            let p = op.state.to_work(&self.start);
            self.prog = Some(p);
            self.tool = p;
        }
    }

    /// Takes one programmed operation.
    pub fn push(&mut self, op: CanonOp) -> Result<(), CompError> {
        self.first_op(&op);
        let now = op.state.comp;
        if let Some(run) = &self.run
            && (now != Some(run.comp) || op.state.plane != run.plane)
        {
            self.end_run()?;
        }
        if self.run.is_none()
            && let Some(comp) = now
        {
            self.run = Some(self.start_run(comp, &op)?);
        }
        if self.run.is_none() {
            self.pass(op);
            return Ok(());
        }
        self.compensate(op)
    }

    fn start_run(&self, comp: CutterComp, op: &CanonOp) -> Result<Run, CompError> {
        let plane = op.state.plane;
        let (a, b, _) = plane.letters();
        let k = |l: char| (l as u8 - b'X') as usize;
        let (Some(ia), Some(ib)) = (self.xyz[k(a)], self.xyz[k(b)]) else {
            return Err(CompError {
                source: op.source.clone(),
                message: format!("cutter compensation in a plane with no {a} or {b} axis"),
            });
        };
        let s = if comp.side == CompSide::Left {
            1.0
        } else {
            -1.0
        };
        Ok(Run {
            comp,
            plane,
            ax: [ia, ib],
            centre: [k(a), k(b)],
            sr: s * comp.radius,
            pending: None,
            held: Vec::new(),
            last: None,
        })
    }

    /// An operation given out unchanged (no compensation on).
    fn pass(&mut self, op: CanonOp) {
        self.follow(&op);
        self.out.push_back(op);
    }

    /// The tool follows the program through `op` (compensation off).
    fn follow(&mut self, op: &CanonOp) {
        self.track(op);
        self.tool = self.prog.unwrap_or_default();
    }

    /// Follows the programmed position through `op`.
    fn track(&mut self, op: &CanonOp) {
        let prog = self.prog.get_or_insert_with(AxisPos::default);
        match &op.kind {
            CanonKind::Single(SegmentKind::Arc { end, .. }) => *prog = *end,
            CanonKind::Single(k) => {
                if let Some(end) = k.line_end() {
                    *prog = *end;
                }
            }
            CanonKind::CannedCycle(cc) => {
                if let Some(h) = cc.holes.last() {
                    prog.0[cc.axes[0]] = h[0];
                    prog.0[cc.axes[1]] = h[1];
                }
                prog.0[cc.axes[2]] = cc.return_level;
            }
        }
    }

    fn compensate(&mut self, op: CanonOp) -> Result<(), CompError> {
        let Some(run) = self.run.as_mut() else {
            return Ok(());
        };
        let prog = self.prog.unwrap_or_default();
        let at = [prog[run.ax[0]], prog[run.ax[1]]];
        let elem = match &op.kind {
            CanonKind::CannedCycle(_) => {
                // Not applied inside a cycle: the contour ends before it and starts again
                // (a new start-up) after it.
                let comp = run.comp;
                let again = self.start_run(comp, &op)?;
                self.end_run()?;
                self.pass(op);
                self.run = Some(again);
                return Ok(());
            }
            CanonKind::Single(SegmentKind::Arc {
                end, center, dir, ..
            }) => Some(Elem::Arc {
                a: at,
                b: [end[run.ax[0]], end[run.ax[1]]],
                c: [center[run.centre[0]], center[run.centre[1]]],
                ccw: *dir == ArcDir::Ccw,
            }),
            CanonKind::Single(SegmentKind::Rapid { end } | SegmentKind::Linear { end, .. }) => {
                let b = [end[run.ax[0]], end[run.ax[1]]];
                (dist(at, b) > 1e-9).then_some(Elem::Line { a: at, b })
            }
            CanonKind::Single(_) => None,
        };
        self.track(&op);
        match elem {
            Some(e) => self.contour(op, e),
            None => self.off_plane(op),
        }
    }

    /// An operation without motion in the plane: held back behind the pending element (up to
    /// the lookahead), else given out at the tool centre's place in the plane.
    fn off_plane(&mut self, op: CanonOp) -> Result<(), CompError> {
        let lookahead = self.cfg.lookahead;
        let Some(run) = self.run.as_mut() else {
            return Ok(());
        };
        if run.pending.is_none() {
            let op = self.at_tool(op);
            self.emit(op);
            return Ok(());
        }
        run.held.push(op);
        if run.held.len() > lookahead
            && let Some(a) = run.pending.take()
        {
            run.last = Some(a.elem);
            let end = a.elem.offset_point(a.elem.end(), run.sr);
            self.give_element(a, end)?;
        }
        Ok(())
    }

    fn contour(&mut self, op: CanonOp, e: Elem) -> Result<(), CompError> {
        let (sr, radius) = match &self.run {
            Some(r) => (r.sr, r.comp.radius),
            None => return Ok(()),
        };
        if let Some(r) = e.offset_radius(sr)
            && r <= EPS
        {
            return Err(CompError {
                source: op.source.clone(),
                message: format!(
                    "the arc's radius {} is not bigger than the tool radius {} on its inside: the tool would cut into the arc",
                    fmt(geom::dist(e.start(), arc_centre(&e))),
                    fmt(radius)
                ),
            });
        }
        let Some(run) = self.run.as_mut() else {
            return Ok(());
        };
        let tool = [self.tool[run.ax[0]], self.tool[run.ax[1]]];
        match (run.pending.take(), run.last.take()) {
            (Some(a), _) => {
                let startup_a = a.startup && self.cfg.startup == CompStartup::A;
                let rapid = joint::feed_of(&op.kind).is_none();
                let j = joint::join(&a.elem, startup_a, &e, sr, rapid, self.cfg).map_err(|m| {
                    CompError {
                        source: op.source.clone(),
                        message: m,
                    }
                })?;
                self.give_element(a, j.a_end)?;
                self.give_pieces(&op, &j.corner);
                self.set_pending(op, e, j.b_start, false);
            }
            (None, Some(last)) => {
                let rapid = joint::feed_of(&op.kind).is_none();
                let j =
                    joint::join(&last, false, &e, sr, rapid, self.cfg).map_err(|m| CompError {
                        source: op.source.clone(),
                        message: m,
                    })?;
                if j.inside {
                    return self.gouge(
                        &op,
                        format!(
                            "more than {} blocks without motion in the plane before this inside corner (interp.cutter_comp_lookahead): the tool would cut into it",
                            self.cfg.lookahead
                        ),
                        j.b_start,
                    )
                    .map(|()| self.set_pending(op, e, j.b_start, false));
                }
                let mut pieces = Vec::new();
                if dist(j.a_end, tool) > EPS {
                    pieces.push(Piece::Line(j.a_end));
                }
                pieces.extend(j.corner);
                self.give_pieces(&op, &pieces);
                self.set_pending(op, e, j.b_start, false);
            }
            (None, None) => {
                if matches!(e, Elem::Arc { .. }) {
                    return Err(CompError {
                        source: op.source.clone(),
                        message: "cutter compensation started on an arc (the start-up move must be G0 or G1)".into(),
                    });
                }
                if dist(tool, e.end()) <= radius + EPS {
                    return Err(CompError {
                        source: op.source.clone(),
                        message: format!(
                            "the start-up move is not longer than the tool radius {}: start from a point farther from the contour",
                            fmt(radius)
                        ),
                    });
                }
                self.set_pending(op, e, tool, true);
            }
        }
        Ok(())
    }

    fn set_pending(&mut self, op: CanonOp, elem: Elem, start: P, startup: bool) {
        if let Some(run) = self.run.as_mut() {
            run.pending = Some(Pending {
                op,
                elem,
                start,
                startup,
            });
        }
    }

    /// Ends compensation: the pending element ends at its own offset end, held operations go
    /// out after it.
    fn end_run(&mut self) -> Result<(), CompError> {
        let Some(run) = self.run.as_mut() else {
            return Ok(());
        };
        if let Some(a) = run.pending.take() {
            let end = a.elem.offset_point(a.elem.end(), run.sr);
            self.give_element(a, end)?;
        }
        let held = self.run.as_mut().map(|r| std::mem::take(&mut r.held));
        for op in held.unwrap_or_default() {
            let op = self.at_tool(op);
            self.emit(op);
        }
        self.run = None;
        Ok(())
    }

    /// Gives out element `a` from its start to `end`, then the held operations.
    fn give_element(&mut self, a: Pending, end: P) -> Result<(), CompError> {
        let Some(run) = self.run.as_ref() else {
            return Ok(());
        };
        let sr = run.sr;
        if let Err(why) = joint::check_piece(&a.elem, a.start, end, sr) {
            self.gouge(&a.op, why, end)?;
        } else if dist(a.start, end) > EPS || matches!(a.elem, Elem::Arc { .. }) {
            let op = self.piece_op(&a.op, &a.elem, end);
            self.emit(op);
        }
        let held = self.run.as_mut().map(|r| std::mem::take(&mut r.held));
        for op in held.unwrap_or_default() {
            let op = self.at_tool(op);
            self.emit(op);
        }
        Ok(())
    }

    /// A gouge: an error, or (`cutter_comp_gouge = "suppress"`) a warning and a straight
    /// move to `to` in place of the element.
    fn gouge(&mut self, op: &CanonOp, why: String, to: P) -> Result<(), CompError> {
        if self.cfg.gouge == CompGouge::Error {
            return Err(CompError {
                source: op.source.clone(),
                message: format!("cutter compensation: {why}"),
            });
        }
        let n = op.source.n.map_or(String::new(), |n| format!(" N{n}"));
        let warn = CanonOp {
            kind: CanonKind::Single(SegmentKind::Message {
                text: format!(
                    "warning: cutter compensation suppressed block{n} (line {}): {why}",
                    op.source.line
                ),
            }),
            source: op.source.clone(),
            state: op.state.clone(),
        };
        self.out.push_back(warn);
        let line = self.line_op(op, to);
        self.emit(line);
        Ok(())
    }

    /// Connecting pieces (corners) made for `op`'s block, from the tool centre.
    fn give_pieces(&mut self, op: &CanonOp, pieces: &[Piece]) {
        for p in pieces {
            let out = match *p {
                Piece::Line(to) => self.line_op(op, to),
                Piece::Arc { to, c, ccw } => self.corner_arc_op(op, to, c, ccw),
            };
            self.emit(out);
        }
    }

    /// A straight move of `op`'s kind (rapid or feed) to `to` in the plane, other axes where
    /// the tool is.
    fn line_op(&self, op: &CanonOp, to: P) -> CanonOp {
        let mut end = self.tool;
        if let Some(run) = &self.run {
            end.0[run.ax[0]] = to[0];
            end.0[run.ax[1]] = to[1];
        }
        let kind = match joint::feed_of(&op.kind) {
            Some(feed) => SegmentKind::Linear { end, feed },
            None => SegmentKind::Rapid { end },
        };
        CanonOp {
            kind: CanonKind::Single(kind),
            source: op.source.clone(),
            state: op.state.clone(),
        }
    }

    /// `op` (a line or an arc of element `e`) ending at `end` in the plane; an arc turns
    /// around `e`'s centre (a corner arc: in the plane only, at the tool's other axes).
    fn piece_op(&self, op: &CanonOp, e: &Elem, end: P) -> CanonOp {
        let Some(run) = &self.run else {
            return op.clone();
        };
        let CanonKind::Single(kind) = &op.kind else {
            return op.clone();
        };
        let mut kind = kind.clone();
        let place = |p: &mut AxisPos| {
            p.0[run.ax[0]] = end[0];
            p.0[run.ax[1]] = end[1];
        };
        match (&mut kind, e) {
            (
                SegmentKind::Arc {
                    end: pe, center, ..
                },
                Elem::Arc { c, .. },
            ) => {
                place(pe);
                center[run.centre[0]] = c[0];
                center[run.centre[1]] = c[1];
            }
            (
                SegmentKind::Rapid { end: pe } | SegmentKind::Linear { end: pe, .. },
                Elem::Line { .. },
            ) => place(pe),
            _ => {}
        }
        CanonOp {
            kind: CanonKind::Single(kind),
            source: op.source.clone(),
            state: op.state.clone(),
        }
    }

    /// A corner arc around `c` to `to`, made for `op`'s block: in the plane only, at the
    /// tool's other axes, at the block's feed.
    fn corner_arc_op(&self, op: &CanonOp, to: P, c: P, ccw: bool) -> CanonOp {
        let mut end = self.tool;
        let mut center = [0.0; 3];
        for (k, i) in self.xyz.iter().enumerate() {
            if let Some(i) = i {
                center[k] = self.tool[*i];
            }
        }
        let plane = self.run.as_ref().map_or(op.state.plane, |r| r.plane);
        if let Some(run) = &self.run {
            end.0[run.ax[0]] = to[0];
            end.0[run.ax[1]] = to[1];
            center[run.centre[0]] = c[0];
            center[run.centre[1]] = c[1];
        }
        CanonOp {
            kind: CanonKind::Single(SegmentKind::Arc {
                end,
                center,
                plane,
                dir: if ccw { ArcDir::Ccw } else { ArcDir::Cw },
                turns: 0,
                feed: joint::feed_of(&op.kind).unwrap_or(0.0),
            }),
            source: op.source.clone(),
            state: op.state.clone(),
        }
    }

    /// `op` with its position in the plane moved to where the tool centre is.
    fn at_tool(&self, mut op: CanonOp) -> CanonOp {
        let Some(run) = &self.run else { return op };
        if let CanonKind::Single(k) = &mut op.kind {
            let end = match k {
                SegmentKind::Rapid { end } | SegmentKind::Linear { end, .. } => Some(end),
                SegmentKind::Tap(t) => Some(&mut t.end),
                _ => None,
            };
            if let Some(end) = end {
                for i in run.ax {
                    end.0[i] = self.tool[i];
                }
            }
        }
        op
    }

    /// Gives out `op` and follows the tool centre.
    fn emit(&mut self, op: CanonOp) {
        if let CanonKind::Single(k) = &op.kind {
            match k {
                SegmentKind::Arc { end, .. } => self.tool = *end,
                k => {
                    if let Some(end) = k.line_end() {
                        self.tool = *end;
                    }
                }
            }
        }
        self.out.push_back(op);
    }
}

fn arc_centre(e: &Elem) -> P {
    match *e {
        Elem::Arc { c, .. } => c,
        Elem::Line { a, .. } => a,
    }
}
