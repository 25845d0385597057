use super::*;

fn translate(lines: &[&str]) -> Result<Vec<String>, String> {
    let mut t = Translator::default();
    lines
        .iter()
        .enumerate()
        .map(|(i, l)| t.line(i, l))
        .collect()
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
        ("CYCL DEF 200 DRILLING", "cycle 200 is not in the subset"),
        ("CALL LBL 1", "CALL is not in the Heidenhain subset"),
        ("TOOL CALL 1 X S100", "tool axis Z"),
        ("L X+Q1", "not a number"),
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
