//! The multi-pass tapping cycle of source 000 (`examples/axioma/metch_cycles.c`), from the
//! segment stream: passes, depths, step-backs, the spindle angle of every block, the
//! `@ITPPATH` check, parameter errors before any motion; and one run through `cnc402 run`
//! for the coupling at every tick.

use cnc402_config::MachineConfig;
use cnc402_interp::{Interpreter, hll};
use cnc402_lang::SourceFile;
use cnc402_motion::segment::{Segment, SegmentKind};

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/..");

fn shipped() -> MachineConfig {
    MachineConfig::load(format!("{ROOT}/config/machine.toml")).unwrap()
}
fn axioma() -> MachineConfig {
    MachineConfig::load(format!("{ROOT}/examples/axioma/machine.toml")).unwrap()
}

/// Runs `text` as if it were the file `examples/axioma/<name>`; every item, and the
/// interpreter (for the globals).
fn run_text(
    cfg: &MachineConfig,
    name: &str,
    text: &str,
) -> (Vec<Result<Segment, String>>, Interpreter) {
    let src = SourceFile::new(format!("{ROOT}/examples/axioma/{name}"), text);
    let prog = cnc402_lang::parse(&src).unwrap_or_else(|e| panic!("{e}"));
    let mut it = Interpreter::new(cfg);
    // `#use` files come from the file system (next to the file, then library_dir).
    it.set_program_library(Some(Box::new(
        cnc402_interp::host_fs::FsLibrary::from_config(cfg),
    )));
    it.load(src, prog);
    let mut out = Vec::new();
    loop {
        match it.next_segment() {
            Ok(Some(s)) => out.push(Ok(s)),
            Ok(None) => break,
            Err(e) => {
                out.push(Err(e.to_string()));
                break;
            }
        }
    }
    (out, it)
}

fn run_file(cfg: &MachineConfig, name: &str) -> (Vec<Result<Segment, String>>, Interpreter) {
    let text = std::fs::read_to_string(format!("{ROOT}/examples/axioma/{name}")).unwrap();
    run_text(cfg, name, &text)
}

fn ok(v: Vec<Result<Segment, String>>) -> Vec<Segment> {
    v.into_iter()
        .map(|r| r.unwrap_or_else(|e| panic!("{e}")))
        .collect()
}

const Z: usize = 2;
const C: usize = 3;

/// (start Z, end Z, start C, end C, feed) of every coupled G1 (Z and C both move): each is a
/// `Tap` segment of Z with C whose pitch is the block's ΔZ/ΔC·360; no plain feed moves both.
fn coupled(segs: &[Segment]) -> Vec<(f64, f64, f64, f64, f64)> {
    let mut pos = [0.0f64; 8];
    let mut out = Vec::new();
    for s in segs {
        match &s.kind {
            SegmentKind::Linear { end, .. } => {
                assert!(
                    end[Z] == pos[Z] || end[C] == pos[C],
                    "a coupled G1 left as a plain feed: {s:?}"
                );
                pos.copy_from_slice(&end.0);
            }
            SegmentKind::Tap(t) => {
                let end = &t.end;
                assert_eq!((t.tool, t.spindle), (Z as u8, C as u8));
                let pitch = (end[Z] - pos[Z]) / (end[C] - pos[C]) * 360.0;
                assert_eq!(t.pitch, pitch, "{s:?}");
                out.push((pos[Z], end[Z], pos[C], end[C], t.feed));
                pos.copy_from_slice(&end.0);
            }
            SegmentKind::Rapid { end } => pos.copy_from_slice(&end.0),
            _ => {}
        }
    }
    out
}

fn assert_spindle_exact(blocks: &[(f64, f64, f64, f64, f64)], pitch: f64) {
    for &(z0, z1, c0, c1, _) in blocks {
        let want = -(z1 - z0) / pitch * 360.0;
        assert!(
            ((c1 - c0) - want).abs() < 1e-9,
            "Z {z0}->{z1}: spindle turned {} deg, not {want}",
            c1 - c0
        );
    }
}

#[test]
fn multipass_example_makes_four_passes_with_a_shorter_last_one() {
    let (items, it) = run_file(&shipped(), "multipass_tap.nc");
    let segs = ok(items);
    let blocks = coupled(&segs);
    // in 12, out 2, in to 20, out 2, in to 28, out 2, in to 30, out to 5
    let cuts: Vec<_> = blocks.iter().filter(|b| b.1 < b.0).collect();
    let outs: Vec<_> = blocks.iter().filter(|b| b.1 > b.0).collect();
    assert_eq!(cuts.len(), 4);
    let depths: Vec<f64> = cuts.iter().map(|b| b.1).collect();
    assert_eq!(depths, vec![-12.0, -20.0, -28.0, -30.0]);
    // The first pass starts at the safe distance; later ones where the step-back left the tap.
    assert_eq!(cuts[0].0, 5.0);
    let backs: Vec<f64> = outs.iter().map(|b| b.1 - b.0).collect();
    assert_eq!(backs, vec![2.0, 2.0, 2.0, 35.0]);
    assert!(cuts.iter().all(|b| b.4 == 300.0) && outs.iter().all(|b| b.4 == 600.0));
    assert_spindle_exact(&blocks, 1.5);
    // The first cut: 17 mm = 11.33 turns = 4080 degrees; the spindle ends where it started.
    assert!((blocks[0].3 - 4080.0).abs() < 1e-9);
    assert!(blocks.last().unwrap().3.abs() < 1e-9);
    // Up to the retract plane at the end, and the @ITPPATH check passed (no terminate).
    let Some(SegmentKind::Rapid { end }) = segs.iter().rev().find_map(|s| match &s.kind {
        k @ SegmentKind::Rapid { .. } => Some(k.clone()),
        _ => None,
    }) else {
        panic!()
    };
    assert_eq!(end[Z], 40.0);
    assert_eq!(hll::global_number(&it, "nTapPasses", None), Some(4.0));
    assert_eq!(hll::global_number(&it, "dTapDepth", Some(4)), Some(30.0));
    let expected = hll::global_number(&it, "dPerm", Some(2)).unwrap();
    // 40 (start) + 35 down + 17 + 2 + 10 + 2 + 10 + 2 + 4 + 35 + 35 up
    assert!((expected - 192.0).abs() < 1e-9, "{expected}");
    assert!((it.path_length() - expected).abs() < 1e-9);
    assert!(hll::global_number(&it, "dPerm", Some(3)).unwrap() < 1e-9);
    assert!(segs.iter().any(
        |s| matches!(&s.kind, SegmentKind::Message { text } if text == "passes: 4, path 192 mm")
    ));
}

#[test]
fn source_000_main_program_runs_as_printed_with_one_clipped_pass() {
    let (items, it) = run_file(&axioma(), "source_000_main.nc");
    let segs = ok(items);
    // dDepth 20, dStep1 60: one pass to the thread length, announced by a message.
    assert!(
        segs.iter().any(|s| matches!(&s.kind,
        SegmentKind::Message { text } if text == "Tapping: dStep1 60 > dDepth 20: one pass to 20"))
    );
    let blocks = coupled(&segs);
    assert_eq!(blocks.len(), 2);
    assert_eq!((blocks[0].0, blocks[0].1), (50.0, -20.0));
    assert_eq!((blocks[1].0, blocks[1].1), (-20.0, 50.0));
    assert_spindle_exact(&blocks, 20.0);
    assert!((blocks[0].3 - 1260.0).abs() < 1e-9);
    assert!(matches!(
        segs.last().unwrap().kind,
        SegmentKind::Stop { .. }
    ));
    // 200 to the start plane, 150 down, 70 in, 70 out, 150 up.
    assert!((it.path_length() - 640.0).abs() < 1e-9);
    assert!(hll::global_number(&it, "dPerm", Some(3)).unwrap() < 1e-9);
    // On the shipped machine (Z max 50) the source's retract plane Z200 is a soft-limit error.
    let (items, _) = run_file(&shipped(), "source_000_main.nc");
    let e = items.last().unwrap().as_ref().unwrap_err();
    assert!(
        e.contains("metch_cycles.c:") && e.contains("Z 200 is outside the soft limits"),
        "{e}"
    );
}

#[test]
fn exit_step_mode_backs_out_to_the_exit_point_between_passes() {
    let text = "#use \"metch_cycles.c\"\nTapping(\"Z\", \"C\", 20, 0, 3, 25, 10, 0, 10, 1.25, 250, 500, 1, 20);\nM30\n";
    let (items, it) = run_text(&shipped(), "exit.nc", text);
    let segs = ok(items);
    let blocks = coupled(&segs);
    let cuts: Vec<f64> = blocks.iter().filter(|b| b.1 < b.0).map(|b| b.1).collect();
    assert_eq!(cuts, vec![-10.0, -20.0, -25.0]);
    let outs: Vec<f64> = blocks.iter().filter(|b| b.1 > b.0).map(|b| b.1).collect();
    assert_eq!(outs, vec![1.0, 1.0, 3.0]);
    assert_spindle_exact(&blocks, 1.25);
    assert!((it.path_length() - hll::global_number(&it, "dTapPath", None).unwrap()).abs() < 1e-9);
}

#[test]
fn single_pass_when_the_first_pass_is_the_thread_length() {
    let text = "#use \"metch_cycles.c\"\nTapping(\"Z\", \"C\", 10, -5, 2, 8, 8, 1, 0, 1, 100, 200, 0, 10);\nM30\n";
    let (items, _) = run_text(&shipped(), "single.nc", text);
    let segs = ok(items);
    let blocks = coupled(&segs);
    assert_eq!(blocks.len(), 2);
    assert_eq!((blocks[0].0, blocks[0].1), (-3.0, -13.0));
    assert_spindle_exact(&blocks, 1.0);
    assert!(
        !segs
            .iter()
            .any(|s| matches!(s.kind, SegmentKind::Message { .. }))
    );
}

#[test]
fn wrong_parameters_stop_before_any_motion() {
    let cases = [
        (
            "1.5, 300, 600",
            "\"Z\", \"C\"",
            "30, 12, 2, 8",
            "terminate 5561",
        ),
        // pitch 0 and negative
        (
            "0, 300, 600",
            "\"Z\", \"C\"",
            "30, 12, 2, 8",
            "terminate 5561: Tapping: dPitch must be > 0",
        ),
        (
            "-1, 300, 600",
            "\"Z\", \"C\"",
            "30, 12, 2, 8",
            "terminate 5561",
        ),
        // feed 0
        (
            "1.5, 0, 600",
            "\"Z\", \"C\"",
            "30, 12, 2, 8",
            "terminate 5562",
        ),
        (
            "1.5, 300, 0",
            "\"Z\", \"C\"",
            "30, 12, 2, 8",
            "terminate 5562",
        ),
        // passes <= 0
        (
            "1.5, 300, 600",
            "\"Z\", \"C\"",
            "30, 0, 2, 8",
            "terminate 5563",
        ),
        (
            "1.5, 300, 600",
            "\"Z\", \"C\"",
            "30, 12, 2, 0",
            "terminate 5564",
        ),
        (
            "1.5, 300, 600",
            "\"Z\", \"C\"",
            "30, 12, 2, -8",
            "terminate 5564",
        ),
        // unknown axis names
        (
            "1.5, 300, 600",
            "\"Q\", \"C\"",
            "30, 12, 2, 8",
            "unknown axis name \"Q\" (this machine has X Y Z C)",
        ),
        (
            "1.5, 300, 600",
            "\"Z\", \"W\"",
            "30, 12, 2, 8",
            "unknown axis name \"W\"",
        ),
        (
            "1.5, 300, 600",
            "\"Z\", \"Z\"",
            "30, 12, 2, 8",
            "terminate 5560",
        ),
    ];
    for (i, (pitch_feeds, axes, steps, want)) in cases.iter().enumerate() {
        let v: Vec<&str> = steps.split(", ").collect();
        let text = format!(
            "#use \"metch_cycles.c\"\nG90\nTapping({axes}, 40, 0, 5, {}, {}, {}, {}, {pitch_feeds}, 2, 40);\nM02\n",
            v[0], v[1], v[2], v[3]
        );
        let (items, _) = run_text(&shipped(), "bad.nc", &text);
        if i == 0 {
            assert!(items.iter().all(|r| r.is_ok()), "the good call runs");
            continue;
        }
        assert_eq!(
            items.len(),
            1,
            "{want}: no segment before the error: {items:?}"
        );
        let e = items[0].as_ref().unwrap_err();
        assert!(e.contains(want), "{e}\n wanted {want}");
        assert!(e.contains("metch_cycles.c:"), "{e}");
    }
}
