//! Programs read line by line (`Interpreter::load_stream`) run exactly as when parsed whole:
//! every shipped program gives the same segments or the same error, and the flow that goes
//! back and forth in a file (GOTO, WHILE, M98/M99, LinuxCNC O-word subs and loops) works
//! across many lines; an error deep in a long file names its line and block.

use std::io::Cursor;
use std::path::{Path, PathBuf};

use cnc402_config::MachineConfig;
use cnc402_interp::Interpreter;
use cnc402_lang::{NcError, SourceFile};
use cnc402_motion::segment::Segment;

/// Most segments compared per program (endless programs are legal).
const MAX_SEGMENTS: usize = 20_000;

fn cfg() -> MachineConfig {
    let mut c = MachineConfig::default_machine();
    c.interp.variables_file = None;
    c
}

/// An error as a user sees it.
fn shown(e: &NcError) -> String {
    format!(
        "{}:{}:{}: {} ({:?}) [{}]",
        e.file, e.line, e.col, e.message, e.expected, e.block
    )
}

fn collect(it: &mut Interpreter) -> (Vec<Segment>, Option<String>) {
    let mut segs = Vec::new();
    while segs.len() < MAX_SEGMENTS {
        match it.next_segment() {
            Ok(Some(s)) => segs.push(s),
            Ok(None) => return (segs, None),
            Err(e) => return (segs, Some(shown(&e))),
        }
    }
    (segs, None)
}

/// The program parsed whole, as `cnc402` did before streaming.
fn whole(name: &str, bytes: &[u8]) -> (Vec<Segment>, Option<String>) {
    let cfg = cfg();
    let src = SourceFile::from_bytes(name, bytes.to_vec());
    let program = match cnc402_interp::parse_program(&cfg, &src, None) {
        Ok(p) => p,
        Err(e) => return (Vec::new(), Some(shown(&e))),
    };
    let mut it = Interpreter::new(&cfg);
    it.load(src, program);
    collect(&mut it)
}

/// The program read line by line.
fn streamed(name: &str, bytes: &[u8]) -> (Vec<Segment>, Option<String>) {
    let mut it = Interpreter::new(&cfg());
    if let Err(e) = it.load_stream(name, Box::new(Cursor::new(bytes.to_vec())), None) {
        return (Vec::new(), Some(shown(&e)));
    }
    collect(&mut it)
}

/// The program read line by line as the run after its dry run reads it (only flow lines
/// parsed at load).
fn streamed_checked(name: &str, bytes: &[u8]) -> (Vec<Segment>, Option<String>) {
    let mut it = Interpreter::new(&cfg());
    let input = Box::new(Cursor::new(bytes.to_vec()));
    if let Err(e) = it.load_stream_checked(name, input, None) {
        return (Vec::new(), Some(shown(&e)));
    }
    collect(&mut it)
}

fn programs(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() {
            programs(&p, out);
        } else if p
            .extension()
            .and_then(|x| x.to_str())
            .is_some_and(|x| matches!(x.to_ascii_lowercase().as_str(), "nc" | "ngc" | "cnc"))
        {
            out.push(p);
        }
    }
}

#[test]
fn every_shipped_program_streams_as_it_runs_whole() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut files = Vec::new();
    for d in [
        "examples",
        "tests/real-programs",
        "interp/tests",
        "runtime/tests",
    ] {
        programs(&root.join(d), &mut files);
    }
    files.sort();
    assert!(files.len() > 100, "{} programs", files.len());
    for f in &files {
        let bytes = std::fs::read(f).unwrap();
        let name = f.display().to_string();
        let (a, b) = (whole(&name, &bytes), streamed(&name, &bytes));
        assert_eq!(a.1, b.1, "{name}: errors differ");
        assert_eq!(a.0.len(), b.0.len(), "{name}: segment counts differ");
        assert!(a.0 == b.0, "{name}: segments differ");
        // A program that parses runs the same when only its flow lines are parsed at load.
        if !a.0.is_empty() || a.1.is_none() {
            let c = streamed_checked(&name, &bytes);
            assert_eq!(a.1, c.1, "{name}: errors differ (checked)");
            assert!(a.0 == c.0, "{name}: segments differ (checked)");
        }
    }
}

/// `n` filler moves (0.001 mm each, incremental).
fn filler(n: usize) -> String {
    "G91 G1 X0.001 F100\n".repeat(n)
}

/// Streams `text` and checks it against the whole parse; returns the segment count.
fn same_both_ways(text: &str) -> usize {
    let (a, b) = (
        whole("p.nc", text.as_bytes()),
        streamed("p.nc", text.as_bytes()),
    );
    assert_eq!(a.1, None, "{:?}", a.1);
    assert_eq!(b.1, None, "{:?}", b.1);
    assert!(a.0 == b.0, "segments differ");
    let c = streamed_checked("p.nc", text.as_bytes());
    assert_eq!(c.1, None, "{:?}", c.1);
    assert!(a.0 == c.0, "segments differ (checked)");
    b.0.len()
}

#[test]
fn goto_forward_and_backward_across_thousands_of_lines() {
    let text = format!(
        "#1=0\nGOTO 9000\n{}N9000 #1=#1+1\n{}IF [#1 LT 3] GOTO 9000\nN20 M30\n",
        filler(5000),
        filler(1500)
    );
    // The 5000 lines skipped by the forward GOTO never run; the loop runs 3 times.
    assert_eq!(same_both_ways(&text), 3 * 1500 + 1);
    // A target behind the GOTO that was never seen: searched forward, then from the start.
    let text = format!("N1 #2=#2+1\n{}IF [#2 LT 2] GOTO 1\nM30\n", filler(3000));
    assert_eq!(same_both_ways(&text), 2 * 3000 + 1);
    // Not there at all: the error at the GOTO's target.
    let (_, e) = streamed("p.nc", format!("{}GOTO 77\nM30\n", filler(100)).as_bytes());
    assert_eq!(
        e.as_deref(),
        Some("p.nc:101:6: sequence number N77 not found in the program p.nc (None) [GOTO 77]")
    );
}

#[test]
fn while_loops_nested_over_many_lines() {
    let text = format!(
        "#1=0\nWHILE [#1 LT 3] DO 1\n#2=0\nWHILE [#2 LT 2] DO 2\n{}#2=#2+1\nEND 2\n{}#1=#1+1\nEND 1\nM30\n",
        filler(700),
        filler(300)
    );
    assert_eq!(same_both_ways(&text), 3 * (2 * 700 + 300) + 1);
    // A loop whose condition is false at once skips its body.
    let text = format!("WHILE [0] DO 1\n{}END 1\nG0 X1\nM30\n", filler(2000));
    assert_eq!(same_both_ways(&text), 2);
}

#[test]
fn m98_and_m99_subprograms_in_a_streamed_file() {
    let text = format!(
        "O0001\nM98 P100 L3\nM98 P200\nN50 G90 G0 X0\nM30\n%\nO100\n{}M99\nO200\n{}M99 P50\n",
        filler(1000),
        filler(10)
    );
    assert_eq!(same_both_ways(&text), 3 * 1000 + 10 + 2);
}

#[test]
fn linuxcnc_o_word_subs_and_loops_in_a_streamed_file() {
    let text = format!(
        "(dialect: linuxcnc)\no100 sub\n{}o100 endsub\n#1=0\no101 while [#1 LT 2]\no100 call\n\
         o102 if [#1 EQ 0]\nG91 G1 Y1 F100\no102 elseif [#1 EQ 1]\nG91 G1 Y2 F100\no102 else\n\
         G91 G1 Y3 F100\no102 endif\n#1=[#1+1]\no101 endwhile\no103 repeat [3]\n{}o103 endrepeat\n\
         #2=0\no104 do\n#2=[#2+1]\no105 if [#2 EQ 2]\no104 continue\no105 endif\nG91 G1 Z0.001\n\
         o104 while [#2 LT 4]\nM2\n",
        filler(800),
        filler(50)
    );
    assert_eq!(same_both_ways(&text), 2 * (800 + 1) + 3 * 50 + 3 + 1);
}

/// A program of `n` lines (comments, with a move every 1000th line) whose line `bad` is
/// `bad_text`.
fn long_program(n: usize, bad: usize, bad_text: &str) -> String {
    let mut t = String::with_capacity(n * 8);
    t.push_str("G21 G90 F100\n");
    for i in 2..=n {
        if i == bad {
            t.push_str(bad_text);
        } else if i % 1000 == 0 {
            t.push_str("G91 G1 X0.01");
        } else {
            t.push_str("(c)");
        }
        t.push('\n');
    }
    t
}

#[test]
fn an_error_on_line_900000_names_that_line_and_its_block() {
    // A syntax error: found when the file is loaded, before any block runs.
    let text = long_program(900_010, 900_000, "G1 X Y2");
    let mut it = Interpreter::new(&cfg());
    let e = it
        .load_stream("big.nc", Box::new(Cursor::new(text.into_bytes())), None)
        .unwrap_err();
    assert_eq!(
        (e.line, e.col, e.block.as_str()),
        (900_000, 4, "G1 X Y2"),
        "{e}"
    );
    assert!(e.to_string().starts_with("big.nc:900000:4: "), "{e}");
    // An interpreter error: found when the block runs, after the moves before it.
    let text = long_program(900_010, 900_000, "G1 G7 X1");
    let mut it = Interpreter::new(&cfg());
    it.load_stream("big.nc", Box::new(Cursor::new(text.into_bytes())), None)
        .unwrap();
    let mut moves = 0;
    let e = loop {
        match it.next_segment() {
            Ok(Some(_)) => moves += 1,
            Ok(None) => panic!("no error"),
            Err(e) => break e,
        }
    };
    assert_eq!(moves, 899);
    assert_eq!((e.line, e.block.as_str()), (900_000, "G1 G7 X1"), "{e}");
    assert!(e.to_string().starts_with("big.nc:900000:"), "{e}");
}

/// Errors found at a later block about an earlier one point into the earlier block's line,
/// not into the window of the block at hand.
#[test]
fn an_unfinished_corner_is_reported_at_its_corner_word() {
    for text in [
        "G1 X10 Y0 ,R2 F100\nG0 X0\nM30\n",
        "G1 X10 Y0 F100\nG1 Y10 ,C1\n(end)\n",
    ] {
        let (a, b) = (
            whole("p.nc", text.as_bytes()),
            streamed("p.nc", text.as_bytes()),
        );
        assert!(a.1.is_some(), "{text}");
        assert_eq!(a, b, "{text}");
    }
}

#[test]
fn a_c_like_program_is_read_whole_and_runs_the_same() {
    let text = "int i;\nfor (i = 0; i < 3; i++) {\nG91 G1 X1 F100\n}\nM30\n";
    assert_eq!(same_both_ways(text), 4);
}
