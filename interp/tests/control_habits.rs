//! Habits of real programs from CAM posts and shop controls (issue 20): arc tolerance like a
//! control, G90.1/G91.1, zero offsets off the plane, corner rounding and chamfers, machine M
//! codes from the config, Haas habits. Each test is named after the habit it pins.
#![allow(clippy::result_large_err)]

use cnc402_config::MachineConfig;
use cnc402_interp::run_program;
use cnc402_lang::SourceFile;
use cnc402_motion::Planner;
use cnc402_motion::segment::{Segment, SegmentKind};

fn cfg() -> MachineConfig {
    MachineConfig::default_machine()
}

fn run(text: &str) -> Result<Vec<Segment>, cnc402_lang::NcError> {
    run_program(&cfg(), &SourceFile::new("t.nc", text))
}

/// Every segment through the planner (which checks arcs once more).
fn plans(segs: &[Segment]) {
    let mut p = Planner::new(&cfg());
    for s in segs {
        p.plan(s).unwrap_or_else(|e| panic!("{s:?}: {e}"));
    }
}

fn arcs(segs: &[Segment]) -> Vec<([f64; 3], cnc402_motion::segment::AxisPos)> {
    segs.iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Arc { center, end, .. } => Some((*center, *end)),
            _ => None,
        })
        .collect()
}

/// Regression: 4-decimal inch CAM output (every coordinate rounded to 0.0001") was refused
/// because 0.0001" = 0.00254 mm is more than the old 0.002 mm arc tolerance.
#[test]
fn four_decimal_inch_cam_arcs_are_accepted() {
    // A 1.25" radius quarter arc about (0, 0) from (1.25, 0): the end (0.8839, 0.8839) is
    // 1.25 · cos 45° = 0.883883… rounded, 0.00009" off the circle; I/J rounded too.
    let text = "G20 G90 G17\nG0 X1.25 Y0\nG3 X0.8839 Y0.8839 I-1.2501 J0.0001 F20\n\
                G2 X1.2501 Y0.0001 I-0.8838 J-0.8840\nM30\n";
    let segs = run(text).unwrap();
    assert_eq!(arcs(&segs).len(), 2);
    plans(&segs);
}

/// A large arc off by more than the absolute tolerance but less than 0.1 % of its radius is
/// accepted (LinuxCNC's rule); the planner still takes it (its centre moved onto the chord's
/// bisector).
#[test]
fn large_arc_within_the_relative_tolerance_is_accepted_and_planned() {
    let text = "G0 X150 Y0\nG3 X0 Y150.1 I-150 J0 F500\nM30\n";
    let segs = run(text).unwrap();
    let a = arcs(&segs);
    assert_eq!(a.len(), 1);
    let (c, end) = a[0];
    let rs = (150.0 - c[0]).hypot(0.0 - c[1]);
    let re = (end.0[0] - c[0]).hypot(end.0[1] - c[1]);
    assert!((rs - re).abs() < 1e-9, "{rs} {re}");
    assert!(c[0].hypot(c[1]) < 0.2, "{c:?}");
    plans(&segs);
}

/// A really wrong arc is still refused, naming both radii.
#[test]
fn wrong_arc_is_refused_naming_both_radii() {
    let e = run("G0 X10 Y0\nG3 X0 Y10.5 I-10 J0 F100\n").unwrap_err();
    assert_eq!(e.line, 2);
    assert!(
        e.message
            .starts_with("arc end point is not on the circle: start radius 10, end radius 10.5"),
        "{}",
        e.message
    );
    // In inch programs the radii are in inches.
    let e = run("G20\nG0 X1 Y0\nG3 X0 Y1.01 I-1 J0 F10\n").unwrap_err();
    assert!(
        e.message.contains("start radius 1, end radius 1.01"),
        "{}",
        e.message
    );
    // Over 100 × the absolute tolerance (2.83 mm) even on a huge radius.
    let e = run("G0 X0 Y0\nG3 X0 Y250 I-10000 J0 F100\n").unwrap_err();
    assert!(
        e.message.starts_with("arc end point is not on the circle"),
        "{}",
        e.message
    );
}

/// G90.1: I/J/K are the centre in work coordinates (G54 here, with a G92 shift on top);
/// G91.1 goes back to Fanuc's incremental centre; a program starts in G91.1.
#[test]
fn g90_1_takes_the_arc_centre_absolute_and_g91_1_incremental() {
    let text = "G0 X10 Y0\nG90.1 G3 X0 Y10 I0 J0 F100\nG91.1 G3 X-10 Y0 I0 J-10\n\
                G90.1 G92 X0 Y10\nG3 X-10 Y0 I0 J0\nM30\n";
    let segs = run(text).unwrap();
    let a = arcs(&segs);
    assert_eq!(a.len(), 3);
    assert_eq!((a[0].0[0], a[0].0[1]), (0.0, 0.0));
    assert_eq!((a[1].0[0], a[1].0[1]), (0.0, 0.0));
    // G92 X0 Y10 at machine (-10, 0): work (0, 0) is machine (-10, -10).
    assert_eq!((a[2].0[0], a[2].0[1]), (-10.0, -10.0));
    // A new program starts in G91.1.
    let segs = run("G0 X10 Y0\nG3 X0 Y10 I-10 J0 F100\n").unwrap();
    assert_eq!((arcs(&segs)[0].0[0], arcs(&segs)[0].0[1]), (0.0, 0.0));
}

/// In G90.1 both centre words are needed (an omitted one is not the start point's
/// coordinate); two codes of the group in one block are an error naming them as written.
#[test]
fn g90_1_arc_without_both_centre_words_is_refused() {
    let e = run("G0 X10 Y0\nG90.1 G3 X0 Y10 J0 F100\n").unwrap_err();
    assert_eq!((e.line, e.col), (2, 7));
    assert!(
        e.message
            .starts_with("I word missing in an absolute centre arc (G90.1)"),
        "{}",
        e.message
    );
    let e = run("G90.1 G91.1\n").unwrap_err();
    assert!(
        e.message
            .starts_with("G90.1 and G91.1 are both in modal group"),
        "{}",
        e.message
    );
}

/// FreeCAD posts write `K0` on G17 arcs (and `J0` on G18, `I0` on G19): accepted when zero,
/// refused when not, in every dialect (`rs274` refuses even `K0`; FreeCAD's LinuxCNC post
/// writes it).
#[test]
fn zero_centre_offset_off_the_plane_is_accepted() {
    let segs = run("G0 X10 Y0\nG3 X0 Y10 I-10 J0 K0 F100\nM30\n").unwrap();
    assert_eq!(arcs(&segs).len(), 1);
    let segs = run("G18 G0 X10 Z0\nG3 X0 Z-10 I-10 K0 J0 F100\nM30\n").unwrap();
    assert_eq!(arcs(&segs).len(), 1);
    let segs = run("G19 G0 Y10 Z0\nG3 Y0 Z10 J-10 K0 I0 F100\nM30\n").unwrap();
    assert_eq!(arcs(&segs).len(), 1);
    let e = run("G0 X10 Y0\nG3 X0 Y10 I-10 J0 K0.5 F100\n").unwrap_err();
    assert_eq!((e.line, e.col), (2, 19));
    assert!(
        e.message.starts_with("K0.5 in a G17 (XY) arc"),
        "{}",
        e.message
    );
    let segs = run("(dialect: linuxcnc)\nG0 X10 Y0\nG3 X0 Y10 I-10 J0 K0 F100\nM30\n").unwrap();
    assert_eq!(arcs(&segs).len(), 1);
    let e = run("(dialect: linuxcnc)\nG0 X10 Y0\nG3 X0 Y10 I-10 J0 K0.5 F100\n").unwrap_err();
    assert!(
        e.message.starts_with("K0.5 in a G17 (XY) arc"),
        "{}",
        e.message
    );
}

/// Fanuc lets a macro keyword be written as its first two letters: `WH[…]DO1` … `EN1`,
/// `GO`, `IF[…]GO`, `IF[…]TH`.
#[test]
fn wh_do_and_other_macro_abbreviations_run() {
    let text = "#1=0\nWH[#1LT3]DO1\nG91 G1 X1 F100\n#1=#1+1\nEN1\n\
                IF[#1EQ3]GO20\nG1 X50\nN20 IF[#1EQ3]TH #2=7\nG90 G1 Y#2\nGO30\nG1 X99\nN30 M30\n";
    let segs = run(text).unwrap();
    let ends: Vec<(f64, f64)> = segs
        .iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Linear { end, .. } => Some((end.0[0], end.0[1])),
            _ => None,
        })
        .collect();
    assert_eq!(ends, vec![(1.0, 0.0), (2.0, 0.0), (3.0, 0.0), (3.0, 7.0)]);
}

/// A library holding `O9001` (M98-style) and `O9020` (G65-style: moves to X#24).
struct Macros;

impl cnc402_interp::host::ProgramLibrary for Macros {
    fn find(&mut self, number: u32, _main: &str) -> Result<Option<SourceFile>, String> {
        Ok(match number {
            9001 => Some(SourceFile::new("O9001.nc", "O9001\nG4 P250\nM99\n")),
            9020 => Some(SourceFile::new("O9020.nc", "O9020\nG0 X#24\nM99\n")),
            _ => None,
        })
    }
    fn resolve_use(
        &mut self,
        _path: &str,
        _including: &str,
    ) -> Result<Option<cnc402_interp::host::UsedFile>, String> {
        Ok(None)
    }
    fn describe(&self) -> String {
        "in the test library".into()
    }
}

fn run_with(cfg: &MachineConfig, text: &str) -> Result<Vec<Segment>, cnc402_lang::NcError> {
    let src = SourceFile::new("t.nc", text);
    let p = cnc402_lang::parse(&src).unwrap();
    let mut it = cnc402_interp::Interpreter::new(cfg);
    it.set_program_library(Some(Box::new(Macros)));
    it.load(src, p);
    let mut v = Vec::new();
    while let Some(s) = it.next_segment()? {
        v.push(s);
    }
    Ok(v)
}

fn kinds(segs: &[Segment]) -> Vec<String> {
    segs.iter()
        .map(|s| match &s.kind {
            SegmentKind::Spindle { rpm, dir, .. } => format!("spindle {rpm} {dir:?}"),
            SegmentKind::Coolant { mist, flood } => format!("coolant {mist} {flood}"),
            SegmentKind::Message { text } => format!("msg {text}"),
            SegmentKind::Dwell { seconds } => format!("dwell {seconds}"),
            SegmentKind::Rapid { end } => format!("rapid {}", end.0[0]),
            SegmentKind::Stop { .. } => "stop".into(),
            k => format!("{k:?}"),
        })
        .collect()
}

/// Regression: machine M codes (M13, M31 …) were "unknown M code"; the shipped `[mcodes]`
/// maps M13 to M3 + M8, M31 to an output event and M10 to a note given once a run.
#[test]
fn machine_m_codes_from_the_config_run() {
    let segs = run("S1000 M13\nM31\nM10\nM10\nM5 M9\nM30\n").unwrap();
    assert_eq!(
        kinds(&segs),
        vec![
            "spindle 1000 Cw",
            "coolant false true",
            "msg M31: output chip_conveyor = 1",
            "msg M10 ignored on this machine ([mcodes]): rotary axis brake clamp: no brake on this machine",
            "spindle 0 Stop",
            "coolant false false",
            "stop",
        ]
    );
    let e = run("G0 X1\nM66\n").unwrap_err();
    assert_eq!((e.line, e.col), (2, 1));
    assert!(e.message.starts_with("unknown M code M66"), "{}", e.message);
    // An alias conflicts like the codes it stands for.
    let e = run("M13 M5\n").unwrap_err();
    assert!(e.message.contains("contradict"), "{}", e.message);
}

/// `dwell` and `wait` actions; a macro M code calls its program like M98, or like G65 with
/// the block's words as arguments (Fanuc's M-code macro call); a missing program is an error
/// at the block.
#[test]
fn machine_m_code_dwell_wait_and_macro_calls() {
    use cnc402_config::MAction;
    let mut cfg = cfg();
    cfg.mcodes.insert(50, MAction::Dwell { seconds: 1.5 });
    cfg.mcodes.insert(
        66,
        MAction::Wait {
            name: "door".into(),
            value: true,
            timeout_s: 5.0,
        },
    );
    cfg.mcodes.insert(
        101,
        MAction::Macro {
            program: 9001,
            args: false,
        },
    );
    cfg.mcodes.insert(
        102,
        MAction::Macro {
            program: 9020,
            args: true,
        },
    );
    cfg.mcodes.insert(
        103,
        MAction::Macro {
            program: 9003,
            args: false,
        },
    );
    let segs = run_with(&cfg, "M50\nM66\nG0 X5 M101\nM102 X7\nM30\n").unwrap();
    assert_eq!(
        kinds(&segs),
        vec![
            "dwell 1.5",
            "msg M66: wait for input door = 1 (timeout 5 s): no inputs are wired yet, taken as met",
            "rapid 5",
            "dwell 0.25",
            "rapid 7",
            "stop",
        ]
    );
    let e = run_with(&cfg, "G0 X1\nM103\n").unwrap_err();
    assert_eq!(e.line, 2);
    assert!(e.message.contains("9003"), "{}", e.message);
    let e = run_with(&cfg, "M101 P5\n").unwrap_err();
    assert!(e.message.contains("cannot give P too"), "{}", e.message);
}

/// Haas: a bare `G28` sends every axis (not the spindle) straight to its reference, in one
/// rapid; Fanuc (cnc402's fanuc dialect) refuses it: it needs the axes named.
#[test]
fn haas_bare_g28_homes_all_axes() {
    let segs = run("(dialect: haas)\nG0 X10 Y20 Z-5\nG28\nM30\n").unwrap();
    let rapids: Vec<[f64; 3]> = segs
        .iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Rapid { end } => Some([end.0[0], end.0[1], end.0[2]]),
            _ => None,
        })
        .collect();
    let c = cfg();
    let r = |l: char| c.axes[c.axis_index(l).unwrap()].references[0].unwrap();
    assert_eq!(rapids, vec![[10.0, 20.0, -5.0], [r('X'), r('Y'), r('Z')]]);
    let e = run("G0 X10\nG28\n").unwrap_err();
    assert!(
        e.message.starts_with("G28 needs the axes to return"),
        "{}",
        e.message
    );
    // Named axes: as Fanuc, in haas too.
    let segs = run("(dialect: haas)\nG0 X10 Y20\nG91 G28 Z0\nM30\n").unwrap();
    let last = segs
        .iter()
        .rev()
        .find_map(|s| match s.kind {
            SegmentKind::Rapid { end } => Some(end),
            _ => None,
        })
        .unwrap();
    assert_eq!((last.0[0], last.0[1], last.0[2]), (10.0, 20.0, r('Z')));
}

/// Haas: a dwell `P` with a decimal point is seconds (`G82 … P0.5`), without one
/// milliseconds; Fanuc refuses `P0.5` (P is whole milliseconds there).
#[test]
fn haas_decimal_p_dwell_is_seconds() {
    let dwells = |text: &str| -> Vec<f64> {
        run(text)
            .unwrap()
            .iter()
            .filter_map(|s| match s.kind {
                SegmentKind::Dwell { seconds } => Some(seconds),
                _ => None,
            })
            .collect()
    };
    let cycle = "G0 Z10\nG82 X0 Y0 R2 Z-5 P0.5 F100\nG80\nG4 P250\nG4 P1.5\nM30\n";
    assert_eq!(
        dwells(&format!("(dialect: haas)\n{cycle}")),
        vec![0.5, 0.25, 1.5]
    );
    let e = run(cycle).unwrap_err();
    assert!(
        e.message.starts_with("P0.5 is not a dwell"),
        "{}",
        e.message
    );
}

fn path(segs: &[Segment]) -> Vec<String> {
    segs.iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Linear { end, .. } => Some(format!(
                "L {} {} @{}",
                fmt(end.0[0]),
                fmt(end.0[1]),
                s.source.line
            )),
            SegmentKind::Arc {
                end, center, dir, ..
            } => Some(format!(
                "A {} {} c {} {} {dir:?} @{}",
                fmt(end.0[0]),
                fmt(end.0[1]),
                fmt(center[0]),
                fmt(center[1]),
                s.source.line
            )),
            _ => None,
        })
        .collect()
}

fn fmt(v: f64) -> String {
    let r = (v * 1e6).round() / 1e6;
    format!("{}", if r == 0.0 { 0.0 } else { r })
}

/// Fanuc corner rounding `,R` and chamfer `,C` between two G1 moves: the first move is
/// shortened, the corner element inserted (with the first block's line), the second starts
/// where it ends. Chained corners and G91 work; a plain `R` in G1 is the same as `,R`.
#[test]
fn corner_rounding_and_chamfer_between_two_g1_moves() {
    let segs = run("G0 X0 Y0\nG1 X10 ,R2 F100\nY10 ,C1\nX0\nM30\n").unwrap();
    assert_eq!(
        path(&segs),
        vec![
            "L 8 0 @2",
            "A 10 2 c 8 2 Ccw @2",
            "L 10 9 @3",
            "L 9 10 @3",
            "L 0 10 @4",
        ]
    );
    // A right turn is clockwise; G91 targets are from the programmed corner.
    let segs = run("G0 X0 Y0\nG91 G1 X10 R2 F100\nY-10\nM30\n").unwrap();
    assert_eq!(
        path(&segs),
        vec!["L 8 0 @2", "A 10 -2 c 8 -2 Cw @2", "L 10 -10 @3"]
    );
    // A 45° corner: the tangent points are r·tan(22.5°) from it.
    let segs = run("G1 X10 Y0 ,R1 F100\nX20 Y10\nM30\n").unwrap();
    let t = (std::f64::consts::PI / 8.0).tan();
    let p = path(&segs);
    assert_eq!(p[0], format!("L {} 0 @1", fmt(10.0 - t)));
    plans(&segs);
}

/// A corner element that does not fit, a next block that is not a G1 move, a corner word on
/// a G0/G2 block, and a program that ends after the held move are errors at the word.
#[test]
fn corner_that_does_not_fit_is_refused_at_its_word() {
    let e = run("G1 X10 ,R20 F100\nY10\n").unwrap_err();
    assert_eq!((e.line, e.col), (1, 8));
    assert!(
        e.message
            .starts_with("corner rounding/chamfer: ,R20 does not fit: it needs 20 of each move, the moves are 10 and 10 long"),
        "{}",
        e.message
    );
    let e = run("G1 X10 ,C2 F100\nG0 Y10\n").unwrap_err();
    assert_eq!((e.line, e.col), (1, 8));
    assert!(
        e.message.contains("the next block is not a G1 move"),
        "{}",
        e.message
    );
    let e = run("G0 X10 ,R2\n").unwrap_err();
    assert!(
        e.message
            .starts_with(",R (corner rounding/chamfer) is only for a G1 move"),
        "{}",
        e.message
    );
    let e = run("G1 X10 ,R2 F100\n").unwrap_err();
    assert_eq!((e.line, e.col), (1, 8));
    assert!(
        e.message.contains("the program ends after this move"),
        "{}",
        e.message
    );
    let e = run("G1 X10 ,R2 F100\nX20\n").unwrap_err();
    assert!(e.message.contains("make no corner"), "{}", e.message);
    let e = run("G1 X10 ,R2 F100\nY10 Z5\n").unwrap_err();
    assert!(e.message.contains("lie in the plane"), "{}", e.message);
    // On this machine C is the spindle axis: a plain C is the axis, not a chamfer.
    let e = run("G1 X10 ,R-1 F100\nY10\n").unwrap_err();
    assert!(
        e.message.starts_with("corner R-1 must be > 0"),
        "{}",
        e.message
    );
}

/// LinuxCNC's I/O codes M62-M68 are built into the linuxcnc dialect (as message events until
/// machine I/O is wired); in fanuc they stay unknown unless `[mcodes]` maps them.
#[test]
fn linuxcnc_io_m_codes_are_built_into_its_dialect() {
    let texts = |segs: &[Segment]| -> Vec<String> {
        segs.iter()
            .filter_map(|s| match &s.kind {
                SegmentKind::Message { text } => Some(text.clone()),
                _ => None,
            })
            .collect()
    };
    let segs = run(
        "(dialect: linuxcnc)\nM64 P2\nM66 P0 L3 Q5\nM65 P2\nM62 P1\nG1 X1 F100\nM67 E0 Q2.5\nM2\n",
    )
    .unwrap();
    assert_eq!(
        texts(&segs),
        [
            "M64: digital output 2 = 1 (now)",
            "M66: wait for digital input 0 (mode L3, timeout 5 s): no inputs are wired yet, taken as met",
            "M65: digital output 2 = 0 (now)",
            "M62: digital output 1 = 1 (with the next move)",
            "M67: analog output 0 = 2.5",
        ]
    );
    let e = run("(dialect: linuxcnc)\nM64\n").unwrap_err();
    assert_eq!(
        (e.line, e.col, e.message.as_str()),
        (2, 1, "M64 needs P (the pin number)")
    );
    let e = run("(dialect: linuxcnc)\nM66 P0 L3\n").unwrap_err();
    assert!(e.message.contains("needs a timeout Q > 0"), "{}", e.message);
    let e = run("(dialect: linuxcnc)\nM66 P0 E1 L0\n").unwrap_err();
    assert!(
        e.message
            .contains("exactly one of P (digital) or E (analog)"),
        "{}",
        e.message
    );
    let e = run("M64 P2\n").unwrap_err();
    assert!(e.message.starts_with("unknown M code M64"), "{}", e.message);
}

/// CAM output for Fanuc rounds R and the end point to the last digit each: an R half circle
/// a few µm short of the chord is a half circle (up to the absolute arc tolerance), not an
/// "impossible radius"; in the linuxcnc dialect only LinuxCNC's 0.00005 in is allowed.
#[test]
fn r_half_circle_a_rounding_short_is_a_half_circle() {
    let segs = run("G0 X0 Y0\nG3 X-20 Y0 R9.99 F100\nM30\n").unwrap();
    assert_eq!(arcs(&segs).len(), 1);
    plans(&segs);
    let e = run("G0 X0 Y0\nG3 X-20 Y0 R9.9 F100\n").unwrap_err();
    assert!(
        e.message.starts_with("R arc with impossible radius"),
        "{}",
        e.message
    );
    let e = run("(dialect: linuxcnc)\nG0 X0 Y0\nG3 X-20 Y0 R9.99 F100\n").unwrap_err();
    assert!(
        e.message.starts_with("R arc with impossible radius"),
        "{}",
        e.message
    );
}

/// G5.1 is Fanuc's AI contour control switch in fanuc and haas, but LinuxCNC's quadratic
/// B-spline in its dialect: refused there rather than read as a path mode.
#[test]
fn g5_1_in_the_linuxcnc_dialect_is_a_spline_not_a_path_mode() {
    run("G05.1 Q1\nG1 X1 F100\nM30\n").unwrap();
    let e = run("(dialect: linuxcnc)\nG5.1 X1 Y1 I1 J0\n").unwrap_err();
    assert_eq!((e.line, e.col), (2, 1));
    assert!(e.message.contains("quadratic B-spline"), "{}", e.message);
}
