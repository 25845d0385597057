//! Parse + interpret throughput in blocks/s on a generated program of 200,000 G0/G1 blocks,
//! against LinuxCNC's `rs274 -g` on the same file in the same run (skipped with a notice when
//! `rs274` is not installed). `cargo bench -p cnc402-interp --bench throughput`.
//!
//! Measured on the shared 2-core development machine (criterion medians, one run): parse alone
//! 1.21 M blocks/s, parse + interpret 0.81 M blocks/s, `rs274 -g` (LinuxCNC 2.9, a whole
//! process writing canonical calls to /dev/null) 0.106 M blocks/s.

use std::hint::black_box;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::Instant;

use cnc402_config::MachineConfig;
use cnc402_interp::Interpreter;
use cnc402_lang::SourceFile;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

const BLOCKS: usize = 200_000;

/// A deterministic program of `n` G0/G1 blocks inside the default machine's limits, with N
/// numbers every tenth block and a feed on every G1, plus a header and M2.
fn program(n: usize) -> String {
    let mut s = String::with_capacity(n * 32);
    s.push_str("G21 G90 G17 G94\n");
    let mut x: u64 = 12345;
    for i in 0..n {
        // xorshift: cheap, reproducible coordinates
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let px = (x % 40000) as f64 / 100.0 - 200.0;
        let py = ((x >> 16) % 30000) as f64 / 100.0 - 150.0;
        let pz = ((x >> 32) % 5000) as f64 / 100.0 - 45.0;
        if i % 10 == 0 {
            s.push_str(&format!("N{} ", i / 10 % 100000));
        }
        if i % 4 == 0 {
            s.push_str(&format!("G0 X{px:.3} Y{py:.3} Z{pz:.3}\n"));
        } else {
            s.push_str(&format!("G1 X{px:.3} Y{py:.3} F{}\n", 500 + (i % 7) * 100));
        }
    }
    s.push_str("M2\n");
    s
}

fn find_rs274() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("rs274"))
        .find(|p| p.is_file())
}

fn run_ours(cfg: &MachineConfig, text: &str) -> usize {
    let src = SourceFile::new("bench.nc", text);
    let program = cnc402_lang::parse(&src).expect("the generated program parses");
    let mut it = Interpreter::new(cfg);
    it.load(src, program);
    let mut n = 0;
    while let Some(s) = it.next_segment().expect("the generated program runs") {
        black_box(&s);
        n += 1;
    }
    n
}

fn bench(c: &mut Criterion) {
    let cfg = MachineConfig::default_machine();
    let text = program(BLOCKS);
    assert_eq!(
        run_ours(&cfg, &text),
        BLOCKS + 1,
        "every block makes one segment, plus M2"
    );

    let mut g = c.benchmark_group("throughput_200k_blocks");
    g.throughput(Throughput::Elements(BLOCKS as u64));
    g.sample_size(10);
    g.bench_function("cnc402_parse", |b| {
        b.iter(|| cnc402_lang::parse(&SourceFile::new("bench.nc", text.as_str())).unwrap())
    });
    g.bench_function("cnc402_parse_interpret", |b| {
        b.iter(|| run_ours(&cfg, &text))
    });

    let rs274 = find_rs274();
    let file = std::env::temp_dir().join(format!("cnc402-bench-{}.ngc", std::process::id()));
    match &rs274 {
        Some(exe) => {
            std::fs::write(&file, &text).expect("temp file");
            g.bench_function("linuxcnc_rs274", |b| {
                b.iter(|| {
                    let st = Command::new(exe)
                        .arg("-g")
                        .arg(&file)
                        .stdout(Stdio::null())
                        .stderr(Stdio::null())
                        .status()
                        .expect("rs274 runs");
                    assert!(st.success());
                })
            });
        }
        None => eprintln!("NOTICE: rs274 (LinuxCNC) not installed; peer comparison skipped"),
    }
    g.finish();

    // One plain figure per contender for the note (criterion's thrpt line says the same).
    let t = Instant::now();
    run_ours(&cfg, &text);
    let ours = BLOCKS as f64 / t.elapsed().as_secs_f64();
    eprintln!("cnc402 parse+interpret: {ours:.0} blocks/s");
    if let Some(exe) = &rs274 {
        let t = Instant::now();
        Command::new(exe)
            .arg("-g")
            .arg(&file)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .expect("rs274 runs");
        let theirs = BLOCKS as f64 / t.elapsed().as_secs_f64();
        eprintln!("rs274 -g (process, output to /dev/null): {theirs:.0} blocks/s");
        let _ = std::fs::remove_file(&file);
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
