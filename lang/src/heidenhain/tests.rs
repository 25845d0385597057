use super::*;

fn translate(lines: &[&str]) -> Result<Vec<String>, String> {
    translate_for(None, lines)
}

#[test]
fn a_program_translates_line_for_line() {
    let out = translate(&[
        "0 BEGIN PGM JOB MM",
        "1 BLK FORM 0.1 Z X+0 Y+0 Z-20",
        "2 TOOL CALL 3 Z S800",
        "3 M3",
        "4 L X+10 Y-5 R0 FMAX",
        "5 L Z+2 FMAX",
        "6 L Z-1,5 F200 ; plunge",
        "7 CC X+0 Y-5",
        "8 C X-10 Y-5 DR+ F400",
        "9 CYCL DEF 9.0 DWELL TIME",
        "10 CYCL DEF 9.1 DWELL 0.5",
        "11 L X+10 RL",
        "12 * - finish",
        "13 M30",
        "14 END PGM JOB MM",
    ])
    .unwrap();
    assert_eq!(
        out,
        [
            "(dialect: fanuc) (BEGIN PGM JOB)",
            "",
            "G21 G90 G90.1 G17 T3 M6 S800",
            "M3",
            "G0 G40 X10. Y-5.",
            "G0 G43 H3 Z2.",
            "G1 Z-1.5 F200. (plunge)",
            "",
            "G3 X-10. Y-5. I0. J-5. F400.",
            "",
            "G4 X0.5",
            "G1 G41 D3 X10.",
            "(- finish)",
            "M30",
            "",
        ]
    );
}

#[test]
fn what_is_outside_the_subset_is_an_error() {
    for (line, why) in [
        ("L IX+10 F100", "IX+10 is not a word"),
        ("C X+1 Y+1 DR+", "C without a CC"),
        (
            "CYCL DEF 203 UNIVERSAL DRILLING",
            "cycle 203 is not in the subset",
        ),
        ("CALL PGM OTHER", "CALL is not in the Heidenhain subset"),
        ("TOOL CALL 1 X S100", "tool axis Z"),
    ] {
        let e = translate(&["0 BEGIN PGM A MM", line]).unwrap_err();
        assert!(e.contains(why), "{line}: {e}");
    }
}

#[test]
fn heidenhain_by_first_line_or_extension() {
    assert!(is_heidenhain("a.nc", "0 BEGIN PGM A MM"));
    assert!(is_heidenhain("A.H", "L X+1"));
    assert!(!is_heidenhain("a.nc", "G0 X1"));
}

const DRILLING: [&str; 10] = [
    "0 BEGIN PGM JOB MM",
    "1 L X+0 Y+0 Z+20 R0 FMAX",
    "2 CYCL DEF 200 DRILLING",
    "  Q200=+0 ;SET-UP CLEARANCE",
    "  Q201=-7 ;DEPTH",
    "  Q206=+100 ;FEED RATE FOR PLNGNG",
    "  Q202=+7 ;PLUNGING DEPTH",
    "  Q210=+0 ;DWELL TIME AT TOP",
    "  Q203=+2 ;SURFACE COORDINATE",
    "  Q204=+18 ;2ND SET-UP CLEARANCE",
];

#[test]
fn cycle_200_calls_read_as_g81_then_g80_and_the_contour_feed_again() {
    let mut lines = DRILLING.to_vec();
    lines.extend([
        "  Q211=+0.3 ;DWELL TIME AT DEPTH",
        "3 L X+10 Y+10 FMAX M99",
        "4 CYCL CALL",
        "5 L X+5 F300",
        "6 L X+6",
        "7 L X+10 Y+10 FMAX M99",
        "8 L Y+20",
    ]);
    let out = translate(&lines).unwrap();
    assert_eq!(out[11], "G98 G82 X10. Y10. Z-5. R2. P300 F100.");
    assert_eq!(out[12], "G98 G82 X10. Y10. Z-5. R2. P300 F100.");
    assert_eq!(out[13], "G80 G1 X5. F300.");
    assert_eq!(out[14], "G1 X6.");
    // The contour's F300 again after the cycle's F100.
    assert_eq!(out[16], "G80 G1 Y20. F300.");
}

#[test]
fn cycle_200_outside_what_is_read_is_an_error_at_its_line() {
    let call = |extra: &[&str], at: &str| {
        let mut lines = DRILLING.to_vec();
        // (The extra lines after the definition's last Q line: a Q202 there is still in it.)
        lines.push("  Q211=+0 ;DWELL TIME AT DEPTH");
        lines.extend(extra);
        lines.push(at);
        translate(&lines).unwrap_err()
    };
    // Pecking (Q202 less than the depth).
    let e = call(&["  Q202=+2"], "3 L X+1 Y+1 FMAX M99");
    assert!(e.contains("one plunge"), "{e}");
    // G98 semantics need the tool at the 2nd set-up clearance.
    let e = call(&["3 L Z+5 FMAX"], "4 L X+1 Y+1 FMAX M99");
    assert!(e.contains("not at the 2nd set-up clearance (Z20.)"), "{e}");
    // A Q line outside a cycle's definition is a Q parameter's value, not the cycle's.
    assert_eq!(
        translate(&["0 BEGIN PGM JOB MM", "1 Q1=+5"]).unwrap(),
        ["(dialect: fanuc) (BEGIN PGM JOB)", ""]
    );
    assert!(
        translate(&["0 BEGIN PGM JOB MM", "1 L X+1 Y+1 FMAX M99"])
            .unwrap_err()
            .contains("without a CYCL DEF 200")
    );
}

#[test]
fn cycl_def_207_reads_as_a_rigid_tap_at_the_tool_call_speed() {
    let out = translate(&[
        "0 BEGIN PGM TAP MM",
        "1 TOOL CALL Z S500",
        "2 L X+0 Y+0 Z+10 R0 FMAX",
        "3 CYCL DEF 207 RIGID TAPPING NEW",
        "  Q200=+0 ;SET-UP CLEARANCE",
        "  Q201=-19 ;DEPTH",
        "  Q239=+1.5 ;PITCH",
        "  Q203=+3 ;SURFACE COORDINATE",
        "  Q204=+7 ;2ND SET-UP CLEARANCE",
        "4 L X+20 Y+20 FMAX M99",
        "5 L X+60 Y+20 FMAX M99",
        "6 CYCL DEF 207 RIGID TAPPING NEW",
        "  Q200=+0 ;SET-UP CLEARANCE",
        "  Q201=-19 ;DEPTH",
        "  Q239=-1.5 ;PITCH",
        "  Q203=+3 ;SURFACE COORDINATE",
        "  Q204=+0 ;2ND SET-UP CLEARANCE",
        "7 L X+20 Y+60 FMAX M99",
        "8 L Z+50 FMAX",
    ])
    .unwrap();
    assert_eq!(out[9], "G98 M29 G84 X20. Y20. Z-16. R3. F750.");
    assert_eq!(out[10], "G98 M29 G84 X60. Y20. Z-16. R3. F750.");
    assert_eq!(out[17], "G99 M29 G74 X20. Y60. Z-16. R3. F750.");
    assert_eq!(out[18], "G80 G0 Z50.");
}

#[test]
fn cycl_def_207_without_a_speed_is_an_error() {
    let e = translate(&[
        "0 BEGIN PGM TAP MM",
        "1 L X+0 Y+0 Z+3 R0 FMAX",
        "2 CYCL DEF 207 RIGID TAPPING NEW",
        "  Q200=+0",
        "  Q201=-19",
        "  Q239=+1.5",
        "  Q203=+3",
        "  Q204=+0",
        "3 L X+20 Y+20 FMAX M99",
    ])
    .unwrap_err();
    assert!(e.contains("without a spindle speed"), "{e}");
}

#[test]
fn labels_become_sub_programs_and_repeated_sections() {
    let out = translate(&[
        "0 BEGIN PGM JOB MM",
        "1 LBL 5",
        "2 CALL LBL 1",
        "3 CALL LBL 5 REP 2/2",
        "4 M30",
        "5 LBL 1",
        "6 L X+1 F100",
        "7 LBL 0",
        "8 END PGM JOB MM",
    ])
    .unwrap();
    assert_eq!(
        out,
        [
            "(dialect: fanuc) (BEGIN PGM JOB)",
            "WHILE [1 EQ 1] DO1",
            "M98 P1",
            "END1",
            "G21 G90 G90.1 G17 M30",
            "O1",
            "G1 X1. F100.",
            "M99",
            "",
        ]
    );
}

#[test]
fn a_section_runs_once_more_than_its_repeats_in_the_order_it_runs() {
    // The lines as the interpreter reads them: END1 jumps back to the WHILE line, which is
    // read (translated) again; after the last repeat its condition is false.
    let mut t = Translator::default();
    let mut run = |i: usize, l: &str| t.line(i, l).unwrap();
    run(0, "0 BEGIN PGM JOB MM");
    let mut passes = 0;
    loop {
        let head = run(1, "1 LBL 7");
        if head.contains("1 EQ 0") {
            break;
        }
        passes += 1;
        assert_eq!(run(2, "2 CALL LBL 7 REP 2"), "END1");
        assert!(passes < 10);
    }
    assert_eq!(passes, 3);
}

#[test]
fn labels_outside_the_subset_are_errors() {
    for (lines, why) in [
        (
            &["0 BEGIN PGM J MM", "1 LBL 0"][..],
            "LBL 0 outside a sub-program",
        ),
        (
            &["0 BEGIN PGM J MM", "1 CALL LBL 2 REP 3"][..],
            "repeats the program section that LBL 2 opened",
        ),
        (
            &["0 BEGIN PGM J MM", "1 LBL \"PART\""][..],
            "numbered labels",
        ),
        (
            &["0 BEGIN PGM J MM", "1 LBL 1", "2 CALL LBL 1 REP X"][..],
            "expected a count",
        ),
        (
            &[
                "0 BEGIN PGM J MM",
                "1 LBL 1",
                "2 LBL 2",
                "3 LBL 3",
                "4 LBL 4",
            ][..],
            "more than 3 program sections",
        ),
    ] {
        let e = translate(lines).unwrap_err();
        assert!(e.contains(why), "{lines:?}: {e}");
    }
}

const PECKING: [&str; 19] = [
    "0 BEGIN PGM JOB MM",
    "1 L X+0 Y+0 Z+20 R0 FMAX",
    "2 CYCL DEF 205 UNIVERSAL PECKING",
    "  Q200=+0 ;SET-UP CLEARANCE",
    "  Q201=-14 ;DEPTH",
    "  Q206=+100 ;FEED RATE FOR PLNGNG",
    "  Q202=+3 ;PLUNGING DEPTH",
    "  Q203=+2 ;SURFACE COORDINATE",
    "  Q204=+18 ;2ND SET-UP CLEARANCE",
    "  Q212=+0 ;DECREMENT",
    "  Q205=+0 ;MIN. PLUNGING DEPTH",
    "  Q258=+0.5 ;UPPER ADV STOP DIST",
    "  Q259=+0.5 ;LOWER ADV STOP DIST",
    "  Q257=+0 ;DEPTH FOR CHIP BRKNG",
    "  Q256=+0.2 ;DIST FOR CHIP BRKNG",
    "  Q211=+0 ;DWELL TIME AT DEPTH",
    "  Q379=+0 ;STARTING POINT",
    "  Q253=+750 ;F PRE-POSITIONING",
    "3 L X+10 Y+10 FMAX M99",
];

fn translate_for(clearance: Option<f64>, lines: &[&str]) -> Result<Vec<String>, String> {
    let mut t = Translator::for_machine(clearance);
    lines
        .iter()
        .enumerate()
        .map(|(i, l)| {
            // As the stream reader gives them: the lines after an L.
            let ahead: Vec<String> = if looks_ahead(l) {
                lines[i + 1..]
                    .iter()
                    .take(AHEAD_LINES)
                    .map(|l| l.to_string())
                    .collect()
            } else {
                Vec::new()
            };
            t.line_ahead(i, l, &ahead)
        })
        .collect()
}

#[test]
fn cycle_205_is_read_as_g83_with_the_machines_clearance() {
    let out = translate_for(Some(0.5), &PECKING).unwrap();
    assert_eq!(out.last().unwrap(), "G98 G83 X10. Y10. Z-12. R2. Q3. F100.");
}

#[test]
fn cycle_205_read_another_way_than_g83_is_an_error() {
    let e = translate_for(None, &PECKING).unwrap_err();
    assert!(e.contains("G83 clearance is known"), "{e}");
    let e = translate_for(Some(1.0), &PECKING).unwrap_err();
    assert!(
        e.contains("Q258 = Q259 = the machine's G83 clearance"),
        "{e}"
    );
    let mut chip = PECKING;
    chip[13] = "  Q257=+2 ;DEPTH FOR CHIP BRKNG";
    let e = translate_for(Some(0.5), &chip).unwrap_err();
    assert!(e.contains("Q212, Q257, Q211 and Q379 all 0"), "{e}");
    let mut short = PECKING;
    short[6] = "  Q202=+0.3 ;PLUNGING DEPTH";
    let e = translate_for(Some(0.5), &short).unwrap_err();
    assert!(
        e.contains("plunging depth Q202 of at least the clearance"),
        "{e}"
    );
}

#[test]
fn an_inch_programs_feeds_are_in_tenths_of_an_inch_per_minute() {
    let out = translate(&[
        "0 BEGIN PGM JOB INCH",
        "1 L X+1.25 Z-0.1 R0 F59.055",
        "2 CC X+1.25 Y+0.75",
        "3 C X+2 Y+0.75 DR- F120",
    ])
    .unwrap();
    assert_eq!(out[1], "G20 G90 G90.1 G17 G1 G40 X1.25 Z-0.1 F5.9055");
    assert_eq!(out[3], "G2 X2. Y0.75 I1.25 J0.75 F12.");
}

#[test]
fn cycle_7_moves_the_g54_entry_by_the_change_of_the_shift() {
    let out = translate(&[
        "0 BEGIN PGM JOB MM",
        "1 CYCL DEF 7.0 DATUM SHIFT",
        "2 CYCL DEF 7.1 X+50",
        "3 CYCL DEF 7.2 IY+20",
        "4 L X+0 Y+0 R0 FMAX",
        "5 CYCL DEF 7.0 DATUM SHIFT",
        "6 CYCL DEF 7.1 X+10",
        "7 L X+1 FMAX",
    ])
    .unwrap();
    assert_eq!(
        &out[1..],
        [
            "",
            "G91 G10 L2 P1 X50.",
            "G91 G10 L2 P1 Y20.",
            "G21 G90 G90.1 G17 G0 G40 X0. Y0.",
            "",
            "G91 G10 L2 P1 X-40.",
            "G90 G0 X1.",
        ]
    );
    let e = translate(&["0 BEGIN PGM J MM", "1 CYCL DEF 7.1 #5"]).unwrap_err();
    assert!(e.contains("datum shifts along X, Y or Z by a value"), "{e}");
}

#[test]
fn cp_is_the_arc_its_incremental_angle_gives_from_where_the_tool_is() {
    let out = translate(&[
        "0 BEGIN PGM JOB MM",
        "1 L X+10 Y+0 Z+0 R0 FMAX",
        "2 CC X+0 Y+0",
        "3 CP IPA-90 IZ-2 DR- F400",
        "4 CP IPA+360 IZ-1.5 DR+",
    ])
    .unwrap();
    assert!(
        out[3].starts_with("G2 X0.0000000000000006") || out[3].starts_with("G2 X0"),
        "{}",
        out[3]
    );
    assert!(out[3].contains(" Y-10. Z-2. I0. J0. F400."), "{}", out[3]);
    // A whole turn ends exactly where it began.
    assert!(out[4].starts_with("G3 X"), "{}", out[4]);
    assert!(out[4].contains(" Z-3.5 I0. J0."), "{}", out[4]);
    for (line, why) in [
        ("3 CP IPA+90 IZ-2 DR-", "DR+ with a positive IPA"),
        ("3 CP IPA+400 DR+", "up to one turn"),
        ("3 CP PA+90 DR+", "read with IPA"),
        ("3 CP IPA+90 X+1 DR+", "IPA and IZ only"),
    ] {
        let e = translate(&[
            "0 BEGIN PGM J MM",
            "1 L X+1 Y+0 Z+0 FMAX",
            "2 CC X+0 Y+0",
            line,
        ])
        .unwrap_err();
        assert!(e.contains(why), "{line}: {e}");
    }
    let e = translate(&["0 BEGIN PGM J MM", "1 CC X+0 Y+0", "2 CP IPA+90 DR+"]).unwrap_err();
    assert!(e.contains("X, Y and Z known"), "{e}");
}

#[test]
fn a_datum_shift_after_a_cycle_call_cancels_the_cycle_first() {
    let mut lines = DRILLING.to_vec();
    lines.extend([
        "  Q211=+0 ;DWELL TIME AT DEPTH",
        "3 L X+10 Y+10 FMAX M99",
        "11 CYCL DEF 7.0 DATUM SHIFT",
        "12 CYCL DEF 7.1 X+5",
        "13 L X+1 FMAX",
    ]);
    let out = translate(&lines).unwrap();
    let n = out.len();
    assert_eq!(out[n - 2], "G80 G91 G10 L2 P1 X5.");
    assert_eq!(out[n - 1], "G90 G0 X1.");
}

#[test]
fn cycle_201_is_read_as_g85_or_g89_with_the_same_feed_out() {
    let reaming = |q208: &'static str| {
        translate(&[
            "0 BEGIN PGM JOB MM",
            "1 L X+0 Y+0 Z+20 R0 FMAX",
            "2 CYCL DEF 201 REAMING",
            "  Q200=+0 ;SET-UP CLEARANCE",
            "  Q201=-9 ;DEPTH",
            "  Q206=+90 ;FEED RATE FOR PLNGNG",
            "  Q211=+0.5 ;DWELL TIME AT DEPTH",
            q208,
            "  Q203=+1 ;SURFACE COORDINATE",
            "  Q204=+19 ;2ND SET-UP CLEARANCE",
            "3 L X+50 Y+10 FMAX M99",
        ])
    };
    let out = reaming("  Q208=+90 ;RETRACTION FEED RATE").unwrap();
    assert_eq!(out.last().unwrap(), "G98 G89 X50. Y10. Z-8. R1. P500 F90.");
    let e = reaming("  Q208=+500 ;RETRACTION FEED RATE").unwrap_err();
    assert!(e.contains("Q208 equal to Q206"), "{e}");
}

#[cfg(test)]
mod contour_blocks;
