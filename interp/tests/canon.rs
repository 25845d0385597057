//! The canonical layer: operations in work coordinates with the state they ran under, a
//! canned cycle kept whole (kind, words, holes, levels, tap plan), and lowering that adds the
//! offsets back and expands the cycle into exactly the segments the interpreter gives out.

use std::sync::Arc;

use cnc402_config::MachineConfig;
use cnc402_interp::Interpreter;
use cnc402_interp::canon::{CanonKind, CanonOp, PathMode};
use cnc402_interp::lower::{lower, xyz_indices};
use cnc402_lang::SourceFile;
use cnc402_motion::segment::{Segment, SegmentKind, SpindleDir};

const X: usize = 0;
const Y: usize = 1;
const Z: usize = 2;

fn interp(text: &str) -> Interpreter {
    let src = SourceFile::new("t.nc", text);
    let prog = cnc402_lang::parse(&src).unwrap_or_else(|e| panic!("{e}"));
    let mut it = Interpreter::new(&MachineConfig::default_machine());
    it.load(src, prog);
    it
}

fn canon(text: &str) -> Vec<CanonOp> {
    let mut it = interp(text);
    let mut ops = Vec::new();
    while let Some(op) = it.next_canon().unwrap_or_else(|e| panic!("{e}")) {
        ops.push(op);
    }
    ops
}

fn segments(text: &str) -> Vec<Segment> {
    let mut it = interp(text);
    let mut segs = Vec::new();
    while let Some(s) = it.next_segment().unwrap_or_else(|e| panic!("{e}")) {
        segs.push(s);
    }
    segs
}

fn lowered(ops: &[CanonOp]) -> Vec<Segment> {
    let xyz = xyz_indices(&MachineConfig::default_machine());
    let mut out = Vec::new();
    for op in ops {
        lower(op, xyz, &mut out);
    }
    out
}

fn cycles(ops: &[CanonOp]) -> Vec<(&CanonOp, &cnc402_interp::canon::CannedCycle)> {
    ops.iter()
        .filter_map(|op| match &op.kind {
            CanonKind::CannedCycle(c) => Some((op, c.as_ref())),
            _ => None,
        })
        .collect()
}

/// Under G55 (X + 100) and G43 H1 (tool length −180 on Z), a G81 block is one operation whose
/// holes and levels are the programmed work values; its state holds the offsets; lowering
/// puts the drill where the segments do.
#[test]
fn a_cycle_under_work_and_tool_offsets_keeps_work_values() {
    let prog =
        "G55 G90 G0 X0 Y0\nG43 H1 Z50\nM3 S1000\nG99 G81 X10 Y20 Z-5 R2 F100\nX30\nG80\nM30\n";
    let ops = canon(prog);
    let cyc = cycles(&ops);
    assert_eq!(cyc.len(), 2, "one operation per drilling block");
    let (op, c) = cyc[0];
    assert_eq!(c.code, 81);
    assert_eq!(c.holes, vec![[10.0, 20.0]]);
    assert_eq!((c.r_level, c.bottom, c.return_level), (2.0, -5.0, 2.0));
    assert_eq!(c.words.r, Some(2.0));
    assert_eq!(c.words.z, Some(-5.0));
    assert!(c.words.return_to_r);
    assert_eq!(op.state.work_offset, 1);
    assert_eq!(op.state.offset[X], 100.0);
    assert_eq!(op.state.offset[Z], -180.0);
    assert_eq!((op.state.tool_length_mode, op.state.h), (43, 1));
    assert_eq!(cyc[1].1.holes, vec![[30.0, 20.0]]);
    // Lowered: machine X = 110, bottom Z = −185.
    let segs = lowered(&ops);
    assert_eq!(segs, segments(prog));
    let bottom = segs
        .iter()
        .filter_map(|s| match s.kind {
            SegmentKind::Linear { end, .. } => Some(end),
            _ => None,
        })
        .next()
        .unwrap();
    assert_eq!((bottom[X], bottom[Y], bottom[Z]), (110.0, 20.0, -185.0));
}

/// G91 with K: the holes step from where the last one left the tool, one operation, K holes.
#[test]
fn g91_repeats_are_one_operation_with_every_hole() {
    let prog = "G90 G0 X0 Y0 Z10\nG91 G98 G81 X15 Z-8 R-7 K4 F200\nG80 G90\nM30\n";
    let ops = canon(prog);
    let cyc = cycles(&ops);
    assert_eq!(cyc.len(), 1);
    let c = cyc[0].1;
    assert_eq!(c.words.repeats, 4);
    assert!(c.words.incremental);
    assert_eq!(
        c.holes,
        vec![[15.0, 0.0], [30.0, 0.0], [45.0, 0.0], [60.0, 0.0]]
    );
    assert_eq!((c.r_level, c.bottom, c.return_level), (3.0, -5.0, 10.0));
    assert_eq!(lowered(&ops), segments(prog));
}

/// A G84 block carries its tap plan; lowering makes the tap segments with the signed pitch.
#[test]
fn a_tap_cycle_carries_its_plan_and_lowers_to_tap_segments() {
    let prog = "M3 S600\nG0 X0 Y0 Z10\nG98 G84 X5 Y5 Z-12 R3 Q4 F900\nG80\nM30\n";
    let ops = canon(prog);
    let c = cycles(&ops)[0].1;
    let t = c.tap.expect("a tap plan");
    assert_eq!(t.pitch, 1.5);
    assert_eq!(t.dir, SpindleDir::Cw);
    assert_eq!(t.peck, Some(4.0));
    let segs = lowered(&ops);
    assert_eq!(segs, segments(prog));
    let taps: Vec<_> = segs
        .iter()
        .filter_map(|s| match s.kind {
            SegmentKind::Tap(t) => Some(t),
            _ => None,
        })
        .collect();
    // In by 4, out by the peck retract, … to 15 mm below R, then out to R.
    assert!(taps.len() >= 4, "{taps:?}");
    assert!(taps.iter().all(|t| t.pitch == -1.5));
}

/// A programmed `G1 Z C` is one rigid-tap stroke; consecutive operations under the same
/// modes share one state; G61/G64 P are in it.
#[test]
fn rigid_tap_strokes_and_shared_states() {
    let ops = canon("G0 Z5\nG1 Z-3 C1440 F300\nG1 Z5 C0\nG61\nG1 X1\nG64 P0.05\nG1 X2\nM30\n");
    let strokes = ops
        .iter()
        .filter(|op| matches!(op.kind, CanonKind::Single(SegmentKind::Tap(_))))
        .count();
    assert_eq!(strokes, 2);
    assert!(Arc::ptr_eq(&ops[1].state, &ops[2].state));
    assert_eq!(ops[3].state.path_mode, PathMode::ExactStop);
    assert_eq!(
        ops[4].state.path_mode,
        PathMode::Continuous {
            tolerance: 0.05,
            collinear: 0.0
        }
    );
}

/// A cycle whose expansion leaves the soft limits is refused at the word to blame, and
/// nothing of the block is given out.
#[test]
fn a_cycle_past_the_soft_limits_is_an_error_at_its_word() {
    let mut it = interp("G0 X0 Y0 Z10\nG81 X10 Y10 Z-400 R2 F100\nM30\n");
    let mut n = 0;
    let err = loop {
        match it.next_canon() {
            Ok(Some(_)) => n += 1,
            Ok(None) => panic!("no error"),
            Err(e) => break e.to_string(),
        }
    };
    assert_eq!(n, 1, "only the G0 before it");
    assert!(err.contains("soft limits") && err.contains(":2:"), "{err}");
}
