//! The toolpath of real programs through the interpreter: positions and arc centres go back to
//! each block's work coordinates (`Interpreter::next_lowered` hands out the state every
//! segment was lowered under), or stay in machine coordinates; cycles come expanded.

use cnc402_config::MachineConfig;
use cnc402_inspect::geom::Shape;
use cnc402_inspect::{Frame, PieceKind, Toolpath};
use cnc402_lang::SourceFile;

fn machine() -> MachineConfig {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../config/machine.toml");
    MachineConfig::load(std::path::Path::new(path)).unwrap()
}

fn toolpath(text: &str, frame: Frame) -> Toolpath {
    let cfg = machine();
    let src = SourceFile::new("t.nc", text);
    let ast = cnc402_interp::parse_program(&cfg, &src, None).unwrap();
    let mut interp = cnc402_interp::Interpreter::new(&cfg);
    interp.load(src, ast);
    Toolpath::collect(&cfg, &mut interp, frame, 10_000)
}

// G55: work zero at machine X100 (config/machine.toml); G43 H1: tool 1's length, -180, on Z.
const ARC_IN_G55: &str = "G90 G55 G0 X0 Y0\nG43 H1 Z5\nG1 Z-1 F100\nG2 X20 Y0 I10 J0\nG0 Z5\nM30\n";

#[test]
fn work_coordinates_are_each_blocks_own() {
    let tp = toolpath(ARC_IN_G55, Frame::Work);
    assert!(tp.error.is_none());
    let arc = tp
        .pieces
        .iter()
        .find(|p| matches!(p.path.shape, Shape::Arc { .. }))
        .unwrap();
    assert_eq!(arc.path.start, [0.0, 0.0, -1.0]);
    assert_eq!(arc.path.end, [20.0, 0.0, -1.0]);
    let Shape::Arc { center, .. } = arc.path.shape else {
        unreachable!()
    };
    assert_eq!(&center[..2], &[10.0, 0.0]);
    assert_eq!(arc.offset, [100.0, 0.0, -180.0]);
    // The clockwise half circle from X0 to X20 around X10 passes Y+10.
    assert!((arc.path.point(0.5)[1] - 10.0).abs() < 1e-9);
    assert_eq!(tp.blocks[arc.block].line, 4);
}

#[test]
fn machine_coordinates_carry_the_offsets() {
    let tp = toolpath(ARC_IN_G55, Frame::Machine);
    let arc = tp
        .pieces
        .iter()
        .find(|p| matches!(p.path.shape, Shape::Arc { .. }))
        .unwrap();
    assert_eq!(arc.path.start, [100.0, 0.0, -181.0]);
    let Shape::Arc { center, .. } = arc.path.shape else {
        unreachable!()
    };
    assert_eq!(&center[..2], &[110.0, 0.0]);
    // The first move starts at machine zero.
    assert_eq!(tp.pieces[0].path.start, [0.0; 3]);
}

#[test]
fn a_canned_cycle_is_its_moves_and_an_error_ends_the_path() {
    let tp = toolpath(
        "G90 G0 X0 Y0 Z10\nG99 G81 X5 Y5 Z-3 R2 F100\nX15\nG80\nG1 X400\n",
        Frame::Work,
    );
    let drilled: Vec<_> = tp
        .pieces
        .iter()
        .filter(|p| p.kind == PieceKind::Feed && p.path.end[2] == -3.0)
        .map(|p| (tp.blocks[p.block].line, p.path.end))
        .collect();
    assert_eq!(drilled, vec![(2, [5.0, 5.0, -3.0]), (3, [15.0, 5.0, -3.0])]);
    let e = tp.error.expect("X400 is beyond the soft limit");
    assert_eq!(e.line, 5);
    assert!(tp.pieces.iter().all(|p| tp.blocks[p.block].line < 5));
}
