//! Two spindles (source 001's machine, `examples/two-spindles/machine.toml`: C is spindle 1,
//! U spindle 2): Fanuc's `P` selects the spindle of an S/M3/M4/M5/M19 block and stays
//! selected, LinuxCNC's `$` selects it for its block, and taps and cycles act on the
//! selected spindle's axis. The segment dump names the spindle only when it is not 1.

use cnc402_config::MachineConfig;
use cnc402_interp::dump::segments_to_jsonl;
use cnc402_interp::run_program;
use cnc402_lang::SourceFile;
use cnc402_motion::segment::{Segment, SegmentKind, SpindleDir};

const Z: usize = 2;
const C: usize = 5;
const U: usize = 6;

fn machine() -> MachineConfig {
    let text = include_str!("../../examples/two-spindles/machine.toml");
    MachineConfig::parse(
        text,
        std::path::Path::new("examples/two-spindles/machine.toml"),
    )
    .unwrap()
}

fn run(text: &str) -> Vec<Segment> {
    run_program(&machine(), &SourceFile::new("t.nc", text)).unwrap_or_else(|e| panic!("{e}"))
}

fn err(cfg: &MachineConfig, text: &str) -> String {
    match run_program(cfg, &SourceFile::new("t.nc", text)) {
        Ok(s) => panic!("accepted: {s:?}"),
        Err(e) => e.to_string(),
    }
}

/// (rpm, dir, spindle) of every spindle segment.
fn spindles(segs: &[Segment]) -> Vec<(f64, SpindleDir, u8)> {
    segs.iter()
        .filter_map(|s| match s.kind {
            SegmentKind::Spindle { rpm, dir, spindle } => Some((rpm, dir, spindle)),
            _ => None,
        })
        .collect()
}

#[test]
fn p_selects_the_spindle_and_stays_selected() {
    use SpindleDir::*;
    let segs = run("M3 S1000\nM4 S2000 P2\nS2500\nM5\nM5 P1\nS300\nM3\nM30\n");
    assert_eq!(
        spindles(&segs),
        vec![
            (1000.0, Cw, 1),
            (2000.0, Ccw, 2),
            (2500.0, Ccw, 2), // S alone: the selected spindle 2's new speed
            (0.0, Stop, 2),
            (0.0, Stop, 1),
            (300.0, Cw, 1), // spindle 1 keeps its own S (300 set while stopped)
        ]
    );
}

#[test]
fn the_dump_names_the_spindle_only_when_it_is_not_the_first() {
    let cfg = machine();
    let segs = run("M3 S1000\nM4 S2000 P2\nM19\nM30\n");
    let dump = segments_to_jsonl(&segs, &cfg);
    let lines: Vec<&str> = dump.lines().collect();
    assert!(
        lines[0].contains("\"rpm\":1000,\"dir\":\"cw\",\"ends\""),
        "{}",
        lines[0]
    );
    assert!(
        lines[1].contains("\"rpm\":2000,\"dir\":\"ccw\",\"spindle\":2,"),
        "{}",
        lines[1]
    );
    // M19 of spindle 2: stop, then orient, both on spindle 2.
    assert!(
        lines[2].contains("\"dir\":\"stop\",\"spindle\":2,"),
        "{}",
        lines[2]
    );
    assert!(
        lines[3].contains("\"kind\":\"spindle_orient\"") && lines[3].contains("\"spindle\":2,"),
        "{}",
        lines[3]
    );
}

#[test]
fn a_dwell_or_cycle_keeps_its_own_p() {
    let segs = run("M3 S1000 P2\nG4 P500 S800\nM30\n");
    assert_eq!(
        spindles(&segs)[1],
        (800.0, SpindleDir::Cw, 2),
        "S on spindle 2"
    );
    assert!(
        segs.iter()
            .any(|s| s.kind == SegmentKind::Dwell { seconds: 0.5 }),
        "P500 is the dwell"
    );
    // In a cycle block P is the dwell at the bottom; the tap couples the selected spindle.
    let segs = run("G0 Z10\nM29 S600 P2\nG84 X0 Y0 Z-5 R2 P300 F900 S600\nM30\n");
    assert!(
        segs.iter()
            .any(|s| s.kind == SegmentKind::Dwell { seconds: 0.3 })
    );
    let taps: Vec<_> = segs
        .iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Tap(t) => Some(t),
            _ => None,
        })
        .collect();
    assert_eq!(taps.len(), 2);
    for t in taps {
        assert_eq!((t.tool as usize, t.spindle as usize), (Z, U));
        assert_eq!(t.end[C], 0.0, "spindle 1 does not turn");
        assert!((t.pitch.abs() - 1.5).abs() < 1e-12, "{t:?}");
    }
}

#[test]
fn a_g1_with_the_second_spindles_letter_taps_with_it() {
    let segs = run("G0 Z2\nG1 Z-10 U4320 F750\nM30\n");
    let tap = segs
        .iter()
        .find_map(|s| match &s.kind {
            SegmentKind::Tap(t) => Some(*t),
            _ => None,
        })
        .expect("a tap");
    assert_eq!((tap.tool as usize, tap.spindle as usize), (Z, U));
    assert!((tap.pitch + 1.0).abs() < 1e-12, "{tap:?}");
}

/// As LinuxCNC's `rs274 -i` with `[TRAJ] SPINDLES = 2` runs this program:
/// SET_SPINDLE_SPEED(1, 1000) START_SPINDLE_CLOCKWISE(1), SET_SPINDLE_SPEED(0, 1200),
/// SET_SPINDLE_SPEED(0, 500) START_SPINDLE_COUNTERCLOCKWISE(0), STOP_SPINDLE_TURNING(1).
#[test]
fn linuxcnc_dollar_selects_the_spindle_of_its_block_only() {
    use SpindleDir::*;
    let segs = run("(dialect: linuxcnc)\nM3 S1000 $1\nS1200\nM4 S500 $0\nM5 $1\nM2\n");
    assert_eq!(
        spindles(&segs),
        // S1200 without `$` is spindle 1's speed, stored while it stands.
        vec![(1000.0, Cw, 2), (500.0, Ccw, 1), (0.0, Stop, 2)]
    );
    let e = err(&machine(), "(dialect: linuxcnc)\nM3 S1000 $2\nM2\n");
    assert!(e.contains("$2 is not a spindle"), "{e}");
    // `$-1`: every spindle (rs274: SET_SPINDLE_SPEED(0 and 1, 1000), START_SPINDLE_CLOCKWISE
    // (0 and 1), SET_SPINDLE_SPEED(0 and 1, 500), STOP_SPINDLE_TURNING(0 and 1)); not M19.
    let segs = run("(dialect: linuxcnc)\nM3 S1000 $-1\nS500 $-1\nM5 $-1\nM3\nM2\n");
    assert_eq!(
        spindles(&segs),
        vec![
            (1000.0, Cw, 1),
            (1000.0, Cw, 2),
            (500.0, Cw, 1),
            (500.0, Cw, 2),
            (0.0, Stop, 1),
            (0.0, Stop, 2),
            (500.0, Cw, 1), // the next block is spindle 1 again
        ]
    );
    let e = err(&machine(), "(dialect: linuxcnc)\nM19 R30 $-1\nM2\n");
    assert!(e.contains("M19 orients one spindle"), "{e}");
    let e = err(&machine(), "(dialect: linuxcnc)\nG0 X1 $1\nM2\n");
    assert!(e.contains("spindle selection without S"), "{e}");
}

#[test]
fn each_spindle_is_checked_on_its_own_axis() {
    let cfg = machine();
    // Spindle 2's max_rpm is 4000, spindle 1's 6000.
    let e = err(&cfg, "M3 S5000 P2\nM30\n");
    assert!(
        e.contains("S5000 is above the spindle's max_rpm 4000"),
        "{e}"
    );
    run("M3 S5000 P1\nM30\n");
    // U cannot be positioned while spindle 2 turns; C can while only spindle 2 turns.
    let e = err(&cfg, "M3 S1000 P2\nG0 U90\nM30\n");
    assert!(e.contains("U positioning while the spindle turns"), "{e}");
    run("M3 S1000 P2\nG0 C90\nM30\n");
    // G28 U orients spindle 2 (program U reads its reference).
    let segs = run("G28 U0\nM30\n");
    assert!(segs.iter().any(|s| matches!(
        s.kind,
        SegmentKind::SpindleOrient {
            program: Some(_),
            spindle: 2,
            ..
        }
    )));
    // One spindle: P2 names none.
    let one = MachineConfig::default_machine();
    let e = err(&one, "M3 S1000 P2\nM30\n");
    assert!(e.contains("spindle 2 is not configured"), "{e}");
}

#[test]
fn the_canonical_dump_names_a_cycles_second_spindle() {
    let cfg = machine();
    let canon = |text: &str| {
        let src = SourceFile::new("t.nc", text);
        let p = cnc402_lang::parse(&src).unwrap();
        let mut it = cnc402_interp::Interpreter::new(&cfg);
        it.load(src, p);
        let mut ops = Vec::new();
        while let Some(op) = it.next_canon().unwrap() {
            ops.push(op);
        }
        cnc402_interp::dump::canon::canon_to_jsonl(&ops, &cfg)
    };
    let cycle = |dump: String| {
        dump.lines()
            .find(|l| l.contains("\"op\":\"canned_cycle\""))
            .unwrap()
            .to_string()
    };
    let two = cycle(canon("G0 Z10\nM29 S600 P2\nG84 X0 Y0 Z-5 R2 F900\nM30\n"));
    assert!(
        two.contains("\"peck_retract\":0.5},\"spindle\":2,"),
        "{two}"
    );
    let one = cycle(canon("G0 Z10\nM29 S600\nG84 X0 Y0 Z-5 R2 F900\nM30\n"));
    assert!(!one.contains("\"spindle\""), "{one}");
}

/// Haas's `M19 P…` is an orientation angle: no spindle selection there.
#[test]
fn haas_m19_p_is_not_a_spindle_selection() {
    let e = err(&machine(), "(dialect: haas)\nM19 P2\nM30\n");
    assert!(!e.contains("spindle"), "{e}");
    let segs = run("(dialect: haas)\nM3 S100 P2\nM30\n");
    assert_eq!(spindles(&segs), vec![(100.0, SpindleDir::Cw, 2)]);
}

/// A channel that owns spindle 2 starts its programs on it (`Options::default_spindle`);
/// a number the machine lacks leaves spindle 1.
#[test]
fn a_program_may_start_on_spindle_2() {
    let cfg = machine();
    let on = |default_spindle: u8, text: &str| {
        let opts = cnc402_interp::Options {
            default_spindle,
            ..Default::default()
        };
        let segs = cnc402_interp::run_program_with(&cfg, opts, &SourceFile::new("t.nc", text))
            .unwrap_or_else(|e| panic!("{e}"));
        spindles(&segs)
    };
    assert_eq!(on(2, "M3 S1000\nM30\n"), vec![(1000.0, SpindleDir::Cw, 2)]);
    assert_eq!(
        on(2, "M3 S1000 P1\nM30\n"),
        vec![(1000.0, SpindleDir::Cw, 1)]
    );
    let lc = "(dialect: linuxcnc)\nM3 S1000\nM2\n";
    assert_eq!(on(2, lc), vec![(1000.0, SpindleDir::Cw, 2)]);
    assert_eq!(on(7, "M3 S1000\nM30\n"), vec![(1000.0, SpindleDir::Cw, 1)]);
    assert_eq!(on(0, "M3 S1000\nM30\n"), vec![(1000.0, SpindleDir::Cw, 1)]);
}

/// Source 000's `Tapping(strToolAx, strSpindleAx, …)` names the spindle by its axis letter:
/// with "U" every pass couples Z with spindle 2.
#[test]
fn the_c_like_tapping_cycle_taps_with_the_spindle_it_names() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/axioma");
    let text = std::fs::read_to_string(format!("{dir}/multipass_tap.nc"))
        .unwrap()
        .replace("Tapping(\"Z\", \"C\",", "Tapping(\"Z\", \"U\",");
    assert!(text.contains("\"U\""));
    let cfg = machine();
    let src = SourceFile::new(format!("{dir}/t.nc"), text.as_str());
    let prog = cnc402_lang::parse(&src).unwrap_or_else(|e| panic!("{e}"));
    let mut it = cnc402_interp::Interpreter::new(&cfg);
    // `#use` files come from the file system, next to the program.
    it.set_program_library(Some(Box::new(
        cnc402_interp::host_fs::FsLibrary::from_config(&cfg),
    )));
    it.load(src, prog);
    let mut taps = Vec::new();
    while let Some(s) = it.next_segment().unwrap_or_else(|e| panic!("{e}")) {
        if let SegmentKind::Tap(t) = s.kind {
            taps.push(t);
        }
    }
    assert!(taps.len() >= 8, "{}", taps.len());
    for t in taps {
        assert_eq!((t.tool as usize, t.spindle as usize), (Z, U));
        assert_eq!(t.end[C], 0.0);
    }
}
