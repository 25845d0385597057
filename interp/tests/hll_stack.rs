//! The C-like executor's thread stack holds the deepest programs the language allows:
//! MAX_CALL_DEPTH nested calls, each from inside the deepest statement and expression nesting.

use cnc402_config::MachineConfig;
use cnc402_interp::hll::MAX_CALL_DEPTH;
use cnc402_lang::SourceFile;

/// Statement nesting (`if` blocks) in each function, and per form of the recursive call its
/// expression nesting (parentheses): the deepest the parser accepts (checked below: one more
/// of either is a parse error).
const STMT_NEST: usize = 15;
const FORMS: [(&str, usize); 3] = [("return", 31), ("gcode", 31), ("builtin", 30)];

/// A recursive function whose recursive call stands `stmts` blocks and `exprs` parentheses
/// deep, in the form `kind`: a return value, a G-code word value, or a builtin's argument.
fn nested(kind: &str, stmts: usize, exprs: usize) -> String {
    let open = "(".repeat(exprs);
    let close = ")".repeat(exprs);
    let call = match kind {
        "return" => format!("return {open}F(n - 1) + 1{close};"),
        "gcode" => format!("G1 X={open}F(n - 1) * 0{close} F100\nreturn n;"),
        _ => format!("MSG(\"\" + {open}F(n - 1) + 1{close});\nreturn n;"),
    };
    let mut body = String::new();
    for _ in 0..stmts {
        body += "if (n > 0) {\n";
    }
    body += &call;
    body += "\n";
    for _ in 0..stmts {
        body += "}\n";
    }
    let top = MAX_CALL_DEPTH - 1;
    format!("int F(int n) {{\n{body}return 0;\n}}\nMSG(\"\" + F({top}));\nM02\n")
}

fn cfg() -> MachineConfig {
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.variables_file = None;
    cfg
}

#[test]
fn the_deepest_programs_are_the_deepest_the_parser_accepts() {
    for (kind, exprs) in FORMS {
        for (s, e) in [(STMT_NEST + 1, exprs), (STMT_NEST, exprs + 1)] {
            let text = nested(kind, s, e);
            let e = cnc402_lang::parse(&SourceFile::new("deep.nc", text.as_str())).unwrap_err();
            assert!(e.message.contains("nested too deeply"), "{kind}: {e}");
        }
    }
}

#[test]
fn deepest_recursion_runs_on_the_executor_stack() {
    let cfg = cfg();
    for (kind, exprs) in FORMS {
        let text = nested(kind, STMT_NEST, exprs);
        let r = cnc402_interp::run_program(&cfg, &SourceFile::new("deep.nc", text.as_str()));
        let segs = r.unwrap_or_else(|e| panic!("{kind}: {e}"));
        assert!(!segs.is_empty(), "{kind}");
        // One call deeper is the located depth error, not a crash.
        let over = text.replace(
            &format!("F({})", MAX_CALL_DEPTH - 1),
            &format!("F({MAX_CALL_DEPTH})"),
        );
        let e = cnc402_interp::run_program(&cfg, &SourceFile::new("deep.nc", over.as_str()))
            .unwrap_err();
        assert!(e.message.contains("recursion too deep"), "{kind}: {e}");
    }
}

/// The recursive call at the bottom of the longest chain the parser accepts, at every one
/// of `MAX_CALL_DEPTH` levels: the executor evaluates a chain by recursion, one frame per
/// operator, so `MAX_HEIGHT` times `MAX_CALL_DEPTH` frames must fit its stack.
#[test]
fn deepest_chain_recursion_runs_on_the_executor_stack() {
    // `F(n - 1)` is two levels high (the call and its `-`): the sum is MAX_HEIGHT high.
    let chain = " + 1".repeat(cnc402_lang::MAX_HEIGHT as usize - 2);
    let top = MAX_CALL_DEPTH - 1;
    let text = format!(
        "int F(int n) {{\nif (n > 0) {{\nreturn F(n - 1){chain};\n}}\nreturn 0;\n}}\nMSG(\"\" + F({top}));\nM02\n"
    );
    let r = cnc402_interp::run_program(&cfg(), &SourceFile::new("chain.nc", text.as_str()));
    assert!(!r.expect("runs").is_empty());
}
