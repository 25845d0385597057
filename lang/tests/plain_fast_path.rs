//! The plain-block fast path of [`parse_line`] (`parse::simple`) against the general parser:
//! for every line the fast path takes, the same [`Line`] (words, values to the bit, spans,
//! N number), in every dialect; and whatever it does not take is left to the general parser.
//! [`parse_line_into`] (a streamed program's lines read into one reused line) the same,
//! whatever line it held before.

use cnc402_lang::stream::{
    is_statement_line, parse_line, parse_line_into, plain_block, plain_block_bytes,
    plain_block_bytes_by_scan,
};
use cnc402_lang::{Dialect, SourceFile, parse_in};
use proptest::prelude::*;

/// Parses `text` as line 7 both ways; panics when they differ. A plain block is never a
/// C-like statement (the load pass of a streamed program asks only the other lines).
fn same(text: &str) {
    // The load pass classifies a line's bytes: as its text.
    assert_eq!(
        plain_block_bytes(text.as_bytes()),
        plain_block(text),
        "{text:?}"
    );
    // The class table's answer is the plain-block parser's.
    assert_eq!(
        plain_block_bytes(text.as_bytes()),
        plain_block_bytes_by_scan(text.as_bytes()),
        "{text:?}"
    );
    if is_statement_line(text) {
        assert!(
            plain_block(text).is_none(),
            "{text:?}: plain and a statement"
        );
        return;
    }
    for dialect in [Dialect::Fanuc, Dialect::Haas, Dialect::LinuxCnc] {
        let window = SourceFile::window("p.nc", text, 7);
        let general = parse_in(&window, dialect).map(|mut p| p.lines.remove(0));
        let fast = parse_line(&window, dialect);
        match (&general, &fast) {
            (Ok(g), Ok(f)) => assert_eq!(g, f, "{text:?} in {dialect:?}"),
            (Err(g), Err(f)) => assert_eq!(g.to_string(), f.to_string(), "{text:?}"),
            _ => panic!("{text:?} in {dialect:?}: {general:?} against {fast:?}"),
        }
        if plain_block(text).is_some() {
            assert!(general.is_ok(), "{text:?}: taken as plain but {general:?}");
        }
        for before in ["N5 G1 X1 Y2 (cut) ;end", "G0 X1", "", "#1=2", "/N7 (only)"] {
            same_after(before, text, dialect, &general);
        }
    }
}

/// `text` read by [`parse_line_into`] into the line `before` was read into: as `general`.
fn same_after(
    before: &str,
    text: &str,
    dialect: Dialect,
    general: &Result<cnc402_lang::ast::Line, cnc402_lang::NcError>,
) {
    let Ok(mut line) = parse_line(&SourceFile::window("p.nc", before, 3), dialect) else {
        return;
    };
    let reused = parse_line_into(&SourceFile::window("p.nc", text, 7), dialect, &mut line);
    match (general, &reused) {
        (Ok(g), Ok(())) => assert_eq!(g, &line, "{text:?} after {before:?} in {dialect:?}"),
        (Err(g), Err(f)) => assert_eq!(g.to_string(), f.to_string(), "{text:?}"),
        _ => panic!("{text:?} after {before:?} in {dialect:?}: {general:?} against {reused:?}"),
    }
}

#[test]
fn plain_blocks_read_as_the_general_parser_reads_them() {
    for text in [
        "",
        "   ",
        "G1 X10.0000 Y-0.0100",
        "N10 G1 X1.5 Y-2",
        "n 5 g0",
        "N0010G90G54G0X1Y2",
        "G01 X10 Y-2.5 Z.5 A+3 B1.",
        "X-.5",
        "x 10 y\t-2",
        "X1E2",
        "G38.2 Z-5",
        "X1234567890.123456789",
        "X0.1234567890123456",
        "N4294967295 G0",
        "N4294967296 G0",
        "N123456789 G0",
        "N1.5 G0",
        "X1.2.3",
        "X1 0",
        "G1 X",
        "X - 5",
        "G1 N5",
        "GOTO 5",
        "GO10",
        "EN1",
        "END 1",
        "IF[#1EQ1]GOTO5",
        "WH[#1LT3]DO1",
        "DO1",
        "O100",
        "o100 sub",
        "X-#1",
        "X[1+2]",
        "F=100*2",
        "G1 X1 (cut)",
        "G1 X1 ;cut",
        "/G1 X1",
        "G1 X1\r",
        "G1 Ä2",
        "@5 ^90",
        "G1X1Y2Z3",
        "G1 X+.5",
        "G1 X.",
        "%",
        "(MSG, hello) G1 X1",
        "G1 X1 (DEBUG, #1 = [#1]) ;end",
        "N10 (a(b)c) G0 X1",
        "(unclosed",
        "G1 X1 (a(b)",
        "G1 X1(c)Y2",
        "X1;",
        "X1.;(",
        "(Fräse) G1",
        "G1 ; é",
        "G1 ;a\r",
        "G1 (a\rb)",
        "N10(c)",
        "N10;x",
        "((()))",
        "(a) / G1",
        "(a) N10 G1",
        "(a) O100",
        "(a) %",
        "G1 X1 (a) (b) ;c (d)",
        "G1 X(1)",
        "G1 X (1) 2",
        "(PRINT, x)",
        "  (only) ",
        "(x) IF[#1EQ1]GOTO5",
        "(x) #1=2",
    ] {
        same(text);
    }
}

/// Pieces of near-plain lines, with the characters that end the fast path.
fn piece() -> impl Strategy<Value = &'static str> {
    prop::sample::select(vec![
        "G",
        "X",
        "y",
        "Z",
        "F",
        "N",
        "n",
        "O",
        "M",
        "E",
        "I",
        "W",
        "H",
        "D",
        "T",
        "1",
        "0",
        "25",
        "9999999999",
        ".",
        "-",
        "+",
        " ",
        "\t",
        "(",
        ")",
        ";",
        "#",
        "[",
        "]",
        "=",
        "\r",
        "é",
        "/",
        "%",
        ":",
        "@",
        "^",
        ",",
        "R",
        "_",
        "{",
        "=",
        "$",
        "(MSG,",
        "(DEBUG,",
        "(a(b)c)",
        ";x(",
    ])
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    /// Bytes that are no UTF-8 (a Latin-1 line) are never a plain block: the load pass
    /// decodes and parses such a line in full.
    #[test]
    fn a_line_that_is_no_utf8_is_no_plain_block(
        head in "[GXN0-9. ]{0,8}", byte in 0x80u8.., tail in "[GXN0-9. ]{0,8}"
    ) {
        let mut body = head.into_bytes();
        body.push(byte);
        body.extend_from_slice(tail.as_bytes());
        prop_assert_eq!(plain_block_bytes(&body), None);
    }

    /// The load pass's class table classifies any bytes as the plain-block parser does:
    /// lines of the bytes where its states change (letters, `N`/`O`, signs, points, digits,
    /// spaces, comments, `\r`, bytes past ASCII), and of the pieces below.
    #[test]
    fn the_class_table_classifies_a_line_as_the_parser_does(
        bytes in prop::collection::vec(prop::sample::select(
            b" \tGXyNnOo019.+-();*\r\x80\xff#[".to_vec()), 0..24),
        // Only bytes the table reads itself: most such lines are decided there.
        table in prop::collection::vec(prop::sample::select(b" \tGXyNn059.+-".to_vec()), 0..16),
        // An `N` number of up to 12 digits (9 are read, no more) and what may follow it.
        n_digits in "[0-9]{0,12}",
        after in prop::sample::select(vec!["", " ", "G1", " X-1.5", ".", ".5", "(c)", ";", "N1", "O1"]),
        parts in prop::collection::vec(piece(), 0..10),
    ) {
        let numbered = format!("N{n_digits}{after}").into_bytes();
        for b in [&bytes, &table, &numbered] {
            prop_assert_eq!(plain_block_bytes(b), plain_block_bytes_by_scan(b), "{:?}", b);
        }
        let text = parts.concat();
        prop_assert_eq!(
            plain_block_bytes(text.as_bytes()),
            plain_block_bytes_by_scan(text.as_bytes()),
            "{:?}", text
        );
    }

    #[test]
    fn any_line_reads_the_same_with_or_without_the_fast_path(
        parts in prop::collection::vec(piece(), 0..14)
    ) {
        same(&parts.concat());
    }

    #[test]
    fn any_line_read_into_the_line_before_it_reads_the_same(
        before in prop::collection::vec(piece(), 0..10),
        parts in prop::collection::vec(piece(), 0..14)
    ) {
        let text = parts.concat();
        if !is_statement_line(&text) {
            for dialect in [Dialect::Fanuc, Dialect::LinuxCnc] {
                let window = SourceFile::window("p.nc", text.as_str(), 7);
                let general = parse_in(&window, dialect).map(|mut p| p.lines.remove(0));
                same_after(&before.concat(), &text, dialect, &general);
            }
        }
    }

    #[test]
    fn generated_plain_blocks_take_the_fast_path_and_agree(
        n in prop::option::of(0u32..100_000),
        words in prop::collection::vec(
            (prop::sample::select(vec!['G', 'X', 'Y', 'Z', 'F', 'S', 'M', 'a', 'b']),
             -1.0e6f64..1.0e6, 0usize..7),
            0..8,
        ),
    ) {
        let mut text = n.map(|n| format!("N{n} ")).unwrap_or_default();
        for (letter, v, decimals) in words {
            text.push_str(&format!("{letter}{v:.decimals$} "));
        }
        prop_assert!(plain_block(&text).is_some(), "{text:?}");
        same(&text);
    }
}
