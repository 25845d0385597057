//! The blocks of each kind of operation: moves and arcs, rigid taps, canned cycles (native
//! where the control has them, plain blocks where it does not), spindle, tool, coolant,
//! dwell, stops and messages.

use std::sync::Arc;

use cnc402_interp::canon::{CannedCycle, CanonKind, CanonOp, CanonState};
use cnc402_motion::segment::{ArcDir, AxisPos, SegmentKind, SpindleDir, StopKind};

use super::Emitter;
use super::format::{decimal, feed, speed};
use crate::PostError;
use crate::assemble::{Block, Word};

const SAME: f64 = 1e-9;

/// The M code of a program stop (the same on every target); `None` for a wait for other
/// channels, which a one-path program cannot express.
pub(crate) fn stop_code(kind: StopKind) -> Option<&'static str> {
    match kind {
        StopKind::Program => Some("M0"),
        StopKind::Optional => Some("M1"),
        StopKind::End => Some("M2"),
        StopKind::EndRewind => Some("M30"),
        StopKind::WaitMark { .. } => None,
    }
}

/// Why a channel wait is refused: the targets are one-path controls.
/// The refusal of an operation on a spindle other than the first (cnc402's `P2`/`$1`): the
/// targets' programs here address one spindle, so writing it as spindle 1 would turn the
/// wrong one.
pub(crate) fn other_spindle_refused(op: &CanonOp) -> Option<String> {
    let spindle = match &op.kind {
        CanonKind::Single(
            SegmentKind::Spindle { spindle, .. } | SegmentKind::SpindleOrient { spindle, .. },
        ) => *spindle,
        CanonKind::CannedCycle(cc) => cc.plan.spindle,
        _ => return None,
    };
    (spindle != 1).then(|| {
        format!("spindle {spindle} (a multi-spindle selection): the post writes one spindle")
    })
}

pub(crate) const WAIT_MARK_REFUSED: &str =
    "a wait for other channels (multi-path M100… / wait_mark): the target is a one-path control";

/// A canned cycle as the control holds it between blocks.
#[derive(Clone, Debug, PartialEq)]
pub struct CycleModal {
    pub code: u32,
    /// The initial level, machine coordinates of the drilling axis.
    pub initial: f64,
    /// The drilling axis.
    pub axis: usize,
    /// The cycle's words as last written (`Z-6.`, `R2.`, …), letter first.
    pub words: Vec<String>,
    /// G98 or G99.
    pub ret: &'static str,
}

impl Emitter<'_> {
    /// An operation that is one segment.
    pub(crate) fn single(&mut self, op: &CanonOp, kind: &SegmentKind) -> Result<(), PostError> {
        let words: Vec<String> = match kind {
            SegmentKind::Rapid { .. }
            | SegmentKind::Linear { .. }
            | SegmentKind::Tap(_)
            | SegmentKind::Arc { .. } => return self.path(op, kind),
            SegmentKind::Dwell { seconds } => {
                vec!["G4".into(), format!("X{}", decimal(*seconds, 3))]
            }
            SegmentKind::Spindle { rpm, dir, .. } => {
                let m = match dir {
                    SpindleDir::Cw => "M3",
                    SpindleDir::Ccw => "M4",
                    SpindleDir::Stop => "M5",
                };
                let mut w = Vec::new();
                let s = speed(self.rules, *rpm, &op.source)?;
                if self.modal.spindle.as_deref() != Some(&s) && *dir != SpindleDir::Stop {
                    w.push(s.clone());
                    self.modal.spindle = Some(s);
                }
                w.push(m.into());
                w
            }
            SegmentKind::SpindleOrient { angle, program, .. } => {
                self.orient(op, *angle, *program)?
            }
            SegmentKind::ToolChange { tool } => {
                if *tool > self.rules.max_tool {
                    return Err(self.refuse(
                        op,
                        format!("T{tool} is past the control's T{}", self.rules.max_tool),
                    ));
                }
                vec![format!("T{tool}"), "M6".into()]
            }
            SegmentKind::Coolant { mist, flood } => return self.coolant(op, *mist, *flood),
            SegmentKind::Stop { kind } => match stop_code(*kind) {
                Some(m) => vec![m.into()],
                None => return Err(self.refuse(op, WAIT_MARK_REFUSED.into())),
            },
            SegmentKind::Message { text } => {
                self.program.main.push(Block {
                    words: Vec::new(),
                    comment: Some(format!("MSG, {text}")),
                    source: Some(op.source.clone()),
                });
                return Ok(());
            }
        };
        self.push(words, Some(op));
        Ok(())
    }

    /// M19, or the spindle axis sent to its reference (G28) when the job's C reads it after.
    fn orient(
        &mut self,
        op: &CanonOp,
        angle: f64,
        program: Option<f64>,
    ) -> Result<Vec<String>, PostError> {
        match program {
            None if (angle - self.cfg.interp.spindle_orient_angle).abs() <= SAME => {
                // M19 stops the spindle itself: an M5 just before it would stop it twice.
                let last = self.program.main.last().map(|b| b.words.as_slice());
                if last == Some(&[Word::Text("M5".into())][..]) {
                    self.program.main.pop();
                }
                Ok(vec!["M19".into()])
            }
            None => Err(self.refuse(
                op,
                format!("a spindle orientation to {angle}° other than the machine's M19 angle"),
            )),
            Some(_) => {
                let Some(c) = self.cfg.spindle_index() else {
                    return Err(
                        self.refuse(op, "a spindle reference without a spindle axis".into())
                    );
                };
                self.push(
                    vec!["G91".into(), "G28".into(), format!("{}0", self.letter(c))],
                    Some(op),
                );
                Ok(vec!["G90".into()])
            }
        }
    }

    /// M7/M8/M9 for the coolant state from here on (M9 first when something turns off).
    fn coolant(&mut self, op: &CanonOp, mist: bool, flood: bool) -> Result<(), PostError> {
        let (had_mist, had_flood) = self.modal.coolant;
        if (had_mist && !mist) || (had_flood && !flood) || (!mist && !flood) {
            self.push(vec!["M9".into()], Some(op));
            self.modal.coolant = (false, false);
        }
        if flood && !self.modal.coolant.1 {
            self.push(vec!["M8".into()], Some(op));
        }
        if mist && !self.modal.coolant.0 {
            self.push(vec!["M7".into()], Some(op));
        }
        self.modal.coolant = (mist, flood);
        Ok(())
    }

    /// A rapid, feed, tap or arc block.
    fn path(&mut self, op: &CanonOp, kind: &SegmentKind) -> Result<(), PostError> {
        self.end_cycle(op);
        let mut words = self.modal_words(op)?;
        let (code, end, f) = match kind {
            SegmentKind::Rapid { end } => (0, end, None),
            SegmentKind::Linear { end, feed } => (1, end, Some(*feed)),
            SegmentKind::Tap(t) => (1, &t.end, Some(t.feed)),
            SegmentKind::Arc { end, dir, feed, .. } => {
                (if *dir == ArcDir::Cw { 2 } else { 3 }, end, Some(*feed))
            }
            _ => return Ok(()),
        };
        if self.modal.motion != Some(code) {
            words.push(format!("G{code}"));
            self.modal.motion = Some(code);
        }
        let arc_axes = match kind {
            SegmentKind::Arc { .. } => self.arc_plane_axes(op)?,
            _ => Vec::new(),
        };
        words.extend(self.axis_words(op, end, &arc_axes)?);
        if let SegmentKind::Arc { center, turns, .. } = kind {
            words.extend(self.arc_words(op, end, *center, *turns)?);
        }
        if let Some(f) = f {
            let f = feed(self.rules, f, self.length_unit(), &op.source)?;
            if self.modal.feed.as_deref() != Some(&f) {
                words.push(f.clone());
                self.modal.feed = Some(f);
            }
        }
        self.modal.offset = op.state.offset;
        self.push(words, Some(op));
        Ok(())
    }

    /// The words of the axes that move to `end` (work coordinates), or whose offset changed,
    /// or that `always` names.
    fn axis_words(
        &self,
        op: &CanonOp,
        end: &AxisPos,
        always: &[usize],
    ) -> Result<Vec<String>, PostError> {
        let mut words = Vec::new();
        let machine = op.state.to_machine(end);
        for i in self.axes() {
            let moves = (machine[i] - self.pos[i]).abs() > SAME;
            let offset_changed = (op.state.offset[i] - self.modal.offset[i]).abs() > SAME;
            // Type A: the block that sets or cancels the length moves the tool axis by it.
            let length_set = self.length_written && op.state.tool_axis == Some(i);
            if moves || offset_changed || length_set || always.contains(&i) {
                words.push(self.axis_word(i, end[i], op)?);
            }
        }
        if words.is_empty() {
            // A move to where the tool is is still a move of the job (a block without axis
            // words would be none).
            words.push(self.axis_word(0, end[0], op)?);
        }
        Ok(words)
    }

    /// The plane's two axes (an arc names both, as Fanuc programs do).
    fn arc_plane_axes(&self, op: &CanonOp) -> Result<Vec<usize>, PostError> {
        let (a, b, _) = op.state.plane.letters();
        [a, b]
            .into_iter()
            .map(|l| {
                self.cfg
                    .axis_index(l)
                    .ok_or_else(|| self.refuse(op, format!("an arc in a plane without axis {l}")))
            })
            .collect()
    }

    /// I/J/K of an arc from the tool's position, refusing what the control cannot do: more
    /// than one turn, a helix where it has no helical interpolation.
    fn arc_words(
        &self,
        op: &CanonOp,
        end: &AxisPos,
        center: [f64; 3],
        turns: u32,
    ) -> Result<Vec<String>, PostError> {
        let start = op.state.to_work(&self.pos);
        let (a, b, normal) = op.state.plane.letters();
        let idx = |l: char| self.cfg.axis_index(l);
        let in_plane = |p: &AxisPos| [a, b].map(|l| idx(l).map_or(0.0, |i| p[i]));
        let closed = in_plane(&start)
            .iter()
            .zip(in_plane(end))
            .all(|(s, e)| (s - e).abs() <= SAME);
        if turns > 1 || (turns == 1 && !closed) {
            return Err(self.refuse(
                op,
                "an arc of more than one full turn (the control's G2/G3 has no turn count)".into(),
            ));
        }
        let helix = self.axes().any(|i| {
            Some(i) != idx(a)
                && Some(i) != idx(b)
                && (op.state.to_machine(end)[i] - self.pos[i]).abs() > SAME
        });
        if helix && !self.rules.helical {
            return Err(self.refuse(
                op,
                format!("a helix (G2/G3 with a move along {normal}) on a control without helical interpolation"),
            ));
        }
        let mut words = Vec::new();
        for (k, letter) in ['I', 'J', 'K'].into_iter().enumerate() {
            let axis = ['X', 'Y', 'Z'][k];
            if axis == normal {
                continue;
            }
            let Some(i) = idx(axis) else { continue };
            words.push(self.length_word(letter, center[k] - start[i], op)?);
        }
        Ok(words)
    }

    /// G80 before a block that is not part of the cycle.
    pub(crate) fn end_cycle(&mut self, op: &CanonOp) {
        if self.modal.cycle.take().is_some() {
            self.push(vec!["G80".into()], Some(op));
            self.modal.motion = None;
        }
    }

    /// A canned cycle block: native when the control has the cycle, else a Custom Macro B
    /// call where the control has macros and a body covers the cycle, else plain blocks.
    pub(crate) fn cycle(&mut self, op: &CanonOp, cc: &CannedCycle) -> Result<(), PostError> {
        if !self.rules.has_cycle(cc.code) {
            if self.rules.macros && self.cycle_as_macro(op, cc)? {
                return Ok(());
            }
            return self.cycle_as_blocks(op, cc);
        }
        let drill = cc.axes[2];
        let initial = cc.initial_level + op.state.offset[drill];
        let data = self.cycle_data(op, cc)?;
        // A word the control holds from the cycle before (P, Q) that this one has not would
        // stay set: such a cycle starts afresh after G80.
        let letters = |w: &[String]| {
            w.iter()
                .filter_map(|d| d.chars().next())
                .collect::<Vec<_>>()
        };
        let continues = self.modal.cycle.as_ref().is_some_and(|c| {
            c.axis == drill
                && (c.initial - initial).abs() <= SAME
                && letters(&c.words).iter().all(|l| letters(&data).contains(l))
        }) && self.modal.offset == op.state.offset;
        if !continues {
            self.end_cycle(op);
            if (self.pos[drill] - initial).abs() > SAME {
                return Err(self.refuse(op, format!(
                    "the G{} series starts at another level than the tool is at; the control could not return to it",
                    cc.code
                )));
            }
        }
        if !continues && !cc.plan.spindle_turning && cc.tap.is_some() {
            // Rigid tapping from a stopped spindle: M29 S, the speed the pitch is F / S of.
            let s = speed(self.rules, cc.plan.speed, &op.source)?;
            self.push(vec!["M29".into(), s], Some(op));
        }
        let mut words = self.modal_words(op)?;
        let ret = if cc.words.return_to_r { "G99" } else { "G98" };
        if !continues || self.modal.cycle.as_ref().is_some_and(|c| c.ret != ret) {
            words.push(ret.into());
        }
        let code = format!("G{}", cc.code);
        let mut first = true;
        for hole in &cc.holes {
            let mut w = std::mem::take(&mut words);
            let new_code = self.modal.motion != Some(cc.code);
            if new_code {
                w.push(code.clone());
                self.modal.motion = Some(cc.code);
            }
            // Every hole names both plane axes: a block without them would not drill.
            for (k, v) in hole.iter().enumerate() {
                w.push(self.axis_word(cc.axes[k], *v, op)?);
            }
            if first {
                let had = self
                    .modal
                    .cycle
                    .as_ref()
                    .map(|c| c.words.clone())
                    .unwrap_or_default();
                w.extend(
                    data.iter()
                        .filter(|d| new_code || !had.contains(d))
                        .cloned(),
                );
                first = false;
            }
            self.modal.cycle = Some(CycleModal {
                code: cc.code,
                initial,
                axis: drill,
                words: data.clone(),
                ret,
            });
            self.push(w, Some(op));
        }
        self.modal.offset = op.state.offset;
        Ok(())
    }

    /// Z R (Q) (P) F of a cycle, absolute.
    fn cycle_data(&self, op: &CanonOp, cc: &CannedCycle) -> Result<Vec<String>, PostError> {
        let mut data = vec![
            self.axis_word(cc.axes[2], cc.bottom, op)?,
            self.length_word('R', cc.r_level, op)?,
        ];
        if let Some(q) = cc.words.q {
            data.push(self.length_word('Q', q, op)?);
        }
        if let Some(p) = cc.words.p {
            data.push(format!("P{}", (p * 1000.0).round() as u64));
        }
        data.push(feed(self.rules, cc.feed, self.length_unit(), &op.source)?);
        Ok(data)
    }

    /// A cycle the control lacks, as the blocks it expands to (in G61, as a cycle's moves end).
    fn cycle_as_blocks(&mut self, op: &CanonOp, cc: &CannedCycle) -> Result<(), PostError> {
        self.end_cycle(op);
        let state = Arc::new(CanonState {
            path_mode: Self::exact_stop(),
            ..(*op.state).clone()
        });
        for step in cnc402_interp::lower::cycle::expand(cc, &op.state) {
            let kind = op.state.convert(step.kind, self.xyz, false);
            let single = CanonOp {
                kind: cnc402_interp::canon::CanonKind::Single(kind.clone()),
                source: op.source.clone(),
                state: state.clone(),
            };
            self.single(&single, &kind)?;
            self.advance(&single);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cnc402_interp::canon::{CanonKind, FeedMode, PathMode, ProgramUnits};
    use cnc402_motion::segment::{Plane, Source};

    fn op(kind: SegmentKind) -> CanonOp {
        CanonOp {
            kind: CanonKind::Single(kind),
            source: Source {
                file: "j.nc".into(),
                line: 7,
                n: Some(70),
            },
            state: Arc::new(CanonState {
                plane: Plane::XY,
                units: ProgramUnits::Mm,
                feed_mode: FeedMode::PerMinute,
                path_mode: PathMode::ExactStop,
                work_offset: 0,
                offset: AxisPos::default(),
                tool: None,
                tool_length_mode: 49,
                h: 0,
                tool_length: 0.0,
                tool_axis: Some(2),
                comp: None,
            }),
        }
    }

    #[test]
    fn an_arc_of_more_than_one_turn_is_refused() {
        let cfg = cnc402_config::MachineConfig::default_machine();
        let rules = crate::Target::Fanuc16.rules();
        let mut e = Emitter::new(&cfg, &rules);
        let mut end = AxisPos::default();
        end[0] = 10.0;
        e.op(&op(SegmentKind::Rapid { end })).unwrap();
        let arc = |turns| {
            op(SegmentKind::Arc {
                end,
                center: [0.0, 0.0, 0.0],
                plane: Plane::XY,
                dir: ArcDir::Ccw,
                turns,
                feed: 100.0,
            })
        };
        // One full circle is a G3 with the end on the start.
        e.op(&arc(1)).unwrap();
        let err = e.op(&arc(2)).unwrap_err().to_string();
        assert_eq!(
            err,
            "j.nc:7: block N70: an arc of more than one full turn (the control's G2/G3 has no \
             turn count) (target fanuc16)"
        );
    }
}
