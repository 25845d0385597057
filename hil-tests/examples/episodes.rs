//! episodes: runs simdrive's Z+C coupling checker (`cnc402_drives::coupling::CouplingChecker`,
//! fed with counts) over a `cnc402 run --trace` CSV (setpoints and
//! actual positions rounded to drive counts as the master sends them), to see offline what
//! simdrive will judge for a program.
//!
//!   cnc402 run PROGRAM --trace t.csv && episodes t.csv [--config PATH]

use cnc402_config::MachineConfig;
use cnc402_drives::coupling::{CountSample, CouplingChecker};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: episodes TRACE.csv [--config PATH]");
        std::process::exit(2);
    };
    let config = match args.iter().position(|a| a == "--config") {
        Some(i) => args.get(i + 1).cloned().unwrap_or_default(),
        None => cnc402_config::DEFAULT_PATH.to_string(),
    };
    let cfg = MachineConfig::load(&config).unwrap_or_else(|e| {
        eprintln!("episodes: {e}");
        std::process::exit(2)
    });
    let cpu = |n: char| {
        cfg.axes
            .iter()
            .find(|a| a.name == n)
            .map(|a| a.counts_per_unit)
            .unwrap_or(1.0)
    };
    let (zc, cc) = (cpu('Z'), cpu('C'));
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| {
        eprintln!("episodes: {path}: {e}");
        std::process::exit(2)
    });
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let col = |n: &str| head.iter().position(|h| *h == n);
    let (Some(z), Some(za), Some(c), Some(ca)) =
        (col("Z_cmd"), col("Z_act"), col("C_cmd"), col("C_act"))
    else {
        eprintln!("episodes: {path}: no Z_cmd/Z_act/C_cmd/C_act columns");
        std::process::exit(2)
    };
    let mut ch = CouplingChecker::new(zc, cc);
    for l in lines {
        let f: Vec<f64> = l
            .split(',')
            .map(|x| x.parse().unwrap_or(f64::NAN))
            .collect();
        let get = |i: usize, k: f64| (f.get(i).copied().unwrap_or(0.0) * k).round() as i64;
        ch.feed_counts(CountSample {
            z_cmd: get(z, zc),
            c_cmd: get(c, cc),
            z_act: get(za, zc),
            c_act: get(ca, cc),
        });
    }
    ch.finish();
    for (i, e) in ch.windows().iter().enumerate() {
        println!(
            "{:3} tick {:6} +{:5}  Z {:8.3} mm  C {:9.1}°  pitch {:8.4}  cmd {:8.4} µm (limit {:.4})  act {:8.2} µm  {}",
            i + 1,
            e.first_tick,
            e.ticks,
            e.z_travel_mm,
            e.c_travel_deg,
            e.pitch_mm,
            e.max_error_um_cmd,
            ch.limit_um(e),
            e.max_error_um_act,
            if e.spindle_running {
                "spindle running"
            } else {
                "TAP"
            }
        );
    }
}
