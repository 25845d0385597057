//! The `linuxcnc` dialect's language: O-word flow, named parameters and their errors and
//! limits (the moves themselves are cross-checked against rs274 in `rs274.rs`).

use cnc402_config::MachineConfig;
use cnc402_interp::run_program;
use cnc402_lang::SourceFile;
use cnc402_motion::segment::{Segment, SegmentKind};

#[allow(clippy::result_large_err)]
fn run(text: &str) -> Result<Vec<Segment>, cnc402_lang::NcError> {
    let cfg = MachineConfig::default_machine();
    run_program(
        &cfg,
        &SourceFile::new("t.ngc", format!("(dialect: linuxcnc)\n{text}")),
    )
}

fn ends(text: &str) -> Vec<[f64; 3]> {
    run(text)
        .unwrap_or_else(|e| panic!("{e}"))
        .iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Rapid { end } | SegmentKind::Linear { end, .. } => {
                Some([end[0], end[1], end[2]])
            }
            _ => None,
        })
        .collect()
}

fn err(text: &str) -> (u32, u32, String) {
    let e = run(text).unwrap_err();
    (e.line, e.col, e.message.clone())
}

#[test]
fn locals_are_per_call_and_value_is_returned() {
    let p = "o1 sub\n#1 = [#1 * 2]\n#<t> = 7\no1 endsub [#1 + 1]\n#1 = 5\n#<t> = 1\no1 call [10]\nG0 X#<_value> Y#1 Z#<t>\nM2\n";
    assert_eq!(ends(p), vec![[21.0, 5.0, 1.0]]);
}

#[test]
fn recursion_is_bounded_by_the_call_depth() {
    let (line, _, m) = err("o<r> sub\no<r> call\no<r> endsub\no<r> call\nM2\n");
    assert_eq!(line, 3, "{m}");
    assert!(m.contains("nested deeper"), "{m}");
}

#[test]
fn a_loop_without_motion_is_a_runaway() {
    let (_, _, m) = err("o1 while [1]\n#1 = [#1 + 1]\no1 endwhile\n");
    assert!(m.contains("runaway"), "{m}");
    let (_, _, m) = err("o2 do\no2 while [1]\n");
    assert!(m.contains("runaway"), "{m}");
}

#[test]
fn an_unknown_named_parameter_is_an_error_at_its_column() {
    let (line, col, m) = err("G0 X1\nG0 X[1 + #<nope>]\n");
    assert_eq!((line, col), (3, 10), "{m}");
    assert_eq!(m, "named parameter #<nope> is not defined");
    let (_, _, m) = err("#<_x> = 1\n");
    assert!(m.contains("read-only"), "{m}");
}

#[test]
fn predefined_parameters_and_numbered_ones_read_as_linuxcnc() {
    // Vacant #5 reads 0 (LinuxCNC has no vacant), #5420.. is the current position.
    assert_eq!(
        ends("G21 G0 X3 Y4\nG0 X[#<_x> + #5] Y[#5421 + #<_metric>] Z#<_imperial>\n"),
        vec![[3.0, 4.0, 0.0], [3.0, 5.0, 0.0]]
    );
}

#[test]
fn broken_blocks_are_errors_where_they_run() {
    // The if runs first, and its end is missing.
    let (line, _, m) = err("o1 if [1]\nG0 X1\no2 endif\n");
    assert_eq!((line, m.as_str()), (2, "o1 if has no end"));
    let (line, _, m) = err("o1 while [0]\no2 if [1]\no1 endwhile\n");
    assert_eq!(line, 2, "{m}");
    let (line, _, m) = err("o2 endif\n");
    assert_eq!((line, m.as_str()), (2, "o2 endif without o2 if before it"));
    let (_, _, m) = err("o1 while [1]\no1 if [1]\no1 endif\no1 endwhile\n");
    assert!(m.contains("duplicate O-word label"), "{m}");
    let (_, _, m) = err("o9 call\n");
    assert!(m.contains("not defined"), "{m}");
    let (_, _, m) = err("o1 break\n");
    assert!(m.contains("not inside"), "{m}");
    let (line, _, m) = err("o1 repeat [2]\nG0 X1\n");
    assert_eq!(line, 2, "{m}");
    assert!(m.contains("has no end"), "{m}");
}

#[test]
fn repeat_break_and_continue() {
    let p = "#1 = 0\no1 repeat [5]\n#1 = [#1 + 1]\no2 if [#1 EQ 2]\no1 continue\no2 endif\no3 if [#1 EQ 4]\no1 break\no3 endif\nG0 X#1\no1 endrepeat\nM2\n";
    assert_eq!(ends(p), vec![[1.0, 0.0, 0.0], [3.0, 0.0, 0.0]]);
}

#[test]
fn fanuc_keeps_o_as_a_program_number() {
    let cfg = MachineConfig::default_machine();
    let segs = run_program(&cfg, &SourceFile::new("t.nc", "O100\nG0 X1\n")).unwrap();
    assert_eq!(segs.len(), 1);
}

fn dwells(text: &str) -> Vec<f64> {
    run(text)
        .unwrap_or_else(|e| panic!("{e}"))
        .iter()
        .filter_map(|s| match s.kind {
            SegmentKind::Dwell { seconds } => Some(seconds),
            _ => None,
        })
        .collect()
}

#[test]
fn dwell_p_is_seconds_in_g4_and_in_cycles() {
    assert_eq!(dwells("G4 P1.5\nG4 P[0.25 * 2]\n"), vec![1.5, 0.5]);
    assert_eq!(
        dwells("G0 Z10\nG98 G82 X1 Y1 Z-2 R2 P0.75 F100\nG80\n"),
        vec![0.75]
    );
    // Fanuc: P is milliseconds.
    let cfg = MachineConfig::default_machine();
    let segs = run_program(&cfg, &SourceFile::new("t.nc", "G4 P1500\n")).unwrap();
    assert_eq!(segs[0].kind, SegmentKind::Dwell { seconds: 1.5 });
}

#[test]
fn polar_words_and_their_errors() {
    assert_eq!(
        ends("G0 @2 ^90\n")[0].map(|v| (v * 1e9).round() / 1e9),
        [0.0, 2.0, 0.0]
    );
    let (line, col, m) = err("G0 @2 X1\n");
    assert_eq!((line, col), (2, 7), "{m}");
    let (_, _, m) = err("G91 G0 ^90\n");
    assert!(m.contains("from the origin"), "{m}");
}

#[test]
fn g92_dot_codes_are_linuxcnc_only() {
    assert_eq!(
        ends("G0 X10\nG92 X0\nG0 X1\nG92.2\nG0 X1\nG92.3\nG0 X0\nG92.1\nG0 X3\nG92.3\nG0 X4\n"),
        vec![
            [10.0, 0.0, 0.0],
            [11.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [10.0, 0.0, 0.0],
            [3.0, 0.0, 0.0],
            [4.0, 0.0, 0.0]
        ]
    );
    let cfg = MachineConfig::default_machine();
    let e = run_program(&cfg, &SourceFile::new("t.nc", "G92.1\n")).unwrap_err();
    assert!(e.message.contains("not supported"), "{e}");
}

#[test]
fn offsets_as_linuxcnc_sets_them() {
    // G10 L2 sets in G91 too; L20 makes the current point read as given; P0 is the active
    // system.
    assert_eq!(
        ends("G0 X10\nG91 G10 L2 P1 X5\nG90 G0 X0\nG10 L20 P1 X1\nG0 X0\nG10 L2 P0 X0\nG0 X2\n"),
        vec![
            [10.0, 0.0, 0.0],
            [5.0, 0.0, 0.0],
            [4.0, 0.0, 0.0],
            [2.0, 0.0, 0.0]
        ]
    );
    let mut cfg = MachineConfig::default_machine();
    cfg.tool_offsets[0].length = -100.0;
    let z = |text: &str| -> Vec<f64> {
        run_program(&cfg, &SourceFile::new("t.ngc", text.to_string()))
            .unwrap()
            .iter()
            .filter_map(|s| match &s.kind {
                SegmentKind::Rapid { end } => Some(end[2]),
                _ => None,
            })
            .collect()
    };
    // LinuxCNC: G43 without Z moves nothing; the next Z move carries the offset.
    assert_eq!(
        z("(dialect: linuxcnc)\nG43 H1\nG0 X1\nG0 Z5\n"),
        vec![0.0, -95.0]
    );
    // Fanuc: the G43 block moves Z by the offset.
    assert_eq!(z("G43 H1\nG0 X1\nG0 Z5\n"), vec![-100.0, -100.0, -95.0]);
}

#[test]
fn a_named_subroutine_comes_from_its_file_next_to_the_program() {
    let dir = std::env::temp_dir().join(format!("cnc402-lc-sub-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("peck.ngc"),
        "o<peck> sub\nG0 X#1\no<peck> endsub [#1 * 2]\nM2\n",
    )
    .unwrap();
    let main = dir.join("main.ngc");
    let text = "(dialect: linuxcnc)\no<peck> call [3]\no<peck> call [4]\nG0 Y#<_value>\nM2\n";
    let cfg = MachineConfig::default_machine();
    let src = SourceFile::new(main.display().to_string(), text);
    let segs = cnc402_interp::host_fs::run_program(&cfg, &src).unwrap();
    let ends: Vec<[f64; 2]> = segs
        .iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Rapid { end } => Some([end[0], end[1]]),
            _ => None,
        })
        .collect();
    assert_eq!(ends, vec![[3.0, 0.0], [4.0, 0.0], [4.0, 8.0]]);
    let src = SourceFile::new(
        main.display().to_string(),
        "(dialect: linuxcnc)\no<nope> call\n",
    );
    let e = cnc402_interp::host_fs::run_program(&cfg, &src).unwrap_err();
    assert!(e.message.contains("nor in a file nope.ngc"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn expressions_have_linuxcnc_precedence_and_operators() {
    // AND/OR/XOR are logical and lowest; ** is power; MOD is never negative.
    let p = "#1 = [1 GT 0 AND 2 LT 5]\n#2 = [2 ** 3 + 1]\n#3 = [-10 MOD 3]\n#4 = [2 AND 1]\n#5 = [0 OR 3 XOR 1]\nG0 X#1 Y#2 Z#3\nG0 X#4 Y#5\n";
    assert_eq!(ends(p), vec![[1.0, 9.0, 2.0], [1.0, 0.0, 2.0]]);
    let (_, _, m) = err("#1 = [2 **]\n");
    assert!(m.contains("missing operand"), "{m}");
}

/// An `M99` that leaves a LinuxCNC subroutine drops its named locals with its frame (they
/// piled up, one scope per call, when only `endsub` dropped them).
#[test]
fn m99_out_of_a_subroutine_drops_its_named_locals() {
    let p = "o1 sub\n#<t> = 5\nM99\no1 endsub\n#<t> = 1\no1 call\nG0 X#<t>\nM2\n";
    assert_eq!(ends(p), vec![[1.0, 0.0, 0.0]]);
}

#[test]
fn g4_p_with_a_move_in_one_block_is_not_address_x_given_twice() {
    let segs = run("G0 X0 Y0 Z0\nG04 P.001 G0 X1.0 Y1.0\nM2\n").unwrap_or_else(|e| panic!("{e}"));
    let kinds: Vec<_> = segs
        .iter()
        .filter(|s| {
            matches!(
                s.kind,
                SegmentKind::Dwell { .. } | SegmentKind::Rapid { .. }
            )
        })
        .map(|s| s.kind.clone())
        .collect();
    assert_eq!(kinds[1], SegmentKind::Dwell { seconds: 0.001 });
    assert!(matches!(kinds[2], SegmentKind::Rapid { end } if end[0] == 1.0 && end[1] == 1.0));
    // A G4 with axis words and no motion G moves in the modal motion mode.
    assert_eq!(
        ends("G1 X0 Y0 Z1 F100\nG4 P0.5 X2\nM2\n"),
        vec![[0.0, 0.0, 1.0], [2.0, 0.0, 1.0]]
    );
}

#[test]
fn hole_circle_g91_polar_cycle_repeats_turn_about_the_origin() {
    let p = "G0 X15 Y0 Z0\nG91 G81 R1 Z-5 ^60 L6 F100\nG80\nM2\n";
    let holes: Vec<[f64; 2]> = ends(p)
        .iter()
        .filter(|e| (e[2] - 1.0).abs() < 1e-9 && (e[0].hypot(e[1]) - 15.0).abs() < 1e-6)
        .map(|e| [e[0], e[1]])
        .collect();
    let mut angles: Vec<i64> = holes
        .iter()
        .map(|h| h[1].atan2(h[0]).to_degrees().round() as i64)
        .collect();
    angles.dedup();
    assert_eq!(angles, vec![0, 60, 120, 180, -120, -60, 0]);
}

#[test]
fn debug_switch_5599_is_writable() {
    assert_eq!(
        ends("G0 X#5599\n#5599=0\nG0 Y[#5599 + 2]\nM2\n"),
        vec![[1.0, 0.0, 0.0], [1.0, 2.0, 0.0]]
    );
}

#[test]
fn g41_without_d_takes_the_loaded_tools_radius() {
    let mut cfg = MachineConfig::default_machine();
    cfg.tool_offsets[1].radius = 2.0;
    let prog = |comp: &str| {
        let text = format!(
            "(dialect: linuxcnc)\nT2 M6\nG0 X0 Y-10 Z0\n{comp} G1 X0 Y0 F100\nX20\nY20\nG40 G0 X30 Y30\nM2\n"
        );
        run_program(&cfg, &SourceFile::new("t.ngc", text))
            .unwrap_or_else(|e| panic!("{e}"))
            .iter()
            .filter_map(|s| match &s.kind {
                SegmentKind::Rapid { end } | SegmentKind::Linear { end, .. } => Some(*end),
                _ => None,
            })
            .collect::<Vec<_>>()
    };
    let without_d = prog("G41");
    assert_eq!(without_d, prog("G41 D2"));
    assert!(without_d.iter().any(|e| (e[0] + 2.0).abs() < 1e-9));
    // Fanuc still wants the D.
    let fanuc = run_program(
        &cfg,
        &SourceFile::new("t.nc", "T2 M6\nG41 G1 X0 Y0 F100\nM2\n"),
    );
    assert!(fanuc.unwrap_err().message.contains("without D"));
}

#[test]
fn g8_lathe_radius_mode_is_a_no_op_and_g7_is_refused() {
    assert_eq!(
        ends("G8\nG0 X1\nG8 G1 X2 F100\nM2\n"),
        vec![[1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]
    );
    let (line, col, m) = err("G0 X1\nG7\nM2\n");
    assert_eq!((line, col), (3, 1));
    assert!(m.contains("G7 (lathe diameter mode)"), "{m}");
}

#[test]
fn else_if_in_two_words_and_return_labelled_by_an_if_of_the_sub() {
    let p = "o1000 sub\no1010 if [#1 GT 0]\no1010 return [123]\no1010 endif\no1000 endsub [7]\no1000 call [1]\nG0 X#<_value>\no1000 call [0]\nG0 Y#<_value>\n#2 = 2\no<100> if [#2 EQ 1]\nG0 Z1\no<100> else if [#2 EQ 2]\nG0 Z2\no<100> end if\nM2\n";
    assert_eq!(
        ends(p),
        vec![[123.0, 0.0, 0.0], [123.0, 7.0, 0.0], [123.0, 7.0, 2.0]]
    );
    // A label that is neither the sub's nor one of its constructs' stays an error.
    let (line, _, m) = err("o1 sub\no2 return\no1 endsub\no1 call\nM2\n");
    assert_eq!(line, 3);
    assert!(m.contains("not inside a sub labelled o2"), "{m}");
}

#[test]
fn several_parameter_assignments_on_one_line_evaluate_all_values_first() {
    let p = "#101=1 #102=2\n#101=#102 #102=#101 #<a>=[#101+#102]\nG0 X#101 Y#102 Z#<a>\nM2\n";
    assert_eq!(ends(p), vec![[2.0, 1.0, 3.0]]);
    let (line, col, m) = err("#1=1 #2=\nM2\n");
    assert_eq!((line, col), (2, 9));
    assert!(m.contains("missing expression"), "{m}");
}

#[test]
fn global_parameters_without_a_fanuc_meaning_are_writable() {
    // #61 and #4100 mean nothing writable to Fanuc; LinuxCNC's #31-#5000 are globals.
    let p = "#61=2 #4100=3\no1 sub\n#61=[#61+1]\no1 endsub\no1 call\nG0 X#61 Y#4100 Z#101\nM2\n";
    assert_eq!(ends(p), vec![[3.0, 3.0, 0.0]]);
}
