//! Plane geometry of cutter compensation: programmed elements (lines, arcs) in the plane's
//! (first, second) axes, their tangents, their offsets by ±R, and the intersections of offset
//! elements at a joint. Pure functions on `[f64; 2]`.

use std::f64::consts::TAU;

pub type P = [f64; 2];

/// Below this (mm) two points are the same and a joint is tangent.
pub const EPS: f64 = 1e-7;

pub fn sub(a: P, b: P) -> P {
    [a[0] - b[0], a[1] - b[1]]
}
pub fn add(a: P, b: P) -> P {
    [a[0] + b[0], a[1] + b[1]]
}
pub fn scale(a: P, k: f64) -> P {
    [a[0] * k, a[1] * k]
}
pub fn dot(a: P, b: P) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}
pub fn cross(a: P, b: P) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}
pub fn len(a: P) -> f64 {
    a[0].hypot(a[1])
}
pub fn dist(a: P, b: P) -> f64 {
    len(sub(a, b))
}
pub fn unit(a: P) -> P {
    let l = len(a);
    if l > 0.0 {
        scale(a, 1.0 / l)
    } else {
        [0.0, 0.0]
    }
}
/// The left normal of direction `t`.
pub fn left(t: P) -> P {
    [-t[1], t[0]]
}

/// A programmed element in the plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Elem {
    Line {
        a: P,
        b: P,
    },
    /// `ccw`: G3 (counter-clockwise seen from the plane's normal).
    Arc {
        a: P,
        b: P,
        c: P,
        ccw: bool,
    },
}

impl Elem {
    pub fn start(&self) -> P {
        match *self {
            Elem::Line { a, .. } | Elem::Arc { a, .. } => a,
        }
    }
    pub fn end(&self) -> P {
        match *self {
            Elem::Line { b, .. } | Elem::Arc { b, .. } => b,
        }
    }
    /// Unit tangent at point `p` of the element (for a line: anywhere).
    pub fn tangent_at(&self, p: P) -> P {
        match *self {
            Elem::Line { a, b } => unit(sub(b, a)),
            Elem::Arc { c, ccw, .. } => {
                let r = unit(sub(p, c));
                if ccw { left(r) } else { [r[1], -r[0]] }
            }
        }
    }
    pub fn start_dir(&self) -> P {
        self.tangent_at(self.start())
    }
    pub fn end_dir(&self) -> P {
        self.tangent_at(self.end())
    }
    /// The point `p` of the element moved by `s·R` along the left normal (s = +1: G41).
    pub fn offset_point(&self, p: P, sr: f64) -> P {
        add(p, scale(left(self.tangent_at(p)), sr))
    }
    /// The radius of the offset arc (arcs only): `r ∓ R`; ≤ 0 means the tool is bigger than
    /// the arc on its inside.
    pub fn offset_radius(&self, sr: f64) -> Option<f64> {
        match *self {
            Elem::Line { .. } => None,
            Elem::Arc { a, c, ccw, .. } => Some(dist(a, c) - if ccw { sr } else { -sr }),
        }
    }
    /// The offset element (same kind; an arc keeps its centre).
    pub fn offset(&self, sr: f64) -> Elem {
        match *self {
            Elem::Line { a, b } => Elem::Line {
                a: self.offset_point(a, sr),
                b: self.offset_point(b, sr),
            },
            Elem::Arc { a, b, c, ccw } => Elem::Arc {
                a: self.offset_point(a, sr),
                b: self.offset_point(b, sr),
                c,
                ccw,
            },
        }
    }
}

/// The angle swept from `p` to `q` around `c` in the direction `ccw`, in (0, 2π] (a whole
/// turn when they coincide).
pub fn sweep(c: P, p: P, q: P, ccw: bool) -> f64 {
    let a = sub(p, c);
    let b = sub(q, c);
    let mut s = cross(a, b).atan2(dot(a, b));
    if !ccw {
        s = -s;
    }
    if s <= 1e-12 { s + TAU } else { s }
}

/// Intersections of two offset elements taken whole (infinite lines, full circles).
pub fn intersections(e: &Elem, f: &Elem) -> Vec<P> {
    match (*e, *f) {
        (Elem::Line { a, b }, Elem::Line { a: c, b: d }) => {
            line_line(a, b, c, d).into_iter().collect()
        }
        (Elem::Line { a, b }, Elem::Arc { a: p, c, .. })
        | (Elem::Arc { a: p, c, .. }, Elem::Line { a, b }) => line_circle(a, b, c, dist(p, c)),
        (Elem::Arc { a: p, c, .. }, Elem::Arc { a: q, c: d, .. }) => {
            circle_circle(c, dist(p, c), d, dist(q, d))
        }
    }
}

/// Where the line through `a`, `b` meets the line through `c`, `d` (none if parallel).
pub fn line_line(a: P, b: P, c: P, d: P) -> Option<P> {
    let r = sub(b, a);
    let s = sub(d, c);
    let den = cross(r, s);
    if den.abs() < 1e-12 * len(r).max(1.0) * len(s).max(1.0) {
        return None;
    }
    let t = cross(sub(c, a), s) / den;
    Some(add(a, scale(r, t)))
}

fn line_circle(a: P, b: P, c: P, r: f64) -> Vec<P> {
    let d = unit(sub(b, a));
    let f = sub(a, c);
    let t0 = -dot(f, d);
    let foot = add(a, scale(d, t0));
    let h2 = r * r - dist(foot, c).powi(2);
    if h2 < -1e-9 {
        return Vec::new();
    }
    let h = h2.max(0.0).sqrt();
    vec![add(foot, scale(d, h)), add(foot, scale(d, -h))]
}

fn circle_circle(c1: P, r1: f64, c2: P, r2: f64) -> Vec<P> {
    let d = dist(c1, c2);
    if d < 1e-12 || d > r1 + r2 + 1e-9 || d < (r1 - r2).abs() - 1e-9 {
        return Vec::new();
    }
    let a = (r1 * r1 - r2 * r2 + d * d) / (2.0 * d);
    let h = (r1 * r1 - a * a).max(0.0).sqrt();
    let u = unit(sub(c2, c1));
    let m = add(c1, scale(u, a));
    vec![add(m, scale(left(u), h)), add(m, scale(left(u), -h))]
}

/// A length as a message shows it (at most 4 decimals, no trailing zeros).
pub fn fmt(v: f64) -> String {
    let s = format!("{v:.4}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_and_intersections() {
        let l = Elem::Line {
            a: [0.0, 0.0],
            b: [10.0, 0.0],
        };
        assert_eq!(
            l.offset(2.0),
            Elem::Line {
                a: [0.0, 2.0],
                b: [10.0, 2.0]
            }
        );
        let arc = Elem::Arc {
            a: [10.0, 0.0],
            b: [0.0, 10.0],
            c: [0.0, 0.0],
            ccw: true,
        };
        assert_eq!(arc.offset_radius(2.0), Some(8.0));
        assert_eq!(arc.offset_radius(-2.0), Some(12.0));
        let x = intersections(&l.offset(2.0), &arc.offset(2.0));
        assert!(
            x.iter()
                .all(|p| (len(*p) - 8.0).abs() < 1e-9 && (p[1] - 2.0).abs() < 1e-9)
        );
        assert!((sweep([0.0, 0.0], [1.0, 0.0], [0.0, 1.0], true) - TAU / 4.0).abs() < 1e-12);
        assert!((sweep([0.0, 0.0], [1.0, 0.0], [0.0, 1.0], false) - 3.0 * TAU / 4.0).abs() < 1e-12);
        assert!((sweep([0.0, 0.0], [1.0, 0.0], [1.0, 0.0], false) - TAU).abs() < 1e-12);
    }
}
