//! Property tests: the parser never panics, every span it reports lies on the text, and
//! generated well-formed blocks parse back to the words they were made from.

use cnc402_lang::ast::*;
use cnc402_lang::{SourceFile, parse};
use proptest::prelude::*;

/// Parses and checks every span the result holds; panics (fails the property) on misuse.
fn check(text: &str) {
    let src = SourceFile::new("p.nc", text);
    match parse(&src) {
        Ok(p) => {
            assert_eq!(p.lines.len() as u32, src.line_count());
            for l in &p.lines {
                let r = l.span.range();
                assert!(
                    r.end <= text.len()
                        && text.is_char_boundary(r.start)
                        && text.is_char_boundary(r.end)
                );
                for c in &l.comments {
                    assert!(c.span.start >= l.span.start && c.span.end <= l.span.end);
                }
                if let LineKind::Block(b) = &l.kind {
                    for w in &b.words {
                        assert!(
                            w.span.start >= l.span.start && w.span.end <= l.span.end,
                            "{w:?}"
                        );
                        assert!(text.is_char_boundary(w.span.start as usize));
                    }
                }
            }
        }
        Err(e) => {
            let r = e.span.range();
            assert!(r.start <= r.end && r.end <= text.len());
            assert!(e.line >= 1 && e.col >= 1 && !e.message.is_empty());
            let _ = e.to_string();
        }
    }
}

/// Pieces that G-code is made of, to build near-valid programs that reach deep paths.
fn piece() -> impl Strategy<Value = &'static str> {
    prop::sample::select(vec![
        "G",
        "X",
        "Y",
        "Z",
        "F",
        "N",
        "O",
        "M",
        "E",
        "1",
        "0",
        "25",
        ".",
        "-",
        "+",
        " ",
        "\t",
        "\n",
        "\r\n",
        "(",
        ")",
        "(c)",
        ";",
        "/",
        "%",
        "[",
        "]",
        "=",
        "*",
        "OR",
        "XOR",
        "AND",
        "MOD",
        "EQ",
        "NE",
        "GT",
        "LE",
        "SIN",
        "ATAN",
        "POW",
        ",",
        "FUP",
        "#",
        "#1",
        "#[",
        "IF",
        "THEN",
        "GOTO",
        "WHILE",
        "DO",
        "END",
        "全",
        "Ä",
        "\u{0}",
        ":",
        "{",
        "}",
        "if (",
        "while(",
        "for (",
        ";",
        "int ",
        "double dA",
        "dA",
        " = ",
        "+=",
        "++",
        "\"",
        "\"s\"",
        "//",
        "/*",
        "*/",
        "$g",
        "@CH",
        ".MODE",
        "AXSTR(",
        "&&",
        "||",
        "!",
        "==",
        "<",
        "else",
        "return",
        "void f(",
        "#use",
        "MSG(",
        "a",
    ])
}

proptest! {
    // 2000 cases per property; more with PROPTEST_CASES=n.
    #![proptest_config(ProptestConfig::with_cases(
        std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(2000)
    ))]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..200)) {
        check(&String::from_utf8_lossy(&bytes));
    }

    #[test]
    fn deep_nesting_is_an_error_not_a_stack_overflow(
        open in prop::sample::select(vec!["[", "(", "{", "!", "-", "a[", "#[", "if(1)", "SIN[", "f("]),
        n in 1usize..2000,
        prefix in prop::sample::select(vec!["", "int nn = 1;\n", "G1 X", "#1=", "dA = "]),
    ) {
        check(&format!("{prefix}{}1", open.repeat(n)));
    }

    #[test]
    fn near_gcode_never_panics(parts in prop::collection::vec(piece(), 0..60)) {
        check(&parts.concat());
    }

    #[test]
    fn generated_blocks_parse_back(
        n in prop::option::of(0u32..100_000),
        words in prop::collection::vec(
            (prop::sample::select(vec!['G', 'X', 'Y', 'Z', 'F', 'S', 'M', 'E', 'I', 'J']),
             -100_000i64..100_000, 0u32..4, any::<bool>(), any::<bool>()),
            1..8),
    ) {
        let mut text = String::new();
        if let Some(n) = n { text.push_str(&format!("N{n} ")); }
        let mut want = Vec::new();
        for &(letter, mantissa, decimals, lower, spaced) in &words {
            let l = if lower { letter.to_ascii_lowercase() } else { letter };
            let value = mantissa as f64 / 10f64.powi(decimals as i32);
            let num = if decimals == 0 { format!("{mantissa}") } else { format!("{value:.*}", decimals as usize) };
            text.push(l);
            if spaced { text.push(' '); }
            text.push_str(&num);
            want.push((letter, num.parse::<f64>().unwrap(), decimals > 0));
        }
        let p = parse(&SourceFile::new("g.nc", text.as_str())).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!(p.lines[0].n.map(|s| s.value), n);
        let LineKind::Block(b) = &p.lines[0].kind else { return Err(TestCaseError::fail("not a block")) };
        let got: Vec<(char, f64, bool)> = b.words.iter().map(|w| match &w.value {
            Value::Number(x) => (w.letter, x.value, x.has_point),
            Value::Expr(_) => (w.letter, f64::NAN, false),
        }).collect();
        prop_assert_eq!(got, want);
    }
}
