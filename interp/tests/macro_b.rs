//! Custom Macro B unit tests through whole small programs: every operator and function, the
//! vacant-variable rules, every control form and its errors, sub-program and macro calls,
//! G65 H instructions, system variables, the motion sync point, alarms and the runaway guard.
//! The Fanuc arithmetic edge-case table is at the end, with where each value comes from.

#![allow(clippy::result_large_err)]

use std::sync::{Arc, Mutex};

use cnc402_config::MachineConfig;
use cnc402_interp::{Interpreter, MotionSync, NvTable, PersistentVars};
use cnc402_lang::{NcError, SourceFile};
use cnc402_motion::segment::{AxisPos, Segment, SegmentKind, StopKind};

fn cfg() -> MachineConfig {
    let mut c = MachineConfig::default_machine();
    c.interp.variables_file = None;
    c
}

fn start(text: &str) -> Interpreter {
    start_cfg(&cfg(), text)
}

fn start_cfg(cfg: &MachineConfig, text: &str) -> Interpreter {
    let src = SourceFile::new("m.nc", text);
    let p = cnc402_lang::parse(&src).unwrap_or_else(|e| panic!("{e}"));
    let mut it = Interpreter::new(cfg);
    it.set_program_library(None);
    it.load(src, p);
    it
}

fn drain(it: &mut Interpreter) -> Result<Vec<Segment>, NcError> {
    let mut v = Vec::new();
    while let Some(s) = it.next_segment()? {
        v.push(s);
    }
    Ok(v)
}

/// Runs `text` and returns the interpreter (for its variables) after the end.
fn ok(text: &str) -> Interpreter {
    let mut it = start(text);
    drain(&mut it).unwrap_or_else(|e| panic!("{e}"));
    it
}

fn err(text: &str) -> NcError {
    let mut it = start(text);
    drain(&mut it).expect_err("an error")
}

/// `#1` after `#1=<e>`.
fn val(e: &str) -> Option<f64> {
    ok(&format!("#1={e}\n")).var(1)
}

fn approx(e: &str, want: f64) {
    let v = val(e).unwrap_or_else(|| panic!("{e} is vacant"));
    assert!((v - want).abs() < 1e-9, "{e} = {v}, want {want}");
}

fn xs(segs: &[Segment]) -> Vec<f64> {
    segs.iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Rapid { end } | SegmentKind::Linear { end, .. } => Some(end[0]),
            _ => None,
        })
        .collect()
}

#[test]
fn every_operator() {
    approx("1+2", 3.0);
    approx("1-2", -1.0);
    approx("3*4", 12.0);
    approx("3/4", 0.75);
    approx("[10 MOD 3]", 1.0);
    approx("[6 OR 3]", 7.0);
    approx("[6 XOR 3]", 5.0);
    approx("[6 AND 3]", 2.0);
    approx("[2 EQ 2]", 1.0);
    approx("[2 NE 2]", 0.0);
    approx("[3 GT 2]", 1.0);
    approx("[2 GE 2]", 1.0);
    approx("[2 LT 2]", 0.0);
    approx("[2 LE 2]", 1.0);
    approx("-[2]", -2.0);
    // Precedence: functions, then * / AND MOD, then + - OR XOR, then comparisons.
    approx("1+2*3", 7.0);
    approx("[1+2]*3", 9.0);
    approx("8/4/2", 1.0);
    approx("2*3 MOD 4", 2.0);
    approx("[1+1 EQ 2]", 1.0);
    assert_eq!(err("#1=1/0\n").message, "division by zero");
}

#[test]
fn every_function() {
    approx("SIN[30]", 0.5);
    approx("COS[60]", 0.5);
    approx("TAN[45]", 1.0);
    approx("ASIN[0.5]", 30.0);
    approx("ACOS[0.5]", 60.0);
    approx("ATAN[1]", 45.0);
    approx("ATAN[1]/[1]", 45.0);
    approx("SQRT[16]", 4.0);
    approx("ABS[-3]", 3.0);
    approx("ROUND[1.5]", 2.0);
    approx("FIX[1.7]", 1.0);
    approx("FUP[1.2]", 2.0);
    approx("LN[EXP[2]]", 2.0);
    approx("POW[2,10]", 1024.0);
    approx("BIN[18]", 12.0);
    approx("BCD[12]", 18.0);
    assert!(err("#1=SQRT[-1]\n").message.contains("SQRT"));
    assert!(err("#1=ASIN[2]\n").message.contains("outside -1..1"));
    assert!(err("#1=LN[0]\n").message.contains("LN"));
}

#[test]
fn vacant_rules() {
    // FANUC 0i-D Operator's Manual (B-64304EN) 14.1, "Undefined variable": replacement keeps
    // vacant, arithmetic reads 0, EQ/NE see vacant as different from 0, GT… read 0.
    assert_eq!(val("#0"), None);
    assert_eq!(val("#2"), None);
    assert_eq!(val("#2*5"), Some(0.0));
    assert_eq!(val("#2+#2"), Some(0.0));
    assert_eq!(val("[#2 EQ #0]"), Some(1.0));
    assert_eq!(val("[#2 EQ 0]"), Some(0.0));
    assert_eq!(val("[#2 NE 0]"), Some(1.0));
    assert_eq!(val("[#2 GE #0]"), Some(1.0));
    assert_eq!(val("[#2 GT 0]"), Some(0.0));
    assert_eq!(val("[#2 LT 0]"), Some(0.0));
    assert_eq!(val("SIN[#2]"), Some(0.0));
    // A word with a vacant value is left out (G90 X#1 = G90).
    let segs = drain(&mut start("G0 X5\nG0 X#1 Y2\n")).unwrap();
    assert_eq!(xs(&segs), vec![5.0, 5.0]);
    // #1=#0 makes a set variable vacant again.
    assert_eq!(ok("#1=3\n#1=#0\n").var(1), None);
    assert_eq!(
        err("#0=1\n").message,
        "#0 is always vacant and cannot be written"
    );
}

#[test]
fn variable_ranges_indirect_and_common_reset() {
    let mut it = ok("#1=1\n#33=33\n#100=5\n#199=6\n#500=7\n#[#100+1]=8\n#[100+#1]=#[#100+1]+1\n");
    assert_eq!(it.var(33), Some(33.0));
    assert_eq!(it.var(100), Some(5.0));
    assert_eq!(it.var(101), Some(9.0));
    assert_eq!(it.var(6), Some(8.0));
    assert_eq!(it.var(500), Some(7.0));
    for bad in ["#34=1\n", "#200=1\n", "#1000=1\n", "#4001=1\n"] {
        assert!(err(bad).message.contains("cannot be written"), "{bad}");
    }
    assert!(err("#1=#34\n").message.contains("not a variable"));
    // A new run (reset) clears common variables and keeps the non-volatile ones.
    let src = SourceFile::new("m.nc", "#1=#100\n#2=#500\n");
    it.load(src.clone(), cnc402_lang::parse(&src).unwrap());
    drain(&mut it).unwrap();
    assert_eq!((it.var(1), it.var(2)), (None, Some(7.0)));
}

#[test]
fn goto_forms() {
    let segs = drain(&mut start("GOTO 20\nN10 G0 X1\nN20 G0 X2\n#1=30\nGOTO #1\nG0 X3\nN30 G0 X4\nGOTO [10+20+5]\nN35 G0 X5\n")).unwrap();
    assert_eq!(xs(&segs), vec![2.0, 4.0, 5.0]);
    let e = err("GOTO 99\n");
    assert_eq!((e.line, e.col), (1, 6));
    assert!(e.message.contains("N99 not found"));
    assert!(err("GOTO #1\n").message.contains("vacant"));
    assert!(
        err("GOTO [1.5]\n")
            .message
            .contains("not a sequence number")
    );
}

#[test]
fn if_forms() {
    let segs = drain(&mut start(
        "#1=2\nIF [#1 EQ 2] GOTO 10\nG0 X1\nN10 IF [#1 GT 5] GOTO 20\nG0 X2\nN20 IF [#1 EQ 2] THEN #2=7\nIF [#1 NE 2] THEN #3=1\nIF [#1 EQ 2] THEN G0 X#2\n",
    ))
    .unwrap();
    assert_eq!(xs(&segs), vec![2.0, 7.0]);
    // A vacant condition is false.
    let it = ok("IF [#5] THEN #1=1\n");
    let mut it = it;
    assert_eq!(it.var(1), None);
}

#[test]
fn while_forms_and_nesting() {
    let mut it = ok(
        "#1=0\n#9=0\nWHILE [#1 LT 3] DO 1\n#2=0\nWHILE [#2 LT 4] DO 2\n#3=0\nWHILE [#3 LT 5] DO 3\n#9=#9+1\n#3=#3+1\nEND 3\n#2=#2+1\nEND 2\n#1=#1+1\nEND 1\n",
    );
    assert_eq!(it.var(9), Some(60.0));
    // A false condition skips the body; the same number may be reused after its END.
    let mut it = ok("WHILE [0] DO 1\n#1=1\nEND 1\nWHILE [#2 LT 2] DO 1\n#2=#2+1\nEND 1\n");
    assert_eq!((it.var(1), it.var(2)), (None, Some(2.0)));
    // GOTO out of a loop.
    let mut it = ok("WHILE [1] DO 1\n#1=#1+1\nIF [#1 GE 5] GOTO 9\nEND 1\nN9 #2=1\n");
    assert_eq!((it.var(1), it.var(2)), (Some(5.0), Some(1.0)));
    let cases: &[(&str, u32, &str)] = &[
        ("WHILE [1] DO 1\n", 1, "WHILE … DO 1 has no END 1"),
        ("END 2\n", 1, "END 2 without a WHILE … DO 2"),
        (
            "WHILE [1] DO 1\nWHILE [1] DO 2\nEND 1\nEND 2\n",
            1,
            "END 1 (line 3) closes DO 1 of line 1 while DO 2 of line 2 is still open",
        ),
        (
            "WHILE [1] DO 1\nWHILE [1] DO 1\nEND 1\nEND 1\n",
            2,
            "DO 1 inside the loop DO 1 of line 1",
        ),
    ];
    for &(text, line, msg) in cases {
        let e = err(text);
        assert_eq!(e.line, line, "{text}: {e}");
        assert!(e.message.starts_with(msg), "{text}: {e}");
    }
}

#[test]
fn runaway_loop_names_its_lines() {
    let mut c = cfg();
    c.interp.block_limit = 1000;
    let mut it = start_cfg(&c, "G0 X1\n#1=0\nWHILE [1] DO 1\n#1=#1+1\nEND 1\n");
    let e = drain(&mut it).unwrap_err();
    assert!(e.message.starts_with("runaway program: 1000 blocks"), "{e}");
    assert!(e.message.contains("lines 3-5 of m.nc"), "{e}");
    // A loop that moves is not a runaway.
    let mut it = start_cfg(
        &c,
        "G91\nWHILE [#1 LT 2000] DO 1\nG0 X0.001\n#1=#1+1\nEND 1\n",
    );
    assert_eq!(drain(&mut it).unwrap().len(), 2000);
}

#[test]
fn subprograms_in_the_file_m98_l_and_p_prefix_m99_p() {
    let text =
        "O0001\nM98 P2 L2\nM98 P30002\n#9=1\nM30\nO0002\n#100=#100+1\nM99\nO0003\nM99 P50\nO0004\n";
    let mut it = ok(text);
    assert_eq!(it.var(100), Some(5.0));
    // M99 P returns to N50 of the caller.
    let text = "O0001\nM98 P3\nG0 X1\nN50 G0 X2\nM30\nO0003\nM99 P50\n";
    let segs = drain(&mut start(text)).unwrap();
    assert_eq!(xs(&segs), vec![2.0]);
    // M99 P in a main program jumps.
    let segs = drain(&mut start("G0 X1\nM99 P7\nG0 X2\nN7 G0 X3\n")).unwrap();
    assert_eq!(xs(&segs), vec![1.0, 3.0]);
    // M99 alone in a main program, by default (a dump, a dry run): one pass, and the line
    // where a machine run would start over.
    let mut it = start("G0 X1\nM99\nG0 X2\n");
    let segs = drain(&mut it).unwrap();
    assert_eq!(xs(&segs), vec![1.0]);
    assert_eq!(it.main_m99_line(), Some(2));
    let mut it = start("G0 X1\nM30\n");
    drain(&mut it).unwrap();
    assert_eq!(it.main_m99_line(), None, "ended by M30");
    // M98 shares the locals of its caller.
    let mut it = ok("O1\n#1=4\nM98 P2\nM30\nO2\n#1=#1*2\nM99\n");
    assert_eq!(it.var(1), Some(8.0));
    let e = err("M98 P77\n");
    assert!(e.message.starts_with("program O0077 not found"), "{e}");
    let e = err("O1\nM98 P1\nM30\n");
    assert!(e.message.contains("nested deeper"), "{e}");
}

#[test]
fn g65_arguments_locals_per_level_and_repeats() {
    let text = "O1\n#1=100\nG65 P9 A1 B2 C3 I4 J5 K6 D7 E8 F9 H11 M13 Q17 R18 S19 T20 U21 V22 W23 X24 Y25 Z26\n#50=#1\nM30\nO9\n#101=#1+#2+#3+#4+#5+#6+#7+#8+#9+#11+#13+#17+#18+#19+#20+#21+#22+#23+#24+#25+#26\n#102=#10\n#1=999\nM99\n";
    let text = text.replace("#50=#1", "#103=#1");
    let mut it = ok(&text);
    let sum: f64 = [
        1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 13, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26,
    ]
    .iter()
    .map(|&x| f64::from(x))
    .sum();
    assert_eq!(it.var(101), Some(sum));
    assert_eq!(it.var(102), None, "#10 has no argument: vacant");
    assert_eq!(it.var(103), Some(100.0), "the caller's #1 is untouched");
    let mut it = ok("G65 P5 L3 A2\nM30\nO5\n#100=#100+#1\nM99\n");
    assert_eq!(it.var(100), Some(6.0));
    assert!(
        err("G65 P5 G0\nO5\nM99\n")
            .message
            .contains("cannot share a block")
    );
    assert!(err("G65 A1\n").message.contains("needs P"));
    // H with another argument is argument #11, not a macro instruction.
    let mut it = ok("G65 P5 H3 A1\nM30\nO5\n#100=#11+#1\nM99\n");
    assert_eq!(it.var(100), Some(4.0));
}

/// Argument specification II (Fanuc Custom Macro B): A B C, then I J K sets 1..10 →
/// #4-#6, #7-#9, … #31-#33, numbered by the order of the words; mixed with specification I,
/// a variable given twice takes the later word.
#[test]
fn g65_argument_specification_ii() {
    // O9 copies #1-#33 to #101-#133.
    let mut body = String::from("O9\n");
    for n in 1..=33 {
        body.push_str(&format!("#{}=#{n}\n", 100 + n));
    }
    body.push_str("M99\n");
    let run = |call: &str| ok(&format!("{call}\nM30\n{body}"));
    let vars =
        |it: &mut Interpreter| -> Vec<Option<f64>> { (101..=133).map(|n| it.var(n)).collect() };
    let mut it = run("G65 P9 A1 B2 I3 J4 K5 I6 J7 K8 I9 K10");
    let v = vars(&mut it);
    assert_eq!(
        &v[..12],
        &[
            Some(1.0),
            Some(2.0),
            None, // A B C
            Some(3.0),
            Some(4.0),
            Some(5.0), // I1 J1 K1
            Some(6.0),
            Some(7.0),
            Some(8.0), // I2 J2 K2
            Some(9.0),
            None,
            Some(10.0), // I3 (J3 not given) K3
        ]
    );
    assert!(v[12..].iter().all(Option::is_none));
    // The manual's example: A1.0 B2.0 I-3.0 I4.0 D5.0 → #7 = 5.0 (D after I2 wins).
    let mut it = run("G65 P9 A1.0 B2.0 I-3.0 I4.0 D5.0");
    let v = vars(&mut it);
    assert_eq!(
        &v[..7],
        &[
            Some(1.0),
            Some(2.0),
            None,
            Some(-3.0),
            None,
            None,
            Some(5.0)
        ]
    );
    // D before I2: the I word is later and wins.
    let mut it = run("G65 P9 D5 I1 I2");
    assert_eq!(it.var(107), Some(2.0));
    // A letter out of I < J < K order starts the next set: I K J → #4, #6, #8.
    let mut it = run("G65 P9 I1 K2 J3");
    assert_eq!(
        (it.var(104), it.var(106), it.var(108)),
        (Some(1.0), Some(2.0), Some(3.0))
    );
    // The example of docs/language.md: a specification I program written K J I reads
    // #6, #8, #10 (three sets), as on Fanuc, not #4-#6.
    let mut it = run("G65 P9 K3 J2 I1");
    let v = vars(&mut it);
    assert_eq!(
        &v[3..10],
        &[None, None, Some(3.0), None, Some(2.0), None, Some(1.0)]
    );
    // All ten sets: I10 J10 K10 are #31-#33.
    let sets: String = (1..=10).map(|k| format!(" I{k} J{k} K{k}")).collect();
    let mut it = run(&format!("G65 P9{sets}"));
    assert_eq!(
        (it.var(131), it.var(132), it.var(133)),
        (Some(10.0), Some(10.0), Some(10.0))
    );
    assert_eq!(it.var(104), Some(1.0));
    // An eleventh set is an error at its first word.
    let e = err(&format!("G65 P9{sets} I11\nM30\n{body}"));
    assert_eq!((e.line, e.col), (1, 101), "{e}");
    assert!(e.message.contains("more than 10 I/J/K sets"), "{e}");
    // Specification I is unchanged, and I given twice outside a call is still an error.
    let mut it = run("G65 P9 I1 J2 K3 X24");
    assert_eq!(
        (it.var(104), it.var(106), it.var(124)),
        (Some(1.0), Some(3.0), Some(24.0))
    );
    assert!(err("G1 I1 I2\n").message.contains("address I given twice"));
    // G66 takes them too.
    let mut it = ok(&format!("G66 P9 I1 I2\nG0 X1\nG67\nM30\n{body}"));
    assert_eq!((it.var(104), it.var(107)), (Some(1.0), Some(2.0)));
}

#[test]
fn g66_modal_call_after_each_move_until_g67() {
    let text = "O1\nG66 P8 A10\nG0 X1\nG0 X2\nG67\nG0 X3\nM30\nO8\n#100=#100+#1\nG0 Y#100\nM99\n";
    let mut it = start(text);
    let segs = drain(&mut it).unwrap();
    assert_eq!(it.var(100), Some(20.0));
    let ys: Vec<f64> = segs
        .iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Rapid { end } => Some(end[1]),
            _ => None,
        })
        .collect();
    assert_eq!(ys, vec![0.0, 10.0, 10.0, 20.0, 20.0]);
    let mut it = ok("G66 P8 A1\n#5=#4012\nG67\n#6=#4012\nM30\nO8\nM99\n");
    assert_eq!((it.var(5), it.var(6)), (Some(66.0), Some(67.0)));
}

#[test]
fn g65_h_macro_instructions() {
    let cases: &[(&str, f64)] = &[
        ("G65 H01 P#1 Q5", 5.0),
        ("G65 H02 P#1 Q5 R3", 8.0),
        ("G65 H03 P#1 Q5 R3", 2.0),
        ("G65 H04 P#1 Q5 R3", 15.0),
        ("G65 H05 P#1 Q6 R3", 2.0),
        ("G65 H11 P#1 Q6 R3", 7.0),
        ("G65 H12 P#1 Q6 R3", 2.0),
        ("G65 H13 P#1 Q6 R3", 5.0),
        ("G65 H21 P#1 Q16", 4.0),
        ("G65 H22 P#1 Q-3", 3.0),
        ("G65 H23 P#1 Q10 R3", 1.0),
        ("G65 H24 P#1 Q18", 12.0),
        ("G65 H25 P#1 Q12", 18.0),
        ("#1=10\nG65 H26 P#1 Q3 R2", 15.0),
        ("G65 H27 P#1 Q3 R4", 5.0),
        ("G65 H28 P#1 Q5 R4", 3.0),
        ("G65 H31 P#1 Q2 R30", 1.0),
        ("G65 H32 P#1 Q2 R60", 1.0),
        ("G65 H33 P#1 Q2 R45", 2.0),
        ("G65 H34 P#1 Q-1 R-1", 225.0),
        ("#2=7\nG65 H01 P#1 Q#2", 7.0),
        ("#2=3\nG65 H01 P#[#2-2] Q9", 9.0),
    ];
    for &(text, want) in cases {
        let v = ok(&format!("{text}\n")).var(1).unwrap();
        assert!((v - want).abs() < 1e-9, "{text}: {v}, want {want}");
    }
    // Jumps: H80 always, H81..H86 EQ NE GT LT GE LE.
    for (h, q, r, jumps) in [
        (80, 0, 0, true),
        (81, 1, 1, true),
        (81, 1, 2, false),
        (82, 1, 2, true),
        (83, 2, 1, true),
        (83, 1, 1, false),
        (84, 1, 2, true),
        (85, 1, 1, true),
        (85, 0, 1, false),
        (86, 1, 1, true),
        (86, 2, 1, false),
    ] {
        let mut it = ok(&format!("G65 H{h} P9 Q{q} R{r}\n#1=1\nN9 #2=1\n"));
        assert_eq!(it.var(1).is_none(), jumps, "H{h} Q{q} R{r}");
    }
    let e = err("G0 X1\nN5 G65 H99 P1(SPINDLE)\n");
    assert_eq!((e.line, e.message.as_str()), (2, "alarm 501: SPINDLE"));
    assert!(
        err("G65 H77 P#1\n")
            .message
            .contains("unknown macro instruction")
    );
    assert!(err("G65 H01 P5 Q1\n").message.contains("P#i"));
    assert!(
        err("G65 H05 P#1 Q1 R0\n")
            .message
            .contains("division by zero")
    );
}

#[test]
fn alarms_and_message_stop() {
    let e = err("G0 X1\n#3000=12(TOOL BROKEN)\n");
    assert_eq!((e.line, e.message.as_str()), (2, "alarm 3012: TOOL BROKEN"));
    let segs = drain(&mut start("#3006=1(CHECK PART)\nG0 X1\n")).unwrap();
    assert_eq!(
        segs[0].kind,
        SegmentKind::Message {
            text: "CHECK PART".into()
        }
    );
    assert_eq!(
        segs[1].kind,
        SegmentKind::Stop {
            kind: StopKind::Program
        }
    );
    assert_eq!(segs.len(), 3);
}

#[test]
fn modal_information_variables() {
    let mut it = ok(
        "G1 G18 G91 G95 G20 G55 G99 F0.5 S300 T12 X0\nM5\n#1=#4001\n#2=#4002\n#3=#4003\n#4=#4005\n#5=#4006\n#6=#4007\n#7=#4009\n#8=#4010\n#9=#4014\n#10=#4016\n#11=#4109\n#12=#4119\n#13=#4120\n#14=#4113\nN77 #15=#4114\n",
    );
    let got: Vec<_> = (1..=15).map(|n| it.var(n).unwrap_or(f64::NAN)).collect();
    assert_eq!(
        got,
        vec![
            1.0, 18.0, 91.0, 95.0, 20.0, 40.0, 80.0, 99.0, 55.0, 69.0, 0.5, 300.0, 12.0, 5.0, 77.0
        ]
    );
    // Restoring saved codes runs (G40 G69 are accepted cancel codes).
    ok("#1=#4007\n#2=#4016\n#3=#4008\nG[FUP[#1]]\nG#2\nG#3\n");
}

#[test]
fn position_and_work_offset_variables() {
    // G55 is X+100 in the shipped config.
    let mut it = ok(
        "G55 G0 X10 Y20 Z-5\n#1=#5001\n#2=#5002\n#3=#5003\n#4=#5021\n#5=#5041\n#6=#5241\n#5241=50\nG0 X10\n#7=#5021\n",
    );
    let got: Vec<_> = (1..=7).map(|n| it.var(n).unwrap()).collect();
    assert_eq!(got, vec![10.0, 20.0, -5.0, 110.0, 10.0, 100.0, 60.0]);
    assert!(
        err("#1=#5004+#5005\n")
            .message
            .contains("#5005 is not a variable")
    );
}

/// A motion sync that records when it was asked and reports a lagging actual position.
struct Lagging {
    calls: Arc<Mutex<Vec<AxisPos>>>,
}

impl MotionSync for Lagging {
    fn wait_motion_done(&mut self, programmed: &AxisPos) -> Result<AxisPos, String> {
        self.calls.lock().unwrap().push(*programmed);
        let mut p = *programmed;
        p[0] -= 0.001;
        Ok(p)
    }
    fn path_length_done(&mut self, produced: f64) -> f64 {
        produced / 2.0
    }
}

#[test]
fn position_reads_are_sync_points() {
    let calls = Arc::new(Mutex::new(Vec::new()));
    let src = SourceFile::new("m.nc", "G0 X10\nG0 X20\n#1=#5021\n#2=#5001\nG0 X[#1+1]\n");
    let mut it = Interpreter::new(&cfg());
    it.set_motion_sync(Box::new(Lagging {
        calls: calls.clone(),
    }));
    it.load(src.clone(), cnc402_lang::parse(&src).unwrap());
    // The interpreter does not run ahead past the read before the motion is handed out.
    let a = it.next_segment().unwrap().unwrap();
    let b = it.next_segment().unwrap().unwrap();
    assert!(calls.lock().unwrap().is_empty(), "{a:?} {b:?}");
    let c = it.next_segment().unwrap().unwrap();
    assert_eq!(calls.lock().unwrap().len(), 1, "#5001 does not sync");
    assert_eq!(calls.lock().unwrap()[0][0], 20.0);
    let SegmentKind::Rapid { end } = c.kind else {
        panic!()
    };
    assert!((end[0] - 20.999).abs() < 1e-9);
    assert!((it.path_length() - 20.999).abs() < 1e-9);
    // A failed sync ends the run at the reading line.
    struct Broken;
    impl MotionSync for Broken {
        fn wait_motion_done(&mut self, _: &AxisPos) -> Result<AxisPos, String> {
            Err("drive 2 faulted".into())
        }
    }
    let mut it = Interpreter::new(&cfg());
    it.set_motion_sync(Box::new(Broken));
    let src = SourceFile::new("m.nc", "G0 X1\n#1=#5042\n");
    it.load(src.clone(), cnc402_lang::parse(&src).unwrap());
    let e = drain(&mut it).unwrap_err();
    assert_eq!((e.line, e.message.as_str()), (2, "drive 2 faulted"));
}

#[test]
fn path_length_counts_lines_and_arcs() {
    let mut it = start("G1 X10 F100\nG3 X10 Y20 I0 J10\nG2 X10 Y20 I0 J-10\n");
    drain(&mut it).unwrap();
    // 10 straight, a half circle of radius 10, a full circle of radius 10.
    let want = 10.0 + 30.0 * std::f64::consts::PI;
    assert!(
        (it.path_length() - want).abs() < 1e-9,
        "{}",
        it.path_length()
    );
}

/// Records every store.
struct Recorder(Arc<Mutex<Vec<Vec<Option<f64>>>>>);

impl PersistentVars for Recorder {
    fn store(&mut self, vars: &[Option<f64>]) -> Result<(), String> {
        self.0.lock().unwrap().push(vars.to_vec());
        if vars[1] == Some(13.0) {
            return Err("disk full".into());
        }
        Ok(())
    }
}

#[test]
fn non_volatile_writes_are_stored_before_the_program_goes_on() {
    let log = Arc::new(Mutex::new(Vec::new()));
    let mut t = NvTable::default();
    t.set(520, Some(3.0)).unwrap();
    let mut it = Interpreter::new(&cfg());
    it.set_persistent_vars(t, Some(Box::new(Recorder(log.clone()))));
    let src = SourceFile::new(
        "m.nc",
        "#1=#520\n#500=1\n#100=2\n#500=#500+1\n#501=13\n#502=1\n",
    );
    it.load(src.clone(), cnc402_lang::parse(&src).unwrap());
    let e = drain(&mut it).unwrap_err();
    assert_eq!(e.line, 5);
    assert!(e.message.contains("disk full"));
    let log = log.lock().unwrap();
    assert_eq!(
        log.len(),
        3,
        "one store per non-volatile write, none for #100"
    );
    assert_eq!(
        (log[0][0], log[1][0], log[0][20]),
        (Some(1.0), Some(2.0), Some(3.0))
    );
    assert_eq!(it.var(1), Some(3.0));
    assert_eq!(it.persistent_vars().get(502), None);
}

// Fanuc arithmetic edge cases. Values and sources:
// - FIX/FUP of ±1.2: FANUC Series 0i-D Operator's Manual B-64304EN, 14.3 "Arithmetic and
//   logic operation", note on FIX/FUP: FUP[1.2]=2.0, FIX[1.2]=1.0, FUP[-1.2]=-2.0,
//   FIX[-1.2]=-1.0.
// - ROUND: same section, rounds off at the first decimal place (half away from zero):
//   ROUND[1.5]=2, ROUND[-1.5]=-2, ROUND[-1.4]=-1.
// - ATAN[a]/[b]: same section: the result is 0..360 (parameter NAT = 0), ATAN[-1]/[-1]=225.0;
//   quadrants 45, 135, 225, 315; on the axes 0, 90, 180, 270. ATAN[a] (one argument,
//   0i-F and later): -90..90.
// - MOD: operands are rounded to integers first; the remainder takes the dividend's sign
//   (as C), so -10 MOD 3 = -1 and 10 MOD -3 = 1. This is how cnc402 reads B-64604EN
//   (0i-F) 14.3; not checked on a control.
#[test]
fn fanuc_arithmetic_edge_table() {
    let table: &[(&str, f64)] = &[
        ("FIX[1.2]", 1.0),
        ("FIX[-1.2]", -1.0),
        ("FUP[1.2]", 2.0),
        ("FUP[-1.2]", -2.0),
        ("FUP[-2]", -2.0),
        ("FIX[-0.9]", 0.0),
        ("ROUND[1.5]", 2.0),
        ("ROUND[-1.5]", -2.0),
        ("ROUND[-1.4]", -1.0),
        ("ROUND[-0.5]", -1.0),
        ("ATAN[1]/[1]", 45.0),
        ("ATAN[1]/[-1]", 135.0),
        ("ATAN[-1]/[-1]", 225.0),
        ("ATAN[-1]/[1]", 315.0),
        ("ATAN[0]/[1]", 0.0),
        ("ATAN[1]/[0]", 90.0),
        ("ATAN[0]/[-1]", 180.0),
        ("ATAN[-1]/[0]", 270.0),
        ("ATAN[-1]", -45.0),
        ("[10 MOD 3]", 1.0),
        ("[-10 MOD 3]", -1.0),
        ("[10 MOD -3]", 1.0),
        ("[-10 MOD -3]", -1.0),
        ("[10.4 MOD 3]", 1.0),
        ("[10.6 MOD 3]", 2.0),
    ];
    for &(e, want) in table {
        approx(e, want);
    }
}

#[test]
fn m99_in_the_main_program_repeats_it_with_state_and_variables_kept_when_asked() {
    // The Fanuc part-counter idiom: the program starts over at M99 until its own branch ends
    // it; modal state (G91 here) and common variables carry over from pass to pass.
    let text = "G0 X1\nG91\n#100=[#100+1]\nIF [#100 GE 3] GOTO 90\nM99\nN90 M30\n";
    let src = SourceFile::new("m.nc", text);
    let p = cnc402_lang::parse(&src).unwrap();
    let opts = cnc402_interp::Options {
        main_m99: cnc402_interp::MainM99::Repeat,
        ..Default::default()
    };
    let mut it = Interpreter::with_options(&cfg(), opts.clone());
    it.set_program_library(None);
    it.load(src, p);
    let segs = drain(&mut it).unwrap();
    // Pass 1 in G90 (X1), passes 2 and 3 in G91 (X+1 each).
    assert_eq!(xs(&segs), vec![1.0, 2.0, 3.0]);
    assert_eq!(it.var(100), Some(3.0));
    assert_eq!(it.main_m99_line(), None);
    // Regression: with the tape's opening `%`, the restart went back to the `%`, which after
    // the first block ends the program, so the run stopped after one pass.
    let text = "%\nO0001\n#100=[#100+1]\nG0 X[#100]\nIF [#100 GE 3] GOTO 90\nM99\nN90 M30\n%\n";
    let src = SourceFile::new("m.nc", text);
    let p = cnc402_lang::parse(&src).unwrap();
    let mut it = Interpreter::with_options(&cfg(), opts.clone());
    it.set_program_library(None);
    it.load(src, p);
    let segs = drain(&mut it).unwrap();
    assert_eq!(xs(&segs), vec![1.0, 2.0, 3.0]);
    // A repeating program that never moves is still a runaway.
    let mut c = cfg();
    c.interp.block_limit = 1000;
    let src = SourceFile::new("m.nc", "#1=1\nM99\n");
    let p = cnc402_lang::parse(&src).unwrap();
    let mut it = Interpreter::with_options(&c, opts);
    it.set_program_library(None);
    it.load(src, p);
    let e = drain(&mut it).unwrap_err();
    assert!(e.message.contains("without motion"), "{e}");
}

/// A library holding one file, `O7001`.
struct OneFile(&'static str);

impl cnc402_interp::host::ProgramLibrary for OneFile {
    fn find(&mut self, number: u32, _main: &str) -> Result<Option<SourceFile>, String> {
        Ok((number == 7001).then(|| SourceFile::new("O7001.nc", self.0)))
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

/// Regression (review item 7): a C-like file called as a sub-program of a Macro B program
/// gave "not supported yet (they come with the C-like language)", although the language
/// exists; the errors now say where C-like code is allowed.
#[test]
fn c_like_code_in_a_macro_b_sub_program_says_where_it_is_allowed() {
    let where_ = "only in a C-like main program and the files it #uses, not in a sub-program that a Macro B program calls (M98, G65, G66)";
    for (sub, line, col, what) in [
        (
            "O7001\nG0 X1\ndouble dA = 1;\nM99\n",
            3,
            1,
            "C-like statements are allowed",
        ),
        (
            "O7001\nG0 AXSTR(\"X\")=2\ndouble dA = 1;\nM99\n",
            2,
            4,
            "AXSTR axis words are allowed",
        ),
        (
            "O7001\nG0 X=dA\ndouble dA = 1;\nM99\n",
            2,
            6,
            "C-like expressions are allowed",
        ),
    ] {
        let src = SourceFile::new("m.nc", "O1\nM98 P7001\nM30\n");
        let p = cnc402_lang::parse(&src).unwrap();
        let mut it = Interpreter::new(&cfg());
        it.set_program_library(Some(Box::new(OneFile(sub))));
        it.load(src, p);
        let e = drain(&mut it).unwrap_err();
        assert_eq!(
            (e.line, e.col, e.message.clone()),
            (line, col, format!("{what} {where_}")),
            "{sub}"
        );
    }
}
