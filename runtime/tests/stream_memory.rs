//! Memory stays bounded by the lookahead, not by the program: a generated program of fine
//! G64 moves streamed through the `segments` path (interpreter → JSON Lines) and through the
//! `run` path (dry run, then the embedded simulator) peaks, in live heap bytes, no higher at
//! 200,000 blocks than at 20,000 plus a fixed margin. (Parsed whole, the AST alone grows by
//! some 60 MB between the two.) One test in this binary: the allocator counts every thread.

use std::alloc::{GlobalAlloc, Layout, System};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use cnc402_config::MachineConfig;
use cnc402_runtime::{ProgramInput, RunOptions, run_input};

/// The system allocator, keeping the live heap bytes and their peak.
struct PeakAlloc;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn grew(by: usize) {
    let now = LIVE.fetch_add(by, Ordering::Relaxed) + by;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

// SAFETY: every call is forwarded unchanged to `System`; the counters are atomics.
unsafe impl GlobalAlloc for PeakAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        grew(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        grew(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size >= layout.size() {
            grew(new_size - layout.size());
        } else {
            LIVE.fetch_sub(layout.size() - new_size, Ordering::Relaxed);
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: PeakAlloc = PeakAlloc;

/// The peak of live heap bytes while `f` runs, above what was live before it.
fn peak_during(f: impl FnOnce()) -> usize {
    let base = LIVE.load(Ordering::SeqCst);
    PEAK.store(base, Ordering::SeqCst);
    f();
    PEAK.load(Ordering::SeqCst).saturating_sub(base)
}

/// `n` G1 blocks along a circle of radius 10 mm in 0.01 mm steps at F3000 under G64 P0.01
/// (the CAM-like program), written to a file of its own.
fn circle_program(n: usize) -> PathBuf {
    let path = std::env::temp_dir().join(format!(
        "cnc402-stream-memory-{}-{n}.nc",
        std::process::id()
    ));
    let mut f = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    writeln!(f, "G21 G90 G17\nG64 P0.01\nG0 X10 Y0 Z0\nF3000").unwrap();
    for i in 1..=n {
        let a = i as f64 * 0.001;
        writeln!(f, "G1 X{:.4} Y{:.4}", 10.0 * a.cos(), 10.0 * a.sin()).unwrap();
    }
    writeln!(f, "M30").unwrap();
    f.flush().unwrap();
    path
}

/// `cnc402 segments`: the program read line by line, every segment printed.
fn segments(cfg: &MachineConfig, path: &Path) -> usize {
    let mut it = cnc402_interp::Interpreter::new(cfg);
    let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    it.load_stream(path.display().to_string(), Box::new(file), None)
        .unwrap();
    let mut out = std::io::sink();
    let mut n = 0;
    while let Some(s) = it.next_segment().unwrap() {
        writeln!(out, "{}", cnc402_interp::dump::segment_to_json(&s, cfg)).unwrap();
        n += 1;
    }
    n
}

/// `cnc402 run` on the embedded simulator: dry run, then the run.
fn run(cfg: &MachineConfig, path: &Path) -> u64 {
    let input = ProgramInput::File {
        path: path.to_path_buf(),
        dialect: None,
    };
    let r = run_input(cfg, input, RunOptions::default(), &mut |_| {})
        .unwrap_or_else(|e| panic!("{e:?}"));
    assert!(r.ok, "{:?}", r.error);
    r.ticks
}

#[test]
fn segments_and_run_hold_memory_bounded_by_the_window_not_the_program() {
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.variables_file = None;
    let (small, large) = (circle_program(20_000), circle_program(200_000));

    let mut counts = (0, 0);
    let seg_small = peak_during(|| counts.0 = segments(&cfg, &small));
    let seg_large = peak_during(|| counts.1 = segments(&cfg, &large));
    assert_eq!(counts, (20_002, 200_002));

    let mut ticks = (0, 0);
    let run_small = peak_during(|| ticks.0 = run(&cfg, &small));
    let run_large = peak_during(|| ticks.1 = run(&cfg, &large));
    assert!(ticks.1 > 5 * ticks.0, "{ticks:?}");

    for p in [&small, &large] {
        let _ = std::fs::remove_file(p);
    }
    println!(
        "peak live heap: segments {seg_small} B (20k blocks) / {seg_large} B (200k); \
         run {run_small} B / {run_large} B"
    );
    // The margin is what fills up to a fixed size as a run gets longer (the plot's series
    // of at most 8000 points), far below what 180,000 more blocks held whole would take.
    const MARGIN: usize = 1 << 20;
    assert!(
        seg_large <= seg_small + MARGIN,
        "segments: {seg_large} B for 200k blocks against {seg_small} B for 20k"
    );
    assert!(
        run_large <= run_small + MARGIN,
        "run: {run_large} B for 200k blocks against {run_small} B for 20k"
    );
}
