//! The deepest expressions the parser accepts ([`MAX_HEIGHT`] operator levels, inside the
//! deepest brackets and calls) run on the smallest stack the product gives an interpreter:
//! the feeder thread of `run`, spawned with Rust's default 2 MiB (the main thread has 8 MiB,
//! the C-like executor 16 MiB, see `hll_stack.rs`). And every input of the crash corpus
//! (`lang/tests/corpus/`) ends in segments or an error with a location.

use cnc402_config::MachineConfig;
use cnc402_lang::{MAX_HEIGHT, SourceFile};

/// The feeder's stack: `std::thread::Builder` without `stack_size`.
const SMALLEST_STACK: usize = 2 << 20;

fn cfg() -> MachineConfig {
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.variables_file = None;
    cfg
}

/// Runs `text` to its end on a thread with the smallest stack; an overflow aborts the test.
fn run_small(text: String) -> Result<usize, String> {
    std::thread::Builder::new()
        .stack_size(SMALLEST_STACK)
        .spawn(move || {
            cnc402_interp::run_program(&cfg(), &SourceFile::new("deep.nc", text.as_str()))
                .map(|s| s.len())
                .map_err(|e| e.to_string())
        })
        .expect("spawn")
        .join()
        .expect("no panic")
}

/// `MAX_HEIGHT` operators in one chain, inside `wrap` (open, close) nested `n` times.
fn chain(op: &str, wrap: (&str, &str), n: usize) -> String {
    let terms = format!("1{}", format!("{op}1").repeat(MAX_HEIGHT as usize));
    format!("{}{terms}{}", wrap.0.repeat(n), wrap.1.repeat(n))
}

#[test]
fn deepest_expressions_run_on_the_smallest_stack() {
    let deep = 31;
    let programs = [
        format!("#1={}\nM30\n", chain("+", ("[", "]"), deep)),
        format!("#1={}\nM30\n", chain("*", ("ABS[", "]"), deep)),
        format!("#1={}\nM30\n", chain("+", ("-[", "]"), deep / 2)),
        format!("G0 X[{}]\nM30\n", chain("-", ("[", "]"), deep - 1)),
        format!("double dA = {};\nM02\n", chain("+", ("(", ")"), deep)),
        format!(
            "double dA = {};\nM02\n",
            chain("*", ("fabs(", ")"), deep - 1)
        ),
        format!("bool bA = {};\nM02\n", chain(" || ", ("!(", ")"), deep / 2)),
        format!(
            "double dA = 0;\nG0 X=({})\nM02\n",
            chain("-", ("(", ")"), deep - 1)
        ),
    ];
    for p in programs {
        let head: String = p.chars().take(60).collect();
        run_small(p).unwrap_or_else(|e| panic!("{head}: {e}"));
    }
}

#[test]
fn corpus_runs_to_a_clear_result() {
    let dir = format!("{}/../lang/tests/corpus", env!("CARGO_MANIFEST_DIR"));
    for entry in std::fs::read_dir(&dir).expect("corpus") {
        let path = entry.expect("entry").path();
        let name = path.display().to_string();
        let src = SourceFile::from_bytes(name.as_str(), std::fs::read(&path).expect("read"));
        let text = src.text.to_string();
        let r = std::thread::Builder::new()
            .stack_size(SMALLEST_STACK)
            .spawn(move || {
                cnc402_interp::run_program(&cfg(), &src)
                    .map(|s| s.len())
                    .map_err(|e| (e.line, e.col, e.file.to_string(), e.to_string()))
            })
            .expect("spawn")
            .join()
            .expect("no panic");
        if let Err((line, col, file, e)) = r {
            assert!(line >= 1 && col >= 1, "{name}: {e}");
            assert!(file.contains(&name) || text.is_empty(), "{name}: {e}");
        }
    }
}
