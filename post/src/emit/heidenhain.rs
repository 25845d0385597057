//! iTNC 530 conversational output: `L … R0 FMAX|F`, `CC` + `C … DR±`, `TOOL CALL n Z S`,
//! `CYCL DEF 9` dwells, M functions. What the iTNC does implicitly is checked against the
//! job instead of written: the called tool's length switches on at the next Z move (the job
//! must have `G43 H` of that tool there), the radius of `RL/RR` is the called tool's, the
//! preset is the config's G54 (other datums: `CYCL DEF 7`, [`super::datum`]). G81/G82 become
//! `CYCL DEF 200`, G83 `205`, rigid taps `207`, each hole `L X Y FMAX M99`; sub-programs
//! labels ([`super::labels`]); helices `CP` ([`super::helix`]); other cycles, G61/G64
//! changes: refused (docs/post.md).

use cnc402_interp::canon::{CannedCycle, CanonKind, CanonOp, CompSide};
use cnc402_motion::segment::{ArcDir, AxisPos, Plane, SegmentKind, SpindleDir};

use super::Emitter;
use super::format::decimal;
use crate::PostError;
use crate::assemble::{Block, Program};

const SAME: f64 = 1e-9;

/// A cycle definition's Q lines: name, value as written, the iTNC's comment.
type QParams = Vec<(&'static str, String, &'static str)>;

/// Where the called tool's length stands on the control.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Length {
    Off,
    /// Called; on from the next move along Z.
    Pending,
    On,
}

/// The iTNC program of `ops`.
pub fn emit_itnc(
    cfg: &cnc402_config::MachineConfig,
    rules: &crate::Rules,
    ops: &[CanonOp],
    subs: &[crate::input::calls::SubBody],
) -> Result<(Program, bool), PostError> {
    let mut runs = super::labels::Runs::new(subs);
    let mut e = Itnc {
        e: Emitter::new(cfg, rules),
        length: Length::Off,
        tool: None,
        comp: None,
        feed: None,
        drilling: None,
        inch: false,
        shift: [0.0; 3],
        written: [false; 3],
    };
    let inch = ops
        .first()
        .is_some_and(|o| o.state.units == cnc402_interp::canon::ProgramUnits::Inch);
    e.inch = inch;
    for op in ops {
        if (op.state.units == cnc402_interp::canon::ProgramUnits::Inch) != inch {
            return Err(e
                .e
                .refuse(op, "a change of units inside an iTNC program".into()));
        }
        if runs.note(op, e.e.program.main.len()) {
            continue;
        }
        e.op(op)?;
        e.e.advance(op);
    }
    runs.place(&mut e.e.program);
    Ok((e.e.program, inch))
}

struct Itnc<'a> {
    e: Emitter<'a>,
    length: Length,
    tool: Option<u32>,
    comp: Option<Option<CompSide>>,
    feed: Option<String>,
    /// The lines of the active `CYCL DEF 200` or `207` (the head and its Q lines).
    drilling: Option<Vec<String>>,
    /// A `BEGIN PGM … INCH` program: lengths in inches, feeds in 1/10 inch/min.
    inch: bool,
    /// The datum shift (cycle 7) the control holds.
    shift: super::datum::Shift,
    /// X, Y, Z written in a block yet (a reader of `CP` needs to know where the tool is).
    written: [bool; 3],
}

impl Itnc<'_> {
    /// A length (mm) as the program writes it: mm, or inches (4 decimals) in an INCH program.
    fn len(&self, mm: f64) -> String {
        if self.inch {
            signed(mm / 25.4, 4)
        } else {
            signed(mm, self.e.rules.position_decimals)
        }
    }

    /// A feed (mm/min) as the program writes it, `F…`: mm/min, or in an INCH program
    /// 1/10 inch/min (the iTNC's unit there: `F100` is 10 inch/min).
    fn feed_word(&self, mm_per_min: f64, op: &CanonOp) -> Result<String, PostError> {
        use super::format::Unit;
        let (v, unit) = if self.inch {
            (mm_per_min * 10.0, Unit::Inch)
        } else {
            (mm_per_min, Unit::Mm)
        };
        let f = super::format::feed(self.e.rules, v, unit, &op.source)?;
        Ok(f.trim_end_matches('.').to_string())
    }

    fn push(&mut self, text: String, op: &CanonOp) {
        self.e
            .program
            .main
            .push(Block::new(vec![text], Some(op.source.clone())));
    }

    fn op(&mut self, op: &CanonOp) -> Result<(), PostError> {
        if let Some(why) = super::ops::other_spindle_refused(op) {
            return Err(self.e.refuse(op, why));
        }
        let kind = match &op.kind {
            CanonKind::CannedCycle(cc) => return self.drilling(op, cc),
            CanonKind::Single(k) => k,
        };
        let text = match kind {
            SegmentKind::Rapid { .. } | SegmentKind::Linear { .. } | SegmentKind::Arc { .. } => {
                return self.path(op, kind);
            }
            SegmentKind::Tap(_) => {
                return Err(self
                    .e
                    .refuse(op, "a programmed rigid tap (a feed move with the spindle axis: the iTNC has no such block; G84/G74 are written as CYCL DEF 207)".into()));
            }
            SegmentKind::Dwell { seconds } => {
                self.push("CYCL DEF 9.0 DWELL TIME".into(), op);
                format!(
                    "CYCL DEF 9.1 DWELL {}",
                    decimal(*seconds, 3).trim_end_matches('.')
                )
            }
            SegmentKind::Spindle { rpm, dir, .. } => {
                let s = super::format::speed(self.e.rules, *rpm, &op.source)?;
                if *dir != SpindleDir::Stop && self.e.modal.spindle.as_deref() != Some(&s) {
                    self.push(format!("TOOL CALL Z {s}"), op);
                    self.e.modal.spindle = Some(s);
                }
                match dir {
                    SpindleDir::Cw => "M3",
                    SpindleDir::Ccw => "M4",
                    SpindleDir::Stop => "M5",
                }
                .into()
            }
            SegmentKind::ToolChange { tool } => {
                if *tool > self.e.rules.max_tool {
                    return Err(self.e.refuse(
                        op,
                        format!("T{tool} is past the control's T{}", self.e.rules.max_tool),
                    ));
                }
                self.tool = Some(*tool);
                self.length = if *tool == 0 {
                    Length::Off
                } else {
                    Length::Pending
                };
                format!("TOOL CALL {tool} Z")
            }
            SegmentKind::Coolant { .. } | SegmentKind::SpindleOrient { program: None, .. } => {
                // The ISO emitter's M7/M8/M9/M19 blocks are the iTNC's too.
                return self.e.single(op, kind);
            }
            SegmentKind::SpindleOrient { .. } => {
                return Err(self
                    .e
                    .refuse(op, "a reference return of the spindle axis".into()));
            }
            SegmentKind::Stop { kind } => match super::ops::stop_code(*kind) {
                Some(m) => m.into(),
                None => {
                    return Err(self.e.refuse(op, super::ops::WAIT_MARK_REFUSED.into()));
                }
            },
            SegmentKind::Message { text } => {
                let clean: String = text.chars().filter(|c| *c != ';').collect();
                format!("; {clean}")
            }
        };
        self.push(text, op);
        Ok(())
    }

    /// G81/G82 as `CYCL DEF 200 DRILLING`, rigid taps G84/G74 (no peck, no dwell) as
    /// `CYCL DEF 207 RIGID TAPPING NEW` (one plunge to the depth, the set-up clearance 0 so
    /// that Q203 is the R level, Q204 the return level above it: 0 for G99) and an
    /// `L X Y FMAX M99` at each hole. Other cycles are refused, naming the block.
    fn drilling(&mut self, op: &CanonOp, cc: &CannedCycle) -> Result<(), PostError> {
        self.datum(op)?;
        let refuse = |why: &str| {
            self.e.refuse(
                op,
                format!(
                    "canned cycle G{}: {why} (the iTNC output writes G81/G82 as CYCL DEF 200, \
                     G83 as 205, G85/G89 as 201 and rigid taps G84/G74 as 207 only)",
                    cc.code
                ),
            )
        };
        self.check_state(op)?;
        let xyz = ['X', 'Y', 'Z'].map(|l| self.e.cfg.axis_index(l));
        let tap = matches!(cc.code, 74 | 84)
            && cc.tap.is_some_and(|t| t.peck.is_none())
            && cc.words.p.unwrap_or(0.0) == 0.0;
        if !(matches!(cc.code, 81..=83 | 85 | 89) || tap)
            || cc.plan.linuxcnc.is_some()
            || xyz.map(Some) != cc.axes.map(|i| Some(Some(i)))
        {
            return Err(refuse(
                "not this cycle, plane or dialect (a peck tap or a tap with a dwell neither)",
            ));
        }
        if self.length == Length::Pending || op.state.comp.is_some() {
            return Err(refuse("the tool length not yet on, or compensation on"));
        }
        let here = op.state.to_work(&self.e.pos)[cc.axes[2]];
        let above = cc.return_level - cc.r_level;
        let depth = cc.bottom - cc.r_level;
        // G98 returns to the initial level, the iTNC to Q204: the same only from there.
        let off_initial = above > SAME && (here - cc.initial_level).abs() > SAME;
        if off_initial || above < -SAME || depth >= -SAME {
            return Err(refuse(
                "a return level below R, a depth above R, or a start off the initial level",
            ));
        }
        let (head, q) = match cc.tap {
            Some(t) => (
                "CYCL DEF 207 RIGID TAPPING NEW",
                self.tapping_q(op, cc, t, depth, above)?,
            ),
            None if cc.code == 83 => (
                "CYCL DEF 205 UNIVERSAL PECKING",
                self.pecking_q(op, cc, depth, above)?,
            ),
            None if matches!(cc.code, 85 | 89) => (
                "CYCL DEF 201 REAMING",
                self.reaming_q(op, cc, depth, above)?,
            ),
            None => (
                "CYCL DEF 200 DRILLING",
                self.drilling_q(op, cc, depth, above)?,
            ),
        };
        // Unnumbered lines of the definition, as the iTNC writes them; a definition stays
        // active until the next, so the same one is not written twice.
        let mut def = vec![head.to_string()];
        def.extend(
            q.iter()
                .map(|(name, value, what)| format!("  {name}={value} ;{what}")),
        );
        if self.drilling.as_ref() != Some(&def) {
            for line in &def {
                self.push(line.clone(), op);
            }
            self.drilling = Some(def);
        }
        for &[x, y] in &cc.holes {
            self.push(format!("L X{} Y{} FMAX M99", self.len(x), self.len(y)), op);
            self.written[0] = true;
            self.written[1] = true;
        }
        // The cycle's feed is not the contour's: the next feed block writes its F.
        self.feed = None;
        Ok(())
    }

    /// The Q parameters of `CYCL DEF 200` for a G81/G82.
    fn drilling_q(
        &self,
        op: &CanonOp,
        cc: &CannedCycle,
        depth: f64,
        above: f64,
    ) -> Result<QParams, PostError> {
        let f = self.feed_word(cc.feed, op)?;
        let dwell = cc.words.p.unwrap_or(0.0);
        Ok(vec![
            ("Q200", "+0".to_string(), "SET-UP CLEARANCE"),
            ("Q201", self.len(depth), "DEPTH"),
            (
                "Q206",
                format!("+{}", f.trim_start_matches('F').trim_end_matches('.')),
                "FEED RATE FOR PLNGNG",
            ),
            ("Q202", self.len(-depth), "PLUNGING DEPTH"),
            ("Q210", "+0".to_string(), "DWELL TIME AT TOP"),
            ("Q203", self.len(cc.r_level), "SURFACE COORDINATE"),
            ("Q204", self.len(above.max(0.0)), "2ND SET-UP CLEARANCE"),
            (
                "Q211",
                format!("+{}", decimal(dwell, 3).trim_end_matches('.')),
                "DWELL TIME AT DEPTH",
            ),
        ])
    }

    /// The Q parameters of `CYCL DEF 201` for a G85 (G89: with the dwell at the depth): in
    /// at Q206, out to the set-up clearance (R) at the retraction feed Q208 — the same F,
    /// as Fanuc's G85/G89 feed out — then to the 2nd set-up clearance at FMAX.
    fn reaming_q(
        &self,
        op: &CanonOp,
        cc: &CannedCycle,
        depth: f64,
        above: f64,
    ) -> Result<QParams, PostError> {
        let q = self.drilling_q(op, cc, depth, above)?;
        let find = |name: &str| {
            q.iter()
                .find(|(n, _, _)| *n == name)
                .map(|(_, v, _)| v.clone())
                .unwrap_or_default()
        };
        let dwell = if cc.code == 89 {
            find("Q211")
        } else {
            "+0".to_string()
        };
        Ok(vec![
            ("Q200", find("Q200"), "SET-UP CLEARANCE"),
            ("Q201", find("Q201"), "DEPTH"),
            ("Q206", find("Q206"), "FEED RATE FOR PLNGNG"),
            ("Q211", dwell, "DWELL TIME AT DEPTH"),
            ("Q208", find("Q206"), "RETRACTION FEED RATE"),
            ("Q203", find("Q203"), "SURFACE COORDINATE"),
            ("Q204", find("Q204"), "2ND SET-UP CLEARANCE"),
        ])
    }

    /// The Q parameters of `CYCL DEF 205` for a G83: the plunging depth Q202 is the job's Q,
    /// both advanced stop distances (Q258 upper, Q259 lower) the machine's G83 re-entry
    /// clearance — so the iTNC goes back to R after each plunge and down at rapid to that
    /// distance above the last depth, as Fanuc's G83 does; no decrement, chip breaking,
    /// dwell or deepened start. A peck shorter than the clearance is refused (Fanuc stops
    /// the re-entry at R, the iTNC would not).
    fn pecking_q(
        &self,
        op: &CanonOp,
        cc: &CannedCycle,
        depth: f64,
        above: f64,
    ) -> Result<QParams, PostError> {
        let clearance = cc.plan.peck_clearance;
        let peck = cc.words.q.unwrap_or(-depth).min(-depth);
        let pecks = peck < -depth - SAME;
        let differs = (clearance - self.e.cfg.interp.peck_clearance).abs() > SAME;
        if (pecks && peck < clearance - SAME) || differs {
            return Err(self.e.refuse(
                op,
                format!(
                    "canned cycle G83: a peck Q shorter than the re-entry clearance {clearance} \
                     (CYCL DEF 205 re-enters above R where the job's G83 stops at R)"
                ),
            ));
        }
        let mut q = self.drilling_q(op, cc, depth, above)?;
        // Cycle 200's Q200 Q201 Q206 Q202 Q210 Q203 Q204 Q211, less Q210, then 205's own.
        q.retain(|(name, _, _)| !matches!(*name, "Q210" | "Q211"));
        q[3].1 = self.len(peck);
        q.extend([
            ("Q212", "+0".to_string(), "DECREMENT"),
            ("Q205", "+0".to_string(), "MIN. PLUNGING DEPTH"),
            ("Q258", self.len(clearance), "UPPER ADV STOP DIST"),
            ("Q259", self.len(clearance), "LOWER ADV STOP DIST"),
            ("Q257", "+0".to_string(), "DEPTH FOR CHIP BRKNG"),
            ("Q256", "+0.2".to_string(), "DIST FOR CHIP BRKNG"),
            ("Q211", "+0".to_string(), "DWELL TIME AT DEPTH"),
            ("Q379", "+0".to_string(), "STARTING POINT"),
            ("Q253", "+750".to_string(), "F PRE-POSITIONING"),
        ]);
        Ok(q)
    }

    /// The Q parameters of `CYCL DEF 207` for a rigid tap: the pitch signed by the hand
    /// (G74: negative), the speed the iTNC taps at is the `TOOL CALL`'s S, so the job's is
    /// written first when the control holds another (the iTNC's feed is S × pitch, the
    /// job's F by construction).
    fn tapping_q(
        &mut self,
        op: &CanonOp,
        cc: &CannedCycle,
        tap: cnc402_interp::canon::TapPlan,
        depth: f64,
        above: f64,
    ) -> Result<QParams, PostError> {
        let d = self.e.rules.position_decimals;
        let s = super::format::speed(self.e.rules, cc.plan.speed, &op.source)?;
        if self.e.modal.spindle.as_deref() != Some(&s) {
            self.push(format!("TOOL CALL Z {s}"), op);
            self.e.modal.spindle = Some(s);
        }
        let hand = if tap.dir == SpindleDir::Ccw {
            -1.0
        } else {
            1.0
        };
        // The pitch in the program's length unit, with the decimals a pitch needs.
        let pitch = if self.inch {
            signed(hand * tap.pitch / 25.4, 5)
        } else {
            signed(hand * tap.pitch, d + 1)
        };
        Ok(vec![
            ("Q200", "+0".to_string(), "SET-UP CLEARANCE"),
            ("Q201", self.len(depth), "DEPTH"),
            ("Q239", pitch, "PITCH"),
            ("Q203", self.len(cc.r_level), "SURFACE COORDINATE"),
            ("Q204", self.len(above.max(0.0)), "2ND SET-UP CLEARANCE"),
        ])
    }

    /// `L` or `CC` + `C`.
    fn path(&mut self, op: &CanonOp, kind: &SegmentKind) -> Result<(), PostError> {
        self.datum(op)?;
        self.check_state(op)?;
        let (end, feed) = match kind {
            SegmentKind::Rapid { end } => (end, None),
            SegmentKind::Linear { end, feed } | SegmentKind::Arc { end, feed, .. } => {
                (end, Some(*feed))
            }
            _ => return Ok(()),
        };
        let z = op.state.tool_axis;
        let mut axes = Vec::new();
        let machine = op.state.to_machine(end);
        for i in self.e.axes() {
            let moves = (machine[i] - self.e.pos[i]).abs() > SAME;
            let arc_axis = matches!(kind, SegmentKind::Arc { .. })
                && self.e.letter(i) != 'Z'
                && self.e.letter(i) != 'C';
            if moves
                || arc_axis
                || (self.length == Length::Pending && Some(i) == z && self.length_wanted(op))
            {
                axes.push(format!(
                    "{}{}",
                    self.e.letter(i),
                    self.axis_value(i, end[i])
                ));
            }
        }
        if axes.is_empty() {
            axes.push(format!(
                "{}{}",
                self.e.letter(0),
                self.axis_value(0, end[0])
            ));
        }
        if self.length == Length::Pending
            && z.is_some_and(|z| axes.iter().any(|a| a.starts_with(self.e.letter(z))))
        {
            self.length = Length::On;
        }
        let mut words = Vec::new();
        if let SegmentKind::Arc {
            center,
            dir,
            plane,
            turns,
            ..
        } = kind
        {
            let helix = self.arc_checks(op, end, *plane, *turns)?;
            let start = op.state.to_work(&self.e.pos);
            let [x, y, z] = self.e.xyz.map(|i| i.unwrap_or(0));
            if helix.is_some() {
                self.start_known(op, [start[x], start[y], start[z]])?;
            }
            self.push(
                format!("CC X{} Y{}", self.len(center[0]), self.len(center[1])),
                op,
            );
            let ccw = *dir == ArcDir::Ccw;
            if let Some(full) = helix {
                words = super::helix::polar_words(
                    [start[x], start[y], start[z]],
                    [end[x], end[y], end[z]],
                    [center[0], center[1]],
                    ccw,
                    full,
                    |v| self.len(v),
                    |a| signed(a, 4),
                );
            } else {
                self.note_written(&axes);
                words.push("C".to_string());
                words.extend(axes);
                words.push(if ccw { "DR+" } else { "DR-" }.into());
            }
        } else {
            self.note_written(&axes);
            words.push("L".into());
            words.extend(axes);
        }
        let comp = op.state.comp.map(|c| c.side);
        if self.comp != Some(comp) {
            words.push(
                match comp {
                    None => "R0",
                    Some(CompSide::Left) => "RL",
                    Some(CompSide::Right) => "RR",
                }
                .into(),
            );
            self.comp = Some(comp);
        }
        match feed {
            None => words.push("FMAX".into()),
            Some(f) => {
                let f = self.feed_word(f, op)?;
                if self.feed.as_deref() != Some(&f) {
                    words.push(f.clone());
                    self.feed = Some(f);
                }
            }
        }
        self.push(words.join(" "), op);
        Ok(())
    }

    /// Notes which of X, Y, Z the words `axes` write.
    fn note_written(&mut self, axes: &[String]) {
        for (k, l) in ['X', 'Y', 'Z'].into_iter().enumerate() {
            self.written[k] |= axes.iter().any(|a| a.starts_with(l));
        }
    }

    /// Before a `CP` (which runs from where the tool is): a rapid to where the tool is when
    /// the program has not yet written all of X, Y, Z (it moves nothing; under compensation
    /// it would, so then the helix is refused).
    fn start_known(&mut self, op: &CanonOp, start: [f64; 3]) -> Result<(), PostError> {
        if self.written.iter().all(|w| *w) {
            return Ok(());
        }
        if self.comp.flatten().is_some() {
            return Err(self.e.refuse(
                op,
                "a helix under compensation before the program wrote X, Y and Z".into(),
            ));
        }
        let at = start.map(|v| self.len(v));
        self.push(format!("L X{} Y{} Z{} FMAX", at[0], at[1], at[2]), op);
        self.written = [true; 3];
        Ok(())
    }

    /// Refuses an arc the iTNC output cannot write; `Some(full turn)` for a helix along Z
    /// (written as `CP`), `None` for a plain XY arc.
    fn arc_checks(
        &self,
        op: &CanonOp,
        end: &AxisPos,
        plane: Plane,
        turns: u32,
    ) -> Result<Option<bool>, PostError> {
        if plane != Plane::XY {
            return Err(self.e.refuse(
                op,
                "an arc outside G17 (the iTNC output writes XY arcs only)".into(),
            ));
        }
        let start = op.state.to_work(&self.e.pos);
        let xy = [self.e.cfg.axis_index('X'), self.e.cfg.axis_index('Y')];
        let closed = xy
            .iter()
            .flatten()
            .all(|&i| (start[i] - end[i]).abs() <= SAME);
        if turns > 1 || (turns == 1 && !closed) {
            return Err(self
                .e
                .refuse(op, "an arc of more than one full turn".into()));
        }
        let moves = |i: usize| (op.state.to_machine(end)[i] - self.e.pos[i]).abs() > SAME;
        let z = self.e.xyz[2];
        let other = self
            .e
            .axes()
            .any(|i| !xy.contains(&Some(i)) && Some(i) != z && moves(i));
        if other || xy.contains(&None) {
            return Err(self.e.refuse(
                op,
                "an arc moving another axis than X, Y, Z (the iTNC output writes XY arcs and \
                 helices along Z)"
                    .into(),
            ));
        }
        Ok(z.is_some_and(moves).then_some(turns == 1))
    }

    /// The job's datum as a cycle-7 shift from the machine's G54, written (four blocks at
    /// once) before the first block that runs under a shift the control does not hold.
    fn datum(&mut self, op: &CanonOp) -> Result<(), PostError> {
        let want = super::datum::shift_of(&self.e, op).map_err(|m| self.e.refuse(op, m))?;
        let blocks = super::datum::shift_blocks(&self.shift, &want, |v| self.len(v));
        for b in blocks {
            self.push(b, op);
        }
        self.shift = want;
        Ok(())
    }

    /// Axis `i`'s value: a length, or degrees for a rotary axis.
    fn axis_value(&self, i: usize, value: f64) -> String {
        match self.e.cfg.axes[i].kind {
            cnc402_config::AxisKind::Linear => self.len(value),
            _ => signed(value, self.e.rules.position_decimals),
        }
    }

    /// The length of the called tool in the machine's table (what the iTNC switches on).
    fn called_length(&self) -> f64 {
        let tool = self.tool.unwrap_or(0) as usize;
        self.e
            .cfg
            .tool_offsets
            .get(tool.wrapping_sub(1))
            .map_or(0.0, |t| t.length + t.length_wear)
    }

    /// The job runs with the tool's length (G43 H of the called tool).
    fn length_wanted(&self, op: &CanonOp) -> bool {
        self.e.effective_length(op) != 0.0
    }

    /// Refuses a state the iTNC program cannot reproduce: another datum than G54's, a tool
    /// length other than the called tool's, a radius other than its, a path mode other than
    /// the machine's default.
    fn check_state(&self, op: &CanonOp) -> Result<(), PostError> {
        let st = &op.state;
        let refuse = |m: &str| Err(self.e.refuse(op, m.to_string()));
        let length = self.e.effective_length(op);
        let tool = self.tool.unwrap_or(0);
        if length != 0.0 {
            let table = self.e.cfg.tool_offsets.get((tool as usize).wrapping_sub(1));
            let own = table.map(|t| t.length + t.length_wear);
            if st.tool_length_mode != 43
                || st.h != tool
                || own.is_none_or(|l| (l - length).abs() > SAME)
            {
                return refuse(
                    "a tool length other than the called tool's (the iTNC takes the length of the tool it calls)",
                );
            }
            if self.length == Length::Off {
                return refuse("a tool length with no tool called");
            }
        } else if self.length == Length::On && self.called_length() != 0.0 {
            // (A called tool of length 0 moves the same with its length on or off.)
            return refuse(
                "a move without the called tool's length (G49) after the iTNC switched it on",
            );
        }
        if let Some(c) = st.comp {
            let table = self.e.cfg.tool_offsets.get((tool as usize).wrapping_sub(1));
            let own = table.map(|t| t.radius + t.radius_wear);
            if c.d != tool || own.is_none_or(|r| (r - c.radius).abs() > SAME) {
                return refuse(
                    "a cutter radius other than the called tool's (RL/RR take the called tool's)",
                );
            }
        }
        if st.path_mode.code() != default_path_code(self.e.cfg) {
            return refuse("a path mode (G61/G64) other than the machine's default");
        }
        Ok(())
    }
}

fn default_path_code(cfg: &cnc402_config::MachineConfig) -> u32 {
    match cfg.interp.path_mode {
        cnc402_config::PathModeDefault::ExactStop => 61,
        _ => 64,
    }
}

/// `+10.5`, `-2`: Heidenhain's signed numbers.
pub fn signed(v: f64, decimals: u32) -> String {
    let d = decimal(v, decimals);
    let d = d.trim_end_matches('.');
    if d.starts_with('-') {
        d.to_string()
    } else {
        format!("+{d}")
    }
}

/// The text: `0 BEGIN PGM NAME MM`, the blocks numbered from 1, the label bodies
/// (`LBL n` … `LBL 0`, after the main program's `M2`/`M30`), `n END PGM NAME MM`.
pub fn assemble_itnc(
    program: &Program,
    inch: bool,
    rules: &crate::Rules,
) -> Result<String, PostError> {
    let units = if inch { "INCH" } else { "MM" };
    let mut text = format!("0 BEGIN PGM CNC402 {units}\n");
    let mut n = 1usize;
    let labels = (1..).zip(&program.subs).flat_map(|(label, sub)| {
        std::iter::once(Block::new(vec![format!("LBL {label}")], None))
            .chain(sub.blocks.iter().cloned())
            .chain([Block::new(vec!["LBL 0".into()], None)])
    });
    for b in program.main.iter().cloned().chain(labels) {
        let body: Vec<String> = b
            .words
            .iter()
            .map(|w| match w {
                crate::assemble::Word::Text(t) => t.clone(),
                crate::assemble::Word::Sub(_) => String::new(),
            })
            .collect();
        let body = body.join(" ");
        // A cycle's Q lines carry no number of their own.
        let numbered = !body.starts_with(' ');
        let line = if numbered {
            format!("{n} {body}")
        } else {
            body
        };
        if line.len() > rules.max_line {
            return Err(PostError::target(
                rules,
                b.source.as_ref(),
                format!("a block longer than {} characters", rules.max_line),
            ));
        }
        text.push_str(&line);
        text.push('\n');
        n += usize::from(numbered);
    }
    text.push_str(&format!("{n} END PGM CNC402 {units}\n"));
    Ok(text)
}
