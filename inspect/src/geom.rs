//! Geometry of one path piece in X Y Z: a straight move or a circular arc / helix in a plane
//! (G17/G18/G19), its point at a path parameter, the nearest point to a given point, and its
//! polyline within a chord tolerance for drawing.

use cnc402_motion::segment::{ArcDir, Plane, arc_sweep};

/// A point X Y Z.
pub type P3 = [f64; 3];

/// Samples per turn when searching an arc for its nearest point: with 64 the distance is
/// unimodal between neighbouring samples for any point, so the refinement finds the minimum.
const SEARCH_PER_TURN: f64 = 64.0;
/// Most samples of one arc searched or drawn (a helix of thousands of turns stays bounded).
const MAX_ARC_SAMPLES: usize = 65_536;

/// The shape of a piece between its start and end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    Line,
    /// Turning around `center` (its in-plane coordinates count) in `plane`, `turns` extra
    /// full turns; the normal axis moves linearly (a helix).
    Arc {
        center: P3,
        plane: Plane,
        dir: ArcDir,
        turns: u32,
    },
}

/// The indices (first, second, normal) of a plane's axes in X Y Z.
fn plane_axes(plane: Plane) -> (usize, usize, usize) {
    match plane {
        Plane::XY => (0, 1, 2),
        Plane::ZX => (2, 0, 1),
        Plane::YZ => (1, 2, 0),
    }
}

pub fn dist(a: &P3, b: &P3) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// One piece of path: from `start` to `end` along `shape`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Path3 {
    pub start: P3,
    pub end: P3,
    pub shape: Shape,
}

/// An arc's parameters in its plane: start angle, radii at both ends, signed sweep
/// (radians, + counter-clockwise); the radius changes linearly with the angle, the normal
/// axis linearly too (a helix).
pub struct ArcParams {
    pub a0: f64,
    pub r0: f64,
    pub r1: f64,
    pub sweep: f64,
}

impl Path3 {
    /// An arc's parameters, its centre and its plane's (first, second, normal) axis indices
    /// in X Y Z; `None` for a line.
    pub fn arc_params(&self) -> Option<(ArcParams, P3, (usize, usize, usize))> {
        let Shape::Arc {
            center,
            plane,
            dir,
            turns,
        } = self.shape
        else {
            return None;
        };
        let (p, q, n) = plane_axes(plane);
        let (s, e) = (self.start, self.end);
        let sweep = arc_sweep(
            [s[p], s[q]],
            [e[p], e[q]],
            [center[p], center[q]],
            dir,
            turns,
        );
        let sign = if dir == ArcDir::Ccw { 1.0 } else { -1.0 };
        let params = ArcParams {
            a0: (s[q] - center[q]).atan2(s[p] - center[p]),
            r0: (s[p] - center[p]).hypot(s[q] - center[q]),
            r1: (e[p] - center[p]).hypot(e[q] - center[q]),
            sweep: sign * sweep,
        };
        Some((params, center, (p, q, n)))
    }

    /// The point at path parameter `t` in 0..=1 (by angle on an arc).
    pub fn point(&self, t: f64) -> P3 {
        let (s, e) = (self.start, self.end);
        let Some((a, c, (p, q, n))) = self.arc_params() else {
            return [0, 1, 2].map(|i| s[i] + t * (e[i] - s[i]));
        };
        let th = a.a0 + t * a.sweep;
        let r = a.r0 + t * (a.r1 - a.r0);
        let mut out = [0.0; 3];
        out[p] = c[p] + r * th.cos();
        out[q] = c[q] + r * th.sin();
        out[n] = s[n] + t * (e[n] - s[n]);
        out
    }

    /// How many samples an arc needs at `per_turn` samples a turn (at least 2, bounded).
    fn arc_samples(&self, per_turn: f64) -> usize {
        match self.arc_params() {
            Some((a, ..)) => {
                let n = (a.sweep.abs() / std::f64::consts::TAU * per_turn).ceil();
                (n as usize).clamp(2, MAX_ARC_SAMPLES)
            }
            None => 1,
        }
    }

    /// The distance from `x` to the nearest point of the piece, and that point's parameter.
    pub fn nearest(&self, x: &P3) -> (f64, f64) {
        if self.arc_params().is_none() {
            let (s, e) = (self.start, self.end);
            let d = [e[0] - s[0], e[1] - s[1], e[2] - s[2]];
            let len2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let t = if len2 > 0.0 {
                (((x[0] - s[0]) * d[0] + (x[1] - s[1]) * d[1] + (x[2] - s[2]) * d[2]) / len2)
                    .clamp(0.0, 1.0)
            } else {
                0.0
            };
            return (dist(&self.point(t), x), t);
        }
        let n = self.arc_samples(SEARCH_PER_TURN).max(16);
        let at = |t: f64| dist(&self.point(t), x);
        let best = (0..=n)
            .map(|i| i as f64 / n as f64)
            .min_by(|a, b| at(*a).total_cmp(&at(*b)))
            .unwrap_or(0.0);
        // Golden-section search between the neighbouring samples (60 steps: far below 1e-9).
        let step = 1.0 / n as f64;
        let (mut lo, mut hi) = ((best - step).max(0.0), (best + step).min(1.0));
        let g = (5f64.sqrt() - 1.0) / 2.0;
        for _ in 0..60 {
            let m1 = hi - g * (hi - lo);
            let m2 = lo + g * (hi - lo);
            if at(m1) <= at(m2) {
                hi = m2;
            } else {
                lo = m1;
            }
        }
        let t = 0.5 * (lo + hi);
        (at(t), t)
    }

    /// The polyline of the piece, start and end included: a line is its two ends; an arc is
    /// sampled so that no chord strays more than `tol` from it (at most 65,536 points).
    pub fn polyline(&self, tol: f64) -> Vec<P3> {
        let Some((a, ..)) = self.arc_params() else {
            return vec![self.start, self.end];
        };
        let r = a.r0.max(a.r1).max(1e-9);
        // Chord of angle δ strays r(1 − cos δ/2) from the arc.
        let delta = 2.0 * (1.0 - (tol / r).min(1.0)).acos();
        let per_turn = (std::f64::consts::TAU / delta.max(1e-6)).max(8.0);
        let n = self.arc_samples(per_turn);
        (0..=n).map(|i| self.point(i as f64 / n as f64)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quarter() -> Path3 {
        Path3 {
            start: [10.0, 0.0, 0.0],
            end: [0.0, 10.0, -4.0],
            shape: Shape::Arc {
                center: [0.0, 0.0, 0.0],
                plane: Plane::XY,
                dir: ArcDir::Ccw,
                turns: 0,
            },
        }
    }

    #[test]
    fn a_line_is_nearest_at_the_foot_of_the_perpendicular() {
        let l = Path3 {
            start: [0.0, 0.0, 0.0],
            end: [10.0, 0.0, 0.0],
            shape: Shape::Line,
        };
        let (d, t) = l.nearest(&[4.0, 3.0, 0.0]);
        assert!((d - 3.0).abs() < 1e-12 && (t - 0.4).abs() < 1e-12);
        let (d, t) = l.nearest(&[-3.0, 4.0, 0.0]);
        assert!((d - 5.0).abs() < 1e-12 && t == 0.0);
    }

    #[test]
    fn a_helix_passes_through_its_midpoint() {
        let h = quarter();
        let mid = h.point(0.5);
        let s = std::f64::consts::FRAC_1_SQRT_2 * 10.0;
        assert!(dist(&mid, &[s, s, -2.0]) < 1e-9);
        let (d, t) = h.nearest(&[s * 1.1, s * 1.1, -2.0]);
        assert!((d - 1.0).abs() < 1e-6, "{d}");
        assert!((t - 0.5).abs() < 1e-6);
        assert!(dist(&h.point(1.0), &h.end) < 1e-9);
    }

    #[test]
    fn a_cw_arc_in_the_zx_plane_goes_the_long_way_round() {
        // G18 (seen from +Y, Z to X counter-clockwise): G2 from Z10 X0 to Z0 X10 around the
        // origin turns 270° through Z-7.07; G3 turns 90° through Z7.07 X7.07.
        let a = Path3 {
            start: [0.0, 0.0, 10.0],
            end: [10.0, 0.0, 0.0],
            shape: Shape::Arc {
                center: [0.0, 0.0, 0.0],
                plane: Plane::ZX,
                dir: ArcDir::Cw,
                turns: 0,
            },
        };
        let m = a.point(0.5);
        assert!(m[0] < -7.0 && m[2] < -7.0, "{m:?}");
        let ccw = Path3 {
            shape: Shape::Arc {
                center: [0.0, 0.0, 0.0],
                plane: Plane::ZX,
                dir: ArcDir::Ccw,
                turns: 0,
            },
            ..a
        };
        let m = ccw.point(0.5);
        assert!(m[0] > 7.0 && m[2] > 7.0, "{m:?}");
    }

    #[test]
    fn a_polyline_keeps_within_the_chord_tolerance() {
        let h = quarter();
        let pts = h.polyline(0.001);
        assert!(pts.len() > 10);
        for w in pts.windows(2) {
            let mid = [0, 1, 2].map(|i| 0.5 * (w[0][i] + w[1][i]));
            assert!(h.nearest(&mid).0 <= 0.001 + 1e-9);
        }
    }
}
