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

/// Renders an expression in Fanuc syntax, fully bracketed, for compact assertions.
fn ex(e: &Expr) -> String {
    match &e.kind {
        ExprKind::Number(v) => format!("{v}"),
        ExprKind::Var(n) => format!("#{n}"),
        ExprKind::IndirectVar(e) => format!("#[{}]", ex(e)),
        ExprKind::Unary(UnaryOp::Neg, a) => format!("-{}", ex(a)),
        ExprKind::Unary(UnaryOp::Plus, a) => format!("+{}", ex(a)),
        ExprKind::Binary(op, a, b) => {
            format!("[{} {} {}]", ex(a), format!("{op:?}").to_uppercase(), ex(b))
        }
        ExprKind::Call(f, args) => format!(
            "{}[{}]",
            format!("{f:?}").to_uppercase(),
            args.iter().map(ex).collect::<Vec<_>>().join(",")
        ),
        other => format!("{other:?}"),
    }
}

/// A line in a normalised Fanuc form: statements spelled out, words with `letter value`.
fn show(kind: &LineKind) -> String {
    match kind {
        LineKind::Empty => String::new(),
        LineKind::Percent => "%".into(),
        LineKind::ProgramNumber { number, .. } => format!("O{number}"),
        LineKind::Block(b) => b
            .words
            .iter()
            .map(|w| match &w.value {
                Value::Number(n) => format!("{}{}", w.letter, n.value),
                Value::Expr(e) => format!("{}{}", w.letter, ex(e)),
            })
            .collect::<Vec<_>>()
            .join(" "),
        LineKind::Assign { target, value } => format!("{}={}", ex(target), ex(value)),
        LineKind::Goto { target } => format!("GOTO {}", ex(target)),
        LineKind::IfGoto { cond, target } => format!("IF{} GOTO {}", ex(cond), ex(target)),
        LineKind::IfThen { cond, then } => format!("IF{} THEN {}", ex(cond), show(then)),
        LineKind::While { cond, id } => format!("WHILE{} DO{id}", ex(cond)),
        LineKind::End { id } => format!("END{id}"),
        other => format!("{other:?}"),
    }
}

#[test]
fn mlt980_main_program_o0001_as_printed() {
    let p = load("mlt980_O0001.nc");
    let shown: Vec<String> = p
        .lines
        .iter()
        .map(|l| match l.n {
            Some(n) => format!("N{} {}", n.value, show(&l.kind))
                .trim_end()
                .to_string(),
            None => show(&l.kind),
        })
        .collect();
    let want = [
        "O1",
        "#113=#0",
        "#114=#0",
        "#115=#0",
        "#116=#0",
        "#100=#4001",
        "#101=#4002",
        "#103=#4005",
        "#104=#4007",
        "#105=#4014",
        "#106=#4016",
        "#107=#4109",
        "#108=#4119",
        "#109=#4120",
        "IF[#520 EQ 3] THEN #113=1",
        "IF[#520 EQ 4] THEN #114=1",
        "IF[[#113 OR #114] NE 1] GOTO 101",
        "IF[#524 EQ 98] THEN #115=1",
        "IF[#524 EQ 99] THEN #116=1",
        "IF[[#115 OR #116] NE 1] GOTO 102",
        "IF[#530 EQ 1] GOTO 1",
        "IF[#530 EQ 2] GOTO 2",
        "IF[#530 EQ 3] GOTO 3",
        "IF[#530 EQ 4] GOTO 4",
        "IF[#530 EQ 5] GOTO 5",
        "GOTO 6",
        "N1 M98 P9001",
        "GOTO 100",
        "N2 M98 P9002",
        "GOTO 100",
        "N3 M98 P9003",
        "GOTO 100",
        "N4 M98 P9004",
        "GOTO 100",
        "N5 M98 P9005",
        "GOTO 100",
        "N6 M98 P9006",
        "N100",
        // Bracket groups are not nodes: `G[FUP[#100]]` is the word G with value FUP[#100].
        "GFUP[#100]",
        "GFUP[#101]",
        "GFUP[#103]",
        "GFUP[#104]",
        "GFUP[#105]",
        "GFUP[#106]",
        "F#107",
        "S#108",
        "TFUP[#109]",
        "M30",
        "N101 G65 H99 P1",
        "N102 G65 H99 P2",
    ];
    assert_eq!(shown, want);
    // The full-width comments, with their nested annotations, are kept whole.
    assert_eq!(p.lines[0].comments[0].text, "主程序模塊");
    assert_eq!(
        p.lines[16].comments[0].text,
        "主軸旋向數(shù)據(jù)非法檢測(cè),若非法,則報(bào)警提示"
    );
    assert_eq!(
        p.lines[48].comments[0].text,
        "∕主軸旋向未指定或指定值錯(cuò)誤"
    );
}

#[test]
fn mlt980_linear_holes_o9001_as_printed() {
    let p = load("mlt980_O9001.nc");
    let shown: Vec<String> = p.lines.iter().map(|l| show(&l.kind)).collect();
    assert_eq!(shown[0], "O9001");
    assert_eq!(shown[1], "M#520 S#521");
    assert_eq!(shown[2], "G0 X#500 Y#501");
    assert_eq!(shown[3], "IF[#519 EQ 81] GOTO 81");
    assert_eq!(shown[11], "IF[#519 EQ 87] GOTO 87");
    assert_eq!(shown[12], "G#524 G#519 X#509 Y#510 Z#502 R#503 L#511 F#522");
    assert_eq!(p.lines[12].n.map(|n| n.value), Some(81));
    assert_eq!(
        shown[20],
        "G#524 G#519 X#509 Y#510 Z#502 R#503 Q#516 P#523 L#511 F#517"
    );
    assert_eq!(shown[22], "G80");
    assert_eq!(p.lines[22].n.map(|n| n.value), Some(999));
    assert_eq!(shown[24], "M99");
    let gotos = p
        .lines
        .iter()
        .filter(|l| matches!(l.kind, LineKind::Goto { .. }))
        .count();
    assert_eq!(gotos, 5);
}

#[test]
fn fanuc_bolt_circle_macro() {
    let p = load("fanuc_bolt_circle.nc");
    let shown: Vec<String> = p.lines.iter().map(|l| show(&l.kind)).collect();
    assert_eq!(
        shown,
        [
            "%",
            "O9010",
            "IF[#11 LE 0] GOTO 900",
            "IF[#18 EQ #0] GOTO 901",
            "#30=#1",
            "#31=[360 DIV #11]",
            "#32=1",
            "WHILE[#32 LE #11] DO1",
            "#33=[#24 ADD [#18 MUL COS[#30]]]",
            "#34=[#25 ADD [#18 MUL SIN[#30]]]",
            "G90 X#33 Y#34",
            "#30=[#30 ADD #31]",
            "#32=[#32 ADD 1]",
            "END1",
            "GOTO 999",
            "#3000=101",
            "#3000=102",
            "M99",
            "%",
        ]
    );
    assert_eq!(p.lines[15].n.map(|n| n.value), Some(900));
    assert_eq!(p.lines[15].comments[0].text, "NO HOLES");
}
