//! Parse throughput on a generated 200,000-block G0/G1 program, against the `gcode` crate
//! (a peer that also builds an AST) on the same text in the same run.

use cnc402_lang::{SourceFile, parse};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;

const BLOCKS: usize = 200_000;

/// `N10 G1 X12.345 Y-6.789 Z-1.5 F1200`-style blocks, G0 every fifth block.
fn program() -> String {
    let mut s = String::with_capacity(BLOCKS * 40);
    s.push_str("%\nO1000 (GENERATED)\nG21 G90 G17\n");
    for k in 0..BLOCKS - 3 {
        let x = (k % 2000) as f64 * 0.137 - 100.0;
        let y = (k % 1777) as f64 * -0.211 + 50.0;
        if k % 5 == 0 {
            s.push_str(&format!(
                "N{} G0 X{:.3} Y{:.3} Z2.\n",
                (k + 1) * 10 % 100_000,
                x,
                y
            ));
        } else {
            s.push_str(&format!(
                "N{} G1 X{:.3} Y{:.3} Z-1.5 F1200\n",
                (k + 1) * 10 % 100_000,
                x,
                y
            ));
        }
    }
    s
}

fn bench(c: &mut Criterion) {
    let text = program();
    let src = SourceFile::new("gen.nc", text.as_str());
    // Both must accept the whole program, or the comparison means nothing.
    assert_eq!(parse(&src).unwrap().lines.len(), BLOCKS);
    assert!(gcode::parse(&text).is_ok());

    let mut g = c.benchmark_group("parse_200k_blocks");
    g.throughput(Throughput::Elements(BLOCKS as u64));
    g.sample_size(20);
    g.bench_function("cnc402_lang", |b| {
        b.iter(|| parse(black_box(&src)).unwrap())
    });
    g.bench_function("gcode_0.7", |b| {
        b.iter(|| gcode::parse(black_box(&text)).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
