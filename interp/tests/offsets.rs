//! Tool length compensation (G43/G44/G49, H), the tool offset table (G10 L10–L13, `#1xxxx`),
//! work offsets by G10 L2, G92, reference position return (G28/G29/G30), G61/G63/G64 and
//! coolant (M7/M8/M9), on the shipped machine (H1 = -180, H2 = -165.5 with wear -0.02,
//! G54 = 0, G55 X = 100, Z reference 0, second reference 40).
//!
//! The position rules chosen (Fanuc 0i/30i milling; Custom Macro manual):
//! - segment `end` and `#5021…` (machine) include the tool length offset vector;
//! - `#5001…` (block end point) is in work coordinates *without* the offset;
//! - `#5041…` (current position) is in work coordinates *with* the offset (machine minus the
//!   work offset and the G92 shift);
//! - the offset is type A: always Z, whatever the plane;
//! - G28/G30 keep G43/G44 modal (`#4008`) but cancel the vector on Z at the reference position;
//!   Z's next programmed move (or a new H) restores it; G53 Z cancels it the same way;
//! - a change of the table while G43 is active takes effect at the next H (Fanuc).

use cnc402_config::MachineConfig;
use cnc402_interp::{Interpreter, dump::segment_to_json};
use cnc402_lang::SourceFile;
use cnc402_motion::segment::{Segment, SegmentKind};

fn cfg() -> MachineConfig {
    MachineConfig::default_machine()
}

/// Runs `text` to its end (panics on an error) and returns its segments and the interpreter,
/// whose variables can then be read.
fn run(text: &str) -> (Vec<Segment>, Interpreter) {
    let src = SourceFile::new("t.nc", text);
    let p = cnc402_lang::parse(&src).expect("parses");
    let mut it = Interpreter::new(&cfg());
    it.load(src, p);
    let mut segs = Vec::new();
    loop {
        match it.next_segment() {
            Ok(Some(s)) => segs.push(s),
            Ok(None) => break,
            Err(e) => panic!("{e}"),
        }
    }
    (segs, it)
}

/// Every motion segment's end as (line, X, Y, Z).
fn ends(segs: &[Segment]) -> Vec<(u32, f64, f64, f64)> {
    let r = |v: f64| (v * 1e6).round() / 1e6;
    segs.iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Rapid { end }
            | SegmentKind::Linear { end, .. }
            | SegmentKind::Arc { end, .. } => {
                Some((s.source.line, r(end[0]), r(end[1]), r(end[2])))
            }
            _ => None,
        })
        .collect()
}

fn var(it: &mut Interpreter, n: u32) -> Option<f64> {
    it.var(n).map(|v| (v * 1e6).round() / 1e6)
}

#[test]
fn g43_adds_h_to_z_and_the_position_variables_follow_fanuc() {
    let (segs, mut it) = run(
        "G90 G54 G0 X0 Y0\nG43 H1 Z50.\n#100=#5003\n#101=#5043\n#102=#5023\n#103=#4008\n#104=#4111\n#105=#5083\n",
    );
    assert_eq!(ends(&segs)[1], (2, 0.0, 0.0, -130.0));
    assert_eq!(var(&mut it, 100), Some(50.0), "#5003: no offset");
    assert_eq!(var(&mut it, 101), Some(-130.0), "#5043: with the offset");
    assert_eq!(var(&mut it, 102), Some(-130.0), "#5023: machine");
    assert_eq!(var(&mut it, 103), Some(43.0));
    assert_eq!(var(&mut it, 104), Some(1.0));
    assert_eq!(var(&mut it, 105), Some(-180.0), "#5083: the vector");
}

#[test]
fn g43_alone_moves_z_by_the_offset_in_the_current_mode() {
    // G0: a rapid of Z by the offset; the programmed Z (#5003) does not change.
    let (segs, mut it) = run("G0 Z20\nG43 H1\n#100=#5003\n");
    assert_eq!(
        ends(&segs),
        vec![(1, 0.0, 0.0, 20.0), (2, 0.0, 0.0, -160.0)]
    );
    assert!(matches!(segs[1].kind, SegmentKind::Rapid { .. }));
    assert_eq!(var(&mut it, 100), Some(20.0));
    // G1: a feed move at the modal F.
    let (segs, _) = run("G1 Z20 F300\nG43 H1\n");
    assert!(matches!(segs[1].kind, SegmentKind::Linear { feed, .. } if feed == 300.0));
    // With other axes: one move of all of them.
    let (segs, _) = run("G0 Z20\nG43 H1 X5\n");
    assert_eq!(ends(&segs)[1], (2, 5.0, 0.0, -160.0));
}

#[test]
fn g44_subtracts_geometry_plus_wear_and_g49_h0_cancel() {
    let (segs, _) = run("G44 H2 Z-200\nG49\nG43 H2 Z0\nG43 H0\nG43 H1 Z0\nG43 H0 Z0\n");
    assert_eq!(
        ends(&segs),
        vec![
            (1, 0.0, 0.0, -34.48), // -200 + 165.52
            (2, 0.0, 0.0, -200.0), // G49 alone: back by the offset
            (3, 0.0, 0.0, -165.52),
            (4, 0.0, 0.0, 0.0), // H0: no offset
            (5, 0.0, 0.0, -180.0),
            (6, 0.0, 0.0, 0.0),
        ]
    );
}

#[test]
fn incremental_moves_carry_the_change_and_a_new_h_replaces_the_offset() {
    let (segs, _) = run("G0 Z10\nG91 G43 H1 Z-10\nG90 Z5\nH2 Z5\nG91 Z1\n");
    assert_eq!(
        ends(&segs),
        vec![
            (1, 0.0, 0.0, 10.0),
            (2, 0.0, 0.0, -180.0), // 10 - 10 - 180
            (3, 0.0, 0.0, -175.0),
            (4, 0.0, 0.0, -160.52), // H2 replaces H1: 5 - 165.52
            (5, 0.0, 0.0, -159.52),
        ]
    );
}

#[test]
fn a_table_change_takes_effect_at_the_next_h() {
    let (segs, mut it) = run(
        "G43 H1 Z10\nG10 L10 P1 R-100\nG0 Z10\n#100=#11001\nH1 Z10\n#11001=-90\n#10001=-0.5\nH1\n",
    );
    assert_eq!(
        ends(&segs),
        vec![
            (1, 0.0, 0.0, -170.0),
            (3, 0.0, 0.0, -170.0),
            (5, 0.0, 0.0, -90.0),
            (8, 0.0, 0.0, -80.5),
        ]
    );
    assert_eq!(var(&mut it, 100), Some(-100.0));
}

#[test]
fn g28_goes_through_the_intermediate_point_and_cancels_the_vector_there() {
    let (segs, mut it) = run(concat!(
        "G43 H1 Z50.\n",
        "G0 X10 Y20\n",
        "G91 G28 Z0\n", // only Z, straight up to the reference
        "#100=#5003\n#101=#4008\n#102=#5043\n",
        "G90 G0 X30\n", // Z stays at the reference
        "G0 Z50\n",     // restores the vector
        "G90 G28 X50 Z60\n",
        "G49\n", // after G28 Z: nothing to move
        "G0 Z10\n",
    ));
    assert_eq!(
        ends(&segs),
        vec![
            (1, 0.0, 0.0, -130.0),
            (2, 10.0, 20.0, -130.0),
            (3, 10.0, 20.0, 0.0),
            (7, 30.0, 20.0, 0.0),
            (8, 30.0, 20.0, -130.0),
            (9, 50.0, 20.0, -120.0), // intermediate: X50, Z60 with the offset
            (9, 0.0, 20.0, 0.0),     // reference, X and Z only
            (11, 0.0, 20.0, 10.0),
        ]
    );
    assert_eq!(var(&mut it, 100), Some(0.0));
    assert_eq!(var(&mut it, 101), Some(43.0), "G43 stays modal after G28");
    let (_, mut it) = run("G43 H1 Z50.\nG91 G28 Z0\n#100=#4008\n#101=#5043\n#102=#5003\n");
    assert_eq!(var(&mut it, 100), Some(43.0), "G43 stays modal after G28");
    assert_eq!(var(&mut it, 101), Some(0.0), "at the reference, no vector");
    assert_eq!(var(&mut it, 102), Some(0.0));
}

#[test]
fn g30_second_reference_and_g29_back_through_the_intermediate_point() {
    let (segs, _) = run("G0 X10 Y10 Z-20\nG30 Z-10\nG28 X20 Y30\nG29 X50 Y0\nG91 G29 Z5\n");
    assert_eq!(
        ends(&segs),
        vec![
            (1, 10.0, 10.0, -20.0),
            (2, 10.0, 10.0, -10.0),
            (2, 10.0, 10.0, 40.0), // second_reference of Z
            (3, 20.0, 30.0, 40.0),
            (3, 0.0, 0.0, 40.0),
            (4, 20.0, 30.0, 40.0), // back through the G28 point
            (4, 50.0, 0.0, 40.0),
            (5, 50.0, 0.0, -10.0), // the G30 point of Z
            (5, 50.0, 0.0, -5.0),  // G91: from the intermediate point
        ]
    );
    // P2 given; an intermediate point where the tool is makes no segment.
    let (segs, _) = run("G30 P2 Z0\nG91 G28 X0\nG28 X0\n");
    assert_eq!(ends(&segs), vec![(1, 0.0, 0.0, 40.0)]);
}

/// Regression (review item 4): G28/G30, G29 and G53 to where the tool already is made a
/// zero-length rapid; they make no segment now (a move of some axes still moves only them).
#[test]
fn reference_moves_and_g53_to_where_the_tool_is_make_no_segment() {
    let (segs, _) = run(concat!(
        "G0 X0 Y0 Z0\n",
        "G91 G28 X0 Y0\n", // at the reference already
        "G90 G28 X0 Z0\n", // the same, in G90
        "G53 X0 Z0\n",     // G53 to where it is
        "G53 X#1\n",       // only a vacant word
        "G29 X0\n",        // back to the intermediate point, which is the end too
        "G0 X10\n",
        "G28 X10\n", // the intermediate point is where the tool is: the reference only
        "G53 X0 Y5\n",
    ));
    assert_eq!(
        ends(&segs),
        vec![
            (1, 0.0, 0.0, 0.0),
            (7, 10.0, 0.0, 0.0),
            (8, 0.0, 0.0, 0.0),
            (9, 0.0, 5.0, 0.0),
        ]
    );
}

fn spindle_events(segs: &[Segment]) -> Vec<String> {
    segs.iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Rapid { end } => Some(format!("{} C{}", s.source.line, end[3])),
            SegmentKind::SpindleOrient { angle, program, .. } => Some(match program {
                Some(c) => format!("{} O{angle}=C{c}", s.source.line),
                None => format!("{} O{angle}", s.source.line),
            }),
            SegmentKind::Spindle { rpm, .. } => Some(format!("{} S{rpm}", s.source.line)),
            _ => None,
        })
        .collect()
}

/// Regression (review item 2): `G28 C0` turned program C to 0, which is not the physical
/// reference after a speed-mode run (motion keeps the spindle's offset), so the spindle did
/// not move. The spindle axis goes to its reference by an orientation to the physical angle
/// (as M19), and then reads the reference (Fanuc): the segment sets program C in motion too
/// (`O0=C0`), and later C words count from it. The intermediate point is an ordinary C move.
#[test]
fn g28_of_the_spindle_axis_orients_it_and_c_reads_the_reference() {
    let (segs, mut it) = run("G0 C90\nS500 M3\nG4 X1\nM5\nG91 G28 C0\nG90 G28 C45\n#100=#5004\n");
    assert_eq!(
        spindle_events(&segs),
        vec!["1 C90", "2 S500", "4 S0", "5 O0=C0", "6 C45", "6 O0=C0"]
    );
    assert_eq!(it.state().pos[3], 0.0, "program C reads the reference");
    assert_eq!(var(&mut it, 100), Some(0.0));

    // A reference angle outside 0..360 is taken modulo 360 (program C reads the reference
    // itself); G30 uses the second reference; G28 of Z and C moves Z, then orients C; G29 C
    // goes back through the intermediate point, from the reference.
    let mut cfg = cfg();
    cfg.axes[3].references = [Some(-90.0), Some(450.0), None, None];
    let src = SourceFile::new(
        "t.nc",
        "G28 C0\nG30 C10\nG0 Z-10\nG28 Z-5 C20\nG29 C30\nM3 S0\nG28 C0\n",
    );
    let segs = cnc402_interp::run_program(&cfg, &src).unwrap();
    assert_eq!(
        spindle_events(&segs),
        vec![
            "1 O270=C-90",
            "2 C10",
            "2 O90=C450",
            "3 C450",
            "4 C20",
            "4 C20",
            "4 O270=C-90",
            "5 C20",
            "5 C30",
            "6 S0",
            "7 C0",
            "7 O270=C-90"
        ]
    );
    assert_eq!(ends(&segs)[3], (4, 0.0, 0.0, 0.0), "Z at its reference");
    // G30 P3 shares the code.
    cfg.axes[3].references[2] = Some(725.5);
    let src = SourceFile::new("t.nc", "G30 P3 C10\nG91 G0 C1\n");
    let segs = cnc402_interp::run_program(&cfg, &src).unwrap();
    assert_eq!(
        spindle_events(&segs),
        vec!["1 C10", "1 O5.5=C725.5", "2 C726.5"]
    );
}

/// Review repro 1 (segments): `G0 C0` / `G28 C30.` / `G0 C45.` oriented the spindle to 0 but
/// left program C at 30, so the `G0 C45.` turned 15° and ended at the physical 15°. Program C,
/// the segments' C and `#5004`/`#5024`/`#5044` read the reference after G28 C (work
/// coordinates: the reference less the work offset), and `G0 C45.` is a turn of 45.
#[test]
fn g28_c_then_absolute_c_counts_from_the_reference() {
    let text = "G0 C0\nG28 C30.\n#100=#5004\n#101=#5024\n#102=#5044\nG0 C45.\n";
    let (segs, mut it) = run(text);
    assert_eq!(
        spindle_events(&segs),
        vec!["1 C0", "2 C30", "2 O0=C0", "6 C45"]
    );
    assert_eq!(
        [var(&mut it, 100), var(&mut it, 101), var(&mut it, 102)],
        [Some(0.0); 3]
    );
    let orient = segs
        .iter()
        .find(|s| matches!(s.kind, SegmentKind::SpindleOrient { .. }))
        .unwrap();
    assert_eq!(
        segment_to_json(orient, &cfg()),
        r#"{"kind":"spindle_orient","file":"t.nc","line":2,"n":null,"angle":0,"program":0,"ends":"exact_stop"}"#
    );

    // With a work offset on C the work coordinates read the reference less it.
    let (segs, mut it) = run(concat!(
        "G10 L2 P1 C10\n",
        "G0 C0\n", // machine 10
        "G28 C30.\n",
        "#100=#5004\n#101=#5024\n#102=#5044\n",
        "G0 C45.\n", // machine 55
    ));
    assert_eq!(
        spindle_events(&segs),
        vec!["2 C10", "3 C40", "3 O0=C0", "7 C55"]
    );
    assert_eq!(
        [var(&mut it, 100), var(&mut it, 101), var(&mut it, 102)],
        [Some(-10.0), Some(0.0), Some(-10.0)]
    );
}

/// Review repro 2 (segments): at C90, `M5`, `G91 G28 C0` (the intermediate point is where C
/// is), `G90 G0 C90.` must turn 90 from the reference; it moved nothing (program C stayed 90).
#[test]
fn g91_g28_c0_then_g90_c90_turns_from_the_reference() {
    let (segs, it) = run("G0 C90.\nM5\nG91 G28 C0\nG90 G0 C90.\n");
    assert_eq!(
        spindle_events(&segs),
        vec!["1 C90", "2 S0", "3 O0=C0", "4 C90"]
    );
    assert_eq!(it.state().pos[3], 90.0);
}

/// Runs `text` through the interpreter, the planner and the interpolator, the spindle left at
/// the physical angle `left_at` (the interpolator's spindle offset at start-up). Returns every
/// tick's (line, Z, machine C) and asserts that the C setpoints never jump: each second
/// difference is within the axis's acceleration (a re-basing of C by even a degree would
/// break that).
fn drive(text: &str, left_at: f64) -> Vec<(u32, f64, f64)> {
    use cnc402_motion::{Interpolator, Planner, segment::AxisPos};
    let cfg = cfg();
    let segs = cnc402_interp::run_program(&cfg, &SourceFile::new("t.nc", text)).unwrap();
    let mut planner = Planner::new(&cfg);
    let mut ip = Interpolator::new(&cfg, AxisPos::default());
    assert!(ip.set_spindle_offset(left_at));
    let mut out = vec![(0, 0.0, left_at)];
    let mut next = segs.iter();
    loop {
        if ip.is_idle() {
            let Some(s) = next.next() else { break };
            ip.start(planner.plan(s).expect("plans")).expect("starts");
        }
        let t = ip.tick();
        out.push((t.line, t.pos.0[2], t.pos.0[3]));
        assert!(out.len() < 1_000_000, "runaway");
    }
    let p = ip.period();
    let a = cfg.axes[3].max_acceleration;
    for w in out.windows(3) {
        let d2 = w[2].2 - 2.0 * w[1].2 + w[0].2;
        assert!(
            d2.abs() <= a * p * p * (1.0 + 1e-9) + 1e-9,
            "C jumps at line {}: {} {} {}",
            w[2].0,
            w[0].2,
            w[1].2,
            w[2].2
        );
    }
    out
}

/// The physical angle of machine C, 0 <= a < 360 (up to rounding).
fn physical(c: f64) -> f64 {
    let a = c.rem_euclid(360.0);
    if 360.0 - a < 1e-9 { 0.0 } else { a }
}

/// Review repros end to end: the final physical C is the programmed one after G28 C, from
/// any angle the spindle was left at and after a speed-mode run; without a jump in the
/// setpoints.
#[test]
fn after_g28_c_absolute_c_lands_on_its_physical_angle() {
    for left_at in [0.0, 200.7, -1234.5] {
        for (text, want) in [
            ("G0 C0\nG28 C30.\nG0 C45.\nM30\n", 45.0),
            ("G0 C90.\nM5\nG91 G28 C0\nG90 G0 C90.\nM30\n", 90.0),
            ("S700 M3\nG4 X0.37\nM5\nG28 C0\nG0 C45.\nM30\n", 45.0),
            (
                "S900 M4\nG4 X0.29\nM5\nG91 G28 C0\nG90 G0 C-30.\nM30\n",
                330.0,
            ),
        ] {
            let ticks = drive(text, left_at);
            let c = ticks.last().unwrap().2;
            assert!(
                (physical(c) - want).abs() < 1e-6,
                "{text:?} from {left_at}: ends at the physical {}",
                physical(c)
            );
        }
    }
}

/// A rigid tap after G28 C starts at the reference angle and turns exactly its pitch's worth
/// (Z -5.25 from R2 at 1 mm: 7.25 turns, the physical 90 at the bottom); M3 after G28 C
/// ramps from the oriented angle (no jump, checked by `drive`).
#[test]
fn tap_and_speed_mode_after_g28_c() {
    let text = concat!(
        "S500 M3\nG4 X0.31\nM5\n",
        "G0 X0 Y0 Z10\n",
        "G28 C30.\n",
        "M29 S600\n",
        "G84 X0 Y0 Z-5.25 R2 F600\n",
        "G80\n",
        "G0 C45.\n",
        "S800 M3\nG4 X0.2\nM5\n",
        "M30\n",
    );
    let ticks = drive(text, 77.7);
    let tap: Vec<_> = ticks.iter().filter(|t| t.0 == 7).collect();
    let bottom = tap.iter().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    assert!((bottom.1 + 5.25).abs() < 1e-9, "Z bottom {}", bottom.1);
    assert!(
        (physical(bottom.2) - 90.0).abs() < 1e-6,
        "bottom at the physical {}",
        physical(bottom.2)
    );
    let after_tap = tap.last().unwrap();
    assert!(physical(after_tap.2) < 1e-6 || physical(after_tap.2) > 360.0 - 1e-6);
    let at_45 = ticks.iter().rfind(|t| t.0 == 9).unwrap();
    assert!((physical(at_45.2) - 45.0).abs() < 1e-6);
}

/// G28/G30/G29 with C while the spindle turns in speed mode is an error at the C word, also
/// when program C would not move; other axes may return while it turns.
#[test]
fn g28_g29_g30_of_the_spindle_axis_while_it_turns_are_errors() {
    for (text, col) in [
        ("S500 M3\nG28 C0\n", 5),
        ("S500 M3\nG91 G30 X0 C0\n", 12),
        ("G28 C10\nS500 M4\nG29 C0\n", 5),
    ] {
        let e = cnc402_interp::run_program(&cfg(), &SourceFile::new("t.nc", text)).unwrap_err();
        let code = if text.contains("G29") {
            "G29"
        } else if text.contains("G30") {
            "G30"
        } else {
            "G28"
        };
        assert_eq!(
            (e.line, e.col, e.message.as_str()),
            (
                text.lines().count() as u32,
                col,
                format!("{code} C: the spindle turns in speed mode (M3/M4); C is positioned only at rest")
                    .as_str()
            ),
            "{text}"
        );
        assert_eq!(
            e.expected.as_deref(),
            Some(format!("M5 before {code} C").as_str())
        );
    }
    let (segs, _) = run("G0 X5\nS500 M3\nG28 X0\n");
    assert_eq!(ends(&segs).last(), Some(&(3, 0.0, 0.0, 0.0)));
}

#[test]
fn g53_cancels_the_vector_on_z_until_z_moves_again() {
    let (segs, _) = run("G43 H1 Z50\nG53 Z0\nG0 X5\nG0 Z50\n");
    assert_eq!(
        ends(&segs),
        vec![
            (1, 0.0, 0.0, -130.0),
            (2, 0.0, 0.0, 0.0),
            (3, 5.0, 0.0, 0.0),
            (4, 5.0, 0.0, -130.0),
        ]
    );
}

#[test]
fn canned_cycles_drill_with_the_offset() {
    let (segs, _) = run("G43 H1 Z50\nG99 G81 X10 Y0 R2 Z-5 F100\nG80\n");
    let z: Vec<f64> = ends(&segs).iter().map(|e| e.3).collect();
    assert_eq!(z, vec![-130.0, -130.0, -178.0, -185.0, -178.0]);
}

#[test]
fn g10_l2_sets_work_offsets_absolute_and_incremental() {
    let (segs, mut it) = run(concat!(
        "G10 L2 P1 X100 Z-5\n",
        "#100=#5221\n",
        "G91 G10 L2 P1 X5\n",
        "G90 G0 X0 Z0\n",
        "G10 L2 P2 X-50\n",
        "G55 G0 X0\n",
        "#101=#5241\n#102=#5001\n",
        "G20 G10 L2 P3 Y1\n#103=#5262\nG21\n#104=#5262\n",
    ));
    assert_eq!(
        ends(&segs),
        vec![(4, 105.0, 0.0, -5.0), (6, -50.0, 0.0, -5.0)]
    );
    assert_eq!(var(&mut it, 100), Some(100.0));
    assert_eq!(var(&mut it, 101), Some(-50.0));
    assert_eq!(var(&mut it, 102), Some(0.0));
    assert_eq!(var(&mut it, 103), Some(1.0), "read in inches in G20");
    assert_eq!(var(&mut it, 104), Some(25.4));
}

#[test]
fn g10_l10_to_l13_and_the_offset_variables() {
    let (_, mut it) = run(concat!(
        "G10 L10 P5 R-120.5\nG10 L11 P5 R-0.1\nG10 L12 P5 R6\nG10 L13 P5 R0.02\n",
        "G91 G10 L10 P5 R0.5\nG90\n",
        "#100=#11005\n#101=#10005\n#102=#13005\n#103=#12005\n#104=#2205\n#105=#2005\n",
        "#2201=-50\n#106=#11001\n#2400=7\n#107=#11200\n#108=#13003\n",
        "G20 G10 L10 P6 R1\n#109=#11006\nG21\n#110=#11006\n",
    ));
    let want = [
        (100, -120.0),
        (101, -0.1),
        (102, 6.0),
        (103, 0.02),
        (104, -120.0),
        (105, -0.1),
        (106, -50.0),
        (107, 7.0),
        (108, 4.0), // the config's radius of offset 3
        (109, 1.0),
        (110, 25.4),
    ];
    for (n, v) in want {
        assert_eq!(var(&mut it, n), Some(v), "#{n}");
    }
}

/// Review item 6: `#2401–#2800` (D values on some older controls) are not mapped; reading or
/// writing one is an error that says where the D values are.
#[test]
fn the_older_d_offset_numbers_are_refused_with_where_d_is() {
    for (text, col) in [("#1=#2401\n", 4), ("#2800=1\n", 1), ("#1=#2600\n", 4)] {
        let e = cnc402_interp::run_program(&cfg(), &SourceFile::new("t.nc", text)).unwrap_err();
        assert_eq!((e.line, e.col), (1, col), "{text}");
        assert!(
            e.message.contains("is not a variable of this control: the D (radius) offsets are #13001-#13400 (geometry) and #12001-#12400 (wear)"),
            "{e}"
        );
    }
}

#[test]
fn program_changes_last_for_the_run_only() {
    let cfg = cfg();
    let mut it = Interpreter::new(&cfg);
    for (text, want_h1, want_g54x) in [
        (
            "G10 L10 P1 R-1\n#5221=7\n#100=#11001\n#101=#5221\nM30\n",
            -1.0,
            7.0,
        ),
        ("#100=#11001\n#101=#5221\nM30\n", -180.0, 0.0),
    ] {
        let src = SourceFile::new("t.nc", text);
        it.load(src.clone(), cnc402_lang::parse(&src).unwrap());
        while it.next_segment().unwrap().is_some() {}
        assert_eq!(it.var(100), Some(want_h1), "{text}");
        assert_eq!(it.var(101), Some(want_g54x), "{text}");
    }
}

#[test]
fn g92_shifts_every_work_system_and_is_cleared_at_the_next_run() {
    let (segs, mut it) = run(concat!(
        "G0 X10 Y5\n",
        "G92 X0 Y0\n",
        "#100=#5001\n#101=#5041\n#102=#5021\n",
        "G0 X5\n",
        "G55 G0 X0\n",  // G55 (X 100) plus the shift (10)
        "G91 G92 X1\n", // always absolute: X now reads 1
        "#103=#5001\n",
        "G90 G0 X0\n",
    ));
    assert_eq!(
        ends(&segs),
        vec![
            (1, 10.0, 5.0, 0.0),
            (6, 15.0, 5.0, 0.0),
            (7, 110.0, 5.0, 0.0),
            (10, 109.0, 5.0, 0.0),
        ]
    );
    assert_eq!(var(&mut it, 100), Some(0.0));
    assert_eq!(var(&mut it, 101), Some(0.0));
    assert_eq!(var(&mut it, 102), Some(10.0));
    assert_eq!(var(&mut it, 103), Some(1.0));
    // The next program starts without the shift.
    let src = SourceFile::new("t.nc", "G0 X5\n");
    it.load(src.clone(), cnc402_lang::parse(&src).unwrap());
    let s = it.next_segment().unwrap().unwrap();
    assert!(matches!(s.kind, SegmentKind::Rapid { end } if end[0] == 5.0));
}

#[test]
fn g92_with_the_tool_length_offset_sets_the_programmed_tip_position() {
    let (segs, mut it) = run("G43 H1 Z50\nG92 Z0\n#100=#5003\n#101=#5043\nG0 Z10\n");
    assert_eq!(
        ends(&segs),
        vec![(1, 0.0, 0.0, -130.0), (5, 0.0, 0.0, -120.0)]
    );
    assert_eq!(var(&mut it, 100), Some(0.0));
    assert_eq!(var(&mut it, 101), Some(-180.0), "#5043 = 0 + the offset");
}

#[test]
fn group_15_is_tracked_and_changes_no_segment() {
    let (segs, mut it) =
        run("#100=#4015\nG61\n#101=#4015\nG63 G1 X1 F100\n#102=#4015\nG64\n#103=#4015\n");
    assert_eq!(ends(&segs), vec![(4, 1.0, 0.0, 0.0)]);
    for (n, v) in [(100, 64.0), (101, 61.0), (102, 63.0), (103, 64.0)] {
        assert_eq!(var(&mut it, n), Some(v));
    }
}

#[test]
fn coolant_events_come_before_the_motion_of_their_block_and_end_with_m30() {
    let (segs, _) = run("M8 G0 X10\nM7\nG1 X20 F100\nM9\nM7 M8\nM30\n");
    let cfg = cfg();
    let json: Vec<String> = segs.iter().map(|s| segment_to_json(s, &cfg)).collect();
    let kinds: Vec<&str> = segs
        .iter()
        .map(|s| match s.kind {
            SegmentKind::Coolant { mist, flood } => match (mist, flood) {
                (false, false) => "off",
                (true, false) => "mist",
                (false, true) => "flood",
                (true, true) => "both",
            },
            SegmentKind::Rapid { .. } => "rapid",
            SegmentKind::Linear { .. } => "linear",
            SegmentKind::Stop { .. } => "stop",
            _ => "other",
        })
        .collect();
    assert_eq!(
        kinds,
        vec![
            "flood", "rapid", "both", "linear", "off", "both", "off", "stop"
        ]
    );
    assert_eq!(
        json[0],
        r#"{"kind":"coolant","file":"t.nc","line":1,"n":null,"mist":false,"flood":true,"ends":"exact_stop"}"#
    );
    // M30 with the coolant off adds nothing.
    let (segs, _) = run("M8\nM9\nM30\n");
    assert_eq!(segs.len(), 3);
}

/// `G0 G43 H2 Z50.` after a contour in G3 (or after a cycle): the block's G0 is the mode the
/// offset moves in.
#[test]
fn a_g0_in_the_block_sets_the_mode_of_the_offset_move() {
    let (segs, _) = run("G3 X10 Y10 R10 F100\nG0 G43 H1 Z50\nG1 G49 Z40\n");
    assert!(matches!(segs[1].kind, SegmentKind::Rapid { .. }));
    assert!(matches!(segs[2].kind, SegmentKind::Linear { .. }));
    assert_eq!(
        ends(&segs)[1..],
        [(2, 10.0, 10.0, -130.0), (3, 10.0, 10.0, 40.0)]
    );
    let (segs, _) = run("G0 Z10\nG81 X1 R2 Z-2 F100\nG0 G43 H1 Z50\n");
    assert_eq!(ends(&segs).last(), Some(&(3, 1.0, 0.0, -130.0)));
}

/// `G91 G28 Z0 G49` and `G49 G53 Z0`: the cancel happens with the move (Fanuc), so Z goes
/// straight to the reference. Without Z in the block it is an error (see the corpus), except
/// when the position holds no vector anyway (after `G28 Z`).
#[test]
fn g49_in_a_g28_or_g53_block_cancels_with_the_move() {
    let (segs, mut it) = run("G43 H1 Z50\nG91 G28 Z0 G49\n#100=#4008\nG90 G0 Z10\n");
    assert_eq!(
        ends(&segs),
        vec![
            (1, 0.0, 0.0, -130.0),
            (2, 0.0, 0.0, 0.0),
            (4, 0.0, 0.0, 10.0)
        ]
    );
    assert_eq!(var(&mut it, 100), Some(49.0));
    let (segs, mut it) = run(concat!(
        "G43 H1 Z50\nG91 G28 Z0\nG28 X5 Y0 G49\n#100=#4008\n#101=#5003\n",
        "G49 G90 G53 X1\nG0 Z10\n",
    ));
    assert_eq!(
        ends(&segs),
        vec![
            (1, 0.0, 0.0, -130.0),
            (2, 0.0, 0.0, 0.0),
            (3, 5.0, 0.0, 0.0),
            (3, 0.0, 0.0, 0.0),
            (6, 1.0, 0.0, 0.0),
            (7, 1.0, 0.0, 10.0),
        ]
    );
    assert_eq!(var(&mut it, 100), Some(49.0));
    assert_eq!(var(&mut it, 101), Some(0.0));
}

/// G49 in a safety line is harmless on a machine without Z; G43 there is an error.
#[test]
fn g49_without_a_z_axis_is_accepted() {
    let mut cfg = cfg();
    cfg.axes.remove(2);
    let src = SourceFile::new("t.nc", "G21 G40 G49 G80 G90\nG0 X1\n");
    assert_eq!(cnc402_interp::run_program(&cfg, &src).unwrap().len(), 1);
    let e = cnc402_interp::run_program(&cfg, &SourceFile::new("t.nc", "G43 H1 X1\n")).unwrap_err();
    assert_eq!((e.line, e.col), (1, 1));
    assert!(e.message.contains("needs axis Z"), "{e}");
}

#[test]
fn h_alone_in_g49_is_remembered_for_the_next_g43() {
    let (segs, mut it) = run("H2\n#100=#4111\nG43 Z0\n");
    assert_eq!(var(&mut it, 100), Some(2.0));
    assert_eq!(ends(&segs), vec![(3, 0.0, 0.0, -165.52)]);
}

/// `examples/fanuc-milling.nc` on the shipped machine: G10 L11 wear on H1, G10 L2 P2 for the
/// second part, G30 to the tool change height, G92 at the first hole, coolant on and off.
#[test]
fn the_fanuc_milling_example_runs_with_its_offsets() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/fanuc-milling.nc");
    let text = std::fs::read_to_string(path).expect("the example exists");
    let (segs, mut it) = run(&text);
    let e = ends(&segs);
    let at = |n: u32| -> Vec<(f64, f64, f64)> {
        segs.iter()
            .filter(|s| s.source.n == Some(n))
            .filter_map(|s| match &s.kind {
                SegmentKind::Rapid { end } | SegmentKind::Linear { end, .. } => {
                    Some((end[0], end[1], (end[2] * 1e6).round() / 1e6))
                }
                _ => None,
            })
            .collect()
    };
    // N70 G43 H1 Z50. with the wear of N30: 50 - 180 - 0.05.
    assert_eq!(at(70), vec![(-10.0, -10.0, -130.05)]);
    // N190 G55 (set by N40 to X120 Y40): X-10 → machine 110, Y-10 → 30.
    assert_eq!(at(190), vec![(110.0, 30.0, -130.05)]);
    // N310 G30 Z0 in G91: straight up to the second reference, 40.
    assert_eq!(at(310), vec![(110.0, 30.0, 40.0)]);
    // N370-N400: holes from the G92 origin at X10 Y10 (G54): X30 → 40, Y30 → 40.
    assert_eq!(at(380)[0], (40.0, 10.0, -163.52));
    assert_eq!(at(390)[0], (40.0, 40.0, -163.52));
    // N460 G28 X0 Y0 (G91): home in X and Y; the program ends there.
    assert_eq!(e.last().map(|l| (l.1, l.2, l.3)), Some((0.0, 0.0, 0.0)));
    assert_eq!(var(&mut it, 100), Some(-130.05), "#5043 at N170");
    let coolant: Vec<(bool, bool)> = segs
        .iter()
        .filter_map(|s| match s.kind {
            SegmentKind::Coolant { mist, flood } => Some((mist, flood)),
            _ => None,
        })
        .collect();
    assert_eq!(
        coolant,
        vec![(false, true), (false, false), (true, false), (false, false)]
    );
}

/// Regression (review f1): a G91 canned cycle after `G91 G28 Z0` in G43 drilled 180 mm too
/// high: its R level (a distance from the initial level, the reference position) lacked the
/// offset vector that G28 took out, while the drilling moves counted it as restored. Now the
/// R level carries the vector as a `G91 G0 Z-5` from there does; G98 returns to where the
/// cycle started (the reference position).
#[test]
fn g91_cycle_after_g28_z_drills_with_the_offset_vector() {
    // G43 H1 (-180), G99: R at 0 - 180 - 5, bottom 10 below, return to R.
    let (segs, mut it) = run(concat!(
        "G90 G0 X0 Y0 Z0\nG43 H1 Z10\nG91 G28 Z0\n",
        "G91 G99 G81 X10 R-5 Z-10 F100\n",
        "X10\n", // a second hole in the same cycle: the same levels
        "G80\n#100=#5003\n#101=#5043\n#102=#5023\n",
        "G91 Z1\n",
    ));
    assert_eq!(
        ends(&segs),
        vec![
            (1, 0.0, 0.0, 0.0),
            (2, 0.0, 0.0, -170.0),
            (3, 0.0, 0.0, 0.0),
            (4, 10.0, 0.0, 0.0),
            (4, 10.0, 0.0, -185.0), // R
            (4, 10.0, 0.0, -195.0), // bottom
            (4, 10.0, 0.0, -185.0), // G99: back to R
            (5, 20.0, 0.0, -185.0),
            (5, 20.0, 0.0, -195.0),
            (5, 20.0, 0.0, -185.0),
            (10, 20.0, 0.0, -184.0), // the vector is in the position: no second -180
        ]
    );
    assert_eq!(var(&mut it, 100), Some(-5.0), "#5003 at R");
    assert_eq!(var(&mut it, 101), Some(-185.0), "#5043");
    assert_eq!(var(&mut it, 102), Some(-185.0), "#5023");

    // G98: back to the initial level, where the cycle started (the reference position).
    let (segs, mut it) = run(concat!(
        "G90 G0 X0 Y0 Z0\nG43 H1 Z10\nG91 G28 Z0\n",
        "G91 G98 G81 X10 R-5 Z-10 F100\n",
        "G80\n#100=#5003\n#101=#5043\n",
    ));
    let z: Vec<f64> = ends(&segs)[3..].iter().map(|e| e.3).collect();
    assert_eq!(z, vec![0.0, -185.0, -195.0, 0.0]);
    assert_eq!(
        var(&mut it, 100),
        Some(180.0),
        "#5003: the reference, offset restored"
    );
    assert_eq!(var(&mut it, 101), Some(0.0), "#5043");

    // G44 with a positive vector (H5 = 20 → -20 on Z).
    let (segs, mut it) = run(concat!(
        "G10 L10 P5 R20\nG90 G0 X0 Y0 Z0\nG44 H5 Z10\nG91 G28 Z0\n",
        "G91 G99 G81 X10 R-5 Z-10 F100\n",
        "G80\n#100=#5003\n#101=#5043\n#102=#5083\n",
    ));
    let z: Vec<f64> = ends(&segs)[2..].iter().map(|e| e.3).collect();
    assert_eq!(z, vec![0.0, 0.0, -25.0, -35.0, -25.0]);
    assert_eq!(var(&mut it, 100), Some(-5.0), "#5003 at R");
    assert_eq!(var(&mut it, 101), Some(-25.0), "#5043 at R");
    assert_eq!(var(&mut it, 102), Some(-20.0), "#5083");
}

/// A G90 cycle after `G91 G28 Z0` takes R and Z as work coordinates with the offset (G43 and
/// G44); G98 returns to the reference position where the cycle started.
#[test]
fn g90_cycle_after_g28_z_drills_with_the_offset_vector() {
    let (segs, mut it) = run(concat!(
        "G90 G0 X0 Y0 Z0\nG43 H1 Z10\nG91 G28 Z0\n",
        "G90 G99 G81 X10 R2 Z-5 F100\n",
        "G80\n#100=#5003\n#101=#5043\n",
    ));
    let z: Vec<f64> = ends(&segs)[3..].iter().map(|e| e.3).collect();
    assert_eq!(z, vec![0.0, -178.0, -185.0, -178.0]);
    assert_eq!(var(&mut it, 100), Some(2.0), "#5003 at R");
    assert_eq!(var(&mut it, 101), Some(-178.0), "#5043 at R");

    let (segs, mut it) = run(concat!(
        "G10 L10 P5 R20\nG90 G0 X0 Y0 Z0\nG44 H5 Z10\nG91 G28 Z0\n",
        "G90 G98 G81 X10 R2 Z-5 F100\n",
        "G80\n#100=#5003\n#101=#5043\n",
    ));
    let z: Vec<f64> = ends(&segs)[3..].iter().map(|e| e.3).collect();
    assert_eq!(z, vec![0.0, -18.0, -25.0, 0.0]);
    assert_eq!(
        var(&mut it, 100),
        Some(20.0),
        "#5003 at the reference, offset restored"
    );
    assert_eq!(var(&mut it, 101), Some(0.0), "#5043");
}
