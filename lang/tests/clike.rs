//! The C-like language of source 000 (AxiOMA Control style): whole programs as printed, and
//! the statement forms one by one.

use cnc402_lang::ast::*;
use cnc402_lang::{SourceFile, parse};

fn load(name: &str) -> Program {
    let path = format!("{}/tests/programs/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    parse(&SourceFile::new(path, text)).unwrap_or_else(|e| panic!("{e}"))
}

fn p(text: &str) -> Program {
    parse(&SourceFile::new("t.nc", text)).unwrap_or_else(|e| panic!("{text:?}: {e}"))
}

fn stmts(l: &Line) -> &[Stmt] {
    match &l.kind {
        LineKind::Stmts(s) => s,
        k => panic!("line {}: not statements: {k:?}", l.line_no),
    }
}

fn err(text: &str) -> (u32, u32, String) {
    let e = parse(&SourceFile::new("t.nc", text)).unwrap_err();
    (e.line, e.col, e.message.clone())
}

#[test]
fn source_000_main_program_as_printed() {
    let p = load("axioma_main.nc");
    assert_eq!(p.lines.len(), 10);
    let s = stmts(&p.lines[0]);
    assert_eq!(
        s[0].kind,
        StmtKind::Use {
            path: "metch_cycles.c".into()
        }
    );
    let LineKind::Block(b) = &p.lines[1].kind else {
        panic!()
    };
    assert_eq!(b.words[0].letter, 'G');
    // The call with its 14 arguments.
    let StmtKind::Call(call) = &stmts(&p.lines[2])[0].kind else {
        panic!()
    };
    let ExprKind::CallNamed(name, args) = &call.kind else {
        panic!()
    };
    assert_eq!(name, "Tapping");
    assert_eq!(args.len(), 14);
    assert_eq!(args[0].kind, ExprKind::Str("Z".into()));
    assert_eq!(args[13].kind, ExprKind::Number(200.0));
    // `$dPerm[1] = @ITPPATH;`
    let StmtKind::Assign { target, op, value } = &stmts(&p.lines[3])[0].kind else {
        panic!()
    };
    assert_eq!(*op, AssignOp::Set);
    let ExprKind::Index(g, i) = &target.kind else {
        panic!("{target:?}")
    };
    assert_eq!(g.kind, ExprKind::Global("dPerm".into()));
    assert_eq!(i.kind, ExprKind::Number(1.0));
    assert_eq!(value.kind, ExprKind::SysVar("ITPPATH".into()));
    // `$dPerm[3] = fabs(@ITPPATH - $dPerm[2]);`
    let StmtKind::Assign { value, .. } = &stmts(&p.lines[4])[0].kind else {
        panic!()
    };
    let ExprKind::CallNamed(f, a) = &value.kind else {
        panic!()
    };
    assert_eq!(f, "fabs");
    assert!(matches!(a[0].kind, ExprKind::Binary(BinaryOp::Sub, _, _)));
    // The `if` runs over four lines; `terminate (…)` has a space and no `;`, as printed.
    let StmtKind::If {
        cond,
        then,
        otherwise,
    } = &stmts(&p.lines[5])[0].kind
    else {
        panic!()
    };
    assert!(matches!(cond.kind, ExprKind::Binary(BinaryOp::Gt, _, _)));
    assert!(otherwise.is_none());
    let StmtKind::Block(body) = &then.kind else {
        panic!()
    };
    let StmtKind::Call(t) = &body[0].kind else {
        panic!()
    };
    assert!(matches!(&t.kind, ExprKind::CallNamed(n, a) if n == "terminate" && a.len() == 2));
    for l in &p.lines[6..9] {
        assert_eq!(l.kind, LineKind::Continued, "line {}", l.line_no);
    }
    let LineKind::Block(b) = &p.lines[9].kind else {
        panic!()
    };
    assert_eq!((b.words[0].letter, b.words.len()), ('M', 1));
}

#[test]
fn source_000_channel_program() {
    let p = load("axioma_channels.nc");
    let StmtKind::Decl { ty, vars } = &stmts(&p.lines[2])[0].kind else {
        panic!()
    };
    assert_eq!(*ty, Type::String);
    assert_eq!(vars[0].name, "chanProgs");
    assert_eq!(
        vars[0].size.as_ref().unwrap().kind,
        ExprKind::Ident("nPartProgNo".into())
    );
    let StmtKind::If { cond, .. } = &stmts(&p.lines[5])[0].kind else {
        panic!()
    };
    let ExprKind::Binary(BinaryOp::Ne, lhs, _) = &cond.kind else {
        panic!()
    };
    let ExprKind::Field(ch, field) = &lhs.kind else {
        panic!("{lhs:?}")
    };
    assert_eq!(field, "MODE");
    assert!(matches!(&ch.kind, ExprKind::Index(s, _) if s.kind == ExprKind::SysVar("CH".into())));
    let for_line = p
        .lines
        .iter()
        .find(
            |l| matches!(&l.kind, LineKind::Stmts(s) if matches!(s[0].kind, StmtKind::For { .. })),
        )
        .unwrap();
    assert_eq!(for_line.line_no, 16);
    let StmtKind::For {
        init,
        cond,
        step,
        body,
    } = &stmts(for_line)[0].kind
    else {
        panic!()
    };
    assert!(matches!(
        init.as_deref().map(|s| &s.kind),
        Some(StmtKind::Assign {
            op: AssignOp::Set,
            ..
        })
    ));
    assert!(matches!(
        cond.as_ref().map(|c| &c.kind),
        Some(ExprKind::Binary(BinaryOp::Lt, _, _))
    ));
    assert!(matches!(
        step.as_deref().map(|s| &s.kind),
        Some(StmtKind::Assign {
            op: AssignOp::Add,
            ..
        })
    ));
    let StmtKind::Block(items) = &body.kind else {
        panic!()
    };
    assert_eq!(items.len(), 4);
    // Every line after the `for` head is part of it.
    assert!(p.lines[16..].iter().all(|l| l.kind == LineKind::Continued));
    assert_eq!(p.lines.len(), 41);
}

#[test]
fn source_000_tapping_cycle_with_gcode_inside() {
    let p = load("axioma_tapping_cycle.c");
    let f = p.lines.iter().find_map(|l| match &l.kind {
        LineKind::Stmts(s) => match &s[0].kind {
            StmtKind::Function(f) => Some(f),
            _ => None,
        },
        _ => None,
    });
    let f = f.expect("a function");
    assert_eq!(f.name, "Tapping");
    assert_eq!(f.ret, Type::Void);
    assert_eq!(f.params.len(), 14);
    assert_eq!(
        (f.params[0].ty, f.params[0].name.as_str()),
        (Type::String, "strToolAx")
    );
    assert_eq!(f.params[13].name, "dZ");
    // The G-code lines inside keep their own line numbers and AXSTR words.
    let mut gcode = Vec::new();
    fn walk<'a>(s: &'a Stmt, out: &mut Vec<&'a Line>) {
        match &s.kind {
            StmtKind::Gcode(l) => out.push(l),
            StmtKind::Block(b) => b.iter().for_each(|s| walk(s, out)),
            StmtKind::If {
                then, otherwise, ..
            } => {
                walk(then, out);
                if let Some(o) = otherwise {
                    walk(o, out);
                }
            }
            StmtKind::For { body, .. } | StmtKind::While { body, .. } => walk(body, out),
            _ => {}
        }
    }
    f.body.iter().for_each(|s| walk(s, &mut gcode));
    assert_eq!(gcode.len(), 18);
    let first = gcode[1];
    assert_eq!(first.line_no, 14);
    let LineKind::Block(b) = &first.kind else {
        panic!()
    };
    assert_eq!(b.words.len(), 1);
    assert_eq!(b.named_axes.len(), 1);
    assert_eq!(
        b.named_axes[0].axis.kind,
        ExprKind::Ident("strToolAx".into())
    );
    assert!(matches!(
        b.named_axes[0].value.kind,
        ExprKind::Binary(BinaryOp::Add, _, _)
    ));
    // `G1 AXSTR(strToolAx)=-(…) AXSTR(strSpindleAx) =dSpindlePath F=dTapFeed`
    let LineKind::Block(b) = &gcode[3].kind else {
        panic!()
    };
    assert_eq!(b.named_axes.len(), 2);
    assert!(matches!(
        b.named_axes[0].value.kind,
        ExprKind::Unary(UnaryOp::Neg, _)
    ));
    assert_eq!(
        b.named_axes[1].value.kind,
        ExprKind::Ident("dSpindlePath".into())
    );
    assert_eq!(b.words[1].letter, 'F');
    assert!(
        matches!(&b.words[1].value, Value::Expr(e) if e.kind == ExprKind::Ident("dTapFeed".into()))
    );
}

#[test]
fn c_precedence_differs_from_fanuc() {
    let prog = p("int a = 1 + 2 * 3 == 7 && !b || c < d;\n");
    let StmtKind::Decl { vars, .. } = &stmts(&prog.lines[0])[0].kind else {
        panic!()
    };
    let e = vars[0].init.as_ref().unwrap();
    let ExprKind::Logical(LogicalOp::Or, l, r) = &e.kind else {
        panic!("{e:?}")
    };
    assert!(matches!(r.kind, ExprKind::Binary(BinaryOp::Lt, _, _)));
    let ExprKind::Logical(LogicalOp::And, eq, not) = &l.kind else {
        panic!()
    };
    assert!(matches!(not.kind, ExprKind::Not(_)));
    let ExprKind::Binary(BinaryOp::Eq, sum, _) = &eq.kind else {
        panic!()
    };
    assert!(
        matches!(&sum.kind, ExprKind::Binary(BinaryOp::Add, _, m) if matches!(m.kind, ExprKind::Binary(BinaryOp::Mul, _, _)))
    );
}

#[test]
fn statement_forms() {
    let prog = p(
        "double dX = 2, dY;\ndX += 3;\ndX++;\n--dY;\nwhile (dX > 0) dX = dX - 1;\nbreak;\ncontinue;\nreturn dX % 2;\nbool ok = true;\nif (ok) { MSG(\"a\"); } else if (dX) { MSG(\"b\"); } else MSG(\"c\");\n",
    );
    let kinds: Vec<&StmtKind> = prog.lines.iter().map(|l| &stmts(l)[0].kind).collect();
    assert!(matches!(kinds[0], StmtKind::Decl { ty: Type::Double, vars } if vars.len() == 2));
    assert!(matches!(
        kinds[1],
        StmtKind::Assign {
            op: AssignOp::Add,
            ..
        }
    ));
    assert!(
        matches!(kinds[2], StmtKind::Assign { op: AssignOp::Add, value, .. } if value.kind == ExprKind::Number(1.0))
    );
    assert!(matches!(
        kinds[3],
        StmtKind::Assign {
            op: AssignOp::Sub,
            ..
        }
    ));
    assert!(matches!(kinds[4], StmtKind::While { .. }));
    assert_eq!(*kinds[5], StmtKind::Break);
    assert_eq!(*kinds[6], StmtKind::Continue);
    assert!(
        matches!(kinds[7], StmtKind::Return(Some(e)) if matches!(e.kind, ExprKind::Binary(BinaryOp::Mod, _, _)))
    );
    assert!(matches!(kinds[8], StmtKind::Decl { ty: Type::Bool, .. }));
    let StmtKind::If {
        otherwise: Some(o), ..
    } = kinds[9]
    else {
        panic!()
    };
    assert!(matches!(
        &o.kind,
        StmtKind::If {
            otherwise: Some(_),
            ..
        }
    ));
    // C numbers take exponents; G-code values in the same program do not.
    let prog = p("double dTol = 1e-3 + 2.5E2;\nG1 X=dTol E2\n");
    let StmtKind::Decl { vars, .. } = &stmts(&prog.lines[0])[0].kind else {
        panic!()
    };
    let ExprKind::Binary(BinaryOp::Add, a, b) = &vars[0].init.as_ref().unwrap().kind else {
        panic!()
    };
    assert_eq!(
        (&a.kind, &b.kind),
        (&ExprKind::Number(1e-3), &ExprKind::Number(250.0))
    );
    let LineKind::Block(blk) = &prog.lines[1].kind else {
        panic!()
    };
    assert_eq!(blk.words.len(), 3);
    // Several statements on one line.
    let prog = p("dX = 1; dY = 2;\n");
    assert_eq!(stmts(&prog.lines[0]).len(), 2);
}

#[test]
fn gcode_in_a_c_program_takes_c_values_and_comments() {
    let prog = p(
        "double dFeed = 100;\nG1 X=(dFeed + 2) * 2 Y#1 F=dFeed // feed\nG0 X[1+2] (fanuc comment)\n",
    );
    let LineKind::Block(b) = &prog.lines[1].kind else {
        panic!()
    };
    assert_eq!(b.words.len(), 4);
    assert!(
        matches!(&b.words[1].value, Value::Expr(e) if matches!(e.kind, ExprKind::Binary(BinaryOp::Mul, _, _)))
    );
    assert!(
        matches!(&b.words[3].value, Value::Expr(e) if e.kind == ExprKind::Ident("dFeed".into()))
    );
    assert_eq!(prog.lines[2].comments[0].text, "fanuc comment");
    // Fanuc macro lines still work in a C-like program.
    let prog = p("int n = 1;\nIF[#1 EQ 1]GOTO 5\nWHILE[#1 LT 3]DO1\nEND1\n");
    assert!(matches!(prog.lines[1].kind, LineKind::IfGoto { .. }));
    assert!(matches!(prog.lines[2].kind, LineKind::While { .. }));
    assert!(matches!(prog.lines[3].kind, LineKind::End { id: 1 }));
}

#[test]
fn without_statements_a_program_stays_iso() {
    // `F=a` is an error in a pure G-code program (no names there), a variable in a C one.
    assert_eq!(err("G1 F=a\n").2, "missing expression after `F=`");
    let prog = p("int a = 5;\nG1 F=a\n");
    assert!(matches!(prog.lines[1].kind, LineKind::Block(_)));
}

#[test]
fn ambiguous_and_bad_statements_are_errors() {
    let cases: &[(&str, u32, u32, &str)] = &[
        (
            "int n = 1;\nx = 5;\n",
            2,
            1,
            "ambiguous line: `x = …;` reads as the address word X=… with a `;` comment and as an assignment to a variable; use a name of two or more characters, or drop the `;` for the G-code word",
        ),
        (
            "int n = 1;\ni++;\n",
            2,
            1,
            "ambiguous line: a single letter is an address in G-code, so it cannot start a statement; use a name of two or more characters",
        ),
        (
            "int n = 1;\na[2] = 5\n",
            2,
            1,
            "ambiguous line: a single letter is an address in G-code, so it cannot start a statement; use a name of two or more characters",
        ),
        (
            "int n = 1;\nif (n) G1 X5\n",
            2,
            8,
            "a G-code block must start its own line",
        ),
        (
            "if (n > 1) {\n  G1 X5 }\n",
            2,
            9,
            "`}` in a G-code block: a block runs to the end of its line",
        ),
        (
            "if (n > 1) {\n  MSG(\"x\");\n",
            1,
            12,
            "unbalanced brace: `{` is not closed",
        ),
        ("}\n", 1, 1, "unbalanced brace: `}` without `{`"),
        ("else MSG(\"x\");\n", 1, 1, "`else` without `if`"),
        ("if n > 1 { }\n", 1, 4, "missing `[` after IF"),
        ("while n { }\n", 1, 7, "missing `[` after WHILE"),
        (
            "int n = 1;\nx1 = 5;\n",
            2,
            1,
            "ambiguous line: a name made of a letter and digits reads as a G-code word; start variable names with two letters",
        ),
        ("if (n > 1\n", 1, 4, "unbalanced bracket: `(` is not closed"),
        ("while (n) \n", 2, 1, "missing statement after while"),
        (
            "for (int k = 0 k < 3; k++) {}\n",
            1,
            16,
            "missing `;` after the for initialiser",
        ),
        ("int = 5;\n", 1, 5, "missing a variable name"),
        ("int if = 5;\n", 1, 5, "`if` is a keyword"),
        ("double dA = ;\n", 1, 13, "missing expression after `=`"),
        (
            "dA + 1;\n",
            1,
            1,
            "a statement must be an assignment, a call or a declaration",
        ),
        ("dA = 1 dB = 2;\n", 1, 8, "missing `;` after the statement"),
        ("MSG(\"abc);\n", 1, 5, "unterminated string"),
        ("MSG(\"a\\q\");\n", 1, 7, "unknown escape `\\q` in string"),
        ("MSG(1,);\n", 1, 7, "missing argument"),
        ("dA = (1 + 2;\n", 1, 12, "unexpected text in expression"),
        (
            "dA = (1 + 2\n",
            1,
            6,
            "unbalanced bracket: `(` is not closed",
        ),
        ("dA = ();\n", 1, 7, "empty parentheses"),
        ("dA = 1 +;\n", 1, 9, "missing operand after `+`"),
        ("dA = 1 && ;\n", 1, 11, "missing operand after `&&`"),
        ("fabs(1) = 2;\n", 1, 1, "cannot assign to this expression"),
        ("$ = 1;\n", 1, 1, "missing name after `$`"),
        ("dA = @CH[0].;\n", 1, 13, "missing field name after `.`"),
        ("#use metch.c\n", 1, 6, "missing file name after #use"),
        ("/* never closed\nG1 X1\n", 1, 1, "unclosed comment `/*`"),
        (
            "void f(int a) { void g() { } }\n",
            1,
            22,
            "functions must be defined at the top level",
        ),
        ("void f(a) { }\n", 1, 8, "missing parameter type"),
        ("void f(int a) G1\n", 1, 15, "missing body of function f"),
        (
            "int n = 1;\nG1 AXSTR(\"Z\") 5\n",
            2,
            15,
            "missing `=` after AXSTR(…)",
        ),
        (
            "int nn = 1;\nG1 F=nn +\n",
            2,
            10,
            "missing operand after `+`",
        ),
        ("int n = 1;\nG1 F=\n", 2, 6, "missing expression after `F=`"),
        ("dA = if;\n", 1, 6, "`if` is a keyword, not a value"),
    ];
    let mut bad = Vec::new();
    for &(text, line, col, msg) in cases {
        match parse(&SourceFile::new("t.nc", text)) {
            Ok(p) => bad.push(format!("{text:?}: parsed: {p:?}")),
            Err(e) if (e.line, e.col, e.message.as_str()) != (line, col, msg) => bad.push(format!(
                "{text:?}: got {}:{} {:?}",
                e.line, e.col, e.message
            )),
            Err(_) => {}
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}
