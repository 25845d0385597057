//! Every program that ever crashed or hung something (the fuzzer's `fuzz/crashes/`, the
//! regression corpora of `lang/tests/corpus/` and `interp/tests/corpus/`) through the
//! `cnc402` binary: `segments` and `canon` end with a documented exit code (0, or 2 for a
//! program error with `file:line:col`), never a panic (101) or an abort.

use std::path::{Path, PathBuf};
use std::process::Command;

fn programs() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut out = Vec::new();
    for dir in [
        "fuzz/crashes/parse",
        "fuzz/crashes/interp",
        "lang/tests/corpus",
        "interp/tests/corpus",
    ] {
        let Ok(rd) = std::fs::read_dir(root.join(dir)) else {
            continue;
        };
        let mut files: Vec<_> = rd
            .flatten()
            .map(|e| e.path())
            // The corpus's expected outcomes are not programs. Endless programs and runaway
            // loops run to the interpreter's bounds (a million blocks or lines: seconds in a
            // debug build); `interp/tests/corpus.rs` checks them through the library.
            .filter(|p| p.extension().is_none_or(|x| x != "expect"))
            .filter(|p| {
                let n = p.to_string_lossy();
                !n.contains("endless") && !n.contains("runaway")
            })
            .collect();
        files.sort();
        out.extend(files);
    }
    out
}

/// `text` holds `<file>:<line>:<col>`.
fn names_a_location(text: &str, file: &str) -> bool {
    text.match_indices(file).any(|(i, _)| {
        let rest = &text[i + file.len()..];
        let mut parts = rest.splitn(3, ':');
        let (_, line, col) = (parts.next(), parts.next(), parts.next());
        let digits = |s: Option<&str>| {
            s.is_some_and(|s| s.chars().take_while(|c| c.is_ascii_digit()).count() > 0)
        };
        digits(line) && digits(col)
    })
}

#[test]
fn crash_corpus_ends_with_a_documented_exit_code() {
    let files = programs();
    assert!(files.len() >= 10, "corpora missing: {files:?}");
    let mut bad = Vec::new();
    for f in &files {
        for cmd in ["segments", "canon"] {
            let o = Command::new(env!("CARGO_BIN_EXE_cnc402"))
                .args([cmd, f.to_str().unwrap()])
                .current_dir(env!("CARGO_MANIFEST_DIR"))
                .output()
                .expect("run cnc402");
            let err = String::from_utf8_lossy(&o.stderr);
            let ok = match o.status.code() {
                Some(0) => true,
                // A program error names where: `file:line:col`.
                Some(2) => names_a_location(&err, &f.display().to_string()),
                _ => false,
            };
            if !ok || err.contains("panicked") {
                let e: String = err.chars().take(300).collect();
                bad.push(format!("{cmd} {}: {:?} {e}", f.display(), o.status.code()));
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}
