//! Offsets and reference positions in a block: tool length compensation (G43/G44/G49 with H,
//! Fanuc type A: always along Z), programmable data input (G10 L2 work offsets, L10–L13 tool
//! offsets, Fanuc memory C), coordinate system setting (G92) and reference position return
//! (G28, G30 P2–P4, G29 back). The position model is in [`super::state::ModalState`]: machine
//! = programmed + work offset + G92 shift + tool length offset vector.

use cnc402_config::TOOL_OFFSETS;
use cnc402_lang::NcError;
use cnc402_lang::ast::Span;
use cnc402_motion::segment::{AxisPos, SegmentKind};

use super::exec::Exec;
use super::state::{ModalState, Motion, ToolLength};
use super::words::{Arg, GGroup, fmt_num};

pub use crate::vars::{OffsetField, tool_offset_var};

/// The one owner of the offset state in [`ModalState`]: work offsets, the G92 shift and the
/// tool length offset are changed only here (the rest of the interpreter calls these).
impl ModalState {
    /// The part of the tool length offset vector on axis `i` that `pos` does not include yet.
    pub fn tlo_pending(&self, i: usize) -> f64 {
        if self.tool_axis == Some(i) {
            self.tlo - self.tlo_in_pos
        } else {
            0.0
        }
    }

    /// The machine position of a programmed value `v` of axis `i` (mm / degrees), G90 or
    /// G91, with the work zero and the tool length offset: the vector is all in the result
    /// (call [`restore_tlo`](Self::restore_tlo) once the move is made).
    pub(crate) fn target(&self, i: usize, v: f64) -> f64 {
        if self.incremental {
            self.pos[i] + v + self.tlo_pending(i)
        } else {
            v + self.origin(i)
        }
    }

    /// A move of axis `i` from here on carries the whole vector (a programmed tool-axis move).
    pub(crate) fn restore_tlo(&mut self, i: usize) {
        if self.tool_axis == Some(i) {
            self.tlo_in_pos = self.tlo;
        }
    }

    /// Axis `i` went to a machine position (G28/G30/G53): `pos` holds none of the vector.
    pub(crate) fn drop_tlo(&mut self, i: usize) {
        if self.tool_axis == Some(i) {
            self.tlo_in_pos = 0.0;
        }
    }

    /// G43/G44/G49 take effect: the mode and its vector (`len`, the H offset's length).
    pub(crate) fn set_tool_length(&mut self, mode: ToolLength, len: f64) {
        self.tool_length = mode;
        self.tlo = match mode {
            ToolLength::Off => 0.0,
            ToolLength::Plus => len,
            ToolLength::Minus => -len,
        };
    }

    /// Work offset G54+`k` on `axis` (G10 L2, `#5221…`), mm / degrees.
    pub(crate) fn set_work_offset(&mut self, k: usize, axis: usize, v: f64) {
        self.work_offsets[k][axis] = v;
    }

    /// A field of tool offset `k` (1-based; G10 L10–L13, `#10001…`).
    pub(crate) fn set_tool_offset(&mut self, k: usize, field: OffsetField, v: f64) {
        field.set(&mut self.tool_offsets[k - 1], v);
    }
}

impl Exec<'_> {
    /// A tool offset number word (H, or P of G10 L10–L13): 0..=400 (`allow_zero`: H0 means
    /// no offset).
    fn offset_number(&self, a: Arg, what: &str, allow_zero: bool) -> Result<usize, NcError> {
        let lo = if allow_zero { 0.0 } else { 1.0 };
        if a.v.fract() != 0.0 || a.v < lo || a.v > TOOL_OFFSETS as f64 {
            let zero = if allow_zero { " (H0: no offset)" } else { "" };
            return Err(self
                .err(
                    a.span,
                    format!(
                        "{what}{} is not a tool offset number: the table has 1..{TOOL_OFFSETS}{zero}",
                        fmt_num(a.v)
                    ),
                )
                .with_expected(format!("a whole number {}..{TOOL_OFFSETS}", lo as u32)));
        }
        Ok(a.v as usize)
    }

    /// G43/G44/G49 and H. The new vector is taken now; the motion of this block carries the
    /// change (see `targets`), so a `G43 H1` alone moves Z by the offset in G0 or G1.
    pub(crate) fn tool_length(&mut self) -> Result<(), NcError> {
        let g = self.w.g_of(GGroup::ToolLength);
        let h = self.w.take('H');
        if g.is_none() && h.is_none() {
            return Ok(());
        }
        if let Some(h) = h {
            self.st.h = self.offset_number(h, "H", true)? as u32;
        } else if let (Some((43, _)), cnc402_lang::Dialect::LinuxCnc) = (g, self.dialect) {
            // LinuxCNC: G43 without H takes the tool in the spindle's offset.
            self.st.h = self.st.tool_loaded.unwrap_or(0).min(TOOL_OFFSETS as u32);
        }
        let mode = match g {
            Some((43, _)) => ToolLength::Plus,
            Some((44, _)) => ToolLength::Minus,
            Some(_) => ToolLength::Off,
            None => self.st.tool_length,
        };
        if g.is_none() && mode == ToolLength::Off {
            // H in G49: remembered (#4111) for the next G43/G44, nothing moves.
            return Ok(());
        }
        let at = g.map(|g| g.1).or(h.map(|h| h.span)).unwrap_or(self.w.span);
        let name = format!("G{}", mode.code());
        let nonmodal = self.w.g_of(GGroup::NonModal).map(|g| g.0);
        if let Some((49, g49)) = g
            && let Some(code @ (28 | 30 | 53)) = nonmodal
        {
            // `G91 G28 Z0 G49`, `G49 G53 Z0`: Fanuc cancels the vector with the move (at the
            // reference position), not before it; see `run`. Without a Z move the vector
            // would stay in the position while `#4008` reads 49, unless the position holds
            // none of it already (after `G28 Z`).
            if let Some(z) = self.st.tool_axis
                && self.w.peek(self.cfg.axes[z].name).is_none()
                && self.st.tlo_in_pos != 0.0
            {
                let zn = self.cfg.axes[z].name;
                return Err(self
                    .err(
                        g49,
                        format!(
                            "G49 with G{code} cancels the tool length offset on the {zn} move, and this block does not move {zn}"
                        ),
                    )
                    .with_expected(format!(
                        "{zn} in this block, or G49 in a block of its own"
                    )));
            }
            self.tlo_cancel_after = true;
            return Ok(());
        }
        if self.st.tool_axis.is_none() {
            if mode == ToolLength::Off {
                // G49 in a safety line on a machine without Z: nothing to cancel.
                self.st.set_tool_length(mode, 0.0);
                return Ok(());
            }
            return Err(self.err(
                at,
                format!("{name}: tool length compensation needs axis Z, which is not configured"),
            ));
        }
        // A group 01 code in this block sets the mode the offset moves in, and ends a cycle.
        let motion_code = self.w.g_of(GGroup::Motion).map(|g| g.0);
        let cycle_here = self.w.g_of(GGroup::Cycle).is_some_and(|c| c.0 != 80);
        if (self.st.cycle.is_some() && motion_code.is_none()) || cycle_here {
            return Err(self
                .err(
                    at,
                    format!("{name} (or a new H) while a canned cycle is active"),
                )
                .with_expected("G80 before changing the tool length offset"));
        }
        if let Some(code) = nonmodal {
            return Err(self
                .err(
                    at,
                    format!("{name} (or a new H) cannot share a block with G{code}"),
                )
                .with_expected("the tool length offset in a G0 or G1 block of its own"));
        }
        let arc_mode = match motion_code {
            Some(c) => c >= 2,
            None => matches!(self.st.motion, Motion::ArcCw | Motion::ArcCcw),
        };
        if arc_mode {
            return Err(self
                .err(
                    at,
                    format!("{name} (or a new H) in G2/G3 mode: the offset is applied by a straight move"),
                )
                .with_expected("G0 or G1 in the block that changes the tool length offset"));
        }
        let len = match self.st.h {
            0 => 0.0,
            n => {
                let t = &self.st.tool_offsets[n as usize - 1];
                t.length + t.length_wear
            }
        };
        self.st.set_tool_length(mode, len);
        self.tlo_commanded = true;
        Ok(())
    }

    /// G10: L2 P1–P6 work offsets G54–G59 from the axis words; L10/L11/L12/L13 Pn R tool
    /// offset n (H geometry, H wear, D geometry, D wear). G90 sets, G91 adds. No motion.
    pub(crate) fn data_input(&mut self, span: Span) -> Result<(), NcError> {
        self.no_cycle_code("G10")?;
        self.apply_motion_code();
        let Some(l) = self.w.take('L') else {
            return Err(self
                .err(span, "G10 needs L (what to set)")
                .with_expected("L2 (work offsets G54-G59) or L10-L13 (tool offsets)"));
        };
        let lv = if l.v.fract() == 0.0 && (0.0..1000.0).contains(&l.v) {
            l.v as u32
        } else {
            u32::MAX
        };
        // LinuxCNC: G10 L2 sets in G91 too, P0 is the active system, and L20 sets the offset
        // from the current position.
        let linuxcnc = self.dialect == cnc402_lang::Dialect::LinuxCnc;
        let add = self.st.incremental && !linuxcnc;
        match lv {
            2 | 20 if lv == 2 || linuxcnc => {
                let Some(p) = self.w.take('P') else {
                    return Err(self
                        .err(span, "G10 L2 needs P (the work offset: P1-P6 for G54-G59)")
                        .with_expected("P1 to P6"));
                };
                if p.v == 0.0 && !linuxcnc {
                    return Err(self
                        .err(
                            p.span,
                            "G10 L2 P0 sets the external work offset, which cnc402 does not have",
                        )
                        .with_expected("P1 to P6 (G54 to G59)"));
                }
                let k = match p.v {
                    0.0 => self.st.work_offset,
                    v if v.fract() == 0.0 && (1.0..=6.0).contains(&v) => v as usize - 1,
                    v => {
                        return Err(self
                            .err(
                                p.span,
                                format!("G10 L2 P{}: P1-P6 select G54-G59", fmt_num(v)),
                            )
                            .with_expected("P1 to P6"));
                    }
                };
                for i in 0..self.cfg.axes.len() {
                    if let Some(a) = self.w.take(self.cfg.axes[i].name) {
                        let v = self.axis_value(i, a);
                        let o = self.st.work_offsets[k][i];
                        let new = if lv == 20 {
                            let active = self.st.work_offsets[self.st.work_offset][i];
                            active + self.st.programmed(i) - v
                        } else if add {
                            o + v
                        } else {
                            v
                        };
                        self.overflow(new, a.span, "the work offset")?;
                        self.st.work_offsets[k][i] = new;
                    }
                }
                Ok(())
            }
            10..=13 => {
                let Some(p) = self.w.take('P') else {
                    return Err(self
                        .err(
                            span,
                            format!("G10 L{lv} needs P (the tool offset number 1..{TOOL_OFFSETS})"),
                        )
                        .with_expected("P1 to P400"));
                };
                let n = self.offset_number(p, &format!("G10 L{lv} P"), false)?;
                let Some(r) = self.w.take('R') else {
                    return Err(self
                        .err(span, format!("G10 L{lv} needs R (the offset value)"))
                        .with_expected("R with the value, e.g. R-120.5"));
                };
                let field = match lv {
                    10 => OffsetField::LengthGeometry,
                    11 => OffsetField::LengthWear,
                    12 => OffsetField::RadiusGeometry,
                    _ => OffsetField::RadiusWear,
                };
                let v = r.v * self.st.unit();
                let t = &mut self.st.tool_offsets[n - 1];
                let new = if add { field.get(t) + v } else { v };
                self.overflow(new, r.span, "the tool offset")?;
                field.set(&mut self.st.tool_offsets[n - 1], new);
                Ok(())
            }
            20 => Err(self
                .err(
                    l.span,
                    "G10 L20 (Fanuc: the additional work offsets of G54.1 P1-P48) is not supported",
                )
                .with_expected("L2 (G54-G59) or L10-L13 (tool offsets)")),
            _ => Err(self
                .err(l.span, format!("G10 L{} is not supported", fmt_num(l.v)))
                .with_expected("L2 (work offsets G54-G59) or L10-L13 (tool offsets, memory C)")),
        }
    }

    /// An error at `span` if the offset value `v` is not finite (G91 G10 adds to it).
    fn overflow(&self, v: f64, span: Span, what: &str) -> Result<(), NcError> {
        if v.is_finite() {
            return Ok(());
        }
        Err(self
            .err(span, format!("{what} overflows (not a finite number)"))
            .with_expected("values that stay within ±1.8e308"))
    }

    /// G92: shifts every work coordinate system so that the programmed position of each named
    /// axis reads as the value given (always absolute, in G91 too). No motion.
    pub(crate) fn set_coordinates(&mut self, span: Span) -> Result<(), NcError> {
        self.no_cycle_code("G92")?;
        self.apply_motion_code();
        let mut any = false;
        for i in 0..self.cfg.axes.len() {
            if let Some(a) = self.w.take(self.cfg.axes[i].name) {
                any = true;
                let v = self.axis_value(i, a);
                self.st.shift[i] += self.st.programmed(i) - v;
            }
        }
        if !any {
            let axes: String = self.cfg.axes.iter().map(|a| a.name).collect();
            return Err(self
                .err(
                    span,
                    "G92 needs an axis word (the current position's new coordinate)",
                )
                .with_expected(format!("one or more of {axes}")));
        }
        Ok(())
    }

    /// The block must not start a canned cycle (group 09 other than G80).
    fn no_cycle_code(&self, what: &str) -> Result<(), NcError> {
        if let Some((c, s)) = self.w.g_of(GGroup::Cycle)
            && c != 80
        {
            return Err(self.err(s, format!("G{c} cannot share a block with {what}")));
        }
        Ok(())
    }

    /// The named axes of the block (index, value in mm / degrees), in config order.
    fn named_axes(&mut self) -> Vec<(usize, f64)> {
        let mut v = Vec::new();
        for i in 0..self.cfg.axes.len() {
            if let Some(a) = self.w.take(self.cfg.axes[i].name) {
                v.push((i, self.axis_value(i, a)));
            }
        }
        v
    }

    /// G28/G29/G30 with the spindle axis while the spindle turns in speed mode: an error at
    /// its word, even when C would not move (its position is not known while it turns).
    fn spindle_still_for(&self, name: &str) -> Result<(), NcError> {
        for (k, axis) in self.map.spindles.into_iter().enumerate() {
            let Some(c) = axis else { continue };
            let Some(a) = self.w.peek(self.cfg.axes[c].name) else {
                continue;
            };
            if !self.st.spindle_turning_of(k as u8 + 1) {
                continue;
            }
            let letter = self.cfg.axes[c].name;
            return Err(self
                .err(
                    a.span,
                    format!(
                        "{name} {letter}: the spindle turns in speed mode (M3/M4); {letter} is positioned only at rest"
                    ),
                )
                .with_expected(format!("M5 before {name} {letter}")));
        }
        Ok(())
    }

    /// G28 (reference position) and G30 P2–P4 (second to fourth): a rapid of the named axes
    /// to the intermediate point (G90/G91 as modal), then a rapid of the same axes to the
    /// reference position (machine coordinates, from the config); a move where the tool
    /// already is makes no segment. The tool length offset stays in force but its vector is
    /// cancelled on Z at the reference position (Fanuc); Z's next programmed move restores
    /// it. The spindle axis goes to its reference by an orientation (`SpindleOrient`) to the
    /// physical angle of the reference, as M19 does (program C is not where the spindle
    /// physically is after a speed-mode run; only motion knows the difference), and then
    /// reads the reference, as on Fanuc: the segment sets program C in motion too, so the
    /// physical angle ≡ program C afterwards and later absolute C moves count from it.
    pub(crate) fn reference_return(&mut self, code: u32, span: Span) -> Result<(), NcError> {
        let name = format!("G{code}");
        self.no_cycle_code(&name)?;
        self.apply_motion_code();
        if self.st.cycle.is_some() {
            return Err(self
                .err(span, format!("{name} while a canned cycle is active"))
                .with_expected(format!("G80 before {name}")));
        }
        self.spindle_still_for(&name)?;
        let slot = if code == 28 {
            0
        } else {
            match self.w.take('P') {
                None => 1,
                Some(p) if p.v.fract() == 0.0 && (2.0..=4.0).contains(&p.v) => p.v as usize - 1,
                Some(p) => {
                    return Err(self
                        .err(
                            p.span,
                            format!(
                                "G30 P{}: P2, P3 or P4 selects the reference position",
                                fmt_num(p.v)
                            ),
                        )
                        .with_expected("P2 (default), P3 or P4"));
                }
            }
        };
        let ord = ["", "second_", "third_", "fourth_"][slot];
        let spindle = |i: usize| self.cfg.spindle_number(i);
        // Haas: a bare G28 sends every axis (not the spindle) straight to its reference.
        let home_all = code == 28
            && self.dialect == cnc402_lang::Dialect::Haas
            && self.cfg.axes.iter().all(|a| self.w.peek(a.name).is_none());
        let mut refs = Vec::new();
        for i in 0..self.cfg.axes.len() {
            let ax = &self.cfg.axes[i];
            if home_all && spindle(i).is_none() {
                refs.push(ax.references[0].unwrap_or_default());
            } else if let Some(a) = self.w.peek(ax.name) {
                let Some(r) = ax.references[slot] else {
                    return Err(self
                        .err(
                            a.span,
                            format!(
                                "{name}{}: axis {} has no {ord}reference in the machine config",
                                if code == 30 {
                                    format!(" P{}", slot + 1)
                                } else {
                                    String::new()
                                },
                                ax.name
                            ),
                        )
                        .with_expected(format!("{ord}reference = … in [[axis]] {}", ax.name)));
                };
                refs.push(r);
            }
        }
        let named: Vec<(usize, Option<f64>)> = if home_all {
            (0..self.cfg.axes.len())
                .filter(|&i| spindle(i).is_none())
                .map(|i| (i, None))
                .collect()
        } else {
            let words = self.named_axes().into_iter();
            words.map(|(i, v)| (i, Some(v))).collect()
        };
        if named.is_empty() {
            let axes: String = self.cfg.axes.iter().map(|a| a.name).collect();
            return Err(self
                .err(
                    span,
                    format!("{name} needs the axes to return (their intermediate point)"),
                )
                .with_expected(format!("axis words of {axes}, e.g. G91 {name} Z0")));
        }
        let mut mid = self.st.pos;
        for &(i, v) in &named {
            if let Some(v) = v {
                mid[i] = self.word_target(i, v);
            }
        }
        let letters: Vec<char> = named.iter().map(|&(i, _)| self.cfg.axes[i].name).collect();
        if mid != self.st.pos {
            self.rapid(mid, &letters)?;
        }
        let mut end = mid;
        let mut orients = Vec::new();
        for (&(i, _), r) in named.iter().zip(refs) {
            self.st.ref_mid[i] = Some(mid[i]);
            if let Some(number) = spindle(i) {
                // The physical angle of the reference, 0 <= a < 360 (rem_euclid of a tiny
                // negative number rounds to 360).
                let a = r.rem_euclid(360.0);
                orients.push((i, number, if a >= 360.0 { 0.0 } else { a }, r));
                continue;
            }
            end[i] = r;
            self.st.drop_tlo(i);
        }
        if end != self.st.pos {
            self.rapid(end, &letters)?;
        }
        for (i, spindle, angle, r) in orients {
            // Program C reads the reference from here on (Fanuc), in motion as here.
            self.push(SegmentKind::SpindleOrient {
                angle,
                program: Some(r),
                spindle,
            });
            self.st.pos[i] = r;
        }
        Ok(())
    }

    /// G29: rapid of the named axes to the last G28/G30 intermediate point, then to the
    /// position given (G90: work coordinates; G91: from the intermediate point).
    pub(crate) fn return_from_reference(&mut self, span: Span) -> Result<(), NcError> {
        self.no_cycle_code("G29")?;
        self.apply_motion_code();
        if self.st.cycle.is_some() {
            return Err(self
                .err(span, "G29 while a canned cycle is active")
                .with_expected("G80 before G29"));
        }
        self.spindle_still_for("G29")?;
        let mut mid = self.st.pos;
        for i in 0..self.cfg.axes.len() {
            let ax = &self.cfg.axes[i];
            if let Some(a) = self.w.peek(ax.name) {
                let Some(m) = self.st.ref_mid[i] else {
                    return Err(self
                        .err(
                            a.span,
                            format!(
                                "G29: no intermediate point for axis {} (no G28 or G30 named it)",
                                ax.name
                            ),
                        )
                        .with_expected(format!("G28 or G30 with {} before G29", ax.name)));
                };
                mid[i] = m;
            }
        }
        let named = self.named_axes();
        if named.is_empty() {
            return Err(self
                .err(span, "G29 needs the axes to move")
                .with_expected("axis words"));
        }
        let letters: Vec<char> = named.iter().map(|&(i, _)| self.cfg.axes[i].name).collect();
        if mid != self.st.pos {
            self.rapid(mid, &letters)?;
        }
        let mut end: AxisPos = mid;
        for &(i, v) in &named {
            end[i] = self.word_target(i, v);
        }
        if end != self.st.pos {
            self.rapid(end, &letters)?;
        }
        Ok(())
    }
}
