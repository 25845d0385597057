//! Macro-heavy throughput: a WHILE loop computing a 10,000-hole bolt circle with SIN/COS and
//! drilling each hole with G81 (6 macro blocks per hole), in blocks/s, against the same 10,000
//! holes written out as plain G81 blocks (the peer, same run). Every segment is pulled.
//! `cargo bench -p cnc402-interp --bench macro_loop`.
//!
//! Measured on the shared 2-core development machine (criterion medians, one run): macro
//! program 11.8 ms per run = 5.07 M macro blocks/s (60,007 blocks, 30,005 segments); the flat
//! peer 19.1 ms = 0.52 M blocks/s (its time is mostly parsing 10,000 lines of coordinates).

use std::hint::black_box;
use std::time::Instant;

use cnc402_config::MachineConfig;
use cnc402_interp::Interpreter;
use cnc402_lang::SourceFile;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

const HOLES: usize = 10_000;
/// Blocks executed by the macro program: 6 per hole (WHILE, 2 assignments, G81, count, END),
/// one last WHILE, and the 6 around the loop.
const MACRO_BLOCKS: usize = 6 * HOLES + 1 + 6;

fn macro_program() -> String {
    format!(
        "G90 G17 G0 Z10\nM3 S1000\n#1=0\n#4=360/{HOLES}\nWHILE [#1 LT {HOLES}] DO 1\n#2=50*COS[#1*#4]\n#3=50*SIN[#1*#4]\nG99 G81 X#2 Y#3 R2 Z-5 F200\n#1=#1+1\nEND 1\nG80\nM5\nM30\n"
    )
}

fn flat_program() -> String {
    let mut s = String::from("G90 G17 G0 Z10\nM3 S1000\n");
    for i in 0..HOLES {
        let a = (i as f64 * 360.0 / HOLES as f64).to_radians();
        s.push_str(&format!(
            "G99 G81 X{:.4} Y{:.4} R2 Z-5 F200\n",
            50.0 * a.cos(),
            50.0 * a.sin()
        ));
    }
    s.push_str("G80\nM5\nM30\n");
    s
}

fn run(cfg: &MachineConfig, text: &str) -> usize {
    let src = SourceFile::new("bench.nc", text);
    let program = cnc402_lang::parse(&src).expect("the bench program parses");
    let mut it = Interpreter::new(cfg);
    it.set_program_library(None);
    it.load(src, program);
    let mut n = 0;
    while let Some(s) = it.next_segment().expect("the bench program runs") {
        black_box(&s);
        n += 1;
    }
    n
}

fn bench(c: &mut Criterion) {
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.variables_file = None;
    let m = macro_program();
    let f = flat_program();
    let (sm, sf) = (run(&cfg, &m), run(&cfg, &f));
    assert_eq!(sm, sf, "both programs drill the same holes");
    let t = Instant::now();
    run(&cfg, &m);
    eprintln!(
        "one macro run: {:.1} ms, {} segments, {:.0} blocks/s",
        t.elapsed().as_secs_f64() * 1e3,
        sm,
        MACRO_BLOCKS as f64 / t.elapsed().as_secs_f64()
    );
    let mut g = c.benchmark_group("bolt_circle_10000");
    g.sample_size(10);
    g.throughput(Throughput::Elements(MACRO_BLOCKS as u64));
    g.bench_function("macro_while_sin_cos_g81", |b| b.iter(|| run(&cfg, &m)));
    g.throughput(Throughput::Elements((HOLES + 5) as u64));
    g.bench_function("flat_g81_peer", |b| b.iter(|| run(&cfg, &f)));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
