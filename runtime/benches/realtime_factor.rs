//! How many times faster than real time the embedded simulator runs a 10-minute program:
//! the whole `cnc402 run` path in virtual time (feeder, loop, CANopen master, SimBus with four
//! SimDrives, recorder), and as the peer in the same run the same loop on the bus-less
//! `ModelLink`, which shows what the bus and drive simulation cost. Target: ≥ 500×.
//!
//! `cargo bench -p cnc402-runtime --bench realtime_factor`

use std::time::Instant;

use cnc402_config::MachineConfig;
use cnc402_lang::SourceFile;
use cnc402_motion::AxisPos;
use cnc402_runtime::feeder::dry_run;
use cnc402_runtime::{RunOptions, Timing, run_program};

/// One block of mixed work: rigid taps, peck drilling on a bolt circle, a contour with arcs.
const BLOCK: &str = "G0 X20. Y20. Z10.
M29 S500
G98 G84 X20. Y20. Z-16. R3. F750.
X60.
G80
M3 S2500
G99 G83 X90. Y30. Z-12. R2. Q3. F180.
X70. Y64.641
X30. Y64.641
G98 X10. Y30.
G80
M3 S6000
G0 X10. Y0 Z5.
G1 Z-2. F300.
G1 X50. F900.
G3 X60. Y10. I0 J10.
G1 Y30.
G3 X50. Y40. I-10. J0
G1 X10.
G3 X0 Y30. I0 J-10.
G1 Y10.
G3 X10. Y0 I10. J0
G0 Z5.
G0 X110. Y0
G1 Z0 F300.
G3 X110. Y0 Z-1.5 I-10. J0 F600.
G3 X110. Y0 Z-3. I-10. J0
G0 Z10.
M5
";

fn ten_minute_program(cfg: &MachineConfig) -> (SourceFile, f64) {
    let mut text = String::from("G21 G90 G17 G94 G54\n");
    let period = cfg.bus.period_s();
    loop {
        text.push_str(BLOCK);
        let src = SourceFile::new("bench.nc", format!("{text}M30\n"));
        let ast = cnc402_lang::parse(&src).expect("parse");
        let d = dry_run(cfg, &src, &ast, AxisPos::default(), None).expect("program");
        let secs = d.ticks as f64 * period;
        if secs >= 600.0 {
            return (src, secs);
        }
    }
}

fn run(cfg: &MachineConfig, src: &SourceFile, model_link: bool) -> (f64, f64, u64) {
    let ast = cnc402_lang::parse(src).expect("parse");
    let opts = RunOptions {
        timing: Timing::Virtual,
        model_link,
        ..RunOptions::default()
    };
    let t = Instant::now();
    let r = run_program(cfg, src.clone(), ast, opts, &mut |_| {}).expect("run");
    let wall = t.elapsed().as_secs_f64();
    assert!(r.ok, "{:?}", r.error);
    (r.ticks as f64 * cfg.bus.period_s(), wall, r.ticks)
}

fn main() {
    // `cargo test --benches` runs this with `--test`-like flags; one quick pass is enough then.
    let quick = std::env::args().any(|a| a == "--test");
    let cfg = MachineConfig::load(cnc402_config::DEFAULT_PATH)
        .or_else(|_| {
            MachineConfig::load(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../config/machine.toml"
            ))
        })
        .unwrap_or_else(|_| MachineConfig::default_machine());
    let (src, planned) = ten_minute_program(&cfg);
    println!(
        "program: {} lines, {:.1} s planned (spindle ramps excluded)",
        src.line_count(),
        planned
    );
    let reps = if quick { 1 } else { 3 };
    for (name, model) in [
        ("embedded simulator (master + SimBus + 4 SimDrives)", false),
        ("peer: bus-less ModelLink", true),
    ] {
        let mut best = f64::INFINITY;
        let mut prog = 0.0;
        let mut ticks = 0;
        for _ in 0..reps {
            let (p, wall, t) = run(&cfg, &src, model);
            best = best.min(wall);
            prog = p;
            ticks = t;
        }
        println!(
            "{name}: {prog:.1} s of machine time in {best:.3} s wall (best of {reps}) = {:.0}× real time, {:.2} µs per tick",
            prog / best,
            best * 1e6 / ticks as f64
        );
    }
}
