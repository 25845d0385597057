//! Whole realistic programs, parsed and checked against the AST.

use cnc402_lang::ast::*;
use cnc402_lang::{SourceFile, parse};

fn load(name: &str) -> Program {
    let path = format!("{}/tests/programs/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    parse(&SourceFile::new(path, text)).unwrap_or_else(|e| panic!("{e}"))
}

fn block(l: &Line) -> &Block {
    match &l.kind {
        LineKind::Block(b) => b,
        k => panic!("line {}: not a block: {k:?}", l.line_no),
    }
}

/// The words of a block as `letter value` strings, for compact assertions.
fn text(l: &Line) -> String {
    block(l)
        .words
        .iter()
        .map(|w| match &w.value {
            Value::Number(n) => format!(
                "{}{}{}",
                w.letter,
                n.value,
                if n.has_point { "." } else { "" }
            ),
            Value::Expr(_) => format!("{}[..]", w.letter),
        })
        .collect::<Vec<_>>()
        .join(" ")
}

#[test]
fn fanuc_drilling_program() {
    let p = load("fanuc_drilling.nc");
    assert_eq!(p.lines.len(), 31);
    assert_eq!(p.lines[0].kind, LineKind::Percent);
    assert_eq!(p.lines[30].kind, LineKind::Percent);
    match &p.lines[1].kind {
        LineKind::ProgramNumber { number, .. } => assert_eq!(*number, 1001),
        k => panic!("{k:?}"),
    }
    assert_eq!(
        p.lines[1].comments[0].text,
        "FANUC DRILLING - 4 HOLES, PECK AND TAP"
    );
    // Every block after the header has an N number in steps of 10.
    for (k, l) in p.lines[2..30].iter().enumerate() {
        assert_eq!(
            l.n.map(|n| n.value),
            Some(10 * (k as u32 + 1)),
            "line {}",
            l.line_no
        );
    }
    assert_eq!(text(&p.lines[2]), "G21 G17 G40 G49 G80 G90");
    assert_eq!(text(&p.lines[6]), "G99 G81 X20. Y20. Z-3. R2. F120");
    assert_eq!(text(&p.lines[16]), "G99 G83 X20. Y20. Z-25. R2. Q5. F90");
    assert_eq!(p.lines[17].comments[0].text, " second hole");
    assert!(p.lines[19].block_delete);
    assert_eq!(p.lines[19].n.map(|n| n.value), Some(180));
    assert!(p.lines.iter().filter(|l| l.block_delete).count() == 1);
    assert_eq!(text(&p.lines[25]), "G99 G84 X20. Y20. Z-18. R5. F375");
    assert_eq!(text(&p.lines[28]), "G4 P500");
    // The span of a word is exactly its text.
    let src = std::fs::read_to_string(format!(
        "{}/tests/programs/fanuc_drilling.nc",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    let w = &block(&p.lines[25]).words[4];
    assert_eq!(&src[w.span.range()], "Z-18.");
}

#[test]
fn linuxcnc_contour() {
    let p = load("linuxcnc_contour.ngc");
    assert_eq!(p.lines.len(), 22);
    assert_eq!(p.lines[0].kind, LineKind::Empty);
    assert_eq!(p.lines[1].comments[0].text, "Tool: 6 mm end mill");
    assert_eq!(text(&p.lines[2]), "G21 G17 G90 G94");
    assert_eq!(text(&p.lines[10]), "G3 X20 Y-5 I0 J5");
    assert_eq!(text(&p.lines[12]), "G3 X15 Y15 R5");
    assert_eq!(text(&p.lines[17]), "G2 X-15 Y-10 I0 J12.5. Z-2.");
    assert_eq!(text(&p.lines[18]), "G1 X[..] Y[..]");
    let w = &block(&p.lines[18]).words;
    let Value::Expr(e) = &w[1].value else {
        panic!()
    };
    let ExprKind::Binary(BinaryOp::Add, a, b) = &e.kind else {
        panic!("{e:?}")
    };
    assert!(matches!(a.kind, ExprKind::Unary(UnaryOp::Neg, _)));
    assert_eq!(b.kind, ExprKind::Number(5.0));
    let moves = p
        .lines
        .iter()
        .filter(|l| matches!(&l.kind, LineKind::Block(b) if b.words[0].letter == 'G'))
        .count();
    assert_eq!(moves, 16);
}
