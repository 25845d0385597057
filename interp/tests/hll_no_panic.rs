//! Property test: random C-like programs (statements, expressions, G-code lines with values)
//! never panic the checker or the executor thread; every outcome is segments or an `NcError`
//! inside the text. A panic on the executor thread would show as "stopped unexpectedly".

use cnc402_config::MachineConfig;
use cnc402_interp::Interpreter;
use cnc402_interp::host::channels::DryChannels;
use cnc402_lang::SourceFile;
use proptest::prelude::*;

fn check(text: &str) {
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.variables_file = None;
    cfg.interp.block_limit = 20_000;
    let src = SourceFile::new("p.nc", text);
    let Ok(program) = cnc402_lang::parse(&src) else {
        return;
    };
    let mut it = Interpreter::new(&cfg);
    // Three channels that answer at once: the channel built-ins run their whole path.
    it.set_channels(Box::new(DryChannels { count: 3, this: 0 }));
    it.load(src.clone(), program);
    for _ in 0..100_000 {
        match it.next_segment() {
            Ok(Some(_)) => {}
            Ok(None) => return,
            Err(e) => {
                assert!(
                    !e.message.contains("stopped unexpectedly"),
                    "executor panicked on {text:?}"
                );
                assert!(e.span.end as usize <= text.len(), "{e}");
                assert!(e.line >= 1 && e.line <= src.line_count().max(1), "{e}");
                return;
            }
        }
    }
}

fn operand() -> impl Strategy<Value = String> {
    prop_oneof![
        (-5i64..100).prop_map(|n| n.to_string()),
        (-100.0f64..100.0).prop_map(|d| format!("{d:.3}")),
        prop::sample::select(vec![
            "nA",
            "nB",
            "dX",
            "sT",
            "bF",
            "aV[nA]",
            "aV[2]",
            "$gQ",
            "$gA[nB]",
            "@ITPPATH",
            "@X",
            "@POS[sT]",
            "@CH[nA].MODE",
            "@CH[nB - 2].STATE",
            "channel_wait(nA)",
            "channel_load(nB, sT)",
            "channel_run(nA, \"01.nc\")",
            "true",
            "\"Z\"",
            "Fn(nA)",
            "Fd(dX, nB)",
            "Fa(aV, nA)",
            "Fa($gA, nB)",
            "Fs(aV, aV)",
            "len(aV)",
            "len($gA)",
            "fabs(dX)",
            "sqrt(dX)",
            "pow(dX, nA)",
            "min(nA, dX)",
            "atan2(dX, nB)",
            "9223372036854775807",
        ])
        .prop_map(String::from),
    ]
}

fn expr() -> impl Strategy<Value = String> {
    let op = prop::sample::select(vec![
        "+", "-", "*", "/", "%", "==", "!=", "<", ">=", "&&", "||", "&", "|", "^",
    ]);
    (operand(), prop::collection::vec((op, operand()), 0..4)).prop_map(|(a, rest)| {
        let mut s = a;
        for (o, b) in rest {
            s = format!("({s} {o} {b})");
        }
        s
    })
}

fn stmt() -> impl Strategy<Value = String> {
    let target = prop::sample::select(vec![
        "nA", "nB", "dX", "sT", "bF", "aV[nB]", "$gQ", "$gA[nA]",
    ]);
    let aop = prop::sample::select(vec!["=", "+=", "-=", "*=", "/=", "%="]);
    prop_oneof![
        (target.clone(), aop, expr()).prop_map(|(t, o, e)| format!("{t} {o} {e};")),
        expr().prop_map(|e| format!("if ({e}) {{ nA++; }} else {{ nB--; }}")),
        expr().prop_map(|e| format!("while ({e}) {{ nA++; if (nA > 5) break; }}")),
        expr().prop_map(|e| format!("for (int nI = 0; nI < {e}; nI++) {{ continue; }}")),
        expr().prop_map(|e| format!("G1 X={e} F100")),
        expr().prop_map(|e| format!("G0 AXSTR(sT)={e}")),
        expr().prop_map(|e| format!("MSG({e});")),
        expr().prop_map(|e| format!("int aW[{e}];")),
        expr().prop_map(|e| format!("sleep({e});")),
        expr().prop_map(|e| format!("terminate(5, {e});")),
        Just("Fn(nA);".to_string()),
        expr().prop_map(|e| format!("Fa(aV, {e});")),
        expr().prop_map(|e| format!("Fa($gA, {e});")),
        Just("M30".to_string()),
        expr().prop_map(|e| format!("wait_mark({e});")),
        expr().prop_map(|e| format!("wait_mark(nA, {e});")),
        expr().prop_map(|e| format!("M100 P={e}")),
        expr().prop_map(|e| format!("bF = channel_start({e}, sT);")),
    ]
}

const HEADER: &str = "int Fn(int n) { if (n > 3) return n; return Fn(n + 1); }\n\
double Fd(double a, int b) { return a / b; }\n\
int Fa(int aA[], int n) { aA[n] = n; return aA[n % len(aA)] + len(aA); }\n\
int Fs(int aA[], const int aB[]) { if (len(aA) > 0) aA[0] += aB[len(aB) - 1]; return Fa(aA, 1); }\n\
int nA = 1;\nint nB = 2;\ndouble dX = 1.5;\nstring sT = \"Z\";\nbool bF = false;\nint aV[3];\n";

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn random_c_like_programs_never_panic(body in prop::collection::vec(stmt(), 1..8)) {
        check(&format!("{HEADER}{}\n", body.join("\n")));
    }
}
