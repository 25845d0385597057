//! Dropping an interpreter (or loading another program) ends the C-like executor thread and
//! waits for it, whether the program is blocked handing out motion or computing in a loop.
//! One test in its own binary: it counts this process's threads named `cnc402-hll`.

use cnc402_config::MachineConfig;
use cnc402_interp::Interpreter;
use cnc402_lang::SourceFile;

fn executor_threads() -> usize {
    std::fs::read_dir("/proc/self/task")
        .unwrap()
        .flatten()
        .filter(|t| {
            std::fs::read_to_string(t.path().join("comm")).is_ok_and(|c| c.trim() == "cnc402-hll")
        })
        .count()
}

fn start(cfg: &MachineConfig, text: &str) -> Interpreter {
    let src = SourceFile::new("t.nc", text);
    let p = cnc402_lang::parse(&src).unwrap();
    let mut it = Interpreter::new(cfg);
    it.load(src, p);
    it
}

#[test]
fn dropping_an_interpreter_mid_program_ends_the_executor_thread() {
    let mut cfg = MachineConfig::default_machine();
    // No runaway stop: only the drop can end the computing loop.
    cfg.interp.block_limit = u64::MAX;
    assert_eq!(executor_threads(), 0);

    // Blocked handing out motion (the channel is full): endless moves.
    let mut it = start(&cfg, "int nI = 0;\nwhile (1) {\nG1 X1 F1000\nG1 X0\n}\n");
    for _ in 0..10 {
        assert!(it.next_segment().unwrap().is_some());
    }
    assert_eq!(executor_threads(), 1);
    drop(it);
    assert_eq!(executor_threads(), 0, "joined on drop");

    // Computing without motion after one move: the executor never sends again.
    let mut it = start(
        &cfg,
        "G1 X1 F1000\nint nI = 0;\nwhile (1) {\nnI = nI + 1;\n}\n",
    );
    assert!(it.next_segment().unwrap().is_some());
    assert_eq!(executor_threads(), 1);
    drop(it);
    assert_eq!(executor_threads(), 0, "a computing loop stops at the drop");

    // Loading the next program replaces (and ends) the running one.
    let mut it = start(&cfg, "while (1) {\nint nJ = 1;\n}\n");
    let src = SourceFile::new("u.nc", "G1 X2 F100\n");
    it.load(src.clone(), cnc402_lang::parse(&src).unwrap());
    assert_eq!(executor_threads(), 0);
    assert!(it.next_segment().unwrap().is_some());
}
