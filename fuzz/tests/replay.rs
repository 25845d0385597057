//! Every input the fuzzer ever found (`fuzz/crashes/<target>/`) and every corpus input
//! (`fuzz/corpus/<target>/`) runs through its target again: no panic, no non-finite segment.
//! A file's first line may name what it was (the fuzzer writes raw inputs; hand-added ones
//! are named after the bug).

use std::path::Path;

use cnc402_fuzz::{Target, run};

fn replay(folder: &str) -> (usize, Vec<String>) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join(folder);
    let (mut n, mut failed) = (0, Vec::new());
    for t in Target::ALL {
        let Ok(rd) = std::fs::read_dir(root.join(t.name())) else {
            continue;
        };
        let mut files: Vec<_> = rd.flatten().map(|e| e.path()).collect();
        files.sort();
        for f in files {
            let input = std::fs::read(&f).unwrap();
            n += 1;
            if let Err(e) = run(t, &input) {
                failed.push(format!("{}: {e:?}", f.display()));
            }
        }
    }
    (n, failed)
}

#[test]
fn every_found_crash_stays_fixed() {
    std::panic::set_hook(Box::new(|_| {}));
    let (_, failed) = replay("crashes");
    let (_, failed_corpus) = replay("corpus");
    let all: Vec<_> = failed.into_iter().chain(failed_corpus).collect();
    assert!(all.is_empty(), "{}", all.join("\n"));
}

#[test]
fn the_targets_catch_a_panic_and_a_clean_input_passes() {
    assert_eq!(run(Target::Parse, b"G0 X1\nM30\n"), Ok(()));
    assert_eq!(run(Target::Interp, b"G0 X1\nG1 Y2 F100\nM30\n"), Ok(()));
    assert_eq!(run(Target::Frames, &[0, 0x80, 0]), Ok(()));
    let cfg = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../config/machine.toml"
    ));
    assert_eq!(run(Target::Config, &cfg.unwrap()), Ok(()));
}
