//! How two compensated elements meet: tangent (nothing to add), inside (both end at the
//! intersection of their offsets, so nothing is undercut), or outside (the configured
//! connection: an arc around the corner, lines to the intersection, or Fanuc's three-block
//! chamfer); and the check that a trimmed element still runs forwards (else a gouge).

use cnc402_config::{CompCorner, CutterComp as CompConfig};
use cnc402_motion::segment::SegmentKind;

use super::geom::{
    EPS, Elem, P, add, cross, dist, dot, fmt, intersections, line_line, scale, sub, sweep,
};
use crate::canon::CanonKind;

/// A connecting block from where the tool is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Piece {
    Line(P),
    Arc { to: P, c: P, ccw: bool },
}

/// Where the first element ends, what connects, where the second starts.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    pub a_end: P,
    pub corner: Vec<Piece>,
    pub b_start: P,
    /// The offsets were intersected (an inside corner).
    pub inside: bool,
}

/// The feed of a feed move (`None`: a rapid or no move).
pub fn feed_of(kind: &CanonKind) -> Option<f64> {
    match kind {
        CanonKind::Single(SegmentKind::Linear { feed, .. } | SegmentKind::Arc { feed, .. }) => {
            Some(*feed)
        }
        _ => None,
    }
}

/// The joint of `a` and `b` at `a`'s end, for offset `sr` (+R left). `type_a`: `a` is the
/// start-up block of a type A start (it ends where `b`'s offset starts). `rapid`: `b` is a
/// rapid (an arc corner would be a feed move: lines to the intersection instead).
pub fn join(
    a: &Elem,
    type_a: bool,
    b: &Elem,
    sr: f64,
    rapid: bool,
    cfg: CompConfig,
) -> Result<Joint, String> {
    let p = a.end();
    let ta = a.end_dir();
    let tb = b.start_dir();
    let ea = a.offset_point(p, sr);
    let sb = b.offset_point(p, sr);
    let plain = |x: P, inside| Joint {
        a_end: x,
        corner: Vec::new(),
        b_start: x,
        inside,
    };
    if type_a {
        return Ok(plain(sb, false));
    }
    if dist(ea, sb) < EPS {
        return Ok(plain(ea, false));
    }
    let turn = cross(ta, tb);
    // A reversal (the contour turns back on itself) has no inside: the tool goes round the
    // turning point as round an outside corner, as LinuxCNC does. A reversal into the tool's
    // side (a turn of nearly 180° on the inside) shows as an element whose offset runs
    // backwards (`check_piece`).
    let reversal = dot(ta, tb) < 0.0 && turn.abs() < 1e-9;
    if sr * turn > 0.0 && !reversal {
        let x = intersections(&a.offset(sr), &b.offset(sr))
            .into_iter()
            .min_by(|u, v| dist(*u, p).total_cmp(&dist(*v, p)))
            .ok_or("the offset paths of this block and the one before do not meet: the tool is too big for this inside corner")?;
        return Ok(plain(x, true));
    }
    let mode = match cfg.corner {
        // Offsets of a reversal never meet: lines go out R, across and back instead.
        CompCorner::Arc | CompCorner::Intersection if rapid && reversal => CompCorner::Chamfer,
        CompCorner::Intersection if reversal => CompCorner::Chamfer,
        CompCorner::Arc if rapid => CompCorner::Intersection,
        CompCorner::Chamfer if dot(ta, tb) > cfg.chamfer_angle.to_radians().cos() => {
            CompCorner::Intersection
        }
        m => m,
    };
    Ok(match mode {
        CompCorner::Arc => Joint {
            a_end: ea,
            corner: vec![Piece::Arc {
                to: sb,
                c: p,
                ccw: sr < 0.0,
            }],
            b_start: sb,
            inside: false,
        },
        CompCorner::Intersection => {
            let x = line_line(ea, add(ea, ta), sb, add(sb, tb)).unwrap_or(ea);
            extended(a, ea, x, b, sb, x)
        }
        CompCorner::Chamfer => {
            let r = sr.abs();
            let q1 = add(ea, scale(ta, r));
            let q2 = sub(sb, scale(tb, r));
            extended(a, ea, q1, b, sb, q2)
        }
    })
}

/// An outside corner cut by lines: `a` runs on to `qa`, across to `qb`, and `b` starts
/// there (a line element is itself extended; an arc gets a straight extension block).
fn extended(a: &Elem, ea: P, qa: P, b: &Elem, sb: P, qb: P) -> Joint {
    let mut corner = Vec::new();
    let a_end = match a {
        Elem::Line { .. } => qa,
        Elem::Arc { .. } => {
            corner.push(Piece::Line(qa));
            ea
        }
    };
    if dist(qa, qb) > EPS {
        corner.push(Piece::Line(qb));
    }
    let b_start = match b {
        Elem::Line { .. } => qb,
        Elem::Arc { .. } => {
            corner.push(Piece::Line(sb));
            sb
        }
    };
    Joint {
        a_end,
        corner,
        b_start,
        inside: false,
    }
}

/// Element `e` compensated from `start` to `end` still runs forwards along `e`: else the
/// tool radius is bigger than the element allows (a step smaller than the radius, or an arc
/// that vanishes).
pub fn check_piece(e: &Elem, start: P, end: P, sr: f64) -> Result<(), String> {
    match *e {
        Elem::Line { a, b } => {
            if dist(start, end) > EPS && dot(sub(end, start), sub(b, a)) <= 0.0 {
                return Err(format!(
                    "the tool (radius {}) cannot follow this block: its offset runs backwards between its neighbours (a step smaller than the tool radius, or a reversal into the tool's side); the tool would cut into the contour",
                    fmt(sr.abs())
                ));
            }
        }
        Elem::Arc { c, ccw, .. } => {
            let na = e.offset_point(e.start(), sr);
            let ea = e.offset_point(e.end(), sr);
            let total = sweep(c, na, ea, ccw);
            let s0 = if dist(start, na) < EPS {
                0.0
            } else {
                sweep(c, na, start, ccw)
            };
            let s1 = if dist(end, ea) < EPS {
                total
            } else {
                sweep(c, na, end, ccw)
            };
            if s1 <= s0 + 1e-9 || s1 > total + 1e-9 {
                return Err(format!(
                    "this arc is too short for the tool radius {}: the tool would cut into the contour",
                    fmt(sr.abs())
                ));
            }
        }
    }
    Ok(())
}
