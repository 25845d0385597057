//! Fanuc canned cycles G73 G74 G76 G81–G89 expanded into rapid, feed, dwell and spindle
//! segments, in any plane (G17 drills along Z, G18 along Y, G19 along X). G74/G84 are rigid
//! taps: the drilling axis and the spindle axis C move together, one turn per pitch.
//!
//! Conventions (documented in the crate docs): G76/G87 orient the spindle by stopping it and
//! turning it to the physical angle `interp.spindle_orient_angle` (a `SpindleOrient` segment
//! that motion resolves), then shift by Q along +first plane axis
//! (G17: +X, G18: +Z, G19: +Y; Fanuc RD2,RD1 = 0,0). G87 always returns to the initial level.

use cnc402_lang::NcError;
use cnc402_lang::ast::Span;
use cnc402_motion::segment::{AxisPos, SegmentKind, SpindleDir, StopKind};

use super::exec::Exec;
use super::state::Cycle;
use super::words::fmt_num;

/// Lengths closer than this are the same point.
const EPS: f64 = 1e-9;

/// What one hole needs, resolved from the block and the modal cycle data.
struct Hole {
    /// Indices of first plane axis and drilling axis.
    ia: usize,
    id: usize,
    /// Machine levels along the drilling axis.
    r_level: f64,
    bottom: f64,
    ret: f64,
    feed: f64,
}

/// Rigid-tap coupling: C = c0 + |d − r_level| · k.
#[derive(Clone, Copy)]
struct Tap {
    ic: usize,
    c0: f64,
    /// Degrees of C per mm of drilling-axis travel into the hole (negative for G74).
    k: f64,
    /// The thread pitch F/S (G94) or F (G95), mm per turn, > 0.
    pitch: f64,
    /// +1 for G84 (right hand), −1 for G74.
    hand: f64,
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
        let data = self.st.cycle_data;
        let Some(r) = data.r else {
            return Err(self
                .err(
                    cyc_span,
                    format!("canned cycle {name} needs R (the R level)"),
                )
                .with_expected("an R word"));
        };
        let Some(z) = data.z else {
            return Err(self
                .err(
                    cyc_span,
                    format!("canned cycle {name} needs {ld} (the bottom of the hole)"),
                )
                .with_expected(format!("a {ld} word")));
        };
        if matches!(cyc, Cycle::G73 | Cycle::G83) && data.q.is_none() {
            return Err(self
                .err(cyc_span, format!("{name} needs Q (the peck depth)"))
                .with_expected("a Q word > 0"));
        }
        let tap = match cyc {
            Cycle::G84 | Cycle::G74 => Some(self.tap_setup(cyc, cyc_span)?),
            _ => None,
        };
        let feed = self.feed_rate(cyc_span)?;
        let turning = self.st.spindle_turning();
        let (speed, dir) = (self.st.speed, self.st.spindle);
        if cyc == Cycle::G87 && !turning {
            return Err(self
                .err(cyc_span, "G87 (back boring) needs the spindle turning")
                .with_expected("M3 or M4 with S > 0 before G87"));
        }
        let restore = |ex: &mut Self| {
            if turning {
                ex.push(SegmentKind::Spindle { rpm: speed, dir });
            }
        };
        if tap.is_some() && turning {
            self.push(SegmentKind::Spindle {
                rpm: 0.0,
                dir: SpindleDir::Stop,
            });
        }
        for _ in 0..reps {
            let mut pos = self.st.pos;
            for (w, i) in [(wa, ia), (wb, ib)] {
                if let Some(a) = w {
                    pos[i] = self.word_target(i, a.v * unit);
                }
            }
            // The levels include the work zero, the G92 shift and the tool length offset. In
            // G91 the R level is a distance from the initial level that carries the part of
            // the offset vector G28/G30/G53 took out at the reference, as any G91 Z move does.
            let r_level = if self.st.incremental {
                data.initial + data.initial_tlo_pending + r
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
            let ret = if self.st.return_to_r && cyc != Cycle::G87 {
                r_level
            } else {
                data.initial
            };
            let h = Hole {
                ia,
                id,
                r_level,
                bottom,
                ret,
                feed,
            };
            // Positioning in the plane at the current level.
            self.rapid_to(pos, &[la, lb])?;
            match cyc {
                Cycle::G87 => self.back_boring(&h, data.q.unwrap_or(0.0), speed, dir)?,
                _ => {
                    self.rapid_d(&h, r_level)?;
                    self.hole_body(cyc, &h, tap, turning, speed, dir)?;
                }
            }
        }
        if tap.is_some() {
            restore(self);
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
    fn tap_setup(&self, cyc: Cycle, span: Span) -> Result<Tap, NcError> {
        let (name, want, wrong, hand) = if cyc == Cycle::G84 {
            ("G84 (right-hand tap)", "M3", SpindleDir::Ccw, 1.0)
        } else {
            ("G74 (left-hand tap)", "M4", SpindleDir::Cw, -1.0)
        };
        let Some(ic) = self.cfg.spindle_index() else {
            return Err(self.err(span, format!("{name} needs a spindle axis in the config")));
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
        Ok(Tap {
            ic,
            c0: self.st.pos[ic],
            k: hand * 360.0 / pitch,
            pitch,
            hand,
        })
    }

    fn rapid_to(&mut self, p: AxisPos, hint: &[char]) -> Result<(), NcError> {
        if p.0
            .iter()
            .zip(self.st.pos.0.iter())
            .any(|(a, b)| (a - b).abs() > EPS)
        {
            self.rapid(p, hint)?;
        }
        Ok(())
    }

    /// Words to blame for a drilling-axis target out of limits: R for the R level.
    fn hint(&self, h: &Hole, level: f64) -> [char; 2] {
        let d = self.plane_letters().2;
        if level == h.r_level {
            ['R', d]
        } else {
            [d, 'R']
        }
    }

    fn rapid_d(&mut self, h: &Hole, level: f64) -> Result<(), NcError> {
        let mut p = self.st.pos;
        p[h.id] = level;
        let hint = self.hint(h, level);
        self.rapid_to(p, &hint)
    }

    fn feed_d(&mut self, h: &Hole, level: f64) -> Result<(), NcError> {
        let mut p = self.st.pos;
        p[h.id] = level;
        let hint = self.hint(h, level);
        self.linear(p, h.feed, &hint)
    }

    /// A tap move to `level`, C coupled: C = c0 + |level − R| · k. Every level lies between
    /// R and the bottom, so Δd / ΔC = sign(bottom − R) / k: the signed pitch is
    /// sign(bottom − R) · hand · pitch (negative for G84 into a hole below R).
    fn tap_d(&mut self, h: &Hole, t: Tap, level: f64) -> Result<(), NcError> {
        let mut p = self.st.pos;
        p[h.id] = level;
        p[t.ic] = t.c0 + (level - h.r_level).abs() * t.k;
        let hint = self.hint(h, level);
        let pitch = (h.bottom - h.r_level).signum() * t.hand * t.pitch;
        self.tap(p, h.feed, h.id, pitch, &hint)
    }

    fn dwell_data(&mut self) {
        if let Some(s) = self.st.cycle_data.p
            && s > 0.0
        {
            self.push(SegmentKind::Dwell { seconds: s });
        }
    }

    /// Spindle orientation (G76, G87, M19): stop, then turn the spindle to the physical angle
    /// `interp.spindle_orient_angle`. Only motion knows the physical angle (program C plus
    /// the offset that speed-mode runs leave), so this emits `SpindleOrient` and leaves the
    /// program's C unchanged (motion puts the turn into the offset).
    pub(crate) fn orient(&mut self) -> Result<(), NcError> {
        self.push(SegmentKind::Spindle {
            rpm: 0.0,
            dir: SpindleDir::Stop,
        });
        if self.cfg.spindle_index().is_some() {
            self.push(SegmentKind::SpindleOrient {
                angle: self.cfg.interp.spindle_orient_angle,
                program: None,
            });
        }
        Ok(())
    }

    fn shift(&mut self, h: &Hole, by: f64) -> Result<(), NcError> {
        let mut p = self.st.pos;
        p[h.ia] += by;
        let l = self.plane_letters().0;
        self.rapid_to(p, &['Q', l])
    }

    /// Level at distance `t` from R into the hole.
    fn level(h: &Hole, t: f64) -> f64 {
        h.r_level + (h.bottom - h.r_level).signum() * t
    }

    /// From the R level: the cycle's drilling, bottom action and return.
    fn hole_body(
        &mut self,
        cyc: Cycle,
        h: &Hole,
        tap: Option<Tap>,
        turning: bool,
        speed: f64,
        dir: SpindleDir,
    ) -> Result<(), NcError> {
        let depth = (h.bottom - h.r_level).abs();
        let q = self.st.cycle_data.q;
        let restore = |ex: &mut Self| {
            if turning {
                ex.push(SegmentKind::Spindle { rpm: speed, dir });
            }
        };
        match cyc {
            Cycle::G81 => {
                self.feed_d(h, h.bottom)?;
                self.rapid_d(h, h.ret)?;
            }
            Cycle::G82 => {
                self.feed_d(h, h.bottom)?;
                self.dwell_data();
                self.rapid_d(h, h.ret)?;
            }
            Cycle::G73 | Cycle::G83 => {
                let q = q.unwrap_or(depth);
                let d = if cyc == Cycle::G73 {
                    self.cfg.interp.peck_retract
                } else {
                    self.cfg.interp.peck_clearance
                };
                let mut t = 0.0;
                loop {
                    let mut nt = (t + q).min(depth);
                    if depth - nt < 1e-6 {
                        nt = depth;
                    }
                    self.feed_d(h, Self::level(h, nt))?;
                    if nt >= depth {
                        break;
                    }
                    if cyc == Cycle::G73 {
                        self.rapid_d(h, Self::level(h, (nt - d).max(0.0)))?;
                    } else {
                        self.rapid_d(h, h.r_level)?;
                        self.rapid_d(h, Self::level(h, (nt - d).max(0.0)))?;
                    }
                    t = nt;
                }
                self.rapid_d(h, h.ret)?;
            }
            Cycle::G84 | Cycle::G74 => {
                let t_ = tap.expect("tap set up for G74/G84");
                match q {
                    Some(q) => {
                        let d = self.cfg.interp.tap_peck_retract;
                        let mut t = 0.0;
                        loop {
                            let mut nt = (t + q).min(depth);
                            if depth - nt < 1e-6 {
                                nt = depth;
                            }
                            self.tap_d(h, t_, Self::level(h, nt))?;
                            if nt >= depth {
                                break;
                            }
                            self.tap_d(h, t_, Self::level(h, (nt - d).max(0.0)))?;
                            t = nt;
                        }
                    }
                    None => self.tap_d(h, t_, h.bottom)?,
                }
                self.dwell_data();
                self.tap_d(h, t_, h.r_level)?;
                self.rapid_d(h, h.ret)?;
            }
            Cycle::G85 => {
                self.feed_d(h, h.bottom)?;
                self.feed_d(h, h.r_level)?;
                self.rapid_d(h, h.ret)?;
            }
            Cycle::G89 => {
                self.feed_d(h, h.bottom)?;
                self.dwell_data();
                self.feed_d(h, h.r_level)?;
                self.rapid_d(h, h.ret)?;
            }
            Cycle::G86 => {
                self.feed_d(h, h.bottom)?;
                self.push(SegmentKind::Spindle {
                    rpm: 0.0,
                    dir: SpindleDir::Stop,
                });
                self.rapid_d(h, h.ret)?;
                restore(self);
            }
            Cycle::G88 => {
                self.feed_d(h, h.bottom)?;
                self.dwell_data();
                self.push(SegmentKind::Spindle {
                    rpm: 0.0,
                    dir: SpindleDir::Stop,
                });
                self.push(SegmentKind::Stop {
                    kind: StopKind::Program,
                });
                self.rapid_d(h, h.ret)?;
                restore(self);
            }
            Cycle::G76 => {
                let q = q.unwrap_or(0.0);
                self.feed_d(h, h.bottom)?;
                self.dwell_data();
                self.orient()?;
                self.shift(h, q)?;
                self.rapid_d(h, h.ret)?;
                self.shift(h, -q)?;
                restore(self);
            }
            Cycle::G87 => unreachable!("G87 has its own sequence"),
        }
        Ok(())
    }

    /// G87: orient, shift, rapid to the R level (the bottom of the bore), shift back, spindle
    /// on, feed up to Z, dwell, orient, shift, rapid to the initial level, shift back, spindle on.
    fn back_boring(
        &mut self,
        h: &Hole,
        q: f64,
        speed: f64,
        dir: SpindleDir,
    ) -> Result<(), NcError> {
        self.orient()?;
        self.shift(h, q)?;
        self.rapid_d(h, h.r_level)?;
        self.shift(h, -q)?;
        self.push(SegmentKind::Spindle { rpm: speed, dir });
        self.feed_d(h, h.bottom)?;
        self.dwell_data();
        self.orient()?;
        self.shift(h, q)?;
        self.rapid_d(h, h.ret)?;
        self.shift(h, -q)?;
        self.push(SegmentKind::Spindle { rpm: speed, dir });
        Ok(())
    }
}
