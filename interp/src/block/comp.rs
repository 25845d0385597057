//! Group 07 in the block: G40/G41/G42 and D set the cutter compensation mode that canonical
//! operations carry, and the block-level rules are checked here with the word to blame (D in
//! the table, no start on an arc, no G41 in a canned cycle, no plane change while on). The
//! offset path itself is made by the `comp` stage on the canonical stream.

use cnc402_config::TOOL_OFFSETS;
use cnc402_lang::NcError;
use cnc402_lang::ast::Span;
use cnc402_motion::segment::Plane;

use super::exec::Exec;
use super::state::Motion;
use super::words::GGroup;
use crate::canon::{CompSide, CutterComp};

impl Exec<'_> {
    /// D and G40/G41/G42 of the block, checked against the modes the block runs in.
    pub(super) fn cutter_comp(&mut self) -> Result<(), NcError> {
        let d_word = self.w.take('D');
        if let Some(d) = d_word {
            let n = self.whole(d, "D (tool radius offset number)")?;
            if n as usize > TOOL_OFFSETS {
                return Err(self
                    .err(d.span, format!("D{n} is not in the tool offset table"))
                    .with_expected(format!("D0-D{TOOL_OFFSETS}")));
            }
            if self.st.comp.is_some() && n != self.st.d {
                return Err(self
                    .err(
                        d.span,
                        format!("D{n} while cutter compensation runs with D{}", self.st.d),
                    )
                    .with_expected("G40 before changing D"));
            }
            self.st.d = n;
        }
        let motion = match self.w.g_of(GGroup::Motion) {
            Some((0, _)) => Motion::Rapid,
            Some((1, _)) => Motion::Linear,
            Some((2, _)) => Motion::ArcCw,
            Some(_) => Motion::ArcCcw,
            None => self.st.motion,
        };
        let is_arc = matches!(motion, Motion::ArcCw | Motion::ArcCcw);
        if let Some((code, span)) = self.w.g_of(GGroup::CutterComp) {
            match code {
                40 => {
                    if self.st.comp.is_some() && is_arc && self.moves_in_plane() {
                        return Err(self
                            .err(span, "G40 on an arc: compensation ends on a G0 or G1 move")
                            .with_expected("G40 with G0 or G1"));
                    }
                    self.st.comp = None;
                    self.st.comp_starting = false;
                }
                _ => self.comp_on(code, span, d_word.map(|d| d.span))?,
            }
        }
        if self.st.comp.is_some() {
            if let Some((code @ (28 | 30 | 53), span)) = self.w.g_of(GGroup::NonModal) {
                return Err(self
                    .err(span, format!("G{code} while cutter compensation is on"))
                    .with_expected("G40 before the reference return or machine move"));
            }
            let cycle = self.w.g_of(GGroup::Cycle).is_some_and(|c| c.0 != 80);
            if self.st.comp_starting && !cycle && self.st.cycle.is_none() && self.moves_in_plane() {
                if is_arc {
                    let span = self.w.g_of(GGroup::Motion).map_or(self.w.span, |g| g.1);
                    return Err(self
                        .err(span, "cutter compensation started on an arc")
                        .with_expected(
                            "a G0 or G1 move in the plane as the first move after G41/G42",
                        ));
                }
                self.st.comp_starting = false;
            }
        }
        Ok(())
    }

    fn comp_on(&mut self, code: u32, span: Span, d_span: Option<Span>) -> Result<(), NcError> {
        let cycle_cancelled = self.w.g_of(GGroup::Motion).is_some();
        if self.st.cycle.is_some() && !cycle_cancelled {
            return Err(self
                .err(span, format!("G{code} while a canned cycle is active"))
                .with_expected("G80 before G41/G42"));
        }
        if d_span.is_none() && self.dialect == cnc402_lang::Dialect::LinuxCnc {
            // LinuxCNC: G41/G42 without D take the radius of the tool in the spindle.
            self.st.d = self.st.tool_loaded.unwrap_or(0).min(TOOL_OFFSETS as u32);
        }
        if self.st.d == 0 {
            return Err(self
                .err(
                    d_span.unwrap_or(span),
                    format!("G{code} without D (no tool radius offset number)"),
                )
                .with_expected(format!("D1-D{TOOL_OFFSETS} with G41/G42")));
        }
        let side = if code == 41 {
            CompSide::Left
        } else {
            CompSide::Right
        };
        if let Some(on) = self.st.comp
            && on.side != side
        {
            return Err(self
                .err(
                    span,
                    format!(
                        "G{code} while G{} is on",
                        if on.side == CompSide::Left { 41 } else { 42 }
                    ),
                )
                .with_expected("G40 before changing the side"));
        }
        let t = &self.st.tool_offsets[self.st.d as usize - 1];
        let radius = t.radius + t.radius_wear;
        if !radius.is_finite() || radius < 0.0 {
            return Err(self.err(
                d_span.unwrap_or(span),
                format!(
                    "D{}: the tool radius (geometry + wear) is {radius}, not >= 0",
                    self.st.d
                ),
            ));
        }
        if self.st.comp.is_none() {
            self.st.comp_starting = true;
        }
        self.st.comp = Some(CutterComp {
            side,
            d: self.st.d,
            radius,
        });
        Ok(())
    }

    /// The block has a word of the plane's first or second axis.
    fn moves_in_plane(&self) -> bool {
        let (a, b, _) = self.plane_letters();
        self.w.has(a) || self.w.has(b)
    }

    /// A plane change (to `p`, by G`code`) while compensation is on is an error.
    pub(super) fn plane_change_in_comp(
        &self,
        p: Plane,
        code: u32,
        span: Span,
    ) -> Result<(), NcError> {
        if self.st.comp.is_some() && p != self.st.plane {
            return Err(self
                .err(span, format!("G{code} while cutter compensation is on"))
                .with_expected("G40 before changing the plane"));
        }
        Ok(())
    }
}
