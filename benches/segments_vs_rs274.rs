//! End to end: `cnc402 segments FILE` against LinuxCNC's `rs274 -g FILE` on the same
//! generated 200,000-block program, each a whole process writing to /dev/null, in one run;
//! prints both wall times (best of 5), their CPU times (user + sys, mean of the 5: `segments`
//! writes on a second thread, so its CPU time may exceed its wall time) and the ratio. `cargo bench --bench segments_vs_rs274`
//! (rs274 not installed: cnc402's time alone). Goal of issue 11: cnc402 10× faster.
//! The program is the CAM-like path: G1 blocks along a circle of radius 10 mm in
//! 0.01 mm steps (4 decimals) at F3000 under G64 P0.01.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const BLOCKS: usize = 200_000;
const RUNS: usize = 5;

fn program(dir: &Path) -> PathBuf {
    let path = dir.join("circle-200k.nc");
    let mut f = std::io::BufWriter::new(std::fs::File::create(&path).expect("temp file"));
    let mut text = String::from("G21 G90 G17\nG64 P0.01\nG0 X10 Y0 Z0\nF3000\n");
    for i in 1..=BLOCKS {
        let a = i as f64 * 0.001;
        text.push_str(&format!(
            "G1 X{:.4} Y{:.4}\n",
            10.0 * a.cos(),
            10.0 * a.sin()
        ));
    }
    text.push_str("M2\n");
    f.write_all(text.as_bytes()).expect("written");
    f.flush().expect("written");
    path
}

/// User + system CPU seconds of this process's waited-for children (Linux: /proc/self/stat,
/// in ticks of 1/100 s; elsewhere none).
fn children_cpu() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The fields after the command name `(…)`, from field 3 (state) on.
    let rest = stat.get(stat.rfind(')')? + 1..)?;
    let mut fields = rest.split_whitespace().skip(13);
    let cutime: f64 = fields.next()?.parse().ok()?;
    let cstime: f64 = fields.next()?.parse().ok()?;
    Some((cutime + cstime) / 100.0)
}

/// Best wall time of `RUNS` runs of `cmd`, which must succeed, and their mean CPU time.
fn best(make: impl FnMut() -> Command) -> (Duration, Option<f64>) {
    let before = children_cpu();
    let wall = best_wall(make);
    let cpu = children_cpu()
        .zip(before)
        .map(|(a, b)| (a - b) / RUNS as f64);
    (wall, cpu)
}

/// Prints `what`'s times.
fn print_times(what: &str, (wall, cpu): (Duration, Option<f64>)) {
    let cpu = cpu.map_or(String::new(), |c| format!(", CPU {c:.3} s"));
    println!("{what}: {:.3} s{cpu}", wall.as_secs_f64());
}

/// Best wall time of `RUNS` runs of `cmd`, which must succeed.
fn best_wall(mut make: impl FnMut() -> Command) -> Duration {
    (0..RUNS)
        .map(|_| {
            let t = Instant::now();
            let out = make()
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .output()
                .expect("the command starts");
            let took = t.elapsed();
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            took
        })
        .min()
        .unwrap_or_default()
}

fn find_rs274() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("rs274"))
        .find(|p| p.is_file())
}

fn main() {
    let dir = std::env::temp_dir().join(format!("cnc402-bench-rs274-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("home")).expect("temp dir");
    let file = program(&dir);
    let config = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/machine.toml");
    let ours = best(|| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_cnc402"));
        c.arg("--config").arg(&config).arg("segments").arg(&file);
        c
    });
    let per_block = ours.0.as_secs_f64() / BLOCKS as f64 * 1e6;
    print_times(
        &format!("cnc402 segments, {BLOCKS} blocks ({per_block:.2} µs/block)"),
        ours,
    );
    match find_rs274() {
        Some(rs274) => {
            // rs274 reads and writes files under $HOME: give it one of its own.
            let theirs = best(|| {
                let mut c = Command::new(&rs274);
                c.env("HOME", dir.join("home")).arg("-g").arg(&file);
                c.current_dir(&dir);
                c
            });
            print_times("rs274 -g, same file", theirs);
            println!(
                "ratio: cnc402 is {:.2}x as fast as rs274 -g (goal 10x)",
                theirs.0.as_secs_f64() / ours.0.as_secs_f64()
            );
        }
        None => println!("rs274 not found on PATH: no ratio (apt-get install linuxcnc-uspace)"),
    }
    let _ = std::fs::remove_dir_all(&dir);
}
