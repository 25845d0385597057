//! One block's execution ([`Exec`]): its collected words run against the modal state and
//! become [`Segment`]s (modes, feed and speed, M codes, dwell, straight and arc motion; the
//! offsets and canned cycles are in their own files and extend `Exec`).

use std::collections::VecDeque;
use std::sync::Arc;

use cnc402_config::{MAX_AXES, MAX_SPINDLES, MachineConfig};
use cnc402_lang::ast::{Comment, Line, Span};
use cnc402_lang::{Dialect, NcError, SourceFile};
use cnc402_motion::segment::{ArcDir, AxisPos, Plane, SegmentKind, Source, SpindleDir, StopKind};

use super::arc::{self, ArcError, ArcGeom, ArcTolerance};
use super::options::Options;
use super::state::{Cycle, CycleData, ModalState, Motion};
use super::words::{Arg, GGroup, Words, fmt_num, g_dec, g_name};
use crate::canon::{CanonKind, CanonOp, CanonState};

/// The modal state as canonical operations carry it, shared with the previous operation
/// (`last`) when nothing in it changed, so a long program does not copy it per move.
pub(crate) fn shared_state(st: &ModalState, last: &mut Option<Arc<CanonState>>) -> Arc<CanonState> {
    match last.as_ref() {
        Some(s) if st.canon_state_is(s) => s.clone(),
        _ => {
            let s = Arc::new(st.canon_state());
            *last = Some(s.clone());
            s
        }
    }
}

/// The canonical operation one segment of `kind` is: machine positions (as the block layer
/// computes them) recorded in work coordinates under the current state.
pub(crate) fn single_op(
    xyz: [Option<usize>; 3],
    st: &ModalState,
    last: &mut Option<Arc<CanonState>>,
    kind: SegmentKind,
    source: Source,
) -> CanonOp {
    let state = shared_state(st, last);
    let kind = state.convert(kind, xyz, false);
    CanonOp {
        kind: CanonKind::Single(kind),
        source,
        state,
    }
}

/// Axis indices a block looks up, found once from the config (which does not change).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct AxisMap {
    /// X, Y and Z (arc centres are X Y Z).
    pub xyz: [Option<usize>; 3],
    /// Each spindle's axis by number − 1.
    pub spindles: [Option<usize>; MAX_SPINDLES],
    /// An axis named C (else a plain C in a G1 block may be a chamfer).
    pub c: Option<usize>,
    /// Each axis's soft limits widened by the 1e-9 every target is allowed past them
    /// (±∞ for an axis without limits or not configured), read in one place for each target.
    pub limits: [(f64, f64); MAX_AXES],
}

/// All of `vs` are finite. (`v * 0.0` is ±0 for a finite `v`, NaN for ±inf and NaN: one
/// pass without a branch per value.)
pub(crate) fn all_finite(vs: &[f64]) -> bool {
    vs.iter().fold(0.0, |sum, v| sum + v * 0.0) == 0.0
}

/// The spindle a LinuxCNC block without `$` acts on: the program's default
/// (`Options::default_spindle`) when the machine has it, else spindle 1.
pub(crate) fn linuxcnc_default_spindle(cfg: &MachineConfig, opts: &Options) -> u8 {
    Some(opts.default_spindle)
        .filter(|&n| cfg.spindle_axis(n).is_some())
        .unwrap_or(1)
}

impl AxisMap {
    /// Whether a target is past some axis's soft limits (widened as they are held here;
    /// every axis without a branch each; a NaN is inside: `check_finite` has it).
    pub(crate) fn outside_limits(&self, end: &AxisPos) -> bool {
        (0..MAX_AXES).fold(false, |out, i| {
            let (lo, hi) = self.limits[i];
            out | (end[i] < lo) | (end[i] > hi)
        })
    }

    pub(crate) fn new(cfg: &MachineConfig) -> AxisMap {
        let mut limits = [(f64::NEG_INFINITY, f64::INFINITY); MAX_AXES];
        for (l, ax) in limits.iter_mut().zip(&cfg.axes) {
            if let Some((lo, hi)) = ax.soft_limits {
                *l = (lo - 1e-9, hi + 1e-9);
            }
        }
        AxisMap {
            xyz: crate::lower::xyz_indices(cfg),
            spindles: cfg.spindle_axes(),
            c: cfg.axis_index('C'),
            limits,
        }
    }
}

/// One block being executed.
pub(crate) struct Exec<'a> {
    pub cfg: &'a MachineConfig,
    /// Axis indices of `cfg` found once.
    pub map: &'a AxisMap,
    pub opts: &'a Options,
    pub src: &'a SourceFile,
    /// The dialect the program is read in (where controls differ).
    pub dialect: Dialect,
    pub st: &'a mut ModalState,
    pub w: &'a mut Words,
    pub source: Source,
    pub line_span: Span,
    /// The canonical operations the block makes, in order: those of `out` from `first` on
    /// (the interpreter's queue, where they wait to be handed out).
    pub out: &'a mut VecDeque<CanonOp>,
    pub first: usize,
    /// The state the last operation ran under, shared by the next while it is the same.
    pub canon: &'a mut Option<Arc<CanonState>>,
    /// M2/M30 was executed.
    pub end: bool,
    /// The block programs the tool length offset (G43/G44/G49, or H in G43/G44): the tool
    /// axis moves by the change even without its own word.
    pub tlo_commanded: bool,
    /// G49 in a G28/G30/G53 block: the offset is cancelled after the block's moves.
    pub tlo_cancel_after: bool,
    /// The block's move finished a held corner move or was held itself.
    pub corner_done: bool,
    /// LinuxCNC's `$-1`: the block's S and M3/M4/M5 act on every spindle.
    pub all_spindles: bool,
}

/// `(MSG, text)` → `text`.
fn msg_text(c: &Comment) -> Option<String> {
    let t = c.text.trim_start();
    // Byte-wise: the comment may hold any UTF-8, and `MSG,` is ASCII.
    let head = t.as_bytes().get(..4)?;
    if head[..3].eq_ignore_ascii_case(b"MSG") && head[3] == b',' {
        Some(t[4..].trim().to_string())
    } else {
        None
    }
}

fn group_name(g: GGroup) -> &'static str {
    match g {
        GGroup::NonModal => "00 (one-shot)",
        GGroup::Motion => "01 (motion)",
        GGroup::Plane => "02 (plane)",
        GGroup::Distance => "03 (G90/G91)",
        GGroup::ArcDistance => "(G90.1/G91.1, arc centre distance)",
        GGroup::FeedMode => "05 (feed mode)",
        GGroup::Units => "06 (units)",
        GGroup::Cycle => "09 (canned cycle)",
        GGroup::ReturnMode => "10 (cycle return)",
        GGroup::WorkOffset => "14 (work offset)",
        GGroup::ToolLength => "08 (tool length compensation)",
        GGroup::PathMode => "15 (exact stop / cutting mode)",
        GGroup::ExactStopOnce => "00 (G9 exact stop)",
        GGroup::MacroCall => "12 (macro call)",
        GGroup::CutterComp => "07 (cutter compensation)",
        GGroup::Cancel(11) => "11 (scaling)",
        GGroup::Cancel(16) => "16 (coordinate rotation)",
        GGroup::Cancel(_) => "17 (polar coordinates)",
    }
}

/// M code groups: two codes of one group in a block are an error.
fn m_group(code: u32) -> Result<u8, String> {
    Ok(match code {
        0 | 1 | 2 | 30 => 0,
        3..=5 | 19 => 1,
        6 => 2,
        29 => 3,
        98 | 99 => 4,
        // M7 and M8 may share a block (mist and flood); M9 contradicts either.
        7 => 5,
        8 => 6,
        9 => 7,
        _ => return Err(format!("unknown M code M{code}")),
    })
}

impl Exec<'_> {
    pub fn err(&self, span: Span, msg: impl Into<String>) -> NcError {
        NcError::new(self.src, span, msg)
    }

    /// The span of `letter`'s word if the block has one, else of the whole block.
    pub fn span_of(&self, letters: &[char]) -> Span {
        letters
            .iter()
            .find_map(|&l| self.w.peek(l).map(|a| a.span))
            .unwrap_or(if self.w.span == Span::default() {
                self.line_span
            } else {
                self.w.span
            })
    }

    /// Adds the operation that one segment of `kind` is (its positions in machine
    /// coordinates, as the block computes them), recorded in work coordinates under the
    /// state it runs in.
    pub fn push(&mut self, kind: SegmentKind) {
        let op = single_op(self.map.xyz, self.st, self.canon, kind, self.source.clone());
        self.out.push_back(op);
    }

    /// The operations this block has made so far.
    fn ops(&self) -> impl Iterator<Item = &CanonOp> {
        self.out.range(self.first..)
    }

    /// The modal state as canonical operations carry it (see [`shared_state`]).
    pub fn canon_state(&mut self) -> Arc<CanonState> {
        shared_state(self.st, self.canon)
    }

    /// Executes one block of `line` (from `src`), its words already collected in `w`, against
    /// the modal state `st`: the operations it makes appended to `out` (none on an error),
    /// and whether it ended the program (M2/M30).
    pub(crate) fn execute(
        (cfg, map): (&MachineConfig, &AxisMap),
        opts: &Options,
        (src, dialect): (&SourceFile, Dialect),
        (st, canon): (&mut ModalState, &mut Option<Arc<CanonState>>),
        (w, line): (&mut Words, &Line),
        out: &mut VecDeque<CanonOp>,
    ) -> Result<bool, NcError> {
        let first = out.len();
        let mut ex = Exec {
            cfg,
            map,
            opts,
            src,
            dialect,
            st,
            canon,
            w,
            source: Source {
                file: src.name.clone(),
                line: line.line_no,
                n: line.n.map(|n| n.value),
            },
            line_span: line.span,
            out,
            first,
            end: false,
            tlo_commanded: false,
            tlo_cancel_after: false,
            corner_done: false,
            all_spindles: false,
        };
        match ex.run(line) {
            Ok(()) => Ok(ex.end),
            Err(e) => {
                ex.out.truncate(first);
                Err(e)
            }
        }
    }

    pub(crate) fn run(&mut self, line: &Line) -> Result<(), NcError> {
        for c in &line.comments {
            if let Some(text) = msg_text(c) {
                self.push(SegmentKind::Message { text });
            }
        }
        self.machine_m_codes()?;
        self.check_groups()?;
        self.modes()?;
        self.cutter_comp()?;
        self.feed_word()?;
        let spindle_m = self.w.m.iter().any(|m| matches!(m.0, 3..=5));
        self.spindle_selection()?;
        self.for_block_spindles(|ex| ex.speed_word(spindle_m))?;
        if let Some(t) = self.w.take('T') {
            self.st.tool_selected = self.whole(t, "T (tool number)")?;
        }
        self.tool_length()?;
        self.m_before_motion()?;
        match self.w.g_of(GGroup::NonModal) {
            Some((4, _)) if self.dialect == Dialect::LinuxCnc => {
                // LinuxCNC runs a dwell and a move of one block in that order.
                self.dwell()?;
                self.motion()?;
            }
            Some((4, _)) => self.dwell()?,
            Some((10, span)) => self.data_input(span)?,
            Some((92, span)) => self.set_coordinates(span)?,
            Some((code @ (28 | 30), span)) => self.reference_return(code, span)?,
            Some((29, span)) => self.return_from_reference(span)?,
            _ => self.motion()?,
        }
        if self.tlo_cancel_after {
            // The vector left in `pos` (if Z did not move) is taken out at Z's next move.
            self.st.set_tool_length(super::state::ToolLength::Off, 0.0);
        }
        self.m_after_motion();
        self.check_corner_words()?;
        self.check_finite()?;
        if let Some((c, a)) = self.w.first_unused() {
            return Err(self
                .err(a.span, format!("address {c} is not used in this block"))
                .with_expected(self.expected_here()));
        }
        Ok(())
    }

    /// Every number the block computed is finite: a target, feed, speed, dwell, arc centre or
    /// offset past f64's range is an error at the word it came from ("X overflows"), so that
    /// no `inf` or `NaN` reaches a segment, the planner or the output.
    fn check_finite(&self) -> Result<(), NcError> {
        if self.surely_finite() {
            debug_assert!(self.first_non_finite().is_none());
            return Ok(());
        }
        let Some((letters, what)) = self.first_non_finite() else {
            return Ok(());
        };
        Err(self
            .err(
                self.span_of(&letters),
                format!("{what} overflows (not a finite number)"),
            )
            .with_expected("values that stay within ±1.8e308"))
    }

    /// The usual block's quick answer for [`check_finite`](Self::check_finite): `true` when
    /// no number [`first_non_finite`](Self::first_non_finite) looks at can be non-finite
    /// (every slot of each position, not just the configured axes'); `false` when one is,
    /// or the block made an operation other than a rapid or a feed move: the search decides.
    fn surely_finite(&self) -> bool {
        // `v * 0.0` is ±0 for a finite `v`, NaN for ±inf and NaN: the sum is 0 when all
        // are finite (one pass without a branch per value).
        let finite = all_finite;
        let st = &*self.st;
        let mut ok = finite(&st.pos.0) && finite(&st.shift) && finite(&[st.feed, st.speed, st.tlo]);
        for op in self.ops() {
            ok &= finite(&op.state.offset.0)
                && match &op.kind {
                    CanonKind::Single(SegmentKind::Rapid { end }) => finite(&end.0),
                    CanonKind::Single(SegmentKind::Linear { end, feed }) => {
                        finite(&end.0) && feed.is_finite()
                    }
                    _ => false,
                };
        }
        ok
    }

    /// The words to blame and what overflowed, for the first non-finite number of the
    /// block's operations or of the modal state it leaves.
    fn first_non_finite(&self) -> Option<(Vec<char>, String)> {
        // Looked up by index, not gathered: this runs for every block.
        let axes = &self.cfg.axes;
        let bad_axis = |p: &AxisPos| {
            (0..axes.len())
                .find(|&i| !p.0[i].is_finite())
                .map(|i| (vec![axes[i].name], axes[i].name.to_string()))
        };
        let bad = |ok: bool, letters: &[char], what: &str| {
            (!ok).then(|| (letters.to_vec(), what.to_string()))
        };
        let feed = ['F', 'S'];
        for op in self.ops() {
            let found = match &op.kind {
                CanonKind::Single(k) => match k {
                    SegmentKind::Rapid { end } => bad_axis(end),
                    SegmentKind::Linear { end, feed: f } => {
                        bad_axis(end).or_else(|| bad(f.is_finite(), &feed, "the feed"))
                    }
                    SegmentKind::Tap(t) => bad_axis(&t.end)
                        .or_else(|| bad(t.feed.is_finite(), &feed, "the feed"))
                        .or_else(|| bad(t.pitch.is_finite(), &feed, "the tap pitch")),
                    SegmentKind::Arc {
                        end,
                        center,
                        feed: f,
                        ..
                    } => bad_axis(end)
                        .or_else(|| {
                            let ok = center.iter().all(|c| c.is_finite());
                            bad(ok, &['R', 'I', 'J', 'K'], "the arc centre")
                        })
                        .or_else(|| bad(f.is_finite(), &feed, "the feed")),
                    SegmentKind::Dwell { seconds } => {
                        bad(seconds.is_finite(), &['P', 'X'], "the dwell")
                    }
                    SegmentKind::Spindle { rpm, .. } => bad(rpm.is_finite(), &['S'], "the speed"),
                    SegmentKind::SpindleOrient { angle, program, .. } => bad(
                        angle.is_finite() && program.is_none_or(f64::is_finite),
                        &['C'],
                        "the spindle angle",
                    ),
                    _ => None,
                },
                CanonKind::CannedCycle(cc) => {
                    let [ia, ib, id] = cc.axes.map(|i| axes.get(i).map_or('Z', |a| a.name));
                    let levels = [cc.initial_level, cc.r_level, cc.bottom, cc.return_level];
                    bad_axis(&cc.start)
                        .or_else(|| {
                            let ok = cc.holes.iter().flatten().all(|v| v.is_finite());
                            bad(ok, &[ia, ib], "a hole position")
                        })
                        .or_else(|| {
                            let ok = levels.iter().all(|v| v.is_finite());
                            bad(ok, &['R', id], "a drilling level")
                        })
                        .or_else(|| bad(cc.feed.is_finite(), &feed, "the feed"))
                }
            };
            if found.is_some() {
                return found;
            }
            if let Some((l, what)) = bad_axis(&op.state.offset) {
                return Some((l, format!("the offset on {what}")));
            }
        }
        let st = &*self.st;
        bad_axis(&st.pos)
            .or_else(|| {
                bad_axis(&AxisPos(st.shift)).map(|(l, w)| (l, format!("the G92 shift on {w}")))
            })
            .or_else(|| bad(st.feed.is_finite(), &feed, "the feed"))
            .or_else(|| bad(st.speed.is_finite(), &['S'], "the speed"))
            .or_else(|| bad(st.tlo.is_finite(), &['H'], "the tool length offset"))
    }

    fn expected_here(&self) -> String {
        let axes: String = self.cfg.axes.iter().map(|a| a.name).collect();
        if self.st.cycle.is_some() {
            "a canned cycle word (the plane and drilling axes, R, Q, P, F, K, L) or G, M, S, T"
                .into()
        } else {
            match self.st.motion {
                Motion::ArcCw | Motion::ArcCcw => {
                    format!("axis words ({axes}), I J K or R, F, or G, M, S, T")
                }
                _ => format!("axis words ({axes}), F, G, M, S, T"),
            }
        }
    }

    /// A whole, non-negative number (tool numbers, repeat counts).
    pub fn whole(&self, a: Arg, what: &str) -> Result<u32, NcError> {
        if a.v < 0.0 || a.v.fract() != 0.0 || a.v > 1e9 {
            return Err(self
                .err(
                    a.span,
                    format!("{what} must be a whole number >= 0, not {}", fmt_num(a.v)),
                )
                .with_expected("a whole number"));
        }
        Ok(a.v as u32)
    }

    fn check_groups(&self) -> Result<(), NcError> {
        let g = self.w.g();
        for (i, &(code, grp, span)) in g.iter().enumerate() {
            if let Some(&(c0, _, _)) = g[..i].iter().find(|x| x.1 == grp) {
                return Err(self.err(
                    span,
                    format!(
                        "{} and {} are both in modal group {}: a block takes one G code of each group",
                        g_name(c0),
                        g_name(code),
                        group_name(grp)
                    ),
                ));
            }
        }
        let motion = g.iter().find(|x| x.1 == GGroup::Motion);
        let cycle = g.iter().find(|x| x.1 == GGroup::Cycle && x.0 != 80);
        if let (Some(m), Some(c)) = (motion, cycle) {
            let later = if m.2.start > c.2.start { m } else { c };
            return Err(self.err(
                later.2,
                format!(
                    "G{} and G{} in one block: both set what the axis words do",
                    m.0, c.0
                ),
            ));
        }
        if g.iter().any(|x| x.0 == 4)
            && self.dialect != Dialect::LinuxCnc
            && let Some(o) = motion.or(cycle)
        {
            return Err(self.err(
                o.2,
                format!("G{} cannot share a block with G4 (dwell)", o.0),
            ));
        }
        let mut seen: [Option<u32>; 8] = [None; 8];
        for &(code, span) in &self.w.m {
            let grp = m_group(code).map_err(|m| self.err(span, m))?;
            if let Some(c0) = seen[grp as usize] {
                return Err(self.err(
                    span,
                    format!("M{c0} and M{code} in one block: they contradict each other"),
                ));
            }
            seen[grp as usize] = Some(code);
            if code == 9
                && let Some(on) = seen[5].or(seen[6])
            {
                return Err(self.err(
                    span,
                    format!("M{on} and M9 in one block: they contradict each other"),
                ));
            }
            if matches!(code, 7 | 8) && seen[7].is_some() {
                return Err(self.err(
                    span,
                    format!("M9 and M{code} in one block: they contradict each other"),
                ));
            }
        }
        Ok(())
    }

    fn modes(&mut self) -> Result<(), NcError> {
        if let Some((c, _)) = self.w.g_of(GGroup::Units) {
            self.st.inch = c == 20;
        }
        if let Some((c, span)) = self.w.g_of(GGroup::Plane) {
            let p = match c {
                17 => Plane::XY,
                18 => Plane::ZX,
                _ => Plane::YZ,
            };
            let cancelling = self.w.g_of(GGroup::Cycle).is_some_and(|g| g.0 == 80)
                || self.w.g_of(GGroup::Motion).is_some();
            self.plane_change_in_comp(p, c, span)?;
            if p != self.st.plane && self.st.cycle.is_some() && !cancelling {
                return Err(self
                    .err(span, format!("G{c} while a canned cycle is active"))
                    .with_expected("G80 before changing the plane"));
            }
            self.st.plane = p;
        }
        if let Some((c, _)) = self.w.g_of(GGroup::Distance) {
            self.st.incremental = c == 91;
        }
        if let Some((c, _)) = self.w.g_of(GGroup::ArcDistance) {
            self.st.arc_center_absolute = c == g_dec(90, 1);
        }
        if let Some((c, _)) = self.w.g_of(GGroup::FeedMode) {
            self.st.feed_per_rev = c == 95;
        }
        if let Some((c, _)) = self.w.g_of(GGroup::WorkOffset) {
            self.st.work_offset = (c - 54) as usize;
        }
        if let Some((c, _)) = self.w.g_of(GGroup::ReturnMode) {
            self.st.return_to_r = c == 99;
        }
        self.st.exact_stop_once = self.w.g_of(GGroup::ExactStopOnce).is_some();
        if let Some((c, span)) = self.w.g_of(GGroup::PathMode) {
            if c == 8 || c == g_dec(5, 1) {
                // The P (G08) or Q (G05.1) is the switch: the tolerance is the configured one.
                self.st.path_mode = self.fanuc_path_switch(c, span)?;
                self.st.path_tolerance = self.cfg.interp.path_tolerance;
                self.st.path_collinear = self.cfg.interp.collinear_tolerance;
            } else {
                self.st.path_mode = c;
                if c == 64 {
                    (self.st.path_tolerance, self.st.path_collinear) = self.g64_tolerance()?;
                }
            }
        }
        if let Some((80, _)) = self.w.g_of(GGroup::Cycle) {
            self.cancel_cycle();
        }
        Ok(())
    }

    /// Fanuc's on/off path-mode switches as G64 (on, at the configured tolerance) / G61
    /// (off): G08 P1/P0 (lookahead) and G05.1 Q1/Q0 (AI contour control).
    fn fanuc_path_switch(&mut self, code: u32, span: Span) -> Result<u32, NcError> {
        if code != 8 && self.dialect == Dialect::LinuxCnc {
            // LinuxCNC's G5.1 is a quadratic B-spline move, not Fanuc's contour control.
            return Err(self
                .err(
                    span,
                    "G5.1 (quadratic B-spline, LinuxCNC) is not supported yet",
                )
                .with_expected("G1/G2/G3 moves, or G64 P for continuous path"));
        }
        let (name, letter, what) = if code == 8 {
            ("G08", 'P', "lookahead")
        } else {
            ("G05.1", 'Q', "AI contour control")
        };
        let expected =
            format!("{name} {letter}1 ({what} on, as G64) or {name} {letter}0 (off, as G61)");
        match self.w.take(letter) {
            Some(a) if a.v == 1.0 => Ok(64),
            Some(a) if a.v == 0.0 => Ok(61),
            Some(a) => Err(self
                .err(
                    a.span,
                    format!("{name} {letter}{}: unknown {what} switch", fmt_num(a.v)),
                )
                .with_expected(expected)),
            None => Err(self
                .err(span, format!("{name} without {letter}"))
                .with_expected(expected)),
        }
    }

    /// The tolerances of a G64 block (path, collinearity; mm): its `P` (LinuxCNC's meaning,
    /// in program units, > 0), else the config's `interp.path_tolerance`; `Q` (LinuxCNC's
    /// collinearity tolerance) only with `P`, else the config's `interp.collinear_tolerance`
    /// (LinuxCNC takes P there: see README "Continuous path" for why cnc402 does not). Both at
    /// most `interp.max_path_tolerance`. A block whose P is a dwell, a G10/G28/G30 selector or
    /// canned-cycle data leaves that P alone.
    fn g64_tolerance(&mut self) -> Result<(f64, f64), NcError> {
        let defaults = (
            self.cfg.interp.path_tolerance,
            self.cfg.interp.collinear_tolerance,
        );
        let p_taken = self.w.g_of(GGroup::NonModal).is_some()
            || self.w.g_of(GGroup::Cycle).is_some_and(|g| g.0 != 80)
            || self.st.cycle.is_some();
        if p_taken {
            return Ok(defaults);
        }
        let expected = "G64, G64 P<tolerance> or G64 P<tolerance> Q<tolerance>, each > 0";
        let p = self.w.take('P');
        let q = self.w.take('Q');
        if let (None, Some(q)) = (p, q) {
            return Err(self
                .err(q.span, format!("G64 Q{} without P", fmt_num(q.v)))
                .with_expected("G64 P<path tolerance> Q<collinearity tolerance>"));
        }
        let max = self.cfg.interp.max_path_tolerance;
        for (letter, what, w) in [('P', "path", p), ('Q', "collinearity", q)] {
            let Some(w) = w else { continue };
            let mm = w.v * self.st.unit();
            if !(w.v > 0.0 && w.v.is_finite()) {
                return Err(self
                    .err(
                        w.span,
                        format!(
                            "G64 {letter}{}: the {what} tolerance must be > 0",
                            fmt_num(w.v)
                        ),
                    )
                    .with_expected(expected));
            }
            if mm > max * (1.0 + 1e-12) {
                return Err(self
                    .err(
                        w.span,
                        format!(
                            "G64 {letter}{}: larger than the configured maximum \
                             (interp.max_path_tolerance = {} mm)",
                            fmt_num(w.v),
                            fmt_num(max)
                        ),
                    )
                    .with_expected(format!("a tolerance of at most {} mm", fmt_num(max))));
            }
        }
        let unit = self.st.unit();
        Ok((
            p.map_or(defaults.0, |p| p.v * unit),
            q.map_or(defaults.1, |q| q.v * unit),
        ))
    }

    fn cancel_cycle(&mut self) {
        self.st.cycle = None;
        self.st.cycle_data = CycleData::default();
        self.st.rigid = false;
    }

    fn feed_word(&mut self) -> Result<(), NcError> {
        if let Some(f) = self.w.take('F') {
            if f.v < 0.0 {
                return Err(self
                    .err(f.span, "F must not be negative")
                    .with_expected("F >= 0"));
            }
            self.st.feed = f.v * self.st.unit();
        }
        Ok(())
    }

    /// The axis of the selected spindle (see [`ModalState::spindle_sel`]).
    pub(crate) fn spindle_axis(&self) -> Option<usize> {
        self.cfg.spindle_axis(self.st.spindle_sel)
    }

    /// The spindle this block's S, M3/M4/M5 and M19 act on. Fanuc's multi-spindle control:
    /// `P` in the block (1 or 2), kept until the next `P` (a `P` that the block's dwell, G10,
    /// G30 or canned cycle takes is theirs). LinuxCNC: `$` (spindles counted from 0) for
    /// this block only, the program's default spindle (`Options::default_spindle`) without.
    fn spindle_selection(&mut self) -> Result<(), NcError> {
        // Haas's `M19 P…` is the orientation angle, not a spindle.
        let orient_p = self.dialect != Dialect::Haas;
        let spindle_block = self.w.has('S')
            || (self.w.m.iter()).any(|m| matches!(m.0, 3..=5) || (m.0 == 19 && orient_p));
        let (number, span) = if self.dialect == Dialect::LinuxCnc {
            let default = linuxcnc_default_spindle(self.cfg, self.opts);
            match self.w.dollar.take() {
                None => (default, None),
                Some(a) if a.v == -1.0 => {
                    self.all_spindles = true;
                    (default, Some(a.span))
                }
                Some(a) if a.v.fract() == 0.0 && (0.0..MAX_SPINDLES as f64).contains(&a.v) => {
                    (a.v as u8 + 1, Some(a.span))
                }
                Some(a) => {
                    return Err(self
                        .err(a.span, format!("${} is not a spindle", fmt_num(a.v)))
                        .with_expected(format!("$0..${} or $-1 (all)", MAX_SPINDLES - 1)));
                }
            }
        } else {
            if !spindle_block || self.p_is_taken() {
                return Ok(());
            }
            let Some(p) = self.w.take('P') else {
                return Ok(());
            };
            if p.v.fract() != 0.0 || !(1.0..=MAX_SPINDLES as f64).contains(&p.v) {
                return Err(self
                    .err(p.span, format!("P{} is not a spindle", fmt_num(p.v)))
                    .with_expected(format!("P1..P{MAX_SPINDLES} (the spindle's number)")));
            }
            (p.v as u8, Some(p.span))
        };
        if let Some(at) = span {
            if !spindle_block {
                return Err(self
                    .err(at, "a spindle selection without S, M3, M4, M5 or M19")
                    .with_expected("the spindle's S, M3/M4/M5 or M19 in this block"));
            }
            if self.cfg.spindle_axis(number).is_none() {
                return Err(self.err(
                    at,
                    format!("spindle {number} is not configured (axis … spindle = {number})"),
                ));
            }
        }
        self.st.select_spindle(number);
        Ok(())
    }

    /// Runs `f` for the selected spindle, or (LinuxCNC's `$-1`) for every configured
    /// spindle in turn, the selection left as it was.
    fn for_block_spindles(
        &mut self,
        mut f: impl FnMut(&mut Self) -> Result<(), NcError>,
    ) -> Result<(), NcError> {
        if !self.all_spindles {
            return f(self);
        }
        let selected = self.st.spindle_sel;
        for number in 1..=MAX_SPINDLES as u8 {
            if self.cfg.spindle_axis(number).is_some() {
                self.st.select_spindle(number);
                f(self)?;
            }
        }
        self.st.select_spindle(selected);
        Ok(())
    }

    /// M3/M4/M5 of the selected spindle.
    fn spindle_m(&mut self, code: u32, span: Span) -> Result<(), NcError> {
        self.check_spindle_configured(span)?;
        let dir = match code {
            3 => SpindleDir::Cw,
            4 => SpindleDir::Ccw,
            _ => SpindleDir::Stop,
        };
        self.st.spindle = dir;
        let rpm = if dir == SpindleDir::Stop {
            0.0
        } else {
            self.st.speed
        };
        self.push(SegmentKind::Spindle {
            rpm,
            dir,
            spindle: self.st.spindle_sel,
        });
        Ok(())
    }

    /// The block's `P` belongs to its dwell, G10, G28/G30 or canned cycle (a cycle in force
    /// takes the `P` of every block that has no motion code).
    fn p_is_taken(&self) -> bool {
        let cycle_code = self
            .w
            .g_of(GGroup::Cycle)
            .is_some_and(|(c, _)| Cycle::from_code(c).is_some());
        let cycle_on = self.st.cycle.is_some() && self.w.g_of(GGroup::Motion).is_none();
        self.w.g_of(GGroup::NonModal).is_some() || cycle_code || cycle_on
    }

    fn speed_word(&mut self, spindle_m: bool) -> Result<(), NcError> {
        let Some(s) = self.w.take('S') else {
            return Ok(());
        };
        if s.v < 0.0 {
            return Err(self
                .err(s.span, "S must not be negative")
                .with_expected("S >= 0"));
        }
        if let Some(max) = self.spindle_axis().and_then(|i| self.cfg.axes[i].max_rpm)
            && s.v > max
        {
            return Err(self.err(
                s.span,
                format!(
                    "S{} is above the spindle's max_rpm {}",
                    fmt_num(s.v),
                    fmt_num(max)
                ),
            ));
        }
        let changed = s.v != self.st.speed;
        self.st.speed = s.v;
        if changed && !spindle_m && self.st.spindle != SpindleDir::Stop {
            self.push(SegmentKind::Spindle {
                rpm: s.v,
                dir: self.st.spindle,
                spindle: self.st.spindle_sel,
            });
        }
        Ok(())
    }

    fn m_before_motion(&mut self) -> Result<(), NcError> {
        if self.w.m.is_empty() {
            // Most blocks: no copy of the (empty) list, no coolant event.
            return Ok(());
        }
        let ms = self.w.m.clone();
        let mut coolant = false;
        for (code, span) in ms {
            match code {
                7..=9 => {
                    coolant = true;
                    match code {
                        7 => self.st.mist = true,
                        8 => self.st.flood = true,
                        _ => (self.st.mist, self.st.flood) = (false, false),
                    }
                }
                6 => {
                    self.st.tool_loaded = Some(self.st.tool_selected);
                    self.push(SegmentKind::ToolChange {
                        tool: self.st.tool_selected,
                    });
                }
                29 => self.st.rigid = true,
                3..=5 => self.for_block_spindles(|ex| ex.spindle_m(code, span))?,
                19 => {
                    if self.all_spindles {
                        return Err(self.err(span, "M19 orients one spindle, not $-1 (all)"));
                    }
                    self.check_spindle_configured(span)?;
                    self.st.spindle = SpindleDir::Stop;
                    self.orient()?;
                }
                _ => {}
            }
        }
        // One event for the block, before its motion (LinuxCNC's order; Fanuc's M8 with a
        // move starts with the move).
        if coolant {
            self.push(SegmentKind::Coolant {
                mist: self.st.mist,
                flood: self.st.flood,
            });
        }
        Ok(())
    }

    fn m_after_motion(&mut self) {
        if self.w.m.is_empty() {
            return;
        }
        let ms = self.w.m.clone();
        for (code, _) in ms {
            let kind = match code {
                0 => StopKind::Program,
                1 if self.opts.optional_stop => StopKind::Optional,
                2 => StopKind::End,
                30 => StopKind::EndRewind,
                _ => continue,
            };
            // M2/M30 turn the coolant off, as the reset that follows them does on Fanuc
            // (and as LinuxCNC's M2/M30 do).
            if matches!(kind, StopKind::End | StopKind::EndRewind)
                && (self.st.mist || self.st.flood)
            {
                (self.st.mist, self.st.flood) = (false, false);
                self.push(SegmentKind::Coolant {
                    mist: false,
                    flood: false,
                });
            }
            self.push(SegmentKind::Stop { kind });
            if matches!(kind, StopKind::End | StopKind::EndRewind) {
                self.end = true;
            }
        }
    }

    /// G4: `X` seconds or `P` milliseconds (Fanuc); LinuxCNC's is `P` seconds only, its X
    /// being an axis word of the block's move.
    fn dwell(&mut self) -> Result<(), NcError> {
        if self.dialect == Dialect::LinuxCnc {
            let Some(p) = self.w.take('P') else {
                return Ok(());
            };
            if p.v < 0.0 {
                return Err(self.err(p.span, "dwell time must not be negative"));
            }
            if p.v > 0.0 {
                self.push(SegmentKind::Dwell { seconds: p.v });
            }
            return Ok(());
        }
        let x = self.w.take('X');
        let p = self.w.take('P');
        let seconds = match (x, p) {
            (Some(_), Some(p)) => {
                return Err(self.err(p.span, "G4 takes X (seconds) or P (milliseconds), not both"));
            }
            (Some(x), None) => {
                if x.v < 0.0 {
                    return Err(self.err(x.span, "dwell time must not be negative"));
                }
                x.v
            }
            (None, Some(p)) => self.dwell_p(p)?,
            (None, None) => return Ok(()),
        };
        if seconds > 0.0 {
            self.push(SegmentKind::Dwell { seconds });
        }
        Ok(())
    }

    /// A Fanuc `P` dwell: whole milliseconds → seconds. In the haas dialect a `P` written
    /// with a decimal point is seconds (`P0.5`, as Haas reads it in G4 and canned cycles).
    pub fn dwell_p(&self, p: Arg) -> Result<f64, NcError> {
        if self.dialect == Dialect::Haas && p.has_point {
            if p.v < 0.0 {
                return Err(self.err(p.span, "dwell time must not be negative"));
            }
            return Ok(p.v);
        }
        if p.v < 0.0 || p.v.fract() != 0.0 {
            return Err(self
                .err(
                    p.span,
                    format!("P{} is not a dwell: P is whole milliseconds", fmt_num(p.v)),
                )
                .with_expected("P as a whole number of milliseconds, e.g. P500 for 0.5 s"));
        }
        Ok(p.v / 1000.0)
    }

    /// Index of the configured axis `letter`, or an error naming what needs it.
    pub fn axis(&self, letter: char, span: Span, what: &str) -> Result<usize, NcError> {
        self.cfg.axis_index(letter).ok_or_else(|| {
            self.err(
                span,
                format!("{what} needs axis {letter}, which is not configured"),
            )
        })
    }

    /// Feed rate in mm/min for a feed move (G94: F; G95: F × S).
    pub fn feed_rate(&self, at: Span) -> Result<f64, NcError> {
        let rate = if self.st.feed_per_rev {
            if self.st.speed <= 0.0 && self.st.feed > 0.0 {
                return Err(self
                    .err(
                        self.w.peek('S').map_or(at, |a| a.span),
                        "feed per revolution (G95) with S0",
                    )
                    .with_expected("S > 0 for a G95 feed"));
            }
            self.st.feed * self.st.speed
        } else {
            self.st.feed
        };
        if rate <= 0.0 {
            let span = self.w.peek('F').map_or(at, |a| a.span);
            return Err(self
                .err(span, "zero feed in a motion block")
                .with_expected("an F word > 0 in this or an earlier block"));
        }
        Ok(rate)
    }

    /// Soft-limit check of a target, before the segment exists. `hint`: words to blame for an
    /// axis whose own word is not in the block.
    pub fn check_limits(&self, end: &AxisPos, hint: &[char]) -> Result<(), NcError> {
        // Every target inside (the usual answer), from the limits as `AxisMap` holds them:
        // ±∞ where an axis has none, which no target (nor NaN) is past.
        if !self.map.outside_limits(end) {
            return Ok(());
        }
        for (i, ax) in self.cfg.axes.iter().enumerate() {
            let Some((lo, hi)) = ax.soft_limits else {
                continue;
            };
            let v = end[i];
            if v < lo - 1e-9 || v > hi + 1e-9 {
                // A hint that names the axis itself gives the whole order of blame.
                let mut letters = Vec::with_capacity(hint.len() + 1);
                if !hint.contains(&ax.name) {
                    letters.push(ax.name);
                }
                letters.extend_from_slice(hint);
                return Err(self
                    .err(
                        self.span_of(&letters),
                        format!(
                            "{} {} is outside the soft limits {}..{} (machine coordinates)",
                            ax.name,
                            fmt_num(v),
                            fmt_num(lo),
                            fmt_num(hi)
                        ),
                    )
                    .with_expected(format!("a target inside {}..{}", fmt_num(lo), fmt_num(hi))));
            }
        }
        Ok(())
    }

    /// Error at a spindle M code when the selected spindle has no axis.
    fn check_spindle_configured(&self, span: Span) -> Result<(), NcError> {
        match (self.spindle_axis(), self.st.spindle_sel) {
            (Some(_), _) => Ok(()),
            (None, 1) => Err(self.err(span, "no spindle axis is configured")),
            (None, n) => Err(self.err(span, format!("spindle {n} is not configured"))),
        }
    }

    /// Error if a spindle axis is asked to move while it turns in speed mode.
    pub(crate) fn check_spindle_still(&self, end: &AxisPos) -> Result<(), NcError> {
        for (k, axis) in self.map.spindles.into_iter().enumerate() {
            let Some(c) = axis else { continue };
            if (end[c] - self.st.pos[c]).abs() > 1e-9 && self.st.spindle_turning_of(k as u8 + 1) {
                let name = self.cfg.axes[c].name;
                return Err(self
                    .err(
                        self.span_of(&[name]),
                        format!("{name} positioning while the spindle turns"),
                    )
                    .with_expected("M5 before positioning the spindle axis"));
            }
        }
        Ok(())
    }

    pub fn rapid(&mut self, end: AxisPos, hint: &[char]) -> Result<(), NcError> {
        self.check_limits(&end, hint)?;
        self.push(SegmentKind::Rapid { end });
        self.st.pos = end;
        Ok(())
    }

    pub fn linear(&mut self, end: AxisPos, feed: f64, hint: &[char]) -> Result<(), NcError> {
        self.check_limits(&end, hint)?;
        self.push(SegmentKind::Linear { end, feed });
        self.st.pos = end;
        Ok(())
    }

    /// A feed move to `end` that couples linear axis `tool` with spindle axis `sp` at `pitch`
    /// (signed, see [`TapSegment`]): a `Tap` when both move, else a plain `Linear` (a move
    /// that turns no spindle or feeds no tool couples nothing).
    pub fn tap(
        &mut self,
        end: AxisPos,
        feed: f64,
        (tool, sp): (usize, usize),
        pitch: f64,
        hint: &[char],
    ) -> Result<(), NcError> {
        self.check_limits(&end, hint)?;
        self.push(SegmentKind::tap_or_feed(
            &self.st.pos,
            end,
            feed,
            (tool, sp),
            pitch,
        ));
        self.st.pos = end;
        Ok(())
    }

    /// A programmed feed move that moves a spindle axis as a position axis together with
    /// linear axes, each with its own word (`G1 Z.. C.. F..`, as source-000 tapping cycles
    /// program it; the spindle named by its axis letter): a rigid tap of the linear axis
    /// that moves most with that spindle, at the pitch the two moves give. `None` when the
    /// block is no such move (or the pitch overflows).
    fn programmed_tap(&self, end: &AxisPos, worded: &[bool]) -> Option<(usize, usize, f64)> {
        let sp = self
            .map
            .spindles
            .into_iter()
            .flatten()
            .find(|&i| worded[i] && end[i] != self.st.pos[i])?;
        let dc = end[sp] - self.st.pos[sp];
        let (tool, dt) = (0..self.cfg.axes.len())
            .filter(|&i| worded[i] && !self.cfg.axes[i].kind.is_rotary())
            .map(|i| (i, end[i] - self.st.pos[i]))
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))?;
        let pitch = dt / dc * 360.0;
        (dt != 0.0 && pitch.is_finite()).then_some((tool, sp, pitch))
    }

    /// A programmed value of axis `i` (already in mm / degrees) → machine position, G90 or
    /// G91, with the work zero and the tool length offset. On the tool axis this (re)applies
    /// the offset vector: after it, `pos` includes all of it.
    pub fn word_target(&mut self, i: usize, v: f64) -> f64 {
        let m = self.st.target(i, v);
        self.st.restore_tlo(i);
        m
    }

    /// The part of the tool length offset vector on axis `i` that `pos` does not include yet.
    pub fn tlo_pending(&self, i: usize) -> f64 {
        self.st.tlo_pending(i)
    }

    /// A programmed value of `ax` in mm / degrees (inch programs converted).
    pub fn axis_value(&self, i: usize, a: Arg) -> f64 {
        if self.cfg.axes[i].kind.is_rotary() {
            a.v
        } else {
            a.v * self.st.unit()
        }
    }

    /// Axis words of the block → machine targets (G53: machine coordinates as given), and
    /// whether anything moves: an axis word, or a tool length offset programmed in this block
    /// (the tool axis then moves by the change of the offset, as on Fanuc).
    fn targets(&mut self, machine: bool) -> (AxisPos, bool) {
        let mut end = self.st.pos;
        let mut any = false;
        for i in 0..self.cfg.axes.len() {
            if let Some(a) = self.w.take(self.cfg.axes[i].name) {
                any = true;
                let v = self.axis_value(i, a);
                end[i] = if machine {
                    // Fanuc: G53 cancels the tool length offset vector of the axis it moves.
                    self.st.drop_tlo(i);
                    v
                } else {
                    self.word_target(i, v)
                };
            } else if self.tlo_commanded
                && self.st.tool_axis == Some(i)
                && self.dialect != cnc402_lang::Dialect::LinuxCnc
            {
                // (LinuxCNC applies a new tool length offset at the axis' next move.)
                // No move when the vector does not change (G49 after G28 Z: Fanuc cancelled
                // it at the reference position already).
                let d = self.tlo_pending(i);
                if d != 0.0 {
                    end[i] = self.st.pos[i] + d;
                    any = true;
                }
                self.st.restore_tlo(i);
            }
        }
        (end, any)
    }

    /// A group 01 code of the block sets the motion mode and cancels a canned cycle.
    pub fn apply_motion_code(&mut self) {
        if let Some((code, _)) = self.w.g_of(GGroup::Motion) {
            self.st.motion = match code {
                0 => Motion::Rapid,
                1 => Motion::Linear,
                2 => Motion::ArcCw,
                _ => Motion::ArcCcw,
            };
            self.cancel_cycle();
        }
    }

    fn motion(&mut self) -> Result<(), NcError> {
        // One code of the group at most (check_groups): G53 is the block's non-modal code.
        let g53 = match self.w.g_of(GGroup::NonModal) {
            Some((53, span)) => Some(span),
            _ => None,
        };
        self.apply_motion_code();
        if let Some((code, span)) = self.w.g_of(GGroup::Cycle)
            && let Some(c) = Cycle::from_code(code)
        {
            if let Some(s) = g53 {
                return Err(self.err(s, "G53 cannot be used in a canned cycle"));
            }
            if self.st.cycle.is_none() {
                let (_, _, d) = self.plane_letters();
                let id = self.axis(d, span, "a canned cycle in this plane")?;
                self.st.cycle_data = CycleData {
                    initial: self.st.pos[id],
                    initial_tlo_pending: self.tlo_pending(id),
                    ..CycleData::default()
                };
            }
            self.st.cycle = Some(c);
            return self.cycle(c, span);
        }
        if let Some(c) = self.st.cycle {
            if let Some(s) = g53 {
                return Err(self.err(s, "G53 cannot be used in a canned cycle"));
            }
            let span = self.w.span;
            return self.cycle(c, span);
        }
        if let Some(s) = g53 {
            if !matches!(self.st.motion, Motion::Rapid | Motion::Linear) {
                return Err(self.err(s, "G53 works only with G0 or G1"));
            }
            if self.st.incremental {
                return Err(self
                    .err(s, "G53 in G91 (Fanuc ignores it; cnc402 refuses)")
                    .with_expected("G90 with G53"));
            }
        }
        let motion_span = self
            .w
            .g_of(GGroup::Motion)
            .map(|g| g.1)
            .unwrap_or(self.w.span);
        match self.st.motion {
            Motion::Rapid | Motion::Linear => {
                let mut worded = [false; cnc402_config::MAX_AXES];
                for (i, a) in self.cfg.axes.iter().enumerate().take(worded.len()) {
                    worded[i] = self.w.has(a.name);
                }
                let (end, any) = self.targets(g53.is_some());
                // G53 to where the tool already is makes no segment, as G28/G30 do.
                if !any || (g53.is_some() && end == self.st.pos) {
                    return Ok(());
                }
                self.check_spindle_still(&end)?;
                if self.st.motion == Motion::Rapid {
                    self.rapid(end, &[])
                } else {
                    let feed = self.feed_rate(motion_span)?;
                    match self.programmed_tap(&end, &worded) {
                        Some((tool, sp, pitch)) => self.tap(end, feed, (tool, sp), pitch, &[]),
                        None => {
                            let corner = self.corner_word()?;
                            self.corner_done = true;
                            self.linear_with_corners(end, feed, corner)
                        }
                    }
                }
            }
            Motion::ArcCw | Motion::ArcCcw => self.arc(motion_span),
        }
    }

    /// (first plane axis, second plane axis, normal / drilling axis) letters.
    pub fn plane_letters(&self) -> (char, char, char) {
        self.st.plane.letters()
    }

    fn arc(&mut self, span: Span) -> Result<(), NcError> {
        let cw = self.st.motion == Motion::ArcCw;
        let (la, lb, ln) = self.plane_letters();
        // The plane's centre offsets, in the order of (first, second) axis.
        let (oa, ob) = match self.st.plane {
            Plane::XY => ('I', 'J'),
            Plane::ZX => ('K', 'I'),
            Plane::YZ => ('J', 'K'),
        };
        let (end, any) = self.targets(false);
        let r = self.w.take('R');
        let (wa, wb) = if r.is_some() {
            // Fanuc: with R given, I/J/K are ignored.
            self.w.consume(oa);
            self.w.consume(ob);
            (None, None)
        } else {
            (self.w.take(oa), self.w.take(ob))
        };
        self.off_plane_offset(r.is_some())?;
        if !any && r.is_none() && wa.is_none() && wb.is_none() {
            return Ok(());
        }
        let ia = self.axis(la, span, "an arc in this plane")?;
        let ib = self.axis(lb, span, "an arc in this plane")?;
        let inn = self.cfg.axis_index(ln);
        self.check_spindle_still(&end)?;
        let feed = self.feed_rate(span)?;
        let unit = self.st.unit();
        let start = (self.st.pos[ia], self.st.pos[ib]);
        let stop = (end[ia], end[ib]);
        let tol = self.arc_tolerance();
        let g = match r {
            Some(r) => arc::arc_radius(start, stop, r.v * unit, cw, self.r_arc_tolerance(tol)),
            None => {
                if wa.is_none() && wb.is_none() {
                    return Err(self
                        .err(
                            span,
                            format!(
                                "G{} needs the centre ({oa}, {ob}) or R",
                                if cw { 2 } else { 3 }
                            ),
                        )
                        .with_expected(format!("{oa}/{ob} or R")));
                }
                let off = self.centre_offset(span, (ia, ib), (oa, ob), (wa, wb), start)?;
                arc::arc_center(start, stop, off, cw, tol)
                    .and_then(|g| self.planner_circle(g, start, stop, cw, tol))
            }
        };
        let g = g.map_err(|e| {
            let at = r.map(|r| r.span).unwrap_or(span);
            match e {
                ArcError::ZeroRadius => self.err(at, "arc radius is zero"),
                ArcError::NotOnCircle {
                    start_radius,
                    end_radius,
                } => self
                    .err(
                        self.span_of(&[la, lb]),
                        format!(
                            "arc end point is not on the circle: start radius {}, end radius {} (difference {} > tolerance {} and > {} % of the radius)",
                            fmt_num(start_radius / unit),
                            fmt_num(end_radius / unit),
                            fmt_num((start_radius - end_radius).abs() / unit),
                            fmt_num(tol.absolute / unit),
                            fmt_num(tol.relative * 100.0)
                        ),
                    )
                    .with_expected("an end point at the start point's distance from the centre"),
                ArcError::ImpossibleRadius { r, chord } => self
                    .err(
                        at,
                        format!(
                            "R arc with impossible radius: R {} but the end point is {} away",
                            fmt_num(r.abs()),
                            fmt_num(chord)
                        ),
                    )
                    .with_expected(format!("|R| >= {}", fmt_num(chord / 2.0))),
                ArcError::RFullCircle => self
                    .err(at, "R arc ending at its start point: the circle is not determined")
                    .with_expected("I/J/K for a full circle"),
            }
        })?;
        for (a, b) in arc::extremes(&g, cw) {
            let mut p = end;
            p[ia] = a;
            p[ib] = b;
            self.check_limits(&p, &[la, lb])?;
        }
        self.check_limits(&end, &[])?;
        let mut center = [0.0f64; 3];
        let xyz = |l: char| (l as u8 - b'X') as usize;
        center[xyz(la)] = g.center.0;
        center[xyz(lb)] = g.center.1;
        center[xyz(ln)] = inn.map_or(0.0, |i| self.st.pos[i]);
        self.push(SegmentKind::Arc {
            end,
            center,
            plane: self.st.plane,
            dir: if cw { ArcDir::Cw } else { ArcDir::Ccw },
            turns: g.turns,
            feed,
        });
        self.st.pos = end;
        Ok(())
    }

    /// The I/J/K radius tolerance of the program's units (`interp.arc_tolerance` in mm,
    /// `interp.arc_tolerance_inch` in inches, `interp.arc_tolerance_relative`), in mm.
    /// How much longer than the diameter an R arc's chord may be (mm): LinuxCNC's 0.00005 in,
    /// in the linuxcnc dialect; otherwise the centre format's absolute tolerance, because CAM
    /// output for Fanuc rounds R and the end point to the last digit each (4-decimal inch R
    /// half circles came out 0.0013 mm short) and a Fanuc runs them.
    fn r_arc_tolerance(&self, centre: ArcTolerance) -> f64 {
        if self.dialect == Dialect::LinuxCnc {
            arc::R_TOLERANCE_INCH * 25.4
        } else {
            centre.absolute.max(arc::R_TOLERANCE_INCH * 25.4)
        }
    }

    fn arc_tolerance(&self) -> ArcTolerance {
        let i = &self.cfg.interp;
        ArcTolerance {
            absolute: if self.st.inch {
                i.arc_tolerance_inch * 25.4
            } else {
                i.arc_tolerance
            },
            relative: i.arc_tolerance_relative,
        }
    }

    /// `g` as the planner takes it: an arc whose radii differ by more than the planner's
    /// spiral limit (`interp.arc_tolerance`, mm) gets its centre moved onto the chord's
    /// bisector; if that is more than `100 ×` the tolerance away, the arc is refused.
    fn planner_circle(
        &self,
        g: ArcGeom,
        start: (f64, f64),
        stop: (f64, f64),
        cw: bool,
        tol: ArcTolerance,
    ) -> Result<ArcGeom, ArcError> {
        let end_radius = (stop.0 - g.center.0).hypot(stop.1 - g.center.1);
        if (g.radius - end_radius).abs() <= self.cfg.interp.arc_tolerance {
            return Ok(g);
        }
        arc::equal_radii(&g, start, stop, cw, 100.0 * tol.absolute).ok_or(ArcError::NotOnCircle {
            start_radius: g.radius,
            end_radius,
        })
    }

    /// The arc centre minus the start point, from the plane's centre words `(wa, wb)`
    /// (letters `(oa, ob)`, of axes `(ia, ib)`): incremental from the start (G91.1, Fanuc's
    /// only mode; a word left out is 0) or the centre in work coordinates (G90.1; both words
    /// needed, as LinuxCNC says "I word missing in absolute center arc").
    fn centre_offset(
        &self,
        span: Span,
        (ia, ib): (usize, usize),
        (oa, ob): (char, char),
        (wa, wb): (Option<Arg>, Option<Arg>),
        start: (f64, f64),
    ) -> Result<(f64, f64), NcError> {
        let unit = self.st.unit();
        if !self.st.arc_center_absolute {
            return Ok((
                wa.map_or(0.0, |a| a.v * unit),
                wb.map_or(0.0, |a| a.v * unit),
            ));
        }
        let (Some(a), Some(b)) = (wa, wb) else {
            let missing = if wa.is_none() { oa } else { ob };
            return Err(self
                .err(
                    span,
                    format!("{missing} word missing in an absolute centre arc (G90.1)"),
                )
                .with_expected(format!(
                    "both {oa} and {ob}, the centre in work coordinates"
                )));
        };
        Ok((
            a.v * unit + self.st.origin(ia) - start.0,
            b.v * unit + self.st.origin(ib) - start.1,
        ))
    }

    /// The centre word along the plane's normal (`K` in a G17 arc, `J` in G18, `I` in G19):
    /// CAM posts write `K0`. Zero is accepted and means nothing; another value is refused. In
    /// every dialect: `rs274` refuses even `K0` (`K word given for arc in xy plane`), but
    /// FreeCAD's LinuxCNC post writes it, and a zero offset along the normal changes nothing.
    /// With R the centre words are ignored (Fanuc), this one too.
    fn off_plane_offset(&mut self, with_r: bool) -> Result<(), NcError> {
        let (letter, plane) = match self.st.plane {
            Plane::XY => ('K', "G17 (XY)"),
            Plane::ZX => ('J', "G18 (ZX)"),
            Plane::YZ => ('I', "G19 (YZ)"),
        };
        let Some(w) = self.w.take(letter) else {
            return Ok(());
        };
        if with_r {
            return Ok(());
        }
        if w.v != 0.0 {
            return Err(self
                .err(
                    w.span,
                    format!(
                        "{letter}{} in a {plane} arc: the centre offset along the plane's normal must be 0",
                        fmt_num(w.v)
                    ),
                )
                .with_expected(format!("{letter}0 or no {letter}")));
        }
        Ok(())
    }

    /// A corner word nothing took (not a G1 move), or a held corner move this block did not
    /// finish: errors.
    fn check_corner_words(&mut self) -> Result<(), NcError> {
        if let Some((l, a)) = self.w.corner.take() {
            return Err(self
                .err(
                    a.span,
                    format!(",{l} (corner rounding/chamfer) is only for a G1 move"),
                )
                .with_expected("G1 and a move in the plane"));
        }
        if !self.corner_done
            && let Some(p) = &self.st.pending_corner
        {
            return Err(self.corner_unfinished(p, "the next block is not a G1 move"));
        }
        Ok(())
    }
}
