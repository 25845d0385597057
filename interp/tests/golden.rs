//! Whole programs under `tests/programs/*.nc` against their reviewed segment dumps
//! (`*.jsonl`) and canonical dumps (`*.canon.jsonl`), byte for byte. `UPDATE_GOLDEN=1 cargo
//! test -p cnc402-interp --test golden` rewrites the dumps; review every changed line before
//! committing it. The canonical stream lowered again must give the segment stream exactly.

use std::path::Path;

use cnc402_config::MachineConfig;
use cnc402_interp::dump::canon::canon_to_jsonl;
use cnc402_interp::dump::{json_str, segments_to_jsonl};
use cnc402_interp::lower::{lower, xyz_indices};
use cnc402_interp::run_program;
use cnc402_lang::SourceFile;

/// The dump of a program, with a final `{"error": …}` line if it stops with an error.
fn dump(cfg: &MachineConfig, name: &str, text: &str) -> String {
    let src = SourceFile::new(name, text);
    let mut it = cnc402_interp::Interpreter::new(cfg);
    let mut out = String::new();
    match cnc402_lang::parse(&src) {
        Err(e) => out.push_str(&format!("{{\"error\":{}}}\n", json_str(&e.to_string()))),
        Ok(p) => {
            it.load(src.clone(), p);
            let mut segs = Vec::new();
            loop {
                match it.next_segment() {
                    Ok(Some(s)) => segs.push(s),
                    Ok(None) => {
                        out.push_str(&segments_to_jsonl(&segs, cfg));
                        break;
                    }
                    Err(e) => {
                        out.push_str(&segments_to_jsonl(&segs, cfg));
                        out.push_str(&format!("{{\"error\":{}}}\n", json_str(&e.to_string())));
                        break;
                    }
                }
            }
        }
    }
    // The iterator API and run_program agree.
    if !out.contains("\"error\"") {
        let all = run_program(cfg, &src).expect("same program runs");
        assert_eq!(segments_to_jsonl(&all, cfg), out);
    }
    out
}

/// The canonical dump of a program (and an `{"error": …}` line), checking on the way that
/// lowering the operations gives exactly the segments `next_segment` gives.
fn canon_dump(cfg: &MachineConfig, name: &str, text: &str) -> String {
    let src = SourceFile::new(name, text);
    let Ok(p) = cnc402_lang::parse(&src) else {
        return String::new();
    };
    let mut it = cnc402_interp::Interpreter::new(cfg);
    it.load(src, p);
    let (mut ops, mut lowered, mut out) = (Vec::new(), Vec::new(), String::new());
    loop {
        match it.next_canon() {
            Ok(Some(op)) => {
                lower(&op, xyz_indices(cfg), &mut lowered);
                ops.push(op);
            }
            Ok(None) => break,
            Err(e) => {
                out = format!("{{\"error\":{}}}\n", json_str(&e.to_string()));
                break;
            }
        }
    }
    let segs = segments_to_jsonl(&lowered, cfg);
    let seg_dump = dump(cfg, name, text);
    assert!(
        seg_dump.starts_with(&segs),
        "{name}: lowered canon ≠ segments"
    );
    canon_to_jsonl(&ops, cfg) + &out
}

#[test]
fn golden_programs() {
    let cfg = MachineConfig::default_machine();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/programs");
    let update = std::env::var_os("UPDATE_GOLDEN").is_some();
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .expect("tests/programs exists")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "nc"))
        .collect();
    names.sort();
    assert!(names.len() >= 5, "programs missing");
    let mut failed = Vec::new();
    for p in names {
        let file = p.file_name().unwrap().to_string_lossy().to_string();
        let text = std::fs::read_to_string(&p).unwrap();
        let name = format!("programs/{file}");
        let canon = canon_dump(&cfg, &name, &text);
        let canon_golden = p.with_extension("canon.jsonl");
        let got = dump(&cfg, &name, &text);
        let golden = p.with_extension("jsonl");
        if update {
            std::fs::write(&golden, &got).unwrap();
            std::fs::write(&canon_golden, &canon).unwrap();
            continue;
        }
        let want_canon = std::fs::read_to_string(&canon_golden).unwrap_or_default();
        if want_canon != canon {
            failed.push(format!(
                "{file}: canonical dump differs from {}",
                canon_golden.display()
            ));
        }
        let want = std::fs::read_to_string(&golden).unwrap_or_default();
        if want != got {
            let first = want
                .lines()
                .zip(got.lines())
                .position(|(a, b)| a != b)
                .unwrap_or(want.lines().count().min(got.lines().count()));
            failed.push(format!(
                "{file}: differs at line {}\n  want: {}\n  got:  {}",
                first + 1,
                want.lines().nth(first).unwrap_or("<end>"),
                got.lines().nth(first).unwrap_or("<end>")
            ));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}
