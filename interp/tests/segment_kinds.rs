//! Segments say what they are: a programmed feed move of a linear axis with the spindle axis
//! is a `Tap` (decided from the block's axis words), a rapid or a feed that couples nothing is
//! not; every segment says how it ends, from the path mode (G61/G63 exact stop, G64
//! continuous within its `P` tolerance or the default), taps and non-path segments always in
//! an exact stop.

use cnc402_config::MachineConfig;
use cnc402_interp::run_program;
use cnc402_lang::SourceFile;
use cnc402_motion::segment::{Segment, SegmentEnd, SegmentKind, TapSegment};

const Z: usize = 2;
const C: usize = 3;

fn run(text: &str) -> Vec<Segment> {
    run_program(
        &MachineConfig::default_machine(),
        &SourceFile::new("t.nc", text),
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

fn err(text: &str) -> String {
    match run_program(
        &MachineConfig::default_machine(),
        &SourceFile::new("t.nc", text),
    ) {
        Ok(s) => panic!("{text}: no error, {s:?}"),
        Err(e) => e.to_string(),
    }
}

fn on_line(segs: &[Segment], line: u32) -> Vec<&Segment> {
    segs.iter().filter(|s| s.source.line == line).collect()
}

#[test]
fn a_programmed_g1_of_z_with_c_is_a_tap() {
    let segs = run("G0 Z5\nG1 Z-3 C1440 F300\nG1 Z5 C0\nM30\n");
    let taps: Vec<TapSegment> = segs
        .iter()
        .filter_map(|s| match s.kind {
            SegmentKind::Tap(t) => Some(t),
            _ => None,
        })
        .collect();
    assert_eq!(taps.len(), 2, "{segs:?}");
    for t in &taps {
        assert_eq!((t.tool, t.spindle, t.feed), (Z as u8, C as u8, 300.0));
        // 8 mm over 4 turns, Z down while C counts up: −2 mm per turn (and out the same).
        assert_eq!(t.pitch, -2.0);
    }
    assert_eq!((taps[0].end[Z], taps[0].end[C]), (-3.0, 1440.0));
    for s in on_line(&segs, 2).into_iter().chain(on_line(&segs, 3)) {
        assert_eq!(s.ends, SegmentEnd::ExactStop, "a tap ends in an exact stop");
    }
}

/// Regression guard for the old geometric guess: a rapid moving Z and C, a feed of C alone,
/// a feed whose C word does not move C, an arc with C and a tool-length move with C couple
/// nothing. The decision is the interpreter's, from the block's words.
#[test]
fn moves_that_couple_nothing_are_no_taps() {
    let cases = [
        "G0 Z-3 C90\nM30\n",
        "G1 C90 F300\nM30\n",
        "G1 Z-3 C0 F300\nM30\n",
        "G17 G2 X10 Y0 I5 J0 Z-2 C90 F300\nM30\n",
        "G43 H1 G1 C90 F300\nM30\n",
    ];
    for prog in cases {
        let segs = run(prog);
        assert!(
            !segs.iter().any(|s| matches!(s.kind, SegmentKind::Tap(_))),
            "{prog}: {segs:?}"
        );
        assert!(segs.iter().any(|s| s.kind.is_path()), "{prog}: no motion");
    }
}

#[test]
fn path_modes_set_how_segments_end() {
    // G64 P without Q takes interp.collinear_tolerance (LinuxCNC would take P).
    let cont = |t: f64, q: f64| SegmentEnd::Continuous {
        tolerance: t,
        collinear: q,
    };
    let d = MachineConfig::default_machine().interp;
    let segs = run(
        "G1 X1 F100\nG64 P0.05 X2\nG61 X3\nG63 X4\nG64 X5\nG20 G64 P0.001 G0 X1\nG21 G61 G4 P10\nG64 G4 P20\nG1 X6\nM30\n",
    );
    let ends =
        |line: u32| -> Vec<SegmentEnd> { on_line(&segs, line).iter().map(|s| s.ends).collect() };
    // The default is G64 with the default tolerance.
    assert_eq!(ends(1), [cont(d.path_tolerance, d.collinear_tolerance)]);
    assert_eq!(ends(2), [cont(0.05, d.collinear_tolerance)]);
    assert_eq!(ends(3), [SegmentEnd::ExactStop]);
    assert_eq!(ends(4), [SegmentEnd::ExactStop]);
    // G64 without P is the default again, not the last P.
    assert_eq!(ends(5), [cont(d.path_tolerance, d.collinear_tolerance)]);
    // P in program units (inch), rapids too.
    let SegmentEnd::Continuous {
        tolerance,
        collinear,
    } = ends(6)[0]
    else {
        panic!("{:?}", ends(6))
    };
    assert!((tolerance - 0.0254).abs() < 1e-15);
    assert_eq!(collinear, d.collinear_tolerance);
    // A dwell is no path: exact stop; in a G64 block with G4 the P is the dwell's.
    assert_eq!(ends(7), [SegmentEnd::ExactStop]);
    assert!(matches!(on_line(&segs, 8)[0].kind, SegmentKind::Dwell { seconds } if seconds == 0.02));
    assert_eq!(ends(9), [cont(d.path_tolerance, d.collinear_tolerance)]);
    // Non-path segments end in an exact stop whatever the mode.
    let stop = segs.last().unwrap();
    assert!(matches!(stop.kind, SegmentKind::Stop { .. }));
    assert_eq!(stop.ends, SegmentEnd::ExactStop);
}

#[test]
fn g64_p_must_be_positive() {
    for (prog, col) in [("G64 P0\nM30\n", 5), ("G1 X1 F10\nG64 P-0.1 X2\nM30\n", 5)] {
        let e = err(prog);
        assert!(e.contains("path tolerance must be > 0"), "{e}");
        assert!(
            e.contains(&format!(":{col}")),
            "{prog}: error not at the P word: {e}"
        );
    }
}

/// G9 stops exactly at the end of its own block only; G08 P1/P0 are G64/G61; the config's
/// `interp.path_mode` gives the mode at program start.
#[test]
fn g9_g08_and_the_configured_default_mode() {
    let d = MachineConfig::default_machine().interp;
    let cont = SegmentEnd::Continuous {
        tolerance: d.path_tolerance,
        collinear: d.collinear_tolerance,
    };
    let segs = run("G1 X1 F100
G9 X2
X3
G08 P0
X4
G08 P1 X5
G9 G0 X6
M30
");
    let ends = |line: u32| on_line(&segs, line)[0].ends;
    assert_eq!(ends(1), cont);
    assert_eq!(ends(2), SegmentEnd::ExactStop, "G9");
    assert_eq!(ends(3), cont, "G9 is one-shot");
    assert_eq!(ends(5), SegmentEnd::ExactStop, "G08 P0 = G61");
    assert_eq!(ends(6), cont, "G08 P1 = G64");
    assert_eq!(ends(7), SegmentEnd::ExactStop, "G9 with a rapid");
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.path_mode = cnc402_config::PathModeDefault::ExactStop;
    let segs = run_program(
        &cfg,
        &SourceFile::new(
            "t.nc",
            "G1 X1 F100
G64 X2
M30
",
        ),
    )
    .unwrap();
    assert_eq!(
        segs[0].ends,
        SegmentEnd::ExactStop,
        "configured G61 at start"
    );
    assert_eq!(segs[1].ends, cont);
}

/// Fanuc's AI contour control G05.1 Q1/Q0 is the same switch as G64/G61 (and G08 P1/P0),
/// at the configured tolerance.
#[test]
fn g05_1_q1_and_q0_are_g64_and_g61() {
    let d = MachineConfig::default_machine().interp;
    let cont = SegmentEnd::Continuous {
        tolerance: d.path_tolerance,
        collinear: d.collinear_tolerance,
    };
    let segs = run("G64 P0.05 G1 X1 F100
G05.1 Q0
X2
G05.1 Q1 X3
X4
G61 X5
M30
");
    let ends = |line: u32| on_line(&segs, line)[0].ends;
    assert_eq!(
        ends(1),
        SegmentEnd::Continuous {
            tolerance: 0.05,
            collinear: 0.0
        }
    );
    assert_eq!(ends(3), SegmentEnd::ExactStop, "G05.1 Q0 = G61");
    assert_eq!(ends(4), cont, "G05.1 Q1 = G64 at the configured tolerance");
    assert_eq!(ends(5), cont, "modal");
    assert_eq!(ends(6), SegmentEnd::ExactStop);
    let e = err("G05.1 Q1 G64\nM30\n");
    assert!(e.contains("t.nc:1:"), "{e}");
}

/// Bad path-mode input is a program error at the word, saying what was expected.
#[test]
fn bad_path_mode_words_are_errors_at_the_word() {
    for (prog, col, says) in [
        ("G64 P-1\nM30\n", 5, "path tolerance must be > 0"),
        ("G1 X1 F10\nG64 Q0.01\nM30\n", 5, "Q0.01 without P"),
        (
            "G64 P0.01 Q0\nM30\n",
            11,
            "collinearity tolerance must be > 0",
        ),
        ("G64 P2\nM30\n", 5, "larger than the configured maximum"),
        (
            "G64 P0.01 Q1.5\nM30\n",
            11,
            "larger than the configured maximum",
        ),
        (
            "G20 G64 P0.1\nM30\n",
            9,
            "larger than the configured maximum",
        ),
        ("G08 P2\nM30\n", 5, "unknown lookahead switch"),
        ("G08\nM30\n", 1, "G08 without P"),
        ("G05.1 Q7\nM30\n", 7, "unknown AI contour control switch"),
        ("G1 X1 F10\nG05.1\nM30\n", 1, "G05.1 without Q"),
    ] {
        let e = err(prog);
        assert!(e.contains(says), "{prog}: {e}");
        assert!(
            e.contains(&format!(":{col}")),
            "{prog}: not at column {col}: {e}"
        );
        assert!(e.contains("expected"), "{prog}: {e}");
    }
    // Q with P is accepted.
    let segs = run("G64 P0.02 Q0.01\nG1 X1 F100\nM30\n");
    assert_eq!(
        segs[0].ends,
        SegmentEnd::Continuous {
            tolerance: 0.02,
            collinear: 0.01
        }
    );
}

/// A canned cycle under G64 ends every move in an exact stop (it must reach each level it
/// names: R, the bottom, the return level), taps included; the moves around it follow G64.
#[test]
fn a_g84_hole_under_g64_gives_exact_stop_taps() {
    let segs = run("M3 S500\nG0 Z10\nG64 P0.05\nG84 X5 Y5 Z-6 R2 F750\nG80 G0 Z20\nM30\n");
    let hole = on_line(&segs, 4);
    let taps: Vec<_> = hole
        .iter()
        .filter_map(|s| match s.kind {
            SegmentKind::Tap(t) => Some((t, s.ends)),
            _ => None,
        })
        .collect();
    assert_eq!(taps.len(), 2);
    for (t, ends) in taps {
        assert_eq!(t.pitch, -1.5);
        assert_eq!(ends, SegmentEnd::ExactStop);
    }
    assert!(hole.iter().all(|s| s.ends == SegmentEnd::ExactStop));
    assert_eq!(
        on_line(&segs, 5)[0].ends,
        SegmentEnd::Continuous {
            tolerance: 0.05,
            collinear: 0.0
        }
    );
}
