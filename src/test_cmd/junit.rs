//! The JUnit XML of `cnc402 test --junit`: one `<testsuite>` with a `<testcase>` per program
//! (`classname` its folder, `name` its file name, `time` the wall-clock seconds the test took),
//! a failure as `<failure message type>`, a program that could not be tried as `<error>`, one
//! Ctrl-C left unrun as `<skipped>`. Every text is escaped for XML 1.0, whatever it holds.

use std::fmt::Write as _;
use std::path::Path;

use super::{Failure, Summary, TestResult, Verdict};

/// The name of the suite (and of the `<testsuites>` around it).
const SUITE: &str = "cnc402 test";

/// The whole document for `results`, run in `wall_s` seconds.
pub(crate) fn document(results: &[TestResult], wall_s: f64) -> String {
    let s = Summary::of(results);
    let counts = format!(
        "tests=\"{}\" failures=\"{}\" errors=\"{}\" skipped=\"{}\" time=\"{wall_s:.3}\"",
        results.len(),
        s.failed,
        s.errors,
        s.not_run
    );
    let mut x = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(x, "<testsuites name=\"{SUITE}\" {counts}>");
    let _ = writeln!(x, "  <testsuite name=\"{SUITE}\" {counts}>");
    for r in results {
        testcase(&mut x, r);
    }
    x.push_str("  </testsuite>\n</testsuites>\n");
    x
}

/// One `<testcase>` element.
fn testcase(x: &mut String, r: &TestResult) {
    let path = Path::new(&r.name);
    let classname = match path.parent().map(|p| p.display().to_string()) {
        Some(p) if !p.is_empty() => p,
        _ => ".".to_string(),
    };
    let name = path
        .file_name()
        .map_or_else(|| r.name.clone(), |n| n.to_string_lossy().into_owned());
    let _ = write!(
        x,
        "    <testcase classname=\"{}\" name=\"{}\" time=\"{:.3}\">\n      ",
        attr(&classname),
        attr(&name),
        r.wall_s
    );
    match &r.verdict {
        Verdict::Pass { .. } => {
            let _ = write!(x, "<system-out>{}</system-out>", text(&r.line()));
        }
        Verdict::Fail(f) => problem(x, "failure", f),
        Verdict::Error(f) => problem(x, "error", f),
        Verdict::NotRun => x.push_str("<skipped message=\"not run: interrupted by Ctrl-C\"/>"),
    }
    x.push_str("\n    </testcase>\n");
}

/// A `<failure>` or `<error>` element: the one-line message and its kind as attributes, the
/// whole text (with the block) as its body.
fn problem(x: &mut String, element: &str, f: &Failure) {
    let _ = write!(
        x,
        "<{element} message=\"{}\" type=\"{}\">{}</{element}>",
        attr(&f.message),
        attr(f.kind),
        text(&f.detail)
    );
}

/// `s` as an attribute value (inside double quotes): line ends and tabs kept as character
/// references (a parser would turn them into spaces otherwise).
fn attr(s: &str) -> String {
    escape(s, true)
}

/// `s` as element text.
fn text(s: &str) -> String {
    escape(s, false)
}

/// Escapes the five markup characters; a character XML 1.0 cannot hold at all (control
/// characters other than tab, line feed and carriage return; U+FFFE, U+FFFF) becomes U+FFFD.
fn escape(s: &str, in_attr: bool) -> String {
    let mut out = String::with_capacity(s.len() + 16);
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\n' if in_attr => out.push_str("&#10;"),
            '\r' => out.push_str("&#13;"),
            '\t' if in_attr => out.push_str("&#9;"),
            '\t' | '\n' => out.push(c),
            c if (c as u32) < 0x20 || c == '\u{FFFE}' || c == '\u{FFFF}' => out.push('\u{FFFD}'),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::BlockCount;
    use super::*;

    fn result(name: &str, verdict: Verdict) -> TestResult {
        TestResult {
            name: name.into(),
            verdict,
            program_time_s: 1.5,
            wall_s: 0.25,
        }
    }

    fn failure(message: &str) -> Failure {
        Failure {
            kind: "program",
            message: message.into(),
            detail: format!("{message}\n    G1 X<1>"),
        }
    }

    #[test]
    fn markup_and_characters_xml_cannot_hold_are_escaped() {
        assert_eq!(
            attr("a<b>&\"c'\n\td\r"),
            "a&lt;b&gt;&amp;&quot;c&apos;&#10;&#9;d&#13;"
        );
        assert_eq!(text("x]]>y\n\tz"), "x]]&gt;y\n\tz");
        assert_eq!(
            text("bell\u{7}nul\u{0}\u{FFFF}"),
            "bell\u{FFFD}nul\u{FFFD}\u{FFFD}"
        );
        assert_eq!(text("Größe ø 10 µm — 工件"), "Größe ø 10 µm — 工件");
    }

    #[test]
    fn counts_cases_and_kinds_are_in_the_document() {
        let results = [
            result(
                "examples/a.nc",
                Verdict::Pass {
                    blocks: Some(BlockCount::Exact(12)),
                    notes: vec![],
                },
            ),
            result("b & <c>.nc", Verdict::Fail(failure("b.nc:3:4: \"F\" < 0"))),
            result("gone.nc", Verdict::Error(failure("gone.nc: No such file"))),
            result("later.nc", Verdict::NotRun),
        ];
        let x = document(&results, 2.0);
        assert!(x.starts_with("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"));
        assert!(x.contains(
            "<testsuite name=\"cnc402 test\" tests=\"4\" failures=\"1\" errors=\"1\" \
             skipped=\"1\" time=\"2.000\">"
        ));
        assert!(x.contains(
            "<testcase classname=\"examples\" name=\"a.nc\" time=\"0.250\">\n      \
             <system-out>PASS examples/a.nc (program time 1.500 s, 12 blocks)</system-out>"
        ));
        assert!(x.contains(
            "<testcase classname=\".\" name=\"b &amp; &lt;c&gt;.nc\" time=\"0.250\">\n      \
             <failure message=\"b.nc:3:4: &quot;F&quot; &lt; 0\" type=\"program\">b.nc:3:4: \
             &quot;F&quot; &lt; 0\n    G1 X&lt;1&gt;</failure>"
        ));
        assert!(x.contains("<error message=\"gone.nc: No such file\" type=\"program\">"));
        assert!(x.contains("<skipped message=\"not run: interrupted by Ctrl-C\"/>"));
        assert!(x.ends_with("  </testsuite>\n</testsuites>\n"));
    }
}
