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
/// from the start point). End = start is a full circle.
///
/// ```
/// use cnc402_interp::arc::arc_center;
/// let g = arc_center((10.0, 0.0), (0.0, 10.0), (-10.0, 0.0), false, 0.002).unwrap();
/// assert_eq!(g.center, (0.0, 0.0));
/// assert!((g.sweep - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
/// ```
pub fn arc_center(
    start: (f64, f64),
    end: (f64, f64),
    offset: (f64, f64),
    cw: bool,
    tolerance: f64,
) -> Result<ArcGeom, ArcError> {
    let center = (start.0 + offset.0, start.1 + offset.1);
    let rs = dist(start, center);
    let re = dist(end, center);
    if rs < EPS {
        return Err(ArcError::ZeroRadius);
    }
    if (rs - re).abs() > tolerance {
        return Err(ArcError::NotOnCircle {
            start_radius: rs,
            end_radius: re,
        });
    }
    Ok(finish(start, end, center, cw))
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
        let g = arc_center((10.0, 0.0), (10.0, 0.0), (-10.0, 0.0), true, 0.002).unwrap();
        assert_eq!(g.turns, 1);
        assert!(close(g.sweep, TAU));
        assert_eq!(extremes(&g, true).len(), 4);
        assert!(matches!(
            arc_center((10.0, 0.0), (0.0, 10.5), (-10.0, 0.0), false, 0.002),
            Err(ArcError::NotOnCircle { .. })
        ));
    }

    #[test]
    fn extremes_only_inside_the_sweep() {
        // CCW quarter from (10,0) to (0,10): reaches +X (start) and +Y (end) only.
        let g = arc_center((10.0, 0.0), (0.0, 10.0), (-10.0, 0.0), false, 0.002).unwrap();
        let e = extremes(&g, false);
        assert_eq!(e.len(), 2);
        // CW from (10,0) to (0,10): three quarters through -Y and -X.
        let g = arc_center((10.0, 0.0), (0.0, 10.0), (-10.0, 0.0), true, 0.002).unwrap();
        assert!(close(g.sweep, 1.5 * PI));
        let e = extremes(&g, true);
        assert_eq!(e.len(), 4);
        assert!(e.iter().any(|p| close(p.0, -10.0)));
        assert!(e.iter().any(|p| close(p.1, -10.0)));
    }
}
