//! Cutter radius compensation (G40/G41/G42) by its geometry, in all three planes and with all
//! three corner settings: every tool-centre point of a compensated contour is at least R from
//! the programmed contour, exactly R where the tool follows an element (and everywhere with
//! arc corners); tangent joints add no blocks; gouges and bad input are errors naming the
//! block; blocks without motion in the plane do not break the contour; canned cycles, G91,
//! work offsets, Macro B and the C-like language work with it.

use cnc402_config::{CompCorner, CompGouge, CompStartup, MachineConfig};
use cnc402_interp::{Interpreter, run_program};
use cnc402_lang::SourceFile;
use cnc402_motion::segment::{ArcDir, Plane, Segment, SegmentKind};

type P = [f64; 2];

const R: f64 = 4.0;

fn cfg(corner: CompCorner) -> MachineConfig {
    let mut cfg = MachineConfig::default_machine();
    cfg.work_offsets = [[0.0; cnc402_config::MAX_AXES]; 6];
    cfg.tool_offsets[0].radius = R - 0.5;
    cfg.tool_offsets[0].radius_wear = 0.5;
    cfg.tool_offsets[1].radius = 1.5;
    cfg.interp.cutter_comp.corner = corner;
    for a in &mut cfg.axes {
        a.soft_limits = None;
    }
    cfg
}

/// The (first, second) axis letters and (first, second) centre letters of a plane.
fn letters(plane: Plane) -> (char, char, char, char, &'static str) {
    match plane {
        Plane::XY => ('X', 'Y', 'I', 'J', "G17"),
        Plane::ZX => ('Z', 'X', 'K', 'I', "G18"),
        Plane::YZ => ('Y', 'Z', 'J', 'K', "G19"),
    }
}

/// A G17 program written with `u v i j` for the plane's letters.
fn in_plane(plane: Plane, text: &str) -> String {
    let (a, b, i, j, g) = letters(plane);
    text.replace("G17", g)
        .chars()
        .map(|c| match c {
            'u' => a,
            'v' => b,
            'i' => i,
            'j' => j,
            c => c,
        })
        .collect()
}

/// An outline with outside and inside corners, line–arc, arc–line and arc–arc joints (some
/// tangent), run with G41 clockwise and with G42 counter-clockwise. Lines 4..=15 and 19..=25
/// are the contour blocks (the start-up moves, lines 3 and 18, are not part of the contour).
const OUTLINE: &str = "\
G17 G90 G94 G21
G0 u-20 v-20
G41 D1 G1 u0 v0 F300
G1 v40
G2 u10 v50 i10 j0
G1 u50
G1 u50 v30
G1 u40 v30
G1 u40 v20
G3 u50 v10 i10 j0
G1 u70 v10
G2 u70 v-10 i0 j-10
G2 u60 v-20 i-10 j0
G1 u60 v0
G1 u0
G40 G1 u-20 v-20
G42 D1 G1 u-10 v5
G1 u0 v0
G1 u60
G3 u70 v10 i0 j10
G3 u60 v20 i-10 j0
G1 u30 v40
G3 u10 v40 i-10 j0
G1 u0 v20
G1 v0
G40 G1 u-15 v-15
M30
";

const CONTOUR_LINES: [std::ops::RangeInclusive<u32>; 2] = [4..=15, 19..=25];

/// A programmed or compensated element in the plane.
#[derive(Clone, Copy, Debug)]
enum El {
    Line(P, P),
    Arc(P, P, P, bool),
}

fn uv(plane: Plane, p: &cnc402_motion::segment::AxisPos, cfg: &MachineConfig) -> P {
    let (a, b, ..) = letters(plane);
    [p[cfg.axis_index(a).unwrap()], p[cfg.axis_index(b).unwrap()]]
}

fn centre_uv(plane: Plane, c: [f64; 3]) -> P {
    match plane {
        Plane::XY => [c[0], c[1]],
        Plane::ZX => [c[2], c[0]],
        Plane::YZ => [c[1], c[2]],
    }
}

/// The elements of `kinds` (with their source lines) whose line is in `lines`.
fn elements(
    plane: Plane,
    cfg: &MachineConfig,
    moves: &[(u32, SegmentKind)],
    keep: &dyn Fn(u32) -> bool,
) -> Vec<(u32, El)> {
    let mut at = [0.0; 2];
    let mut v = Vec::new();
    for (line, k) in moves {
        let (end, el) = match k {
            SegmentKind::Rapid { end } | SegmentKind::Linear { end, .. } => {
                let e = uv(plane, end, cfg);
                (e, El::Line(at, e))
            }
            SegmentKind::Arc {
                end, center, dir, ..
            } => {
                let e = uv(plane, end, cfg);
                (
                    e,
                    El::Arc(at, e, centre_uv(plane, *center), *dir == ArcDir::Ccw),
                )
            }
            _ => continue,
        };
        if keep(*line) && (end != at || matches!(el, El::Arc(..))) {
            v.push((*line, el));
        }
        at = end;
    }
    v
}

fn sub(a: P, b: P) -> P {
    [a[0] - b[0], a[1] - b[1]]
}
fn norm(a: P) -> f64 {
    a[0].hypot(a[1])
}

fn angle_in(c: P, a: P, b: P, ccw: bool, q: P) -> bool {
    let ang = |p: P| (p[1] - c[1]).atan2(p[0] - c[0]);
    let tau = std::f64::consts::TAU;
    let span = |from: f64, to: f64| {
        let d = if ccw { to - from } else { from - to };
        d.rem_euclid(tau)
    };
    let total = if norm(sub(a, b)) < 1e-12 {
        tau
    } else {
        span(ang(a), ang(b))
    };
    span(ang(a), ang(q)) <= total + 1e-12
}

fn distance(e: &El, q: P) -> f64 {
    match *e {
        El::Line(a, b) => {
            let d = sub(b, a);
            let t = ((q[0] - a[0]) * d[0] + (q[1] - a[1]) * d[1]) / (d[0] * d[0] + d[1] * d[1]);
            let t = t.clamp(0.0, 1.0);
            norm(sub(q, [a[0] + t * d[0], a[1] + t * d[1]]))
        }
        El::Arc(a, b, c, ccw) => {
            let r = norm(sub(a, c));
            if angle_in(c, a, b, ccw, q) {
                (norm(sub(q, c)) - r).abs()
            } else {
                norm(sub(q, a)).min(norm(sub(q, b)))
            }
        }
    }
}

fn samples(e: &El, n: usize) -> Vec<P> {
    (0..=n)
        .map(|k| {
            let t = k as f64 / n as f64;
            match *e {
                El::Line(a, b) => [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])],
                El::Arc(a, b, c, ccw) => {
                    let a0 = (a[1] - c[1]).atan2(a[0] - c[0]);
                    let a1 = (b[1] - c[1]).atan2(b[0] - c[0]);
                    let tau = std::f64::consts::TAU;
                    let mut d = if ccw { a1 - a0 } else { a0 - a1 }.rem_euclid(tau);
                    if d < 1e-12 {
                        d = tau;
                    }
                    let ang = a0 + if ccw { t * d } else { -t * d };
                    let r = norm(sub(a, c));
                    [c[0] + r * ang.cos(), c[1] + r * ang.sin()]
                }
            }
        })
        .collect()
}

fn canon_moves(cfg: &MachineConfig, text: &str) -> Vec<(u32, SegmentKind)> {
    let src = SourceFile::new("t.nc", text);
    let p = cnc402_lang::parse(&src).unwrap();
    let mut it = Interpreter::new(cfg);
    it.load(src, p);
    let mut v = Vec::new();
    while let Some(op) = it.next_canon().unwrap() {
        if let cnc402_interp::canon::CanonKind::Single(k) = op.kind {
            v.push((op.source.line, k));
        }
    }
    v
}

fn segments(cfg: &MachineConfig, text: &str) -> Vec<Segment> {
    run_program(cfg, &SourceFile::new("t.nc", text)).unwrap_or_else(|e| panic!("{e}"))
}

fn seg_moves(segs: &[Segment]) -> Vec<(u32, SegmentKind)> {
    segs.iter()
        .map(|s| (s.source.line, s.kind.clone()))
        .collect()
}

/// Checks the outline in `plane` with `corner`: (points checked, points at exactly R).
fn check_outline(plane: Plane, corner: CompCorner) -> (usize, usize) {
    let cfg = cfg(corner);
    let text = in_plane(plane, OUTLINE);
    let in_contour = |l: u32| CONTOUR_LINES.iter().any(|r| r.contains(&l));
    let programmed = elements(plane, &cfg, &canon_moves(&cfg, &text), &in_contour);
    let segs = segments(&cfg, &text);
    let tool = elements(plane, &cfg, &seg_moves(&segs), &in_contour);
    assert!(programmed.len() >= 19 && tool.len() >= programmed.len());
    let (mut n, mut at_r) = (0, 0);
    for (line, e) in &tool {
        // The contour this part of the path belongs to (G41 or G42).
        let part = CONTOUR_LINES.iter().find(|r| r.contains(line)).unwrap();
        for q in samples(e, 16) {
            let d = programmed
                .iter()
                .filter(|(l, _)| part.contains(l))
                .map(|(_, p)| distance(p, q))
                .fold(f64::INFINITY, f64::min);
            assert!(
                d >= R - 1e-6,
                "{plane:?} {corner:?}: line {line}: tool centre {q:?} is {d} from the contour (R = {R})"
            );
            if corner == CompCorner::Arc {
                assert!((d - R).abs() < 1e-6, "{plane:?}: line {line}: {q:?} at {d}");
            }
            n += 1;
            at_r += usize::from((d - R).abs() < 1e-6);
        }
    }
    (n, at_r)
}

#[test]
fn every_tool_centre_point_is_r_from_the_contour_in_every_plane_and_corner_setting() {
    for plane in [Plane::XY, Plane::ZX, Plane::YZ] {
        for corner in [
            CompCorner::Arc,
            CompCorner::Intersection,
            CompCorner::Chamfer,
        ] {
            let (n, at_r) = check_outline(plane, corner);
            // Most of the path follows an element at exactly R; only the corner blocks of
            // the line settings are farther.
            assert!(
                at_r * 10 >= n * 7,
                "{plane:?} {corner:?}: {at_r} of {n} at R"
            );
        }
    }
}

/// The three settings differ only at outside corners: the arc setting makes arcs there, the
/// intersection setting none of its own for line–line corners, the chamfer setting three
/// blocks for corners sharper than 90°.
#[test]
fn outside_corners_by_setting() {
    let text = "G17 G21 G90\nG0 X-10 Y-10\nG41 D1 G1 X0 Y0 F100\nG1 Y20\nG1 X20\nG1 X0 Y5\nG40 G1 X-10 Y-10\n";
    let count = |corner| segments(&cfg(corner), text).len();
    // Outside corners at (0,20) (90°) and (20,20) (sharp, ~143°); inside at (0,0).
    assert_eq!(count(CompCorner::Arc), 2 + 4 + 2);
    assert_eq!(count(CompCorner::Intersection), 2 + 4);
    assert_eq!(count(CompCorner::Chamfer), 2 + 4 + 1);
    // Intersection: the 90° corner is the intersection of the offset lines.
    let segs = segments(&cfg(CompCorner::Intersection), text);
    let SegmentKind::Linear { end, .. } = segs[2].kind else {
        panic!("{:?}", segs[2])
    };
    assert!(
        (end[0] + R).abs() < 1e-9 && (end[1] - (20.0 + R)).abs() < 1e-9,
        "{end:?}"
    );
}

#[test]
fn tangent_joints_add_no_blocks() {
    // An obround slot outline: line, half circle, line, half circle, all tangent.
    for corner in [
        CompCorner::Arc,
        CompCorner::Intersection,
        CompCorner::Chamfer,
    ] {
        for plane in [Plane::XY, Plane::ZX, Plane::YZ] {
            let text = in_plane(
                plane,
                "G17 G21 G90\nG0 u-5 v-20\nG41 D1 G1 u0 v-10 F100\nG1 v0\nG2 u20 i10\nG1 v-10\nG2 u0 i-10\nG40 G1 u-5 v-20\n",
            );
            let cfg = cfg(corner);
            let programmed = canon_moves(&cfg, &text)
                .iter()
                .filter(|(_, k)| k.is_path())
                .count();
            let segs = segments(&cfg, &text);
            // The entry joint is an inside corner (no block) in this outline.
            assert_eq!(segs.len(), programmed, "{plane:?} {corner:?}: {segs:#?}");
            // The half circles keep their centres and grow by R (G41 clockwise: outside).
            let r: Vec<f64> = segs
                .iter()
                .filter_map(|s| match &s.kind {
                    SegmentKind::Arc { end, center, .. } => {
                        let e = uv(plane, end, &cfg);
                        Some(norm(sub(e, centre_uv(plane, *center))))
                    }
                    _ => None,
                })
                .collect();
            assert_eq!(r.len(), 2);
            assert!(r.iter().all(|r| (r - (10.0 + R)).abs() < 1e-9), "{r:?}");
        }
    }
}

fn err(cfg: &MachineConfig, text: &str) -> cnc402_lang::NcError {
    run_program(cfg, &SourceFile::new("t.nc", text)).unwrap_err()
}

#[test]
fn gouges_are_errors_naming_the_block() {
    let c = cfg(CompCorner::Arc);
    // An inside arc of radius 3 with R = 4.
    let e = err(
        &c,
        "G0 X-10 Y-10\nG41 D1 G1 X0 Y0 F100\nG1 Y20\nN40 G3 X-6 Y20 I-3\nG1 Y0\nG40 G1 X-10 Y-10\n",
    );
    assert_eq!((e.line, e.col), (4, 1), "{e}");
    assert!(
        e.message
            .contains("radius 3 is not bigger than the tool radius 4"),
        "{e}"
    );
    assert_eq!(e.block, "N40 G3 X-6 Y20 I-3");
    // A step of 2 (< R) in a pocket wall: the offsets of its neighbours cross before it.
    let e = err(
        &c,
        "G0 X-20 Y-20\nG41 D1 G1 X0 Y0 F100\nG1 X30\nG1 Y2\nG1 X40\nG1 Y30\nG1 X0\nG1 Y0\nG40 G1 X-20 Y-20\n",
    );
    assert!(e.message.contains("smaller than the tool radius"), "{e}");
    assert!((4..=5).contains(&e.line), "{e}");
    // A reversal into the tool's side (back along X, slightly to the left, under G41).
    let e = err(
        &c,
        "G0 X-10 Y-10\nG41 D1 G1 X0 Y0 F100\nG1 X20\nG1 X10 Y1\nG40 G1 X-10 Y-10\n",
    );
    assert_eq!(e.line, 3, "{e}");
    assert!(e.message.contains("reversal into the tool's side"), "{e}");
    // A plain reversal: the tool goes round the turning point (a half circle).
    let segs = segments(
        &c,
        "G0 X-10 Y-10\nG41 D1 G1 X0 Y0 F100\nG1 X20\nG1 X10\nG40 G1 X10 Y-10\n",
    );
    let half = segs
        .iter()
        .find_map(|s| match &s.kind {
            SegmentKind::Arc {
                end, center, dir, ..
            } if s.source.line == 4 => Some((end[0], end[1], center[0], center[1], *dir)),
            _ => None,
        })
        .unwrap();
    assert_eq!(half, (20.0, -R, 20.0, 0.0, ArcDir::Cw));
    // The start-up move must be longer than R.
    let e = err(
        &c,
        "G0 X0 Y-3\nG41 D1 G1 X0 Y0 F100\nG1 X20\nG40 G1 X20 Y-10\n",
    );
    assert_eq!(e.line, 2, "{e}");
    assert!(e.message.contains("start-up move"), "{e}");
}

#[test]
fn a_gouge_is_suppressed_with_a_warning_when_the_config_asks() {
    let mut c = cfg(CompCorner::Arc);
    c.interp.cutter_comp.gouge = CompGouge::Suppress;
    let segs = segments(
        &c,
        "G0 X-20 Y-20\nG41 D1 G1 X0 Y0 F100\nG1 X30\nN4 G1 Y2\nG1 X40\nG1 Y30\nG1 X0\nG1 Y0\nG40 G1 X-20 Y-20\n",
    );
    let warn: Vec<_> = segs
        .iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Message { text } => Some(text.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(warn.len(), 1, "{warn:?}");
    assert!(
        warn[0].starts_with("warning: cutter compensation suppressed block"),
        "{warn:?}"
    );
}

/// Blocks without motion in the plane (Z moves, M codes, a dwell, an assignment) between two
/// contour blocks leave the path as it is without them, up to the lookahead; one more breaks
/// the contour, which is an error at an inside corner.
#[test]
fn blocks_without_motion_in_the_plane_keep_the_contour() {
    let c = cfg(CompCorner::Arc);
    // G42 counter-clockwise: outside corners.
    let plain =
        "G0 X-20 Y-20 Z1\nG42 D1 G1 X0 Y0 F100\nG1 X30\nG1 Y30\nG1 X0\nG1 Y0\nG40 G1 X-20 Y-20\n";
    let busy = "G0 X-20 Y-20 Z1\nG42 D1 G1 X0 Y0 F100\nG1 X30\nG1 Z-1\nM8\nG4 P100\n#100=1\nM9\nG1 Y30\nG1 X0\nG1 Y0\nG40 G1 X-20 Y-20\n";
    let path = |text: &str, cfg: &MachineConfig| -> Vec<P> {
        segments(cfg, text)
            .iter()
            .filter_map(|s| match &s.kind {
                SegmentKind::Linear { end, .. } | SegmentKind::Arc { end, .. } => {
                    Some([end[0], end[1]])
                }
                _ => None,
            })
            .collect()
    };
    let mut a = path(plain, &c);
    let mut b = path(busy, &c);
    a.dedup();
    b.dedup();
    assert_eq!(a, b);
    // The Z move happens where the tool centre is: at the end of the offset X line.
    let segs = segments(&c, busy);
    let z = segs.iter().find(|s| s.source.line == 4).unwrap();
    let SegmentKind::Linear { end, .. } = z.kind else {
        panic!()
    };
    assert!(
        (end[0] - 30.0).abs() < 1e-9 && (end[1] + R).abs() < 1e-9,
        "{end:?}"
    );
    assert!((end[2] + 1.0).abs() < 1e-9, "{end:?}");
    // Lookahead 2: four blocks without motion in the plane before an outside corner break
    // the contour (the corner arc is still made)…
    let mut short = c.clone();
    short.interp.cutter_comp.lookahead = 2;
    assert_eq!(path(busy, &short).last(), path(busy, &c).last());
    // …and before an inside corner they are an error.
    let inside = busy.replace("G42", "G41");
    let inside = inside.as_str();
    let e = err(&short, inside);
    assert_eq!(e.line, 9, "{e}");
    assert!(e.message.contains("cutter_comp_lookahead"), "{e}");
    assert!(run_program(&c, &SourceFile::new("t.nc", inside)).is_ok());
}

/// Type A start-up ends the start-up move where the next block's offset starts; type B (the
/// default) perpendicular to the start-up move, then joins like any corner.
#[test]
fn start_up_types() {
    let text = "G0 X-20 Y10\nG41 D1 G1 X0 Y0 F100\nG1 X30\nG40 G1 X40 Y10\n";
    let first = |startup| {
        let mut c = cfg(CompCorner::Arc);
        c.interp.cutter_comp.startup = startup;
        let segs = segments(&c, text);
        match segs[1].kind {
            SegmentKind::Linear { end, .. } => [end[0], end[1]],
            _ => panic!(),
        }
    };
    // Type A: at (0, R), the offset start of the X line.
    let a = first(CompStartup::A);
    assert!(a[0].abs() < 1e-9 && (a[1] - R).abs() < 1e-9, "{a:?}");
    // Type B: the start-up line (direction (2,-1)) and the X line meet on the inside: the
    // tool stops where their offsets cross, on y = R, at x = R·(√5 − 2).
    let b = first(CompStartup::B);
    let x = R * (5f64.sqrt() - 2.0);
    assert!((b[1] - R).abs() < 1e-9 && (b[0] - x).abs() < 1e-9, "{b:?}");
}

/// Compensation with G91, a work offset, the tool length, a canned cycle inside (not
/// compensated), Macro B variables and a sub-program: the same tool-centre path as the plain
/// program.
#[test]
fn works_with_g91_offsets_cycles_macro_b_and_the_c_like_language() {
    let mut c = cfg(CompCorner::Arc);
    c.work_offsets[1][0] = 100.0;
    c.work_offsets[1][1] = 50.0;
    c.tool_offsets[4].length = 20.0;
    let plain = "G55 G43 H5 G0 X-20 Y-20 Z5\nG41 D1 G1 X0 Y0 F100\nG1 X30\nG1 Y30\nG1 X0\nG1 Y0\nG40 G1 X-20 Y-20\n";
    let g91 = "G55 G43 H5 G0 X-20 Y-20 Z5\nG91 G41 D1 G1 X20 Y20 F100\nX30\nY30\nX-30\nY-30\nG40 X-20 Y-20\nG90\n";
    let macro_b = "#1=30\nG55 G43 H5 G0 X-20 Y-20 Z5\nG41 D1 G1 X0 Y0 F100\nX#1\nY#1\nX[#1-30]\nY0\nG40 G1 X-20 Y-20\n";
    let path = |text: &str| -> Vec<[f64; 3]> {
        segments(&c, text)
            .iter()
            .filter_map(|s| match &s.kind {
                SegmentKind::Linear { end, .. } | SegmentKind::Arc { end, .. } => {
                    Some([end[0], end[1], end[2]])
                }
                _ => None,
            })
            .collect()
    };
    let want = path(plain);
    assert!(want.iter().any(|p| (p[0] - (100.0 + R)).abs() < 1e-9));
    for t in [g91, macro_b] {
        let got = path(t);
        assert_eq!(got.len(), want.len(), "{t}");
        for (a, b) in got.iter().zip(&want) {
            assert!(
                a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9),
                "{t}: {a:?} {b:?}"
            );
        }
    }
    // A canned cycle while compensating: the holes are drilled where programmed (not
    // offset), and the contour starts again after it.
    let cyc = "G0 X-20 Y-20 Z5\nG41 D1 G1 X0 Y0 F100\nG1 X30\nG98 G81 X15 Y15 Z-2 R1 F50\nG80\nG1 X30 Y30\nG1 X0\nG40 G1 X-20 Y-20\n";
    let segs = segments(&cfg(CompCorner::Arc), cyc);
    let drill = segs
        .iter()
        .find(|s| s.source.line == 4 && matches!(s.kind, SegmentKind::Linear { .. }))
        .unwrap();
    let SegmentKind::Linear { end, .. } = drill.kind else {
        panic!()
    };
    assert_eq!((end[0], end[1]), (15.0, 15.0));
}

#[test]
fn the_c_like_language_compensates_too() {
    let c = cfg(CompCorner::Arc);
    let g = "G0 X-20 Y-20\nG41 D1 G1 X0 Y0 F100\nG1 X30\nG1 Y30\nG40 G1 X40 Y40\n";
    let hll = "double d = 30;\nG0 X-20 Y-20\nG41 D1 G1 X0 Y0 F100\nfor (int i = 0; i < 1; i++)\n{\n    G1 X=d\n}\nG1 Y=d\nG40 G1 X40 Y40\n";
    let ends = |t: &str| -> Vec<String> {
        run_program(&c, &SourceFile::new("t.nc", t))
            .unwrap_or_else(|e| panic!("{e}"))
            .iter()
            .filter(|s| s.kind.is_path())
            .map(|s| format!("{:?}", s.kind))
            .collect()
    };
    assert_eq!(ends(g), ends(hll));
}

/// `examples/plate-cutter-comp.nc` on `config/machine.toml`: one contour sub-program run
/// with D4 (roughing, radius 5.3) and D2 (finishing, radius 3.3). `canon` keeps the drawing's
/// contour both times; the segments are the tool centre, R from each wall.
#[test]
fn the_plate_example_roughs_and_finishes_from_one_contour() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    let cfg = MachineConfig::load(format!("{root}/config/machine.toml")).unwrap();
    let file = format!("{root}/examples/plate-cutter-comp.nc");
    let text = std::fs::read_to_string(&file).unwrap();
    let segs = segments(&cfg, &text);
    let canon = canon_moves(&cfg, &text);
    // N240 G1 Y50 (the left wall, line 35): programmed X0 twice, the tool at -R.
    let left_wall = |moves: &[(u32, SegmentKind)]| -> Vec<f64> {
        moves
            .iter()
            .filter(|(l, _)| *l == 35)
            .filter_map(|(_, k)| k.line_end().map(|e| e[0]))
            .collect()
    };
    assert_eq!(left_wall(&canon), vec![0.0, 0.0]);
    let tool = left_wall(&seg_moves(&segs));
    assert_eq!(tool.len(), 2);
    assert!(
        (tool[0] + 5.3).abs() < 1e-9 && (tool[1] + 3.3).abs() < 1e-9,
        "{tool:?}"
    );
    // The bore (Ø30): the tool circles at 15 - R around X80 Y30.
    let radii: Vec<f64> = segs
        .iter()
        .filter(|s| s.source.n == Some(500))
        .filter_map(|s| match &s.kind {
            SegmentKind::Arc { end, center, .. } => {
                Some((end[0] - center[0]).hypot(end[1] - center[1]))
            }
            _ => None,
        })
        .collect();
    assert_eq!(radii.len(), 2);
    assert!(
        (radii[0] - 9.7).abs() < 1e-9 && (radii[1] - 11.7).abs() < 1e-9,
        "{radii:?}"
    );
    // The pocket's bottom wall (Y20, N360): at Y 20 + R in work coordinates.
    let pocket: Vec<f64> = segs
        .iter()
        .filter(|s| s.source.n == Some(360))
        .filter_map(|s| s.kind.line_end().map(|e| e[1]))
        .collect();
    assert_eq!(pocket.len(), 2);
    assert!(
        (pocket[0] - 25.3).abs() < 1e-9 && (pocket[1] - 23.3).abs() < 1e-9,
        "{pocket:?}"
    );
}

/// `#4007` reads the group 07 code and `#4107` the D number, so a macro can save and restore
/// the compensation mode.
#[test]
fn system_variables_read_the_compensation_mode() {
    let c = cfg(CompCorner::Arc);
    let text = "G0 X-20 Y-20\n#1=#4007\nG42 D2 G1 X0 Y0 F100\n#2=#4007\n#3=#4107\nG1 X10\nG40 G1 X20 Y-20\n#4=#4007\n";
    let src = SourceFile::new("t.nc", text);
    let p = cnc402_lang::parse(&src).unwrap();
    let mut it = Interpreter::new(&c);
    it.load(src, p);
    while it.next_segment().unwrap().is_some() {}
    assert_eq!(
        [it.var(1), it.var(2), it.var(3), it.var(4)],
        [Some(40.0), Some(42.0), Some(2.0), Some(40.0)]
    );
}

/// An error is the last item of a run: the contour blocks compensation still held back when
/// a later block failed are not given out after it.
#[test]
fn an_error_while_compensating_ends_the_run_without_the_held_blocks() {
    let c = cfg(CompCorner::Arc);
    let text = "G0 X-20 Y-20\nG41 D1 G1 X0 Y0 F100\nG1 X30\nG7\nG1 Y30\n";
    let src = SourceFile::new("t.nc", text);
    let p = cnc402_lang::parse(&src).unwrap();
    let mut it = Interpreter::new(&c);
    it.load(src, p);
    let mut lines = Vec::new();
    let e = loop {
        match it.next_segment() {
            // The element itself (a line); line 3's corner arc is made when it arrives.
            Ok(Some(s)) if matches!(s.kind, SegmentKind::Linear { .. }) => {
                lines.push(s.source.line)
            }
            Ok(Some(_)) => {}
            Ok(None) => panic!("no error"),
            Err(e) => break e,
        }
    };
    assert_eq!(e.line, 4);
    assert_eq!(it.next_segment().unwrap(), None);
    // The start-up move was out before; the X30 block was still held.
    assert_eq!(lines, [2]);
}

/// A reversal (back along the same line) in every corner setting: the tool goes round the
/// turning point, never closer than R to the contour, and ends on the other side.
#[test]
fn a_reversal_is_gone_round_in_every_corner_setting() {
    let text = "G0 X-10 Y10\nG41 D1 G1 X0 Y0 F100\nG1 X20\nG1 X10\nG40 G1 X10 Y-10\n";
    for corner in [
        CompCorner::Arc,
        CompCorner::Intersection,
        CompCorner::Chamfer,
    ] {
        let c = cfg(corner);
        let segs = segments(&c, text);
        let keep = |l: u32| l == 3 || l == 4;
        let tool = elements(Plane::XY, &c, &seg_moves(&segs), &keep);
        let contour = [El::Line([0.0, 0.0], [20.0, 0.0])];
        for (line, e) in &tool {
            for q in samples(e, 16) {
                let d = distance(&contour[0], q);
                assert!(d >= R - 1e-6, "{corner:?}: line {line}: {q:?} at {d}");
            }
        }
        let last = tool.last().unwrap().1;
        let El::Line(_, end) = last else {
            panic!("{last:?}")
        };
        assert!(
            (end[0] - 10.0).abs() < 1e-9 && (end[1] + R).abs() < 1e-9,
            "{corner:?}: {end:?}"
        );
    }
}
