//! Inputs that crashed the parser or the diagnostics (issue 18), and the committed corpus
//! in `tests/corpus/`: every file ends in a program or an error with a location, and the
//! error renders, however long its line.

use cnc402_lang::{MAX_HEIGHT, NcError, SourceFile, parse};

fn corpus(name: &str) -> SourceFile {
    let path = format!("{}/tests/corpus/{name}", env!("CARGO_MANIFEST_DIR"));
    SourceFile::from_bytes(name, std::fs::read(&path).expect(&path))
}

fn render(e: &NcError) -> String {
    let mut out = String::new();
    miette::GraphicalReportHandler::new_themed(miette::GraphicalTheme::unicode_nocolor())
        .render_report(&mut out, e)
        .expect("renders");
    out
}

fn too_deep(name: &str) -> NcError {
    let e = parse(&corpus(name)).expect_err(name);
    assert!(
        e.message.contains("expression nested too deeply"),
        "{name}: {e}"
    );
    assert!(render(&e).contains(&e.location()), "{name}");
    e
}

#[test]
fn long_macro_b_sum_is_no_stack_overflow() {
    let e = too_deep("long_macro_b_sum.nc");
    // `#1=1` and MAX_HEIGHT `+1` are accepted; the error is at the next `+`.
    assert_eq!((e.line, e.col), (3, 5 + 2 * MAX_HEIGHT));
}

#[test]
fn long_gcode_word_sum_is_no_stack_overflow() {
    too_deep("long_gcode_word_sum.nc");
}

#[test]
fn long_clike_sum_is_no_stack_overflow() {
    too_deep("long_clike_sum.nc");
    too_deep("long_clike_gcode_value.nc");
    too_deep("long_clike_logical_chain.nc");
    too_deep("long_clike_field_chain.nc");
}

#[test]
fn deep_brackets_are_no_stack_overflow() {
    too_deep("deep_macro_b_brackets.nc");
    too_deep("deep_clike_parentheses.nc");
}

#[test]
fn a_chain_at_the_bound_parses() {
    let at = format!("#1=1{}\n", "+1".repeat(MAX_HEIGHT as usize));
    parse(&SourceFile::new("at.nc", at.as_str())).expect("MAX_HEIGHT operators parse");
    let c = format!("double dA = 1{};\n", " * 2".repeat(MAX_HEIGHT as usize));
    parse(&SourceFile::new("at.nc", c.as_str())).expect("MAX_HEIGHT operators parse");
}

#[test]
fn error_past_column_65536_renders_without_panic() {
    let e = parse(&corpus("error_past_column_65536.nc")).expect_err("`$` is no address");
    assert_eq!((e.line, e.col), (3, 200_006));
    let out = render(&e);
    assert!(out.contains("error_past_column_65536.nc:3:200006"), "{out}");
    assert!(out.lines().all(|l| l.chars().count() < 1000), "{out}");
    // The message's block is cut around the error too.
    assert!(e.to_string().len() < 1000);
    assert_eq!(e.block.len(), 200_006);
}

#[test]
fn error_on_a_short_line_renders_as_before() {
    let src = SourceFile::new("p.nc", "G0 X1\nG1 X Y2\nM30\n");
    let e = NcError::new(&src, cnc402_lang::ast::Span::new(9, 10), "missing number");
    assert_eq!(e.to_string(), "p.nc:2:4: missing number\n    G1 X Y2");
    let out = render(&e);
    assert!(out.contains("[p.nc:2:4]"), "{out}");
    assert!(
        out.contains(" 1 │ G0 X1") && out.contains(" 2 │ G1 X Y2"),
        "{out}"
    );
    assert!(out.contains(" 3 │ M30"), "{out}");
}

#[test]
fn latin1_comment_is_read_not_an_io_error() {
    let src = corpus("latin1_comment.nc");
    assert_eq!(src.line_text(3), "(Fräse Ø 10)");
    parse(&src).expect("a Latin-1 comment parses");
}

#[test]
fn nul_outside_comment_is_an_error_at_its_column() {
    let e = parse(&corpus("nul_outside_comment.nc")).expect_err("NUL is no text");
    assert_eq!((e.line, e.col), (3, 6));
    assert!(e.message.contains("U+0000"), "{e}");
}

/// Every file of the corpus: no panic, a program or an error with a location that renders.
#[test]
fn corpus_replays_without_panic() {
    let dir = format!("{}/tests/corpus", env!("CARGO_MANIFEST_DIR"));
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).expect("corpus") {
        let path = entry.expect("entry").path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let src = SourceFile::from_bytes(name.as_str(), std::fs::read(&path).expect("read"));
        if let Err(e) = parse(&src) {
            assert!(e.line >= 1 && e.col >= 1, "{name}: {e}");
            assert!(render(&e).contains(&e.location()), "{name}");
        }
        n += 1;
    }
    assert!(n >= 10, "{n} files in {dir}");
}
