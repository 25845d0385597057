//! Property tests: random bytes and random G-code-ish text never panic the parser or the
//! interpreter; every outcome is segments or an `NcError` inside the text.

use cnc402_config::MachineConfig;
use cnc402_interp::{Interpreter, dump::segment_to_json};
use cnc402_lang::SourceFile;
use proptest::prelude::*;

fn check(text: &str) {
    let mut cfg = MachineConfig::default_machine();
    // Random programs may write #500-#999: keep them in memory. Loops stop sooner.
    cfg.interp.variables_file = None;
    cfg.interp.block_limit = 20_000;
    let src = SourceFile::new("p.nc", text);
    let Ok(program) = cnc402_lang::parse(&src) else {
        return;
    };
    let mut it = Interpreter::new(&cfg);
    it.load(src.clone(), program);
    // A bounded pull: K9999 cycles can make many segments, all fine.
    for _ in 0..200_000 {
        match it.next_segment() {
            Ok(Some(s)) => {
                let j = segment_to_json(&s, &cfg);
                assert!(j.starts_with("{\"kind\":") && j.ends_with('}'));
            }
            Ok(None) => return,
            Err(e) => {
                assert!(e.span.end as usize <= text.len());
                assert!(e.line >= 1 && e.line <= src.line_count().max(1));
                return;
            }
        }
    }
}

fn word() -> impl Strategy<Value = String> {
    let letter = prop::sample::select(vec![
        'G', 'G', 'G', 'M', 'X', 'Y', 'Z', 'C', 'I', 'J', 'K', 'R', 'Q', 'P', 'F', 'S', 'T', 'L',
        'A', 'D', 'H',
    ]);
    let num = prop_oneof![
        prop::sample::select(vec![
            "0", "1", "2", "3", "4", "17", "18", "19", "20", "21", "53", "54", "55", "73", "74",
            "76", "80", "81", "82", "83", "84", "85", "86", "87", "88", "89", "90", "91", "94",
            "95", "98", "99", "29", "5", "6", "30", "10", "28", "43", "44", "49", "61", "63", "64",
            "92", "7", "8", "9", "400", "401"
        ])
        .prop_map(str::to_string),
        (-500.0f64..500.0).prop_map(|v| format!("{v:.3}")),
        (0u32..100000).prop_map(|v| v.to_string()),
        Just("[1/0]".to_string()),
        Just("-0".to_string()),
    ];
    (letter, num).prop_map(|(l, n)| format!("{l}{n}"))
}

fn block() -> impl Strategy<Value = String> {
    prop::collection::vec(word(), 0..7).prop_map(|w| w.join(" "))
}

/// A Custom Macro B line: assignments, jumps, loops, calls, H instructions, program numbers.
fn macro_line() -> impl Strategy<Value = String> {
    let var = prop::sample::select(vec![
        "#0",
        "#1",
        "#2",
        "#33",
        "#100",
        "#150",
        "#500",
        "#999",
        "#3000",
        "#3006",
        "#4001",
        "#4120",
        "#5001",
        "#5021",
        "#5043",
        "#5221",
        "#5083",
        "#11001",
        "#10400",
        "#2201",
        "#13401",
        "#34",
        "#[#1]",
        "#[#2+100]",
    ]);
    let val = prop_oneof![
        (-50i32..50).prop_map(|v| v.to_string()),
        (-50.0f64..50.0).prop_map(|v| format!("{v:.2}")),
        Just("#1".to_string()),
        Just("#[#1+1]".to_string()),
        Just("SIN[#2]".to_string()),
        Just("ATAN[#1]/[#2]".to_string()),
        Just("[#1 MOD #2]".to_string()),
        Just("SQRT[#1]".to_string()),
        Just("[#1 EQ #0]".to_string()),
        Just("FUP[#100/3]".to_string()),
    ];
    let n = 0u32..12;
    prop_oneof![
        (var.clone(), val.clone()).prop_map(|(v, e)| format!("{v}={e}")),
        (val.clone(), n.clone()).prop_map(|(e, n)| format!("IF[{e} GT 0]GOTO{n}")),
        (val.clone(), var.clone(), val.clone()).prop_map(|(c, v, e)| format!("IF[{c}]THEN{v}={e}")),
        (1u8..5, val.clone()).prop_map(|(id, c)| format!("WHILE[{c} LT 3]DO{id}")),
        (1u8..5).prop_map(|id| format!("END{id}")),
        n.clone().prop_map(|n| format!("GOTO{n}")),
        n.clone().prop_map(|n| format!("N{n}")),
        (n.clone(), 0u32..3).prop_map(|(n, l)| format!("M98 P{n} L{l}")),
        n.clone().prop_map(|n| format!("M99 P{n}")),
        Just("M99".to_string()),
        n.clone().prop_map(|n| format!("O{n}")),
        (n.clone(), val.clone()).prop_map(|(n, a)| format!("G65 P{n} A{a} M3")),
        (n.clone(), val.clone()).prop_map(|(n, a)| format!("G66 P{n} X{a}")),
        Just("G67".to_string()),
        (
            prop::sample::select(vec![
                1u32, 2, 5, 11, 21, 23, 24, 25, 26, 28, 34, 80, 86, 99, 7
            ]),
            var,
            val.clone(),
            val.clone()
        )
            .prop_map(|(h, v, q, r)| format!("G65 H{h} P{v} Q{q} R{r}")),
        val.prop_map(|v| format!("G91 G1 X{v}")),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
        check(&String::from_utf8_lossy(&bytes));
    }

    #[test]
    fn random_gcode_never_panics(blocks in prop::collection::vec(block(), 1..25)) {
        let mut text = String::from("M3 S500\nF100\nG0 Z20\n");
        text.push_str(&blocks.join("\n"));
        check(&text);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 600, ..ProptestConfig::default() })]

    #[test]
    fn random_macro_programs_never_panic(lines in prop::collection::vec(macro_line(), 1..30)) {
        let mut text = String::from("F100\n");
        text.push_str(&lines.join("\n"));
        check(&text);
    }
}

/// A line of a LinuxCNC-dialect program: O-word flow with few labels (so that they pair, cross
/// and nest at random), named parameters, polar words, G92.x, cycles and offsets.
fn linuxcnc_line() -> impl Strategy<Value = String> {
    let label = prop::sample::select(vec!["o1", "o2", "o3", "o<s>", "o<t>"]);
    let val = prop_oneof![
        (-20i32..20).prop_map(|v| v.to_string()),
        Just("#1".to_string()),
        Just("#<a>".to_string()),
        Just("#<_g>".to_string()),
        Just("#<_x>".to_string()),
        Just("#<_value>".to_string()),
        Just("[#1 + 1]".to_string()),
        Just("[#<a> LT 3]".to_string()),
    ];
    let kw = prop::sample::select(vec![
        "sub",
        "endsub",
        "return",
        "call",
        "if",
        "elseif",
        "else",
        "endif",
        "do",
        "while",
        "endwhile",
        "repeat",
        "endrepeat",
        "break",
        "continue",
    ]);
    prop_oneof![
        (label, kw, val.clone()).prop_map(|(l, k, v)| format!("{l} {k} [{v}]")),
        (label_free(), val.clone()).prop_map(|(t, v)| format!("{t} = {v}")),
        (val.clone(), val.clone()).prop_map(|(r, a)| format!("G1 @[{r}] ^[{a}] F100")),
        Just("G91 G0 ^30".to_string()),
        Just("G90".to_string()),
        prop::sample::select(vec!["G92 X1", "G92.1", "G92.2", "G92.3", "G43 H1", "G49"])
            .prop_map(str::to_string),
        (prop::sample::select(vec!["G98", "G99"]), val.clone())
            .prop_map(|(m, z)| format!("{m} G81 X1 Y1 Z-2 R[{z}] F50")),
        Just("G88 X2 Y2 Z-1 R1 P0.1".to_string()),
        Just("G80".to_string()),
        val.prop_map(|v| format!("G4 P[{v} / 100]")),
        Just("G10 L20 P0 X0".to_string()),
    ]
}

fn label_free() -> impl Strategy<Value = &'static str> {
    prop::sample::select(vec!["#1", "#<a>", "#<_g>", "#<_x>", "#2"])
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 600, ..ProptestConfig::default() })]

    #[test]
    fn random_linuxcnc_programs_never_panic(lines in prop::collection::vec(linuxcnc_line(), 1..30)) {
        let mut text = String::from("(dialect: linuxcnc)\nM3 S500\nG0 Z20\n");
        text.push_str(&lines.join("\n"));
        check(&text);
    }
}
