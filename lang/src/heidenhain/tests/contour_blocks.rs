//! CR, CT, RND, CHF and Q parameters: the ISO each gives, computed by hand, and the input
//! read as errors.

use super::translate_for;

fn read(lines: &[&str]) -> Vec<String> {
    let mut all = vec!["0 BEGIN PGM C MM"];
    all.extend(lines);
    let mut out = translate_for(None, &all).unwrap();
    out.remove(0);
    // The first block carries the program's modal words: not what these tests look at.
    out.iter()
        .map(|l| l.replace("G21 G90 G90.1 G17 ", ""))
        .collect()
}

fn error(lines: &[&str]) -> String {
    let mut all = vec!["0 BEGIN PGM C MM"];
    all.extend(lines);
    translate_for(None, &all).unwrap_err()
}

/// The numbers after `letter` in an ISO block.
fn word(block: &str, letter: char) -> f64 {
    block
        .split_whitespace()
        .find_map(|w| w.strip_prefix(letter))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no {letter} in {block}"))
}

#[test]
fn rnd_rounds_a_square_corner_with_an_arc_tangent_to_both_legs() {
    let out = read(&[
        "1 L X+0 Y+0 R0 FMAX",
        "2 L X+20 Y+0 F100",
        "3 RND R5",
        "4 L X+20 Y+20",
    ]);
    assert_eq!(
        out,
        [
            "G0 G40 X0. Y0.",
            "G1 X15. Y0. F100.",
            "G3 X20. Y5. I15. J5.",
            "G1 X20. Y20.",
        ]
    );
}

#[test]
fn rnd_on_a_right_turn_at_any_angle_is_tangent_to_both_legs() {
    // From (0,0) to (30,0), then down-right at 60° below: a right (clockwise) turn.
    let out = read(&[
        "1 L X+0 Y+0 R0 FMAX",
        "2 L X+30 Y+0 F100",
        "3 RND R4 F50",
        "4 L X+40 Y-17.3205080757",
        "5 L X+60",
    ]);
    let (arc, next) = (&out[2], &out[3]);
    assert!(arc.starts_with("G2 "), "{arc}");
    let (t1x, t1y) = (word(&out[1], 'X'), word(&out[1], 'Y'));
    let (t2x, t2y) = (word(arc, 'X'), word(arc, 'Y'));
    let (cx, cy) = (word(arc, 'I'), word(arc, 'J'));
    // The radius from both tangent points, the centre at r from both legs.
    assert!(((t1x - cx).hypot(t1y - cy) - 4.0).abs() < 1e-9);
    assert!(((t2x - cx).hypot(t2y - cy) - 4.0).abs() < 1e-9);
    assert!((t1y - 0.0).abs() < 1e-12 && (cy + 4.0).abs() < 1e-9);
    let (ux, uy) = (0.5, -(3f64.sqrt()) / 2.0);
    let from_leg2 = ((cx - 30.0) * uy - (cy - 0.0) * ux).abs();
    assert!((from_leg2 - 4.0).abs() < 1e-9, "{from_leg2}");
    // tan(60°/2)·4 off each leg; the arc's F only in its block.
    let cut = 4.0 * (30f64.to_radians()).tan();
    assert!((t1x - (30.0 - cut)).abs() < 1e-9, "{t1x}");
    assert!(arc.ends_with("F50."), "{arc}");
    assert!(next.ends_with("F100."), "{next}");
}

#[test]
fn chf_cuts_the_corner_by_its_length_on_both_legs() {
    let out = read(&[
        "1 L X+0 Y+0 R0 FMAX",
        "2 L X+20 Y+0 F100",
        "3 CHF 5",
        "4 L X+20 Y+20",
    ]);
    assert_eq!(
        out[1..],
        ["G1 X15. Y0. F100.", "G1 X20. Y5.", "G1 X20. Y20."]
    );
}

#[test]
fn rnd_and_chf_chain_along_a_contour() {
    let out = read(&[
        "1 L X+0 Y+0 R0 FMAX",
        "2 L X+20 F100",
        "3 RND R2",
        "4 L Y+20 ; up",
        "5 CHF 3",
        "6 L X+0",
    ]);
    assert_eq!(
        out[1..],
        [
            "G1 X18. Y0. F100.",
            "G3 X20. Y2. I18. J2.",
            "G1 X20. Y17. (up)",
            "G1 X17. Y20.",
            "G1 X0.",
        ]
    );
}

#[test]
fn rnd_or_chf_where_it_cannot_be_is_an_error_naming_what_was_expected() {
    for (lines, why) in [
        (
            &["1 TOOL CALL 1 Z S1000", "2 RND R5", "3 L X+5 Y+5"][..],
            "RND after a block that is not a straight L",
        ),
        (
            &[
                "1 L X+0 Y+0 FMAX",
                "2 CC X+0 Y+5",
                "3 C X+5 Y+5 DR+",
                "4 CHF 1",
                "5 L X+9",
            ],
            "CHF after a block that is not a straight L",
        ),
        (
            &["1 L X+0 Y+0 FMAX", "2 L X+20 F100", "3 RND R30", "4 L Y+20"],
            "more than the legs have",
        ),
        (
            &[
                "1 L X+0 Y+0 FMAX",
                "2 L X+20 F100",
                "3 RND R3",
                "4 CC X+20 Y+5",
                "5 C Y+10 DR+",
            ],
            "needs a straight L block after it",
        ),
        (
            &["1 L X+0 Y+0 FMAX", "2 L X+20 F100", "3 RND R3", "4 L X+30"],
            "does not turn",
        ),
        (&["1 L X+20 F100", "2 CHF 2", "3 L Y+9"], "known X and Y"),
    ] {
        let e = error(lines);
        assert!(e.contains(why), "{lines:?}: {e}");
    }
}

#[test]
fn cr_is_the_short_arc_with_r_plus_and_the_long_one_with_r_minus() {
    let h = 75f64.sqrt();
    for (r, dr, g, cy) in [
        ("R+5", "DR+", "G3", 0.0),
        ("R+10", "DR-", "G2", -h),
        ("R-10", "DR-", "G2", h),
        ("R+10", "DR+", "G3", h),
        ("R-10", "DR+", "G3", -h),
    ] {
        let cr = format!("2 CR X+10 Y+0 {r} {dr} F200");
        let out = read(&["1 L X+0 Y+0 R0 FMAX", &cr]);
        let b = &out[1];
        assert!(b.starts_with(g) && b.contains("X10. Y0."), "{b}");
        assert!((word(b, 'I') - 5.0).abs() < 1e-9, "{b}");
        assert!((word(b, 'J') - cy).abs() < 1e-9, "{r} {dr}: {b}");
    }
}

#[test]
fn cr_radius_smaller_than_half_the_chord_is_an_error() {
    let e = error(&["1 L X+0 Y+0 FMAX", "2 CR X+10 Y+0 R+4 DR+"]);
    assert!(e.contains("smaller than half the chord"), "{e}");
    let e = error(&["1 L X+0 Y+0 FMAX", "2 CR X+10 Y+0 DR+"]);
    assert!(e.contains("needs its radius"), "{e}");
}

#[test]
fn ct_is_tangent_to_the_block_before_it() {
    let out = read(&[
        "1 L X+0 Y+0 R0 FMAX",
        "2 L X+10 F100",
        "3 CT X+20 Y+10",
        "4 CT X+30 Y+0",
    ]);
    // A quarter turn left about (10,10), then on (left ends going +Y) to the right about
    // (30,10): centre on the normal at (20,10), as far from (30,0) as from (20,10).
    assert_eq!(out[2], "G3 X20. Y10. I10. J10.");
    assert_eq!(out[3], "G2 X30. Y0. I30. J10.");
}

#[test]
fn ct_without_a_direction_before_it_is_an_error() {
    for lines in [
        &["1 L X+0 Y+0 Z+5 FMAX", "2 CT X+10 Y+10"][..],
        &[
            "1 L X+0 Y+0 FMAX",
            "2 L X+5 F100",
            "3 TOOL CALL 2 Z S500",
            "4 CT X+9 Y+9",
        ],
        &[
            "1 L X+0 Y+0 FMAX",
            "2 L X+5 F100",
            "3 L Z-2",
            "4 CT X+9 Y+9",
        ],
    ] {
        let e = error(lines);
        assert!(e.contains("CT with no previous contour direction"), "{e}");
    }
    let e = error(&["1 L X+0 Y+0 FMAX", "2 L X+5 F100", "3 CT X+9 Y+0"]);
    assert!(e.contains("straight line"), "{e}");
}

#[test]
fn q_parameters_are_values_in_the_blocks_after_them() {
    let out = read(&[
        "1 Q1 = 5",
        "2 FN 0: Q2 = +10",
        "3 FN 1: Q3 = +Q1 + +Q2",
        "4 FN 2: Q4 = +Q3 - +20",
        "5 FN 3: Q5 = +Q1 * -2",
        "6 FN 4: Q6 = +Q2 DIV +4",
        "7 Q7 = (Q1 + Q2) * 2 / 3 ; formula",
        "8 L X+Q3 Y-Q4 Z+Q6 R0 FMAX",
        "9 L X-Q5 Y+Q7 F+Q2",
    ]);
    assert_eq!(out[7], "G0 G40 X15. Y5. Z2.5");
    assert_eq!(out[8], "G1 X10. Y10. F10.");
    assert!(out[..6].iter().all(|l| l.is_empty()), "{out:?}");
}

#[test]
fn q_parameters_feed_the_cycles_and_the_contour_blocks() {
    let out = read(&[
        "1 Q10 = 4",
        "2 L X+0 Y+0 R0 FMAX",
        "3 L X+20 F100",
        "4 RND R+Q10",
        "5 L Y+20",
    ]);
    assert_eq!(out[2..4], ["G1 X16. Y0. F100.", "G3 X20. Y4. I16. J4."]);
}

#[test]
fn q_parameters_outside_what_is_read_are_errors() {
    for (line, why) in [
        ("1 FN 4: Q1 = +1 DIV +0", "division by zero"),
        ("1 Q2000 = 1", "not a Q parameter"),
        ("1 FN 9: IF +1 EQU +1 GOTO LBL 2", "FN 9 is not read"),
        ("1 Q1 = 2 +", "expected a number"),
        ("1 FN 1: Q1 = +1 * +2", "expected Qn = a + b"),
    ] {
        let e = error(&[line]);
        assert!(e.contains(why), "{line}: {e}");
    }
}

#[test]
fn the_lines_ahead_come_from_the_buffer_or_are_read_and_sought_back() {
    use std::io::{BufRead, BufReader, Cursor, Seek};
    let text = (0..20)
        .map(|i| format!("{i} L X+{i}\n"))
        .collect::<String>();
    // A buffer that holds every line ahead, and one (16 bytes) that holds one at most.
    for capacity in [1 << 16, 16] {
        let mut input = BufReader::with_capacity(capacity, Cursor::new(text.clone().into_bytes()));
        let mut first = String::new();
        input.read_line(&mut first).unwrap();
        let at = first.len() as u64;
        let ahead = super::super::peek_lines(&mut input, at, 1 << 20).unwrap();
        assert_eq!(ahead.len(), super::super::AHEAD_LINES);
        assert_eq!(ahead[0], "1 L X+1");
        assert_eq!(ahead[7], "8 L X+8");
        // The reader is where it was: the next line read is line 1.
        assert_eq!(input.stream_position().unwrap(), at);
        let mut next = String::new();
        input.read_line(&mut next).unwrap();
        assert_eq!(next, "1 L X+1\n");
    }
    // At the end of the file: what there is.
    let mut input = Cursor::new(b"0 L X+0\n1 RND R2".to_vec());
    let mut first = String::new();
    input.read_line(&mut first).unwrap();
    let ahead = super::super::peek_lines(&mut input, 8, 1 << 20).unwrap();
    assert_eq!(ahead, ["1 RND R2"]);
}

#[test]
fn lp_is_the_line_to_the_point_its_polar_radius_and_angle_give_about_the_cc() {
    let out = read(&[
        "1 CC X+10 Y+10",
        "2 LP PR+5 PA+0 R0 FMAX",
        "3 LP PA+90 F100",
        "4 LP IPA+90",
        "5 LP IPA+90",
        "6 LP IPR+5",
        "7 RND R1",
        "8 L X+30",
    ]);
    assert_eq!(
        out[1..7],
        [
            "G0 G40 X15. Y10.",
            "G1 X10. Y15. F100.",
            "G1 X5. Y10.",
            "G1 X10. Y5.",
            "G1 X10. Y1.",
            "G3 X11. Y0. I11. J1.",
        ]
    );
    for (lines, why) in [
        (&["1 LP PR+5 PA+0"][..], "LP without a CC"),
        (&["1 CC X+0 Y+0", "2 LP PA+30"], "LP needs PR and PA"),
        (
            &["1 CC X+0 Y+0", "2 LP PR-2 PA+30"],
            "negative polar radius",
        ),
    ] {
        let e = error(lines);
        assert!(e.contains(why), "{lines:?}: {e}");
    }
}

#[test]
fn a_q_parameter_with_no_value_yet_is_an_alarm_when_its_block_runs() {
    // (Not an error when read: the load pass reads the lines in file order.)
    for line in ["1 L X+Q1 F100", "1 Q2 = Q3 + 1", "1 FN 1: Q2 = +Q4 + +1"] {
        let out = read(&[line]);
        assert!(out[0].starts_with("#3000=1 (Q"), "{line}: {out:?}");
        assert!(out[0].contains("HAS NO VALUE"), "{line}: {out:?}");
    }
}
