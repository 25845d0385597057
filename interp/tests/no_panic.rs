//! Property tests: random bytes and random G-code-ish text never panic the parser or the
//! interpreter; every outcome is segments or an `NcError` inside the text.

use cnc402_config::MachineConfig;
use cnc402_interp::{Interpreter, dump::segment_to_json};
use cnc402_lang::SourceFile;
use proptest::prelude::*;

fn check(text: &str) {
    let cfg = MachineConfig::default_machine();
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
            "95", "98", "99", "29", "5", "6", "30"
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
