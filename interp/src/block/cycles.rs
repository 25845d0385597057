//! Fanuc canned cycles G73 G74 G76 G81–G89 as the block layer executes them: the cycle data
//! Fanuc keeps, the checks (with the word to blame), and one canonical [`CannedCycle`]
//! operation per drilling block with its holes. The moves themselves come from
//! `lower::cycle::expand`, which the block runs here to check every move against the soft
//! limits and to know where the block leaves the tool, and lowering runs again to make the
//! segments. Any plane: G17 drills along Z, G18 along Y, G19 along X. G74/G84 are rigid taps.

use cnc402_lang::NcError;
use cnc402_lang::ast::Span;
use cnc402_motion::segment::{SegmentKind, SpindleDir};

use super::exec::Exec;
use super::state::Cycle;
use super::words::{Arg, fmt_num};
use crate::canon::{
    CannedCycle, CanonKind, CanonOp, CanonState, CyclePlan, CycleWords, LinuxCncCycle, TapPlan,
};
use crate::lower::cycle::{Expander, MAX_CYCLE_MOVES, MAX_PECKS, moves_per_hole, peck_count};

/// Lengths closer than this are the same point.
const EPS: f64 = 1e-9;

/// LinuxCNC's G73 retract and G83 clearance: 0.010 in, mm.
const LINUXCNC_PECK: f64 = 0.254;

/// The block's hole-position words and what the cycle needs besides the modal data.
struct Drill {
    cyc: Cycle,
    span: Span,
    /// Plane axes and drilling axis: letters and indices.
    letters: (char, char, char),
    axes: [usize; 3],
    /// The plane-axis words (program units).
    wa: Option<Arg>,
    wb: Option<Arg>,
    reps: u32,
}

impl Exec<'_> {
    /// Executes a block in canned-cycle mode: stores the cycle data it carries and, if it has
    /// a position, R or drilling-axis word, drills (K/L times).
    pub(crate) fn cycle(&mut self, cyc: Cycle, cyc_span: Span) -> Result<(), NcError> {
        let name = format!("G{}", cyc.code());
        let (la, lb, ld) = self.plane_letters();
        let ia = self.axis(la, cyc_span, "a canned cycle in this plane")?;
        let ib = self.axis(lb, cyc_span, "a canned cycle in this plane")?;
        let id = self.axis(ld, cyc_span, "a canned cycle in this plane")?;
        for ax in &self.cfg.axes {
            if ![la, lb, ld].contains(&ax.name)
                && let Some(a) = self.w.peek(ax.name)
            {
                return Err(self
                    .err(
                        a.span,
                        format!("axis {} cannot move in a canned cycle ({name})", ax.name),
                    )
                    .with_expected(format!("{la}, {lb} (hole position) and {ld} (bottom)")));
            }
        }
        let unit = self.st.unit();
        let wa = self.w.take(la);
        let wb = self.w.take(lb);
        let wd = self.w.take(ld);
        let wr = self.w.take('R');
        if let Some(r) = wr {
            self.st.cycle_data.r = Some(r.v * unit);
        }
        if let Some(z) = wd {
            self.st.cycle_data.z = Some(z.v * unit);
        }
        if let Some(q) = self.w.take('Q') {
            let peck = matches!(cyc, Cycle::G73 | Cycle::G83 | Cycle::G74 | Cycle::G84);
            if q.v < 0.0 || (peck && q.v == 0.0) {
                let what = if peck {
                    "Q (peck depth) must be > 0"
                } else {
                    "Q (shift) must be >= 0"
                };
                return Err(self.err(q.span, format!("{what}, not {}", fmt_num(q.v))));
            }
            self.st.cycle_data.q = Some(q.v * unit);
        }
        if let Some(p) = self.w.take('P') {
            self.st.cycle_data.p = Some(self.dwell_p(p)?);
        }
        let reps = self.repeats()?;
        if (wa.is_none() && wb.is_none() && wd.is_none() && wr.is_none()) || reps == 0 {
            return Ok(()); // Fanuc: data stored, no drilling.
        }
        self.drill(Drill {
            cyc,
            span: cyc_span,
            letters: (la, lb, ld),
            axes: [ia, ib, id],
            wa,
            wb,
            reps,
        })
    }

    /// A drilling block: checks the data, resolves the levels, runs the expansion hole by
    /// hole (G91 repeats count from where the last hole left the tool) to check every move,
    /// and emits the block as one canonical operation.
    fn drill(&mut self, d: Drill) -> Result<(), NcError> {
        let (cyc, (la, lb, ld), [ia, ib, id]) = (d.cyc, d.letters, d.axes);
        let name = format!("G{}", cyc.code());
        let data = self.st.cycle_data;
        let Some(r) = data.r else {
            return Err(self
                .err(d.span, format!("canned cycle {name} needs R (the R level)"))
                .with_expected("an R word"));
        };
        let Some(z) = data.z else {
            return Err(self
                .err(
                    d.span,
                    format!("canned cycle {name} needs {ld} (the bottom of the hole)"),
                )
                .with_expected(format!("a {ld} word")));
        };
        if matches!(cyc, Cycle::G73 | Cycle::G83) && data.q.is_none() {
            return Err(self
                .err(d.span, format!("{name} needs Q (the peck depth)"))
                .with_expected("a Q word > 0"));
        }
        let tap = match cyc {
            Cycle::G84 | Cycle::G74 => Some(self.tap_setup(cyc, d.span)?),
            _ => None,
        };
        let feed = self.feed_rate(d.span)?;
        let turning = self.st.spindle_turning();
        if cyc == Cycle::G87 && !turning {
            return Err(self
                .err(d.span, "G87 (back boring) needs the spindle turning")
                .with_expected("M3 or M4 with S > 0 before G87"));
        }
        // The levels include the work zero, the G92 shift and the tool length offset. In G91
        // the R level is a distance from the initial level that carries the part of the
        // offset vector G28/G30/G53 took out at the reference, as any G91 Z move does.
        let r_level = if self.st.incremental {
            data.lc_g91_r_from.unwrap_or(data.initial) + data.initial_tlo_pending + r
        } else {
            r + self.st.origin(id)
        };
        let bottom = if self.st.incremental {
            r_level + z
        } else {
            z + self.st.origin(id)
        };
        // The drilling moves carry the whole offset vector (restored after G28).
        self.st.restore_tlo(id);
        self.check_levels(&name, ld, cyc, r_level, bottom)?;
        self.check_work(&name, cyc, ld, (r_level - bottom).abs(), d.reps)?;
        let state = self.canon_state();
        let o = state.offset.0[id];
        let linuxcnc = (self.dialect == cnc402_lang::Dialect::LinuxCnc).then(|| LinuxCncCycle {
            first: data.lc_level.is_none(),
            level: data.lc_level.unwrap_or(self.st.pos[id]) - o,
        });
        let initial = self.linuxcnc_initial(linuxcnc, r_level, bottom);
        let ret = if self.st.return_to_r && cyc != Cycle::G87 {
            r_level
        } else if linuxcnc.is_some() && (r_level - initial) * (r_level - bottom) > 0.0 {
            // LinuxCNC's G98 never returns below R.
            r_level
        } else {
            initial
        };
        if linuxcnc.is_some() {
            self.st.cycle_data.lc_level = Some(ret);
        }
        // LinuxCNC's G73 retract and G83 clearance are a fixed 0.010 in.
        let (peck_retract, peck_clearance) = match linuxcnc {
            Some(_) => (LINUXCNC_PECK, LINUXCNC_PECK),
            None => (self.cfg.interp.peck_retract, self.cfg.interp.peck_clearance),
        };
        let mut cc = CannedCycle {
            code: cyc.code(),
            words: CycleWords {
                r: data.r,
                z: data.z,
                q: data.q,
                p: data.p,
                f: self.st.feed,
                repeats: d.reps,
                incremental: self.st.incremental,
                return_to_r: self.st.return_to_r,
            },
            axes: [ia, ib, id],
            start: state.to_work(&self.st.pos),
            holes: Vec::new(),
            initial_level: initial - o,
            r_level: r_level - o,
            bottom: bottom - o,
            return_level: ret - o,
            feed,
            tap,
            plan: CyclePlan {
                peck_retract,
                peck_clearance,
                orient_angle: self
                    .spindle_axis()
                    .map(|_| self.cfg.interp.spindle_orient_angle),
                spindle: self.st.spindle_sel,
                spindle_turning: turning,
                speed: self.st.speed,
                spindle_dir: self.st.spindle,
                linuxcnc,
            },
        };
        let holes = self.run_holes(&d, &cc, &state, [r_level, bottom, ret])?;
        cc.holes = holes;
        let _ = (la, lb);
        self.out.push_back(CanonOp {
            kind: CanonKind::CannedCycle(Box::new(cc)),
            source: self.source.clone(),
            state,
        });
        Ok(())
    }

    /// Bottom ≠ R; G87 starts below the part.
    fn check_levels(
        &self,
        name: &str,
        ld: char,
        cyc: Cycle,
        r_level: f64,
        bottom: f64,
    ) -> Result<(), NcError> {
        if (bottom - r_level).abs() < EPS {
            return Err(self
                .err(
                    self.span_of(&[ld, 'R']),
                    format!("{name}: the bottom equals the R level"),
                )
                .with_expected(format!("{ld} different from R")));
        }
        // Fanuc: back boring starts below the part (R) and bores up to Z.
        if cyc == Cycle::G87 && r_level > bottom {
            return Err(self
                .err(
                    self.span_of(&[ld, 'R']),
                    format!(
                        "G87 (back boring) starts below the part: the R level must be below {ld}"
                    ),
                )
                .with_expected(format!("R below {ld} (R is the bottom of the bore)")));
        }
        Ok(())
    }

    /// Bounds the work of one block before anything is expanded: at most [`MAX_PECKS`] a
    /// hole (G73/G83, and G74/G84 with Q) and [`MAX_CYCLE_MOVES`] moves in all (holes ×
    /// moves a hole), blaming the Q word, then K or L.
    fn check_work(
        &self,
        name: &str,
        cyc: Cycle,
        ld: char,
        depth: f64,
        reps: u32,
    ) -> Result<(), NcError> {
        let q = self.st.cycle_data.q;
        let pecks = match (cyc, q) {
            (Cycle::G73 | Cycle::G83 | Cycle::G74 | Cycle::G84, Some(q)) => peck_count(q, depth),
            _ => 1.0,
        };
        if pecks > MAX_PECKS {
            let q_prog = self
                .w
                .peek('Q')
                .map_or_else(|| q.unwrap_or(0.0) / self.st.unit(), |a| a.v);
            return Err(self
                .err(
                    self.span_of(&['Q', ld, 'R']),
                    format!(
                        "{name} Q{} makes {pecks} pecks (more than {MAX_PECKS})",
                        fmt_num(q_prog)
                    ),
                )
                .with_expected("a larger Q (peck depth)"));
        }
        let moves = f64::from(reps) * moves_per_hole(pecks);
        if moves > MAX_CYCLE_MOVES {
            return Err(self
                .err(
                    self.span_of(&['K', 'L', 'Q', ld]),
                    format!(
                        "{name} with {reps} repeats of {pecks} pecks makes up to {moves} moves in one block (more than {MAX_CYCLE_MOVES})"
                    ),
                )
                .with_expected("fewer repeats (K/L) or a larger Q"));
        }
        Ok(())
    }

    /// Runs the expansion from the tool's machine position with the block's machine
    /// `levels` (R, bottom, return), hole by hole; checks every move against the soft limits
    /// (blaming the step's words) and leaves `pos` where the block ends. The hole positions,
    /// in work coordinates.
    fn run_holes(
        &mut self,
        d: &Drill,
        cc: &CannedCycle,
        state: &CanonState,
        levels: [f64; 3],
    ) -> Result<Vec<[f64; 2]>, NcError> {
        let [ia, ib, _] = d.axes;
        let unit = self.st.unit();
        let mut ex = Expander::at_machine(cc, state, self.st.pos, levels);
        ex.begin();
        let mut holes: Vec<[f64; 2]> = Vec::with_capacity(d.reps as usize);
        // LinuxCNC's G91 polar repeats (G17 only: polar words are X and Y).
        let polar_step = self
            .st
            .polar_step
            .filter(|_| d.letters.0 == 'X' && d.letters.1 == 'Y');
        for k in 0..d.reps {
            self.st.pos = ex.position();
            let mut pos = self.st.pos;
            match (polar_step, holes.last()) {
                (Some([dr, da]), Some(&[x, y])) if k > 0 => {
                    let r = x.hypot(y) + dr * unit;
                    let a = y.atan2(x) + da.to_radians();
                    pos[ia] = r * a.cos() + state.offset.0[ia];
                    pos[ib] = r * a.sin() + state.offset.0[ib];
                }
                _ => {
                    for (w, i) in [(d.wa, ia), (d.wb, ib)] {
                        if let Some(a) = w {
                            pos[i] = self.word_target(i, a.v * unit);
                        }
                    }
                }
            }
            holes.push([pos[ia] - state.offset.0[ia], pos[ib] - state.offset.0[ib]]);
            ex.hole(pos[ia], pos[ib]);
            self.check_steps(&mut ex)?;
        }
        ex.finish();
        self.st.pos = ex.position();
        Ok(holes)
    }

    /// The initial level the block returns to in G98. LinuxCNC (`linuxcnc` is `Some(true)`
    /// on the series' first block): a tool below R in G90 goes up to R first, and R is then
    /// the initial level.
    fn linuxcnc_initial(
        &mut self,
        linuxcnc: Option<LinuxCncCycle>,
        r_level: f64,
        bottom: f64,
    ) -> f64 {
        let data = &mut self.st.cycle_data;
        let below_r = (data.initial - r_level) * (r_level - bottom) < 0.0;
        if linuxcnc.is_some_and(|l| l.first) && below_r && !self.st.incremental {
            data.lc_g91_r_from = Some(data.initial);
            data.initial = r_level;
        }
        data.initial
    }

    /// The soft-limit check of the moves expanded so far.
    fn check_steps(&self, ex: &mut Expander) -> Result<(), NcError> {
        for step in ex.take_steps() {
            if let Some(end) = step.kind.line_end() {
                self.check_limits(end, &step.hint)?;
            }
        }
        Ok(())
    }

    /// K or L (both are the repeat count; default 1).
    fn repeats(&mut self) -> Result<u32, NcError> {
        let k = self.w.take('K');
        let l = self.w.take('L');
        let a = match (k, l) {
            (Some(_), Some(l)) => {
                return Err(self
                    .err(l.span, "K and L both give the repeat count")
                    .with_expected("one of K or L"));
            }
            (Some(a), None) | (None, Some(a)) => a,
            (None, None) => return Ok(1),
        };
        let n = self.whole(a, "the repeat count")?;
        if n > 9999 {
            return Err(self.err(a.span, "repeat count above 9999"));
        }
        Ok(n)
    }

    /// Checks a rigid tap can run and returns its coupling.
    fn tap_setup(&self, cyc: Cycle, span: Span) -> Result<TapPlan, NcError> {
        let (name, want, wrong, hand) = if cyc == Cycle::G84 {
            ("G84 (right-hand tap)", "M3", SpindleDir::Ccw, 1.0)
        } else {
            ("G74 (left-hand tap)", "M4", SpindleDir::Cw, -1.0)
        };
        let Some(ic) = self.spindle_axis() else {
            return Err(self.err(
                span,
                format!(
                    "{name} needs a spindle axis in the config (spindle {})",
                    self.st.spindle_sel
                ),
            ));
        };
        if self.st.spindle == wrong {
            return Err(self
                .err(
                    span,
                    format!(
                        "{name} with the spindle turning the wrong way ({} is active)",
                        if want == "M3" { "M4" } else { "M3" }
                    ),
                )
                .with_expected(format!("{want} before {}", &name[..3])));
        }
        if self.st.spindle == SpindleDir::Stop && !self.st.rigid {
            return Err(self
                .err(
                    span,
                    format!("{name} needs the spindle direction {want} or rigid mode M29"),
                )
                .with_expected(format!("{want} S… or M29 S… before {}", &name[..3])));
        }
        if self.st.speed <= 0.0 {
            return Err(self
                .err(
                    self.w.peek('S').map_or(span, |a| a.span),
                    format!("tapping with S = 0 ({})", &name[..3]),
                )
                .with_expected("S > 0 (the pitch is F/S in G94)"));
        }
        let pitch = if self.st.feed_per_rev {
            self.st.feed
        } else {
            self.st.feed / self.st.speed
        };
        if pitch <= 0.0 {
            let at = self.w.peek('F').map_or(span, |a| a.span);
            return Err(self
                .err(at, "zero feed in a motion block")
                .with_expected("an F word > 0 (the tap's feed gives its pitch)"));
        }
        Ok(TapPlan {
            spindle: ic,
            pitch,
            dir: if hand > 0.0 {
                SpindleDir::Cw
            } else {
                SpindleDir::Ccw
            },
            peck: self.st.cycle_data.q,
            peck_retract: self.cfg.interp.tap_peck_retract,
        })
    }

    /// Spindle orientation (G76, G87, M19): stop, then turn the spindle to the physical angle
    /// `interp.spindle_orient_angle`. Only motion knows the physical angle (program C plus
    /// the offset that speed-mode runs leave), so this emits `SpindleOrient` and leaves the
    /// program's C unchanged (motion puts the turn into the offset).
    pub(crate) fn orient(&mut self) -> Result<(), NcError> {
        let spindle = self.st.spindle_sel;
        self.push(SegmentKind::Spindle {
            rpm: 0.0,
            dir: SpindleDir::Stop,
            spindle,
        });
        if self.spindle_axis().is_some() {
            self.push(SegmentKind::SpindleOrient {
                angle: self.cfg.interp.spindle_orient_angle,
                program: None,
                spindle,
            });
        }
        Ok(())
    }
}
