//! The bad-input corpus: malformed programs, each with the exact line, column and message of
//! the error the parser must report. Columns count characters, 1-based.

use cnc402_lang::{SourceFile, parse};

/// (name, program, line, col, message)
const CASES: &[(&str, &str, u32, u32, &str)] = &[
    // --- words and numbers ---
    (
        "address_without_value_at_eol",
        "G1 X",
        1,
        4,
        "no value after address X",
    ),
    (
        "address_followed_by_address",
        "G1 X Y2",
        1,
        4,
        "no value after address X",
    ),
    (
        "address_followed_by_comment",
        "G0 Z(up)",
        1,
        4,
        "no value after address Z",
    ),
    ("lone_letter", "G", 1, 1, "no value after address G"),
    ("sign_without_digits", "G1 X-", 1, 6, "no digits after `-`"),
    (
        "plus_without_digits",
        "G1 X+ Y1",
        1,
        6,
        "no digits after `+`",
    ),
    ("double_sign", "G1 X--1", 1, 6, "no digits after `-`"),
    ("sign_space_digits", "G1 X- 5", 1, 6, "no digits after `-`"),
    (
        "point_without_digits",
        "G1 X.",
        1,
        5,
        "a decimal point without digits",
    ),
    (
        "signed_point_without_digits",
        "G1 X-.",
        1,
        6,
        "a decimal point without digits",
    ),
    (
        "two_decimal_points",
        "G1 X1.2.3",
        1,
        8,
        "a second decimal point in a number",
    ),
    (
        "space_inside_number",
        "G1 X1 0",
        1,
        7,
        "a number without an address letter",
    ),
    (
        "number_at_block_start",
        "10 G1",
        1,
        1,
        "a number without an address letter",
    ),
    (
        "number_after_comment",
        "G1 (c) 5",
        1,
        8,
        "a number without an address letter",
    ),
    (
        "exponent_is_not_a_number",
        "G1 X1E",
        1,
        6,
        "no value after address E",
    ),
    (
        "unknown_letter_umlaut",
        "G1 Ä1",
        1,
        4,
        "unknown address letter `Ä`",
    ),
    (
        "unknown_char_at",
        "G1 @1",
        1,
        4,
        "unknown address letter `@`",
    ),
    (
        "unknown_char_dollar",
        "$X1",
        1,
        1,
        "unknown address letter `$`",
    ),
    (
        "unknown_char_ampersand",
        "G1 X1 &",
        1,
        7,
        "unknown address letter `&`",
    ),
    (
        "full_width_letter",
        "G1 Ｘ1",
        1,
        4,
        "unknown address letter `Ｘ`",
    ),
    (
        "control_char",
        "G1\u{7}X1",
        1,
        3,
        "unexpected control character U+0007",
    ),
    (
        "second_line_error",
        "G0 X0\nG1 Y\n",
        2,
        4,
        "no value after address Y",
    ),
    (
        "error_after_utf8_comment",
        "(角度)G1 X",
        1,
        8,
        "no value after address X",
    ),
    (
        "lower_case_missing_value",
        "g1 x",
        1,
        4,
        "no value after address X",
    ),
    (
        "tab_separated_missing_value",
        "G1\tF\tX1",
        1,
        4,
        "no value after address F",
    ),
    // --- N and O numbers ---
    (
        "n_not_first",
        "G1 N10 X1",
        1,
        4,
        "a sequence number N must start the block",
    ),
    (
        "n_twice",
        "N10 N20",
        1,
        5,
        "a sequence number N must start the block",
    ),
    ("n_without_digits", "N G1", 1, 3, "missing sequence number"),
    (
        "n_with_point",
        "N10.5 G1",
        1,
        2,
        "a sequence number must be a whole number",
    ),
    (
        "n_too_large",
        "N99999999999 G1",
        1,
        2,
        "sequence number too large",
    ),
    ("n_negative", "N-5", 1, 2, "missing sequence number"),
    (
        "o_without_digits",
        "O(MAIN)",
        1,
        2,
        "missing program number",
    ),
    (
        "o_with_point",
        "O12.3",
        1,
        2,
        "a program number must be a whole number",
    ),
    (
        "o_too_large",
        "O4294967296",
        1,
        2,
        "program number too large",
    ),
    (
        "o_followed_by_words",
        "O1000 G1 X1",
        1,
        7,
        "unexpected text after the program number",
    ),
    (
        "o_in_block",
        "G1 O100",
        1,
        4,
        "a program number O must stand at the start of its own line",
    ),
    ("colon_without_digits", ":", 1, 2, "missing program number"),
    (
        "o_named_linuxcnc_sub",
        "o<probe> sub",
        1,
        2,
        "missing program number",
    ),
    // --- percent and block delete ---
    (
        "percent_followed_by_words",
        "% G1",
        1,
        3,
        "unexpected text after `%`",
    ),
    (
        "percent_in_block",
        "G1 %",
        1,
        4,
        "`%` must stand on its own line",
    ),
    (
        "slash_in_block",
        "G1 / X1",
        1,
        4,
        "block delete `/` must start the block",
    ),
    (
        "slash_after_n",
        "N10 /G1",
        1,
        5,
        "block delete `/` must start the block",
    ),
    // --- comments ---
    ("unclosed_comment", "G1 (open", 1, 4, "unclosed comment"),
    (
        "unclosed_comment_later_line",
        "G0\n\nG1 X1 (never closed\nG0",
        3,
        7,
        "unclosed comment",
    ),
    (
        "close_paren_without_open",
        "G1 X1 )",
        1,
        7,
        "`)` without `(`",
    ),
    (
        "comment_does_not_span_lines",
        "(a\nb)",
        1,
        1,
        "unclosed comment",
    ),
    (
        "comment_inside_number_gap",
        "G1 X(c)1",
        1,
        4,
        "no value after address X",
    ),
    // --- brackets and expressions ---
    (
        "unclosed_bracket",
        "G1 X[1+2",
        1,
        5,
        "unbalanced bracket: `[` is not closed",
    ),
    (
        "unclosed_inner_bracket",
        "G1 X[[1+2]",
        1,
        5,
        "unbalanced bracket: `[` is not closed",
    ),
    (
        "extra_close_bracket",
        "G1 X[1]]",
        1,
        8,
        "unbalanced bracket: `]` without `[`",
    ),
    (
        "close_bracket_alone",
        "G1 ]",
        1,
        4,
        "unbalanced bracket: `]` without `[`",
    ),
    (
        "bracket_without_address",
        "G1 [1+2]",
        1,
        4,
        "`[` without an address letter",
    ),
    (
        "equals_without_address",
        "G1 =5",
        1,
        4,
        "`=` without an address letter",
    ),
    ("empty_brackets", "G1 X[]", 1, 6, "empty brackets"),
    (
        "dangling_plus",
        "G1 X[1+]",
        1,
        8,
        "missing operand after `+`",
    ),
    (
        "dangling_times",
        "G1 X[2*]",
        1,
        8,
        "missing operand after `*`",
    ),
    (
        "dangling_or",
        "G1 X[1 OR]",
        1,
        10,
        "missing operand after `OR`",
    ),
    (
        "dangling_eq",
        "G1 X[1 EQ ]",
        1,
        11,
        "missing operand after `EQ`",
    ),
    (
        "dangling_unary",
        "G1 X[-]",
        1,
        7,
        "missing operand after `-`",
    ),
    (
        "two_numbers_in_brackets",
        "G1 X[1 2]",
        1,
        8,
        "unexpected text in expression",
    ),
    (
        "paren_group_in_brackets",
        "G1 X[(1+2)]",
        1,
        6,
        "`(` starts a comment, not a group; group with `[ ]`",
    ),
    (
        "unknown_function",
        "G1 X[FOO[1]]",
        1,
        6,
        "unknown function `FOO`",
    ),
    (
        "function_without_bracket",
        "G1 X[SIN 30]",
        1,
        10,
        "missing `[` after function SIN",
    ),
    (
        "function_without_argument",
        "G1 X[COS[]]",
        1,
        10,
        "missing argument of COS",
    ),
    (
        "function_too_many_args",
        "G1 X[SQRT[1,2]]",
        1,
        6,
        "SQRT takes 1 argument, found 2",
    ),
    (
        "pow_one_arg",
        "G1 X[POW[2]]",
        1,
        6,
        "POW takes 2 arguments, found 1",
    ),
    (
        "function_unclosed",
        "G1 X[SIN[30]",
        1,
        5,
        "unbalanced bracket: `[` is not closed",
    ),
    (
        "function_arg_unclosed",
        "G1 X[SIN[30",
        1,
        9,
        "unbalanced bracket: `[` is not closed",
    ),
    (
        "atan_second_unclosed",
        "G1 X[ATAN[1]/[2]",
        1,
        5,
        "unbalanced bracket: `[` is not closed",
    ),
    (
        "equals_without_expression",
        "G1 F= X1",
        1,
        7,
        "missing expression after `F=`",
    ),
    (
        "equals_at_eol",
        "G1 F=",
        1,
        6,
        "missing expression after `F=`",
    ),
    (
        "equals_dangling_operator",
        "G1 F=100* X1",
        1,
        11,
        "missing operand after `*`",
    ),
    (
        "nested_too_deep",
        "G1 X[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[1]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]",
        1,
        37,
        "expression nested too deeply (more than 32 levels)",
    ),
    (
        "comma_outside_call",
        "G1 X[1,2]",
        1,
        7,
        "unexpected text in expression",
    ),
    (
        "operator_keyword_as_operand",
        "G1 X[AND 1]",
        1,
        6,
        "unexpected `AND` in expression",
    ),
    (
        "unknown_function_after_operator",
        "G1 X[1+FOO[2]]",
        1,
        8,
        "unknown function `FOO`",
    ),
];

#[test]
fn every_bad_program_reports_line_col_and_message() {
    let mut failures = Vec::new();
    for &(name, text, line, col, message) in CASES {
        let src = SourceFile::new(format!("{name}.nc"), text);
        match parse(&src) {
            Ok(p) => failures.push(format!("{name}: parsed without error: {p:?}")),
            Err(e) => {
                if (e.line, e.col, e.message.as_str()) != (line, col, message) {
                    failures.push(format!(
                        "{name}: got {}:{} {:?}, want {line}:{col} {message:?}",
                        e.line, e.col, e.message
                    ));
                }
                // The rendered error names the file and the location.
                let shown = e.to_string();
                if !shown.starts_with(&format!("{name}.nc:{}:{}: ", e.line, e.col)) {
                    failures.push(format!("{name}: rendered as {shown:?}"));
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases wrong:\n{}",
        failures.len(),
        CASES.len(),
        failures.join("\n")
    );
}

#[test]
fn the_corpus_is_big_and_names_are_unique() {
    assert!(CASES.len() >= 60, "{}", CASES.len());
    let mut names: Vec<&str> = CASES.iter().map(|c| c.0).collect();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), CASES.len());
}
