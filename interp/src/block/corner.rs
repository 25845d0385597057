//! Fanuc's optional corner rounding and chamfering between two G1 moves: `,R r` rounds the
//! corner at the end of the block's move with an arc of radius r tangent to both moves, `,C c`
//! cuts it with a straight line from c before the corner to c after it. The move with the
//! corner word is held back until the next block's move is known, then both are shortened.

use cnc402_lang::{Dialect, NcError};
use cnc402_motion::segment::{ArcDir, AxisPos, SegmentKind};

use super::exec::Exec;
use super::state::{CornerCut, PendingCorner};
use super::words::{Arg, fmt_num};

/// The corner element of a held move: where the first move ends, the element, where the
/// second move starts.
struct Fitted {
    first_end: AxisPos,
    element: SegmentKind,
    second_start: AxisPos,
}

impl Exec<'_> {
    /// The block's corner word: `,R`/`,C`, or (outside the linuxcnc dialect) a plain `R` in a
    /// G1 block (the form of some simulators), or a plain `C` when no axis is named C. Only
    /// for the G1 move itself: the caller has checked that.
    pub(crate) fn corner_word(&mut self) -> Result<Option<(CornerCut, Arg)>, NcError> {
        let word = match self.w.corner.take() {
            Some(w) => Some(w),
            None if self.dialect != Dialect::LinuxCnc => {
                let c_free = self.map.c.is_none();
                match (self.w.take('R'), c_free.then(|| self.w.take('C')).flatten()) {
                    (Some(r), None) => Some(('R', r)),
                    (None, Some(c)) => Some(('C', c)),
                    (Some(_), Some(c)) => {
                        return Err(self.err(
                            c.span,
                            "a block takes R (corner rounding) or C (chamfer), not both",
                        ));
                    }
                    (None, None) => None,
                }
            }
            None => None,
        };
        let Some((letter, a)) = word else {
            return Ok(None);
        };
        if a.v <= 0.0 || a.v.is_nan() {
            return Err(self
                .err(
                    a.span,
                    format!("corner {letter}{} must be > 0", fmt_num(a.v)),
                )
                .with_expected(format!("a positive ,{letter}")));
        }
        let mm = a.v * self.st.unit();
        let cut = if letter == 'R' {
            CornerCut::Round(mm)
        } else {
            CornerCut::Chamfer(mm)
        };
        Ok(Some((cut, a)))
    }

    /// A G1 move to `end` at `feed` with the block's corner word `corner`: finishes a held
    /// move (shortened, with its corner element), then holds this one if it has a corner
    /// word, else makes it.
    pub(crate) fn linear_with_corners(
        &mut self,
        end: AxisPos,
        feed: f64,
        corner: Option<(CornerCut, Arg)>,
    ) -> Result<(), NcError> {
        if let Some(p) = self.st.pending_corner.take() {
            let f = self.fit(&p, &end)?;
            let here = std::mem::replace(&mut self.source, p.source.clone());
            if f.first_end != p.start {
                self.push(SegmentKind::Linear {
                    end: f.first_end,
                    feed: p.feed,
                });
            }
            self.push(f.element);
            self.source = here;
            self.st.pos = f.second_start;
        }
        match corner {
            None => {
                if end != self.st.pos {
                    self.linear(end, feed, &[])?;
                }
            }
            Some((cut, a)) => {
                self.check_limits(&end, &[])?;
                self.st.pending_corner = Some(PendingCorner {
                    cut,
                    start: self.st.pos,
                    corner: end,
                    feed,
                    source: self.source.clone(),
                    word: a.span,
                    file: self.src.name.clone(),
                    window: (self.src.line_count() == 1).then(|| self.src.clone()),
                });
                self.st.pos = end;
            }
        }
        Ok(())
    }

    /// The error for a held move whose next block is not a G1 move: at the corner word if
    /// it is in this file, else at this block.
    pub(crate) fn corner_unfinished(&self, p: &PendingCorner, why: &str) -> NcError {
        if let Some(w) = &p.window {
            return NcError::new(w, p.word, format!("corner rounding/chamfer: {why}"))
                .with_expected("a G1 move in the plane in the block after a `,R`/`,C` block");
        }
        let at = if p.file == self.src.name {
            p.word
        } else {
            self.line_span
        };
        self.err(at, format!("corner rounding/chamfer: {why}"))
            .with_expected("a G1 move in the plane in the block after a `,R`/`,C` block")
    }

    /// Where the two moves are cut and the element between them.
    fn fit(&self, p: &PendingCorner, end: &AxisPos) -> Result<Fitted, NcError> {
        let (la, lb, _) = self.plane_letters();
        let (Some(ia), Some(ib)) = (self.cfg.axis_index(la), self.cfg.axis_index(lb)) else {
            return Err(self.corner_unfinished(p, "the plane's axes are not configured"));
        };
        let off_plane = (0..self.cfg.axes.len())
            .filter(|&i| i != ia && i != ib)
            .any(|i| p.start[i] != p.corner[i] || p.corner[i] != end[i]);
        if off_plane {
            return Err(self.corner_unfinished(
                p,
                "both moves must lie in the plane (only its two axes move)",
            ));
        }
        let q = (p.corner[ia], p.corner[ib]);
        let (d1, l1) = unit((q.0 - p.start[ia], q.1 - p.start[ib]));
        let (d2, l2) = unit((end[ia] - q.0, end[ib] - q.1));
        let cross = d1.0 * d2.1 - d1.1 * d2.0;
        let dot = d1.0 * d2.0 + d1.1 * d2.1;
        if l1 < 1e-9 || l2 < 1e-9 || cross.abs() < 1e-9 {
            return Err(self.corner_unfinished(
                p,
                "the two moves make no corner (one is empty, or they are in line)",
            ));
        }
        // Turning angle θ between the directions; the cut's distance from the corner.
        let theta = cross.atan2(dot).abs();
        let (cut_len, what) = match p.cut {
            CornerCut::Round(r) => (r * (theta / 2.0).tan(), format!(",R{}", fmt_num(r))),
            CornerCut::Chamfer(c) => (c, format!(",C{}", fmt_num(c))),
        };
        if cut_len > l1 + 1e-9 || cut_len > l2 + 1e-9 {
            return Err(self.corner_unfinished(
                p,
                &format!(
                    "{what} does not fit: it needs {} of each move, the moves are {} and {} long",
                    fmt_num(cut_len),
                    fmt_num(l1),
                    fmt_num(l2)
                ),
            ));
        }
        let mut first_end = p.corner;
        first_end[ia] = q.0 - cut_len * d1.0;
        first_end[ib] = q.1 - cut_len * d1.1;
        let mut second_start = p.corner;
        second_start[ia] = q.0 + cut_len * d2.0;
        second_start[ib] = q.1 + cut_len * d2.1;
        let element = match p.cut {
            CornerCut::Chamfer(_) => SegmentKind::Linear {
                end: second_start,
                feed: p.feed,
            },
            CornerCut::Round(r) => {
                // The centre is r to the inside of the turn from where the first move ends.
                let side = cross.signum();
                let c = (
                    first_end[ia] - side * r * d1.1,
                    first_end[ib] + side * r * d1.0,
                );
                let mut center = [0.0f64; 3];
                let xyz = |l: char| (l as u8 - b'X') as usize;
                center[xyz(la)] = c.0;
                center[xyz(lb)] = c.1;
                let (_, _, ln) = self.plane_letters();
                center[xyz(ln)] = self.cfg.axis_index(ln).map_or(0.0, |i| p.corner[i]);
                SegmentKind::Arc {
                    end: second_start,
                    center,
                    plane: self.st.plane,
                    dir: if side > 0.0 { ArcDir::Ccw } else { ArcDir::Cw },
                    turns: 0,
                    feed: p.feed,
                }
            }
        };
        Ok(Fitted {
            first_end,
            element,
            second_start,
        })
    }
}

/// `v` as a unit vector and its length (a zero vector stays zero).
fn unit(v: (f64, f64)) -> ((f64, f64), f64) {
    let l = v.0.hypot(v.1);
    if l > 0.0 {
        ((v.0 / l, v.1 / l), l)
    } else {
        ((0.0, 0.0), 0.0)
    }
}
