//! `cnc402-fuzz`: mutation fuzzing on stable Rust. Seeds come from the shipped examples, the
//! golden programs, the configs and a few well-formed CAN frames, plus `fuzz/corpus/<target>`;
//! every input that breaks a property (a panic, a non-finite segment) or runs past the hang
//! bound is written to `fuzz/crashes/<target>/` (replayed by `cargo test -p cnc402-fuzz`).
//!
//! ```text
//! cargo run --release -p cnc402-fuzz -- --minutes 10               # every target, in turn
//! cargo run --release -p cnc402-fuzz -- --target interp --minutes 5 --seed 7
//! ```
//! Exit codes: 0 nothing found, 1 findings written, 64 bad usage. An input that kills the
//! process (stack overflow, out-of-memory abort) is saved as an `abort` finding by the next
//! start.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use cnc402_fuzz::{Finding, Rng, Target, mutate, run};

struct Plan {
    targets: Vec<Target>,
    duration: Duration,
    seed: u64,
    max_len: usize,
    hang: Duration,
}

fn usage(msg: &str) -> ExitCode {
    eprintln!(
        "cnc402-fuzz: {msg}\nusage: cnc402-fuzz [--target parse|interp|config|frames] \
         [--minutes M | --seconds S] [--seed N] [--max-len BYTES] [--hang-seconds S]"
    );
    ExitCode::from(64)
}

fn plan(args: &[String]) -> Result<Plan, String> {
    let mut p = Plan {
        targets: Target::ALL.to_vec(),
        duration: Duration::from_secs(60),
        seed: 402,
        max_len: 64 * 1024,
        hang: Duration::from_secs(10),
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |what: &str| {
            it.next()
                .ok_or_else(|| format!("{a} needs {what}"))
                .cloned()
        };
        let num = |v: String, a: &str| {
            v.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite() && *x > 0.0 && *x < 1e7)
                .ok_or_else(|| format!("{a}: not a positive number: {v}"))
        };
        match a.as_str() {
            "--target" => {
                let v = value("a target")?;
                p.targets = vec![Target::from_name(&v).ok_or(format!("unknown target {v}"))?];
            }
            "--minutes" => p.duration = Duration::from_secs_f64(num(value("M")?, a)? * 60.0),
            "--seconds" => p.duration = Duration::from_secs_f64(num(value("S")?, a)?),
            "--hang-seconds" => p.hang = Duration::from_secs_f64(num(value("S")?, a)?),
            "--seed" => {
                let v = value("N")?;
                p.seed = v
                    .parse()
                    .map_err(|_| format!("--seed: not a number: {v}"))?;
            }
            "--max-len" => {
                let v = value("BYTES")?;
                p.max_len = v
                    .parse()
                    .ok()
                    .filter(|n| (16..=1 << 24).contains(n))
                    .ok_or(format!("--max-len: 16..16777216, not {v}"))?;
            }
            _ => return Err(format!("unknown argument {a}")),
        }
    }
    Ok(p)
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn files_in(dir: &Path, exts: &[&str], out: &mut Vec<Vec<u8>>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    let mut paths: Vec<_> = rd.flatten().map(|e| e.path()).collect();
    paths.sort();
    for p in paths {
        if p.is_dir() {
            files_in(&p, exts, out);
        } else if (exts.is_empty()
            || p.extension()
                .is_some_and(|x| exts.iter().any(|e| x.eq_ignore_ascii_case(e))))
            && let Ok(b) = std::fs::read(&p)
        {
            out.push(b);
        }
    }
}

/// The seeds of a target: shipped inputs plus its corpus folder.
fn seeds(t: Target) -> Vec<Vec<u8>> {
    let r = root();
    let mut s = Vec::new();
    match t {
        Target::Parse | Target::Interp => {
            files_in(&r.join("examples"), &["nc", "cnc", "c"], &mut s);
            files_in(&r.join("interp/tests/programs"), &["nc"], &mut s);
        }
        Target::Config => {
            files_in(&r.join("config"), &["toml"], &mut s);
            files_in(&r.join("examples"), &["toml"], &mut s);
        }
        Target::Frames => {
            // SYNC; heartbeat boot-up of node 1; an SDO upload response; an EMCY; a TPDO1.
            s.push(vec![0, 0x80, 0]);
            s.push(vec![7, 0x01, 1, 0]);
            s.push(vec![5, 0x81, 8, 0x43, 0x00, 0x10, 0, 0x92, 0x01, 0, 0]);
            s.push(vec![0, 0x81, 8, 0x10, 0x73, 0x11, 0, 0, 0, 0, 0]);
            s.push(vec![1, 0x81, 6, 0x37, 0x02, 0x10, 0x27, 0, 0]);
        }
    }
    files_in(&r.join("fuzz/corpus").join(t.name()), &[], &mut s);
    if s.is_empty() {
        s.push(Vec::new());
    }
    s
}

/// Writes a finding to `fuzz/crashes/<target>/<kind>-<hash>` and says so.
fn save(t: Target, kind: &str, input: &[u8], what: &str) {
    let dir = root().join("fuzz/crashes").join(t.name());
    let _ = std::fs::create_dir_all(&dir);
    let h = input.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x100_0000_01b3)
    });
    let p = dir.join(format!("{kind}-{h:016x}"));
    let _ = cnc402_durable::write_atomic(&p, input);
    let what: String = what.chars().take(300).collect();
    println!("{} {kind}: {what} -> {}", t.name(), p.display());
}

/// Where the input being run is kept: an input that aborts the process (a stack overflow, an
/// out-of-memory abort) is found there by the next start and saved as a finding.
fn inflight(t: Target) -> PathBuf {
    root()
        .join("fuzz/crashes")
        .join(format!(".inflight-{}", t.name()))
}

/// Saves the inputs a previous run died on.
fn recover_aborts() -> usize {
    let mut n = 0;
    for t in Target::ALL {
        if let Ok(input) = std::fs::read(inflight(t)) {
            save(t, "abort", &input, "the process died on this input");
            let _ = std::fs::remove_file(inflight(t));
            n += 1;
        }
    }
    n
}

/// Runs `input` on a worker thread, waiting at most `hang`: `None` when it did not finish.
fn run_bounded(t: Target, input: Vec<u8>, hang: Duration) -> Option<Result<(), Finding>> {
    let (tx, rx) = mpsc::channel();
    std::thread::Builder::new()
        .stack_size(8 << 20)
        .spawn(move || {
            let _ = tx.send(run(t, &input));
        })
        .ok()?;
    rx.recv_timeout(hang).ok()
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let p = match plan(&args) {
        Ok(p) => p,
        Err(e) => return usage(&e),
    };
    // Panics are findings, printed once by `save`, not by the default hook.
    std::panic::set_hook(Box::new(|_| {}));
    let mut rng = Rng::new(p.seed);
    let mut found = recover_aborts();
    let per_target = p.duration / p.targets.len() as u32;
    for &t in &p.targets {
        let seeds = seeds(t);
        let (start, mut runs) = (Instant::now(), 0u64);
        while start.elapsed() < per_target {
            let mut input = seeds[rng.below(seeds.len())].clone();
            let other = &seeds[rng.below(seeds.len())];
            for _ in 0..1 + rng.below(8) {
                mutate(&mut rng, &mut input, other, p.max_len);
            }
            runs += 1;
            let _ = std::fs::create_dir_all(root().join("fuzz/crashes"));
            // Not through cnc402_durable: an fsync per input would cut the fuzzer's rate
            // many times over, and the file is read only after this process died running
            // the input, which it wrote in full before.
            let _ = std::fs::write(inflight(t), &input);
            let result = run_bounded(t, input.clone(), p.hang);
            let _ = std::fs::remove_file(inflight(t));
            match result {
                Some(Ok(())) => {}
                Some(Err(Finding::Panic(m))) => {
                    found += 1;
                    save(t, "panic", &input, &m);
                }
                Some(Err(Finding::NonFinite(m))) => {
                    found += 1;
                    save(t, "nonfinite", &input, &m);
                }
                None => {
                    save(t, "hang", &input, &format!("no result after {:?}", p.hang));
                    // The worker cannot be stopped; end here with what was found.
                    println!("stopping: a hang leaves its worker running");
                    return ExitCode::from(1);
                }
            }
        }
        println!(
            "{}: {runs} inputs in {:.0} s, {found} findings so far",
            t.name(),
            start.elapsed().as_secs_f64()
        );
    }
    if found == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
