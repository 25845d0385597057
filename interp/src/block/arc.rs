//! Circle geometry in the working plane: the centre of an I/J/K or R arc, its sweep, and the
//! points where it reaches furthest along each plane axis (so soft limits see the bulge of an
//! arc, not only its end point). Coordinates are the plane's (first axis, second axis) in mm.

use std::f64::consts::{FRAC_PI_2, TAU};

/// An arc resolved to a centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArcGeom {
    pub center: (f64, f64),
    pub radius: f64,
    /// Angle of the start point around the centre (radians).
    pub start_angle: f64,
    /// Angle travelled, > 0, in the arc's direction (2π for a full circle).
    pub sweep: f64,
    /// 1 for a full circle (end = start), else 0.
    pub turns: u32,
}

/// How far an I/J/K arc's end radius may differ from its start radius, LinuxCNC's rule
/// (`arc_data_ijk`): refused when the difference is over `100 × absolute`, or over both
/// `absolute` and `relative × ` the larger radius. `absolute` is in mm (the program's unit's
/// tolerance, converted).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArcTolerance {
    pub absolute: f64,
    pub relative: f64,
}

impl ArcTolerance {
    /// Only an absolute tolerance (the relative rule off).
    pub const fn absolute(mm: f64) -> Self {
        ArcTolerance {
            absolute: mm,
            relative: 0.0,
        }
    }

    /// The radii `rs` (start) and `re` (end) are close enough to make one arc.
    ///
    /// ```
    /// use cnc402_interp::arc::ArcTolerance;
    /// let t = ArcTolerance { absolute: 0.028, relative: 0.001 };
    /// assert!(t.accepts(100.0, 100.05)); // 0.05 mm over 0.028 but only 0.05 %
    /// assert!(!t.accepts(10.0, 10.05)); // 0.5 %
    /// assert!(!t.accepts(5000.0, 5003.0)); // over 100 × 0.028 whatever the radius
    /// ```
    pub fn accepts(&self, rs: f64, re: f64) -> bool {
        let d = (rs - re).abs();
        !(d > 100.0 * self.absolute || (d > self.absolute && d > self.relative * rs.max(re)))
    }
}

/// Why an arc cannot be made.
#[derive(Clone, Debug, PartialEq)]
pub enum ArcError {
    /// The centre is (nearly) at the start point.
    ZeroRadius,
    /// I/J/K form: start and end radius differ by more than the tolerance.
    NotOnCircle { start_radius: f64, end_radius: f64 },
    /// R form: the end point is further away than the diameter.
    ImpossibleRadius { r: f64, chord: f64 },
    /// R form with end = start: the circle is not determined.
    RFullCircle,
}

const EPS: f64 = 1e-7;

/// How much longer than the diameter an R arc's chord may be (taken as a half circle), in
/// inches: LinuxCNC's `RADIUS_TOLERANCE_INCH` (0.00005" = 0.00127 mm, in mm programs too).
pub const R_TOLERANCE_INCH: f64 = 0.00005;

fn dist(a: (f64, f64), b: (f64, f64)) -> f64 {
    (a.0 - b.0).hypot(a.1 - b.1)
}

fn finish(start: (f64, f64), end: (f64, f64), center: (f64, f64), cw: bool) -> ArcGeom {
    let sa = (start.1 - center.1).atan2(start.0 - center.0);
    let ea = (end.1 - center.1).atan2(end.0 - center.0);
    let full = dist(start, end) < EPS;
    let sweep = if full {
        TAU
    } else {
        let mut s = if cw { sa - ea } else { ea - sa };
        while s <= 0.0 {
            s += TAU;
        }
        while s > TAU {
            s -= TAU;
        }
        s
    };
    ArcGeom {
        center,
        radius: dist(start, center),
        start_angle: sa,
        sweep,
        turns: u32::from(full),
    }
}

/// The arc from `start` to `end` around `start + offset` (Fanuc I/J/K are always incremental
/// from the start point, `offset` is the centre minus the start). End = start is a full
/// circle. Radii that differ within `tolerance` make an arc whose radius changes from start
/// to end (LinuxCNC's spiral); see [`equal_radii`] for one the planner must take as a circle.
///
/// ```
/// use cnc402_interp::arc::{arc_center, ArcTolerance};
/// let t = ArcTolerance::absolute(0.002);
/// let g = arc_center((10.0, 0.0), (0.0, 10.0), (-10.0, 0.0), false, t).unwrap();
/// assert_eq!(g.center, (0.0, 0.0));
/// assert!((g.sweep - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
/// ```
pub fn arc_center(
    start: (f64, f64),
    end: (f64, f64),
    offset: (f64, f64),
    cw: bool,
    tolerance: ArcTolerance,
) -> Result<ArcGeom, ArcError> {
    let center = (start.0 + offset.0, start.1 + offset.1);
    let rs = dist(start, center);
    let re = dist(end, center);
    if rs < EPS || re < EPS {
        return Err(ArcError::ZeroRadius);
    }
    if !tolerance.accepts(rs, re) {
        return Err(ArcError::NotOnCircle {
            start_radius: rs,
            end_radius: re,
        });
    }
    Ok(finish(start, end, center, cw))
}

/// `g` (an arc from `start` to `end`) moved onto the perpendicular bisector of its chord, so
/// that start and end are at one radius: for an arc whose radii differ by more than the
/// planner follows as a spiral. `None` when that moves the centre more than `limit` (a nearly
/// closed circle, whose bisector is far from the programmed centre).
pub fn equal_radii(
    g: &ArcGeom,
    start: (f64, f64),
    end: (f64, f64),
    cw: bool,
    limit: f64,
) -> Option<ArcGeom> {
    let chord = dist(start, end);
    if chord < EPS {
        return Some(*g);
    }
    let u = ((end.0 - start.0) / chord, (end.1 - start.1) / chord);
    let mid = ((start.0 + end.0) / 2.0, (start.1 + end.1) / 2.0);
    let along = (g.center.0 - mid.0) * u.0 + (g.center.1 - mid.1) * u.1;
    if along.abs() > limit {
        return None;
    }
    let center = (g.center.0 - along * u.0, g.center.1 - along * u.1);
    Some(finish(start, end, center, cw))
}

/// The arc from `start` to `end` of radius `|r|`: the shorter arc for `r > 0`, the longer one
/// (more than 180°) for `r < 0`. A chord up to `tolerance` longer than the diameter is taken as
/// a half circle.
///
/// ```
/// use cnc402_interp::arc::arc_radius;
/// let g = arc_radius((0.0, 0.0), (10.0, 0.0), 5.0, true, 0.002).unwrap();
/// assert!((g.center.0 - 5.0).abs() < 1e-12 && g.center.1.abs() < 1e-12);
/// ```
pub fn arc_radius(
    start: (f64, f64),
    end: (f64, f64),
    r: f64,
    cw: bool,
    tolerance: f64,
) -> Result<ArcGeom, ArcError> {
    let d = dist(start, end);
    if d < EPS {
        return Err(ArcError::RFullCircle);
    }
    let rr = r.abs();
    if rr < EPS {
        return Err(ArcError::ZeroRadius);
    }
    let half = d / 2.0;
    if half > rr + tolerance {
        return Err(ArcError::ImpossibleRadius { r, chord: d });
    }
    let h = (rr * rr - half * half).max(0.0).sqrt();
    let mid = ((start.0 + end.0) / 2.0, (start.1 + end.1) / 2.0);
    let u = ((end.0 - start.0) / d, (end.1 - start.1) / d);
    let left = (-u.1, u.0);
    // Shorter arc CCW: centre left of the chord; CW: right. A negative R takes the other side.
    let side = if cw { -1.0 } else { 1.0 } * if r > 0.0 { 1.0 } else { -1.0 };
    let center = (mid.0 + side * h * left.0, mid.1 + side * h * left.1);
    Ok(finish(start, end, center, cw))
}

/// The points of the arc furthest along ±first and ±second axis that lie inside its sweep.
pub fn extremes(g: &ArcGeom, cw: bool) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for k in 0..4 {
        let phi = k as f64 * FRAC_PI_2;
        let mut delta = if cw {
            g.start_angle - phi
        } else {
            phi - g.start_angle
        };
        delta = delta.rem_euclid(TAU);
        if delta <= g.sweep + 1e-12 {
            out.push((
                g.center.0 + g.radius * phi.cos(),
                g.center.1 + g.radius * phi.sin(),
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    const T: ArcTolerance = ArcTolerance::absolute(0.002);

    #[test]
    fn linuxcnc_rule_needs_both_absolute_and_relative() {
        let t = ArcTolerance {
            absolute: 0.0283,
            relative: 0.001,
        };
        // 4-decimal inch rounding: 0.0001" = 0.00254 mm on a 1" radius.
        assert!(t.accepts(25.4, 25.4 + 0.00254));
        // Over the absolute but under 0.1 %: a large arc.
        assert!(t.accepts(200.0, 200.1));
        // Over both.
        assert!(!t.accepts(20.0, 20.1));
        // Over 100 × absolute, however large the radius.
        assert!(!t.accepts(10_000.0, 10_003.0));
    }

    #[test]
    fn equal_radii_moves_the_centre_onto_the_bisector() {
        let t = ArcTolerance {
            absolute: 0.0283,
            relative: 0.001,
        };
        // Radius 100, end 0.05 outside the circle.
        let g = arc_center((100.0, 0.0), (0.0, 100.05), (-100.0, 0.0), false, t).unwrap();
        let e = equal_radii(&g, (100.0, 0.0), (0.0, 100.05), false, 2.83).unwrap();
        let rs = dist((100.0, 0.0), e.center);
        let re = dist((0.0, 100.05), e.center);
        assert!(close(rs, re), "{rs} {re}");
        assert!(dist(e.center, (0.0, 0.0)) < 0.1);
        // A nearly closed circle: the bisector is far from the centre.
        let end = (100.05, 0.01);
        let g = arc_center((100.0, 0.0), end, (-100.0, 0.0), false, t).unwrap();
        assert!(equal_radii(&g, (100.0, 0.0), end, false, 2.83).is_none());
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn r_sign_selects_minor_or_major_arc() {
        // CW from (0,0) to (10,0): the minor arc bulges up, centre below.
        let g = arc_radius((0.0, 0.0), (10.0, 0.0), 10.0, true, 0.0).unwrap();
        assert!(close(g.center.0, 5.0) && g.center.1 < 0.0);
        assert!(g.sweep < PI);
        let g = arc_radius((0.0, 0.0), (10.0, 0.0), -10.0, true, 0.0).unwrap();
        assert!(g.center.1 > 0.0 && g.sweep > PI);
        let g = arc_radius((0.0, 0.0), (10.0, 0.0), 10.0, false, 0.0).unwrap();
        assert!(g.center.1 > 0.0 && g.sweep < PI);
    }

    #[test]
    fn impossible_radius_and_tolerance() {
        assert!(matches!(
            arc_radius((0.0, 0.0), (10.0, 0.0), 4.0, true, 0.002),
            Err(ArcError::ImpossibleRadius { .. })
        ));
        let g = arc_radius((0.0, 0.0), (10.002, 0.0), 5.0, true, 0.002).unwrap();
        assert!(close(g.sweep, PI));
        assert_eq!(
            arc_radius((1.0, 1.0), (1.0, 1.0), 4.0, true, 0.002),
            Err(ArcError::RFullCircle)
        );
    }

    #[test]
    fn full_circle_and_not_on_circle() {
        let g = arc_center((10.0, 0.0), (10.0, 0.0), (-10.0, 0.0), true, T).unwrap();
        assert_eq!(g.turns, 1);
        assert!(close(g.sweep, TAU));
        assert_eq!(extremes(&g, true).len(), 4);
        assert!(matches!(
            arc_center((10.0, 0.0), (0.0, 10.5), (-10.0, 0.0), false, T),
            Err(ArcError::NotOnCircle { .. })
        ));
    }

    #[test]
    fn extremes_only_inside_the_sweep() {
        // CCW quarter from (10,0) to (0,10): reaches +X (start) and +Y (end) only.
        let g = arc_center((10.0, 0.0), (0.0, 10.0), (-10.0, 0.0), false, T).unwrap();
        let e = extremes(&g, false);
        assert_eq!(e.len(), 2);
        // CW from (10,0) to (0,10): three quarters through -Y and -X.
        let g = arc_center((10.0, 0.0), (0.0, 10.0), (-10.0, 0.0), true, T).unwrap();
        assert!(close(g.sweep, 1.5 * PI));
        let e = extremes(&g, true);
        assert_eq!(e.len(), 4);
        assert!(e.iter().any(|p| close(p.0, -10.0)));
        assert!(e.iter().any(|p| close(p.1, -10.0)));
    }
}
