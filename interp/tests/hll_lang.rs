//! The C-like language beyond the reference's examples: `#use` lookup, once-only and cycles,
//! globals shared by the programs of one interpreter, the motion sync of `@ITPPATH`, error
//! locations (checked before running and at run time), and segments of G-code lines.

// NcError is large; these helpers only run in tests.
#![allow(clippy::result_large_err)]

mod hll_common;
use hll_common::{cfg, msgs, run};

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use cnc402_config::MachineConfig;
use cnc402_interp::{Interpreter, MotionSync, hll};
use cnc402_lang::SourceFile;
use cnc402_motion::segment::{AxisPos, Segment, SegmentKind};

fn err(text: &str) -> (u32, u32, String) {
    let e = run(text).unwrap_err();
    (e.line, e.col, e.message.clone())
}

/// A fresh folder under the system temp dir.
fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cnc402-hll-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run_file(
    cfg: &MachineConfig,
    path: &std::path::Path,
) -> Result<Vec<Segment>, cnc402_lang::NcError> {
    let text = std::fs::read_to_string(path).unwrap();
    cnc402_interp::host_fs::run_program(cfg, &SourceFile::new(path.display().to_string(), text))
}

#[test]
fn use_looks_next_to_the_file_then_in_the_library_and_loads_once() {
    let d = tmp("use");
    let lib = d.join("lib");
    std::fs::create_dir_all(&lib).unwrap();
    std::fs::create_dir_all(d.join("progs")).unwrap();
    // a.c next to the program uses b.c, found in the library; b.c's top level runs once.
    std::fs::write(
        d.join("progs/a.c"),
        "#use \"b.c\"\nint Twice(int n) { return 2 * Base(n); }\n",
    )
    .unwrap();
    std::fs::write(
        lib.join("b.c"),
        "MSG(\"b loaded\");\nint Base(int n) { return n + 1; }\n",
    )
    .unwrap();
    std::fs::write(
        d.join("progs/main.nc"),
        "#use \"a.c\"\n#use \"b.c\"\nMSG(\"\" + Twice(4));\n",
    )
    .unwrap();
    let mut c = cfg();
    c.interp.library_dir = Some(lib.clone());
    let segs = run_file(&c, &d.join("progs/main.nc")).unwrap();
    assert_eq!(msgs(&segs), vec!["b loaded", "10"]);
    // Without the library folder b.c is not found: the error is at the #use in a.c.
    let e = run_file(&cfg(), &d.join("progs/main.nc")).unwrap_err();
    assert!(e.file.ends_with("a.c"), "{e}");
    assert_eq!((e.line, e.col), (1, 1));
    assert!(e.message.contains("#use \"b.c\": no such file"), "{e}");
    // A cycle a -> b -> a is an error naming the chain.
    std::fs::write(
        lib.join("b.c"),
        "#use \"cyc.c\"\nint Base(int n) { return n; }\n",
    )
    .unwrap();
    std::fs::write(lib.join("cyc.c"), "#use \"b.c\"\n").unwrap();
    let e = run_file(&c, &d.join("progs/main.nc")).unwrap_err();
    assert!(e.message.starts_with("#use cycle: "), "{e}");
    assert!(
        e.message.contains("b.c uses") && e.file.ends_with("cyc.c"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn globals_are_shared_by_the_programs_of_one_interpreter() {
    let c = cfg();
    let mut it = Interpreter::new(&c);
    for (text, want) in [
        ("$nRuns = 1;\n$dPerm[5] = 2.5;\n", None),
        (
            "$nRuns += 1;\nMSG(\"runs \" + $nRuns + \" \" + $dPerm[5]);\n",
            Some("runs 2 2.5"),
        ),
    ] {
        let src = SourceFile::new("g.nc", text);
        it.load(src.clone(), cnc402_lang::parse(&src).unwrap());
        let segs: Vec<Segment> = (&mut it).collect::<Result<_, _>>().unwrap();
        if let Some(w) = want {
            assert_eq!(msgs(&segs), vec![w]);
        }
    }
    assert_eq!(hll::global_number(&it, "nRuns", None), Some(2.0));
    assert_eq!(hll::global_number(&it, "dPerm", Some(5)), Some(2.5));
    assert_eq!(hll::global_number(&it, "dPerm", Some(4)), None);
}

/// A motion sync that records how many segments had been handed out when it was asked, and
/// reports a path 0.25 mm longer than produced (as a machine might).
struct Probe {
    handed: Arc<AtomicUsize>,
    seen: Arc<Mutex<Vec<(&'static str, usize)>>>,
}

impl MotionSync for Probe {
    fn wait_motion_done(&mut self, programmed: &AxisPos) -> Result<AxisPos, String> {
        self.seen
            .lock()
            .unwrap()
            .push(("wait", self.handed.load(Ordering::SeqCst)));
        let mut p = *programmed;
        p[0] += 0.5;
        Ok(p)
    }
    fn path_length_done(&mut self, produced: f64) -> f64 {
        self.seen
            .lock()
            .unwrap()
            .push(("path", self.handed.load(Ordering::SeqCst)));
        produced + 0.25
    }
}

#[test]
fn itppath_and_positions_wait_for_the_motion_queued_before_them() {
    let c = cfg();
    let handed = Arc::new(AtomicUsize::new(0));
    let seen = Arc::new(Mutex::new(Vec::new()));
    let mut it = Interpreter::new(&c);
    it.set_motion_sync(Box::new(Probe {
        handed: handed.clone(),
        seen: seen.clone(),
    }));
    let text = "G90 G1 X10 F100\nG1 X20\nfor (int i = 0; i < 3; i++) { MSG(\"m\" + i); }\n$dA = @ITPPATH;\nG1 Y5\n$dB = @X;\nMSG(\"\" + $dA + \" \" + $dB);\nM30\n";
    let src = SourceFile::new("s.nc", text);
    it.load(src.clone(), cnc402_lang::parse(&src).unwrap());
    let mut segs = Vec::new();
    while let Some(s) = it.next_segment().unwrap() {
        segs.push(s);
        handed.fetch_add(1, Ordering::SeqCst);
    }
    // The @ITPPATH read came after the two moves and three messages were handed out.
    assert_eq!(
        *seen.lock().unwrap(),
        vec![("wait", 5), ("path", 5), ("wait", 6)]
    );
    assert_eq!(msgs(&segs).last().unwrap(), "20.25 20.5");
}

#[test]
fn errors_found_before_running_point_at_file_line_col() {
    let cases: &[(&str, (u32, u32), &str)] = &[
        (
            "G0 X1\nint nn = 1;\nnn = mm + 1;\n",
            (3, 6),
            "undefined name `mm`",
        ),
        (
            "int n = \"a\";\n",
            (1, 9),
            "cannot assign string to n (int)",
        ),
        (
            "double F(double a) { return a; }\ndouble d = F(1, 2);\n",
            (2, 12),
            "`F` takes 1 argument(s), not 2",
        ),
        (
            "double F(double a) { return a; }\ndouble d = F(\"x\");\n",
            (2, 14),
            "cannot assign string to parameter 1 of `F` (double)",
        ),
        ("void V() { }\nint n = V();\n", (2, 9), "cannot assign void"),
        ("break;\n", (1, 1), "break/continue outside a loop"),
        ("return 1;\n", (1, 1), "return outside a function"),
        ("int F() { return; }\n", (1, 11), "`return` needs a value"),
        (
            "double d = @NOPE;\n",
            (1, 12),
            "unknown system variable @NOPE",
        ),
        (
            "int nn = 1;\nG1 AXSTR(\"Q\")=1 F10\n",
            (2, 10),
            "unknown axis name \"Q\"",
        ),
        (
            "int n = 1;\nint n = 2;\n",
            (2, 5),
            "`n` is already declared in this scope",
        ),
        (
            "double d = undefinedFn(1);\n",
            (1, 12),
            "undefined function `undefinedFn`",
        ),
        (
            "string s = \"a\";\nif (s) MSG(\"x\");\n",
            (2, 5),
            "a condition cannot be string",
        ),
        (
            "int nn = 1;\nG1 X=(nn == 1) F10\n",
            (2, 6),
            "address X needs a number, not bool",
        ),
        (
            "G1 X#1 F10\nint n;\n",
            (1, 5),
            "macro variables (#n) are not available",
        ),
        (
            "void Fn(int a)\n{\n    G1 X=nTop F10\n}\nint nTop = 1;\n",
            (3, 10),
            "undefined name `nTop`",
        ),
    ];
    for (text, (l, c), want) in cases {
        let e = run(text).unwrap_err();
        assert!(e.message.contains(want), "{text:?}: {e}");
        assert_eq!((e.line, e.col), (*l, *c), "{text:?}: {e}");
    }
}

#[test]
fn checks_happen_before_any_motion() {
    // The error is in a branch that never runs, after a motion block: still no segment.
    let c = cfg();
    let src = SourceFile::new("c.nc", "G0 X5\nif (false) { int n = \"x\"; }\n");
    let mut it = Interpreter::new(&c);
    it.load(src.clone(), cnc402_lang::parse(&src).unwrap());
    let e = it.next_segment().unwrap_err();
    assert_eq!((e.line, e.col), (2, 22));
}

#[test]
fn run_time_errors_stop_at_the_expression() {
    let cases: &[(&str, (u32, u32), &str)] = &[
        (
            "int aa[3];\nint ii = 3;\naa[ii] = 1;\n",
            (3, 1),
            "index 3 is out of range (the array has 3 elements)",
        ),
        (
            "int a[2];\nint n = a[-1];\n",
            (2, 9),
            "index -1 is out of range",
        ),
        (
            "int z = 0;\ndouble d = 1.0 / z;\n",
            (2, 12),
            "division by zero",
        ),
        ("int z = 0;\nint m = 7 % z;\n", (2, 9), "division by zero"),
        (
            "int big = 4611686018427387904;\nbig *= 2;\n",
            (2, 1),
            "integer overflow",
        ),
        (
            "int n = -1;\nint a[n];\n",
            (2, 5),
            "array size -1 is out of range",
        ),
        (
            "$s = \"t\";\ndouble d = $s * 2;\n",
            (2, 12),
            "string * int: wrong operand types",
        ),
        (
            "double d = sqrt(-1);\n",
            (1, 12),
            "sqrt of a negative number",
        ),
        (
            "string s = \"W\";\nG1 AXSTR(s)=1 F10\n",
            (2, 4),
            "unknown axis name \"W\"",
        ),
        (
            "G0 X1\nint F(int n) { return F(n + 1); }\nint x = F(0);\n",
            (2, 23),
            "recursion too deep",
        ),
        (
            "int F(int n) { if (n > 0) return 1; }\nint x = F(0);\n",
            (2, 9),
            "function `F` ended without returning a int",
        ),
        (
            "channel_reset(1);\n",
            (1, 1),
            "channel_reset(1): this machine has one channel (0)",
        ),
        (
            "double d = @CH[1].MODE;\n",
            (1, 12),
            "@CH[1]: this machine has one channel (0)",
        ),
        ("sleep(-5);\n", (1, 1), "sleep(-5)"),
        (
            "G0 X1\nterminate(42, \"stop here\");\nG0 X2\n",
            (2, 1),
            "terminate 42: stop here",
        ),
    ];
    for (text, (l, c), want) in cases {
        let (line, col, m) = err(text);
        assert!(m.contains(want), "{text:?}: {m}");
        assert_eq!((line, col), (*l, *c), "{text:?}: {m}");
    }
    // Motion before the error is kept; nothing after it.
    let c = cfg();
    let src = SourceFile::new("t.nc", "G0 X1\nterminate(42, \"stop here\");\nG0 X2\n");
    let items: Vec<_> = cnc402_interp::Interpreter::new(&c).tap_load(src).collect();
    assert_eq!(items.len(), 2);
    assert!(items[0].is_ok() && items[1].is_err());
}

trait TapLoad {
    fn tap_load(self, src: SourceFile) -> Self;
}
impl TapLoad for Interpreter {
    fn tap_load(mut self, src: SourceFile) -> Self {
        let p = cnc402_lang::parse(&src).unwrap();
        self.load(src, p);
        self
    }
}

#[test]
fn gcode_lines_take_expressions_and_keep_their_source() {
    let segs = run(
        "double dR = 10;\nint nHoles = 4;\nG90 G0 Z5\nfor (int i = 0; i < nHoles; i++)\n{\n    double dA = i * 90 * M_PI / 180;\n    N100 G1 X=dR * cos(dA) Y=dR * sin(dA) F=100 + i\n}\nG4 P=250\nM3 S=1000 / 2\nM5\nM30\n",
    )
    .unwrap();
    let lin: Vec<_> = segs
        .iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Linear { end, feed } => {
                Some((end[0], end[1], *feed, s.source.line, s.source.n))
            }
            _ => None,
        })
        .collect();
    assert_eq!(lin.len(), 4);
    assert!((lin[1].0).abs() < 1e-9 && (lin[1].1 - 10.0).abs() < 1e-9);
    assert!((lin[2].0 + 10.0).abs() < 1e-9);
    assert_eq!((lin[3].2, lin[3].3, lin[3].4), (103.0, 7, Some(100)));
    assert!(
        segs.iter()
            .any(|s| matches!(s.kind, SegmentKind::Dwell { seconds } if seconds == 0.25))
    );
    assert!(
        segs.iter()
            .any(|s| matches!(s.kind, SegmentKind::Spindle { rpm, .. } if rpm == 500.0))
    );
    // The G-code core's own errors keep their message and location.
    let (l, c, m) = err("double dF = 0;\nG1 X10 F=dF\n");
    assert_eq!((l, m.contains("zero feed")), (2, true), "{c} {m}");
    // Macro B calls are refused in a C-like program.
    let (l, _, m) = err("int n = 1;\nM98 P1000\n");
    assert_eq!(l, 2);
    assert!(m.contains("Macro B sub-program call"), "{m}");
}

#[test]
fn types_promote_like_c() {
    let segs = run(concat!(
        "int a = 7;\nint b = 2;\ndouble d = a / b;\ndouble e = a / (b * 1.0);\n",
        "string s = \"x\" + a + d;\nbool t = \"abc\" < \"abd\" && \"b\" > \"abc\" && s == \"x73\";\n",
        "int c = -7 / 2;\nint m = -7 % 2;\nint f = 2.99;\nint g = -2.99;\n",
        "MSG(\"\" + d + \" \" + e + \" \" + s + \" \" + t + \" \" + c + \" \" + m + \" \" + f + \" \" + g + \" \" + (a > 6.5) + \" \" + (true == 1));\n",
    ))
    .unwrap();
    assert_eq!(msgs(&segs), vec!["3 3.5 x73 true -3 -1 2 -2 true true"]);
}

#[test]
fn int_literals_keep_all_64_bits() {
    // Read from their digits, not through an f64 (2^53 + 1 and i64::MAX were rounded).
    let segs = run(concat!(
        "int nA = 9007199254740993;\nint nMax = 9223372036854775807;\n",
        "double dBig = 18446744073709551616;\n",
        "MSG(\"\" + nA + \" \" + nMax + \" \" + (nMax - 1) + \" \" + (dBig > nMax));\n",
    ))
    .unwrap();
    assert_eq!(
        msgs(&segs),
        vec!["9007199254740993 9223372036854775807 9223372036854775806 true"]
    );
    let (line, col, m) = err("int nMax = 9223372036854775807;\nnMax += 1;\n");
    assert_eq!((line, col), (2, 1), "{m}");
    assert!(m.contains("integer overflow"), "{m}");
}

#[test]
fn source_000_channel_program_stops_where_it_leaves_the_language_implemented_here() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../lang/tests/programs/axioma_channels.nc"
    );
    let text = std::fs::read_to_string(path).unwrap();
    // As printed it uses `Iterator` and `msSleep` without declaring them.
    let e =
        cnc402_interp::run_program(&cfg(), &SourceFile::new("ch.nc", text.as_str())).unwrap_err();
    assert_eq!(
        (e.line, e.message.as_str()),
        (16, "undefined name `Iterator`")
    );
    // Declared, on a one-channel machine it reads channel 0, the channel running it: in Auto
    // (1) but running (3), not ready (2), so its own check stops it (line 13, + 2 added).
    let fixed = format!("int Iterator;\nint msSleep = 1;\n{text}");
    let e = cnc402_interp::run_program(&cfg(), &SourceFile::new("ch.nc", fixed)).unwrap_err();
    assert_eq!(e.line, 15);
    assert!(
        e.message
            .contains("terminate 5555: Neverное состояние канала"),
        "{e}"
    );
}

/// Regression: `@X` subtracted the configured G54 offset, so a work offset changed by the
/// program (G10 L2, `#5221`) or a G92 shift was ignored and `@X` read machine-relative values.
#[test]
fn axis_reads_follow_work_offsets_set_by_the_program_and_g92() {
    let segs = run(
        "G90 G54 G10 L2 P1 X5 Y0 Z0\nG0 X10 Y0 Z0\n$dA = @X;\nG92 X1\n$dB = @X;\n\
         MSG(\"\" + $dA + \" \" + $dB);\nM30\n",
    )
    .unwrap();
    assert_eq!(msgs(&segs), vec!["10 1"]);
}

#[test]
fn int_conversions_cover_the_whole_int_range_exactly() {
    // -2^63 is an int (the literal 2^63 is a double, negated: exactly -2^63).
    let segs = run("int nMin = -9223372036854775808;\nMSG(\"\" + nMin);\nM30\n").unwrap();
    assert_eq!(msgs(&segs), vec!["-9223372036854775808"]);
    // 2^63 is not, and the message says the range.
    let (line, col, m) = err("int nBig = 9223372036854775808.0;\nM30\n");
    assert_eq!(line, 1, "{m}");
    assert!(col >= 1);
    assert!(
        m.contains("does not fit in an int (-9223372036854775808 to 9223372036854775807)"),
        "{m}"
    );
    // 9.21e18 fits (the old bound of 9.2e18 refused it).
    let segs = run("int n = 9.21e18;\nMSG(\"\" + n);\nM30\n").unwrap();
    assert_eq!(msgs(&segs), vec!["9210000000000000000"]);
}
