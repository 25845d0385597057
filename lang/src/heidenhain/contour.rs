//! The geometry of the contour blocks that are not an end point and a centre: `CR` (arc by
//! radius), `CT` (arc tangent to the previous element), `RND R` (a rounding arc tangent to
//! both neighbours) and `CHF` (a chamfer cutting both legs). Each becomes an ISO G1/G2/G3
//! with an end point and an absolute centre, all in the XY plane.

/// A point or a direction in the XY plane.
pub type Xy = (f64, f64);

/// Below this (program units) two points are one, a direction is none.
const EPS: f64 = 1e-9;

/// An arc: where it ends, its centre, counter-clockwise or not.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arc {
    pub end: Xy,
    pub centre: Xy,
    pub ccw: bool,
}

impl Arc {
    /// The direction of travel where the arc ends.
    pub fn end_tangent(&self) -> Xy {
        let r = sub(self.end, self.centre);
        unit(if self.ccw { (-r.1, r.0) } else { (r.1, -r.0) }).unwrap_or((0.0, 0.0))
    }
}

/// What replaces a corner between two straight legs: where the first leg now ends, and the
/// rounding arc or chamfer to the point on the second leg.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corner {
    pub leg_end: Xy,
    pub arc: Option<Arc>,
    pub end: Xy,
    pub feed: Option<f64>,
}

pub fn sub(a: Xy, b: Xy) -> Xy {
    (a.0 - b.0, a.1 - b.1)
}

fn add(a: Xy, b: Xy, k: f64) -> Xy {
    (a.0 + b.0 * k, a.1 + b.1 * k)
}

fn len(a: Xy) -> f64 {
    a.0.hypot(a.1)
}

pub fn unit(a: Xy) -> Option<Xy> {
    let l = len(a);
    (l > EPS).then(|| (a.0 / l, a.1 / l))
}

fn cross(a: Xy, b: Xy) -> f64 {
    a.0 * b.1 - a.1 * b.0
}

/// `CR X Y R±r DR±` from `start`: the arc of radius |r| to `end`, the short one (≤ 180°)
/// for R+, the long one for R-.
pub fn by_radius(start: Xy, end: Xy, r: f64, ccw: bool) -> Result<Arc, String> {
    let chord = sub(end, start);
    let d = len(chord);
    if d <= EPS {
        return Err("CR to where the tool already is: the circle is not defined".into());
    }
    let half = d / 2.0;
    if r.abs() < half - 1e-7 {
        return Err(format!(
            "CR radius {} is smaller than half the chord ({half}) from the start to the end \
             point: expected |R| >= {half}",
            r.abs()
        ));
    }
    let h = (r * r - half * half).max(0.0).sqrt();
    let left = (-chord.1 / d, chord.0 / d);
    // A short arc turning left (DR+) has its centre on the chord's left; a long one, or one
    // turning right, on its right (both: left again).
    let on_left = ccw == (r > 0.0);
    let mid = add(start, chord, 0.5);
    let centre = add(mid, left, if on_left { h } else { -h });
    Ok(Arc { end, centre, ccw })
}

/// `CT X Y` from `start` leaving in direction `tangent`: the arc tangent to it to `end`.
pub fn tangential(start: Xy, tangent: Xy, end: Xy) -> Result<Arc, String> {
    let d = sub(end, start);
    let left = (-tangent.1, tangent.0);
    let side = left.0 * d.0 + left.1 * d.1;
    if len(d) <= EPS {
        return Err("CT to where the tool already is: the arc is not defined".into());
    }
    if side.abs() <= EPS * len(d).max(1.0) {
        return Err(
            "CT end point on the line of the previous element's direction: a tangent arc to \
             it is a straight line (expected an end point off that line, or an L)"
                .into(),
        );
    }
    // The centre is on the normal at the start, as far from the end as from the start.
    let r = (d.0 * d.0 + d.1 * d.1) / (2.0 * side);
    Ok(Arc {
        end,
        centre: add(start, left, r),
        ccw: r > 0.0,
    })
}

/// The corner at `corner` between the legs `start`→`corner` and `corner`→`next`: rounded
/// with radius `r` (`round`) or chamfered by `length` on each leg.
pub fn corner(
    start: Xy,
    corner: Xy,
    next: Xy,
    size: f64,
    round: bool,
    feed: Option<f64>,
) -> Result<Corner, String> {
    let what = if round { "RND" } else { "CHF" };
    let (Some(u1), Some(u2)) = (unit(sub(corner, start)), unit(sub(next, corner))) else {
        return Err(format!(
            "{what} between legs of no length: expected an L to a new point before and after it"
        ));
    };
    let turn = cross(u1, u2);
    let along = u1.0 * u2.0 + u1.1 * u2.1;
    if turn.abs() <= 1e-9 {
        return Err(format!(
            "{what} where the contour does not turn (the blocks before and after it are in line)"
        ));
    }
    if size <= 0.0 {
        return Err(format!("{what} needs a positive size"));
    }
    // How far from the corner each leg is cut: r·tan(θ/2) for a rounding arc turning by θ.
    let cut = if round {
        size * turn.abs() / (1.0 + along)
    } else {
        size
    };
    let (l1, l2) = (len(sub(corner, start)), len(sub(next, corner)));
    if cut > l1 + 1e-7 || cut > l2 + 1e-7 {
        return Err(format!(
            "{what} {size} cuts {cut:.4} off each leg, more than the legs have ({l1:.4} and \
             {l2:.4})"
        ));
    }
    let leg_end = add(corner, u1, -cut);
    let end = add(corner, u2, cut);
    let arc = round.then(|| {
        let ccw = turn > 0.0;
        let normal = if ccw { (-u1.1, u1.0) } else { (u1.1, -u1.0) };
        Arc {
            end,
            centre: add(leg_end, normal, size),
            ccw,
        }
    });
    Ok(Corner {
        leg_end,
        arc,
        end,
        feed,
    })
}
