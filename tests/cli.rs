//! The `cnc402` binary end to end: `segments` and `run` on every shipped example, the report,
//! trace and plot files, a drive fault injected mid-tap, and the documented exit codes.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

const EXAMPLES: [&str; 5] = [
    "examples/m10x1.5-rigid-tap.nc",
    "examples/peck-tap.nc",
    "examples/bolt-circle-drilling.nc",
    "examples/contour-arcs.nc",
    "examples/plate-cutter-comp.nc",
];

fn cnc402(args: &[&str]) -> Output {
    cnc402_logging(args, "warn")
}

/// `cnc402` run to its end with log level `log` (`info` shows the events of a run).
fn cnc402_logging(args: &[&str], log: &str) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("RUST_LOG", log)
        .output()
        .expect("run cnc402")
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cnc402-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// A folder of the test's own under the per-process temp dir.
fn test_dir(test: &str) -> PathBuf {
    let dir = tmp(test);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes program `text` as `dir/name`.
fn write_program(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// `cnc402` with the repository as working directory, log level `log`, and stdin, stdout
/// and stderr piped (for tests that talk to it while it runs).
fn cnc402_piped(log: &str) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_cnc402"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("RUST_LOG", log)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped());
    c
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn read_json(p: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

#[test]
fn segments_of_every_example_are_json_lines() {
    for ex in EXAMPLES {
        let o = cnc402(&["segments", ex]);
        assert_eq!(o.status.code(), Some(0), "{ex}: {}", stderr(&o));
        let text = String::from_utf8(o.stdout).unwrap();
        let mut n = 0;
        for line in text.lines() {
            let v: Value =
                serde_json::from_str(line).unwrap_or_else(|e| panic!("{ex}: {e}: {line}"));
            assert!(v["kind"].is_string() && v["line"].is_u64(), "{line}");
            n += 1;
        }
        assert!(n > 5, "{ex}: {n} segments");
    }
}

/// `canon` prints every example's canonical operations: valid JSON Lines with the state each
/// ran under; a drilling example keeps its canned cycles whole, with their holes.
#[test]
fn canon_of_every_example_is_json_lines_with_cycles_whole() {
    for ex in EXAMPLES {
        let o = cnc402(&["canon", ex]);
        assert_eq!(o.status.code(), Some(0), "{ex}: {}", stderr(&o));
        let text = String::from_utf8(o.stdout).unwrap();
        let ops: Vec<Value> = text
            .lines()
            .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{ex}: {e}: {l}")))
            .collect();
        assert!(!ops.is_empty(), "{ex}");
        for v in &ops {
            assert!(v["op"].is_string() && v["line"].is_u64(), "{v}");
            assert!(v["state"]["work_offset"].is_string(), "{v}");
        }
        if ex.contains("bolt-circle") {
            let cycles: Vec<_> = ops.iter().filter(|v| v["op"] == "canned_cycle").collect();
            assert!(!cycles.is_empty(), "{ex}: no canned cycle");
            assert!(
                cycles
                    .iter()
                    .all(|c| !c["holes"].as_array().unwrap().is_empty())
            );
        }
    }
}

/// One count of the tool axis or the tool-axis equivalent of one spindle count, in µm, from
/// the shipped config: Z 10000 counts/mm, C 131072 counts/rev.
fn coupling_bound_um(pitch_mm: f64) -> f64 {
    let z: f64 = 1.0 / 10000.0;
    let c = pitch_mm / 131072.0;
    z.max(c) * 1000.0
}

/// The following-error window of axis `name` in the shipped config (mm or degrees).
fn following_error_window(name: &str) -> f64 {
    let cfg = cnc402_config::MachineConfig::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/config/machine.toml"
    ))
    .expect("config/machine.toml");
    let axis = cfg
        .axes
        .iter()
        .find(|a| a.name.to_string() == name)
        .expect("axis in the config");
    axis.following_error_window
}

#[test]
fn run_every_example_ok_with_exact_report_keys_and_coupled_taps() {
    for ex in EXAMPLES {
        let report = tmp(&format!("{}.json", ex.replace('/', "_")));
        let o = cnc402(&["run", ex, "--report", report.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(0), "{ex}: {}", stderr(&o));
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(stdout.starts_with("ok:"), "{stdout}");
        assert!(
            stdout.contains("bus:") && stdout.contains("path length"),
            "{stdout}"
        );
        let v = read_json(&report);
        for key in [
            "ok",
            "error",
            "period_us",
            "ticks",
            "program_time_s",
            "path_length_mm",
            "feed_time_s",
            "max_path_deviation_mm",
            "exact_stops",
            "axes",
            "tapping",
            "bus",
        ] {
            assert!(v.get(key).is_some(), "{ex}: no key {key}");
        }
        // The path figures: the feed alone is faster than the program (acceleration costs
        // time), the setpoints stay on the programmed path, and every example stops at least
        // once between two motions (taps, tool changes, spindle starts).
        let feed_time = v["feed_time_s"].as_f64().unwrap();
        let program_time = v["program_time_s"].as_f64().unwrap();
        assert!(
            feed_time > 0.0 && feed_time < program_time,
            "{ex}: {feed_time} {program_time}"
        );
        let dev = v["max_path_deviation_mm"].as_f64().unwrap();
        assert!((0.0..1e-6).contains(&dev), "{ex}: deviation {dev}");
        assert!(v["exact_stops"].as_u64().unwrap() >= 1, "{ex}");
        assert!(stdout.contains("exact stops"), "{stdout}");
        assert_eq!(v["ok"], true);
        assert!(v["error"].is_null());
        assert_eq!(v["period_us"], 1000);
        assert!(v["ticks"].as_u64().unwrap() > 1000);
        assert!(v["program_time_s"].as_f64().unwrap() > 1.0);
        assert!(v["path_length_mm"].as_f64().unwrap() > 10.0);
        let axes = v["axes"].as_object().unwrap();
        assert_eq!(
            axes.keys().cloned().collect::<Vec<_>>(),
            ["C", "X", "Y", "Z"]
        );
        for (name, a) in axes {
            // Every axis moves in every example (C turns for the taps or the spindle), so it
            // lags: above zero, and below the axis's following-error window (else the master
            // would have stopped the run).
            let fe = a["max_following_error"].as_f64().unwrap();
            let window = following_error_window(name);
            assert!(
                fe > 0.0 && fe < window,
                "{ex}: {name}: {fe} (window {window})"
            );
            assert!(a["final_position"].as_f64().unwrap().is_finite(), "{name}");
        }
        // Every program ends with G0 Z50.
        assert!((axes["Z"]["final_position"].as_f64().unwrap() - 50.0).abs() < 1e-4);
        let bus = &v["bus"];
        assert!(bus["frames"].as_u64().unwrap() > 1000);
        let load = bus["load_percent"].as_f64().unwrap();
        assert!(load > 50.0 && load <= 100.0, "{load}");

        let taps = v["tapping"].as_array().unwrap();
        let expected_taps = match ex {
            "examples/m10x1.5-rigid-tap.nc" => 4,
            "examples/peck-tap.nc" => 2,
            _ => 0,
        };
        assert_eq!(taps.len(), expected_taps, "{ex}: {taps:?}");
        for t in taps {
            let pitch = t["pitch_mm"].as_f64().unwrap();
            let want = if ex.contains("m10x1.5") { 1.5 } else { 1.25 };
            assert!((pitch - want).abs() < 1e-9, "{pitch}");
            // What the setpoints showed (the coupling checker's travel ratio over the window).
            let observed = t["pitch_observed_mm"].as_f64().unwrap();
            assert!(
                (observed - want).abs() < 1e-4,
                "{ex}: observed pitch {observed}"
            );
            let cmd = t["max_coupling_error_um_cmd"].as_f64().unwrap();
            assert!(
                cmd <= coupling_bound_um(pitch),
                "{ex} line {}: {cmd} µm",
                t["line"]
            );
            // Actual positions, Z and C compared at equal sample age: both drives follow with
            // the same dynamics, so the thread stays within a few counts.
            let act = t["max_coupling_error_um_act"].as_f64().unwrap();
            assert!(
                act < 1.0,
                "{ex} line {}: actual coupling {act} µm",
                t["line"]
            );
            assert!(t["line"].as_u64().unwrap() > 0);
        }
    }
}

#[test]
fn trace_and_plot_are_well_formed() {
    let trace = tmp("tap.csv");
    let plot = tmp("tap.svg");
    let report = tmp("tap-trace.json");
    let o = cnc402(&[
        "run",
        "examples/peck-tap.nc",
        "--trace",
        trace.to_str().unwrap(),
        "--plot",
        plot.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let ticks = read_json(&report)["ticks"].as_u64().unwrap();
    let csv = std::fs::read_to_string(&trace).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t,line,X_cmd,X_act,Y_cmd,Y_act,Z_cmd,Z_act,C_cmd,C_act,X_sw,Y_sw,Z_sw,C_sw,panel"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len() as u64, ticks, "one row per tick");
    let mut t_prev = -1.0;
    let mut z_min = f64::INFINITY;
    for r in &rows {
        // 14 columns and the operator's panel (empty: no hold or override in this run).
        assert_eq!(r.len(), 15);
        assert_eq!(r[14], "");
        let t: f64 = r[0].parse().unwrap();
        assert!(
            (t - t_prev - 0.001).abs() < 1e-9 || t_prev < 0.0,
            "{t} after {t_prev}"
        );
        t_prev = t;
        let _: u32 = r[1].parse().unwrap();
        for v in &r[2..10] {
            let x: f64 = v.parse().unwrap();
            assert!(x.is_finite());
        }
        z_min = z_min.min(r[6].parse().unwrap());
        for sw in &r[10..14] {
            assert!(
                sw.starts_with("0x") && u16::from_str_radix(&sw[2..], 16).is_ok(),
                "{sw}"
            );
        }
    }
    assert!(
        (z_min - -20.0).abs() < 1e-6,
        "the peck tap reaches Z-20: {z_min}"
    );
    // Operation enabled (0x0027 in the low bits) while running.
    assert_eq!(
        u16::from_str_radix(&rows[10][12][2..], 16).unwrap() & 0x6F,
        0x27
    );

    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(
        svg.trim_start().starts_with("<svg"),
        "{}",
        &svg[..100.min(svg.len())]
    );
    assert!(svg.trim_end().ends_with("</svg>"));
    assert!(
        svg.contains("<polyline") || svg.contains("<path"),
        "has line series"
    );
    // A tapping program keeps its tapping panels beside the path panels.
    for panel in PATH_PANELS.iter().chain(&TAP_PANELS) {
        assert!(svg.contains(panel), "no {panel:?} panel");
    }
    assert!(svg.contains("C setpoint") && svg.contains("coupling error"));
}

/// The time (s) of the first trace row with Z below `z` (inside the first hole).
fn first_time_below(csv: &str, z: f64) -> f64 {
    for l in csv.lines().skip(1) {
        let r: Vec<&str> = l.split(',').collect();
        if r[6].parse::<f64>().unwrap() < z {
            return r[0].parse().unwrap();
        }
    }
    panic!("Z never below {z}");
}

#[test]
fn drive_fault_mid_tap_stops_all_axes_and_names_node_emcy_and_line() {
    let trace = tmp("clean.csv");
    let o = cnc402(&[
        "run",
        "examples/m10x1.5-rigid-tap.nc",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let t_in = first_time_below(&std::fs::read_to_string(&trace).unwrap(), -8.0);

    let report = tmp("fault.json");
    let trace = tmp("fault.csv");
    let fault = format!("3:8611@{t_in:.3}");
    let o = cnc402(&[
        "run",
        "examples/m10x1.5-rigid-tap.nc",
        "--inject-fault",
        &fault,
        "--report",
        report.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("node 3"), "{err}");
    assert!(err.contains("EMCY 0x8611"), "{err}");
    assert!(err.contains("statusword 0x"), "{err}");
    assert!(
        err.contains("examples/m10x1.5-rigid-tap.nc:11"),
        "the first tap is on line 11: {err}"
    );
    let v = read_json(&report);
    assert_eq!(v["ok"], false);
    assert!(v["error"].as_str().unwrap().contains("node 3"));
    assert_eq!(v["stop"]["node"], 3);
    assert_eq!(v["stop"]["emcy"], "0x8611");

    // All axes at rest at the end, none still enabled, and the setpoints stayed coupled
    // through the stop.
    let csv = std::fs::read_to_string(&trace).unwrap();
    let rows: Vec<Vec<String>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    let last = rows.last().unwrap();
    let prev = &rows[rows.len() - 2];
    for k in [3, 5, 7, 9] {
        let a: f64 = last[k].parse().unwrap();
        let b: f64 = prev[k].parse().unwrap();
        assert!(
            (a - b).abs() < 1e-3,
            "axis column {k} still moving: {b} -> {a}"
        );
    }
    for sw in &last[10..14] {
        let w = u16::from_str_radix(&sw[2..], 16).unwrap();
        assert_ne!(
            w & 0x6F,
            0x27,
            "a drive is still in OPERATION ENABLED: {sw}"
        );
    }
    let t_end: f64 = last[0].parse().unwrap();
    assert!(
        t_end < t_in + 1.0,
        "stopped soon after the fault: {t_end} vs {t_in}"
    );
    for t in v["tapping"].as_array().unwrap() {
        let cmd = t["max_coupling_error_um_cmd"].as_f64().unwrap();
        assert!(
            cmd <= coupling_bound_um(1.5),
            "coupling during the stop: {cmd} µm"
        );
    }
}

#[test]
fn program_error_exits_2_with_file_line_col() {
    let p = tmp("bad.nc");
    std::fs::write(&p, "G21 G90\nG0 X10.\nG1 X20. Y F\nM30\n").unwrap();
    let report = tmp("bad.json");
    let o = cnc402(&[
        "run",
        p.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains(&format!("{}:3:", p.display())), "{err}");
    let v = read_json(&report);
    assert_eq!(v["ok"], false);
    assert_eq!(v["ticks"], 0);
    assert!(
        v["error"]
            .as_str()
            .unwrap()
            .starts_with(&format!("{}:3:", p.display())),
        "{v}"
    );

    // Found by planning, before anything moves: a spindle speed above max_rpm.
    std::fs::write(&p, "G21\nG0 X1.\nM3 S9000\nM30\n").unwrap();
    let o = cnc402(&["run", p.to_str().unwrap()]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains(&format!("{}:3:", p.display())), "{err}");
}

#[test]
fn config_error_exits_3_and_missing_file_4() {
    let cfg = tmp("bad.toml");
    std::fs::write(&cfg, "[bus]\ninterface = \"sim\"\nbogus = 1\n").unwrap();
    let o = cnc402(&["run", EXAMPLES[0], "--config", cfg.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let o = cnc402(&["run", "examples/no-such-program.nc"]);
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
}

/// A config naming a CAN interface that cannot be opened: exit 4 with the reason, before
/// anything moves. On this project's machines the kernel has no CAN (errno 97); where it has,
/// the made-up interface does not exist. Either way the message names the interface.
#[test]
fn a_can_interface_that_cannot_be_opened_exits_4_with_the_reason() {
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("config/machine.toml"))
            .unwrap();
    let text = text.replace("interface = \"sim\"", "interface = \"nosuchcan4\"");
    let cfg = tmp("nosuchcan.toml");
    std::fs::write(&cfg, text).unwrap();
    let report = tmp("nosuchcan.json");
    let o = cnc402(&[
        "run",
        EXAMPLES[0],
        "--config",
        cfg.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(4), "{err}");
    // miette wraps long messages: compare with the wrapping undone.
    let err = err
        .replace('│', " ")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    let kernel_without_can = err.contains(
        "cannot open CAN interface nosuchcan4: this kernel has no CAN support (AF_CAN, errno 97)",
    ) && err.contains("hil-tests/run.sh");
    let no_such = err.contains("cannot open CAN interface nosuchcan4: no such interface");
    assert!(kernel_without_can || no_such, "{err}");
    if std::fs::read_to_string("/proc/net/protocols").is_ok_and(|p| !p.contains("CAN")) {
        // No AF_CAN here: the errno-97 message, not "no such interface".
        assert!(kernel_without_can, "{err}");
    }
    // Nothing ran: the report says why.
    let v = read_json(&report);
    assert_eq!(v["ok"], false);
    assert!(v["error"].as_str().unwrap().contains("nosuchcan4"), "{v}");
    assert_eq!(v["ticks"], 0);

    // Faults can only be injected into simulated drives.
    let o = cnc402(&[
        "run",
        EXAMPLES[0],
        "--config",
        cfg.to_str().unwrap(),
        "--inject-fault",
        "3:8611@0.5",
    ]);
    assert_eq!(o.status.code(), Some(64), "{}", stderr(&o));
    assert!(stderr(&o).contains("simdrive --fault"), "{}", stderr(&o));
}

#[test]
fn absurd_start_up_timeouts_are_usage_errors() {
    for (opt, v) in [
        ("--boot-timeout", "0"),
        ("--boot-timeout", "-1"),
        ("--enable-timeout", "nan"),
        ("--enable-timeout", "1e12"),
    ] {
        let o = cnc402(&["run", EXAMPLES[0], opt, v]);
        assert_eq!(o.status.code(), Some(64), "{opt} {v}: {}", stderr(&o));
    }
    // A sane value on the simulator runs as before.
    let o = cnc402(&[
        "run",
        EXAMPLES[0],
        "--boot-timeout",
        "2.5",
        "--enable-timeout",
        "1",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn bad_fault_option_is_a_usage_error() {
    let o = cnc402(&["run", EXAMPLES[0], "--inject-fault", "banana"]);
    assert_eq!(o.status.code(), Some(64), "{}", stderr(&o));
}

/// A child whose stderr is read line by line on a thread of its own, so that a test can act
/// on what the program says (a prompt, "drives enabled") instead of on a guess of how long it
/// takes to get there: on a loaded machine a fixed sleep is too short.
struct WatchedChild {
    child: std::process::Child,
    lines: std::sync::mpsc::Receiver<String>,
    seen: Vec<String>,
    reader: std::thread::JoinHandle<()>,
}

impl WatchedChild {
    fn new(mut child: std::process::Child) -> WatchedChild {
        use std::io::BufRead as _;
        let err = child.stderr.take().expect("stderr piped");
        let (tx, lines) = std::sync::mpsc::channel();
        let reader = std::thread::spawn(move || {
            for line in std::io::BufReader::new(err).lines() {
                let Ok(line) = line else { break };
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        WatchedChild {
            child,
            lines,
            seen: Vec::new(),
            reader,
        }
    }

    /// Waits (60 s at most) for a stderr line containing `needle`.
    fn wait_for(&mut self, needle: &str) {
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
        if self.seen.iter().any(|l| l.contains(needle)) {
            return;
        }
        while let Some(left) = deadline.checked_duration_since(std::time::Instant::now()) {
            match self.lines.recv_timeout(left) {
                Ok(line) => {
                    let hit = line.contains(needle);
                    self.seen.push(line);
                    if hit {
                        return;
                    }
                }
                Err(_) => break,
            }
        }
        panic!(
            "no stderr line with {needle:?} within 60 s; stderr so far:\n{}",
            self.seen.join("\n")
        );
    }

    fn pid(&self) -> String {
        self.child.id().to_string()
    }

    /// Waits for the exit; the exit status and all of stderr.
    fn finish(mut self) -> (std::process::ExitStatus, String) {
        let status = self.child.wait().expect("wait for cnc402");
        let _ = self.reader.join();
        self.seen.extend(self.lines.try_iter());
        (status, self.seen.join("\n"))
    }
}

fn sigint(pid: &str) {
    assert!(
        Command::new("kill")
            .args(["-INT", pid])
            .status()
            .unwrap()
            .success()
    );
}

#[test]
fn sigint_stops_the_machine_like_a_fault_and_exits_cleanly() {
    let report = tmp("sigint.json");
    let child = Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args([
            "run",
            "examples/m10x1.5-rigid-tap.nc",
            "--realtime",
            "--report",
            report.to_str().unwrap(),
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("RUST_LOG", "info")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut child = WatchedChild::new(child);
    // Well into the program (it takes ~16 s against the clock), then an operator's Ctrl-C.
    child.wait_for("drives enabled");
    let enabled = std::time::Instant::now();
    std::thread::sleep(std::time::Duration::from_millis(2000));
    sigint(&child.pid());
    let signalled = enabled.elapsed().as_secs_f64();
    let (status, err) = child.finish();
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(err.contains("operator stop (SIGINT)"), "{err}");
    assert!(err.contains("examples/m10x1.5-rigid-tap.nc:"), "{err}");
    let v = read_json(&report);
    assert_eq!(v["ok"], false);
    assert_eq!(v["stop"]["cause"], "operator stop (SIGINT)");
    // Program time runs at most at the wall clock's pace (late ticks are skipped, so it may
    // lag behind on a loaded machine): it ran for a while, and stopped within the quick-stop
    // time of the signal, not at the end of the 16 s program.
    let t = v["program_time_s"].as_f64().unwrap();
    assert!(
        t > 0.2 && t < signalled + 3.0,
        "stopped soon after the signal: {t} s (signal {signalled:.2} s after enable)"
    );
    let lat = &v["wakeup_latency_us"];
    let (p50, p99) = (lat["p50"].as_f64().unwrap(), lat["p99"].as_f64().unwrap());
    assert!(p50 > 0.0 && p99 >= p50, "p50 {p50} µs, p99 {p99} µs");
    assert!(lat["samples"].as_u64().unwrap() > 200, "{lat}");
    for t in v["tapping"].as_array().unwrap() {
        assert!(t["max_coupling_error_um_cmd"].as_f64().unwrap() <= coupling_bound_um(1.5));
    }
}

#[test]
fn dry_run_does_not_write_non_volatile_variables() {
    let vars = tmp("vars.dat");
    let _ = std::fs::remove_file(&vars);
    let cfg = tmp("vars.toml");
    config_with_vars_file(&vars, &cfg);
    let prog = tmp("count.nc");
    std::fs::write(&prog, "#500 = [#500 + 1]\nG0 X[#500]\nM30\n").unwrap();
    for want in [1.0, 2.0] {
        let o = cnc402(&[
            "run",
            prog.to_str().unwrap(),
            "--config",
            cfg.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let table = cnc402_interp::NvTable::load(&vars).unwrap();
        assert_eq!(table.get(500), Some(want), "one increment per run");
    }
}

#[test]
fn faults_and_taps_in_an_included_file_name_that_file() {
    // The AxiOMA program taps through `Tapping(...)` from `#use "metch_cycles.c"`, and checks
    // @ITPPATH against its own path sum (the runtime's motion sync answers it).
    let ex = "examples/axioma/multipass_tap.nc";
    let report = tmp("axioma.json");
    let o = cnc402(&["run", ex, "--report", report.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v = read_json(&report);
    let taps = v["tapping"].as_array().unwrap();
    assert!(!taps.is_empty());
    for t in taps {
        assert_eq!(t["file"], "examples/axioma/metch_cycles.c");
        assert!(t["max_coupling_error_um_cmd"].as_f64().unwrap() <= coupling_bound_um(1.5));
    }
    let o = cnc402(&["run", ex, "--inject-fault", "4:8611@3"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("examples/axioma/metch_cycles.c:"), "{err}");
    assert!(
        err.contains("node 4") && err.contains("EMCY 0x8611"),
        "{err}"
    );
}

/// X10 Y5 Z5 at the M0 on line 4, X20 Y-3 Z2 at the M1 on line 6, X4 Y7 Z2 at the end.
const STOPS_NC: &str = "G21 G90 G17\nG0 X0 Y0 Z5\nG1 X10 Y5 F1200\nM0\nG1 X20 Y-3 Z2 F1200\nM1\n\
                        G1 X4 Y7 F1200\nM30\n";

/// The stops program under a name of the test's own: tests run in parallel, and one test
/// rewriting a file another test's `cnc402` is reading made it read an empty program.
fn stops_program(test: &str) -> PathBuf {
    let dir = test_dir(test);
    let p = dir.join("stops.nc");
    std::fs::write(&p, STOPS_NC).unwrap();
    p
}

/// `cnc402 run PROG ARGS… --report <tmp REPORT>`, which must exit 0; its output and the report.
fn run_ok_with_report(prog: &Path, report: &str, args: &[&str]) -> (Output, Value) {
    let report = tmp(report);
    let mut all = vec!["run", prog.to_str().unwrap()];
    all.extend_from_slice(args);
    all.extend(["--report", report.to_str().unwrap()]);
    let o = cnc402(&all);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    (o, read_json(&report))
}

fn final_xyz(v: &Value) -> [f64; 3] {
    ["X", "Y", "Z"].map(|a| v["axes"][a]["final_position"].as_f64().unwrap())
}

fn assert_at(v: &Value, want: [f64; 3]) {
    let got = final_xyz(v);
    for (g, w) in got.iter().zip(want) {
        assert!((g - w).abs() < 1e-3, "final {got:?}, want {want:?}");
    }
}

#[test]
fn m0_with_at_stop_end_ends_there_ok_and_m1_needs_optional_stop() {
    let prog = stops_program("m0_with_at_stop_end_ends_there_ok_and_m1_needs_optional_stop");
    let (o, v) = run_ok_with_report(&prog, "stops-end.json", &["--at-stop", "end"]);
    assert_eq!(v["ok"], true);
    assert_at(&v, [10.0, 5.0, 5.0]);
    let stops = v["stops"].as_array().unwrap();
    assert_eq!(stops.len(), 1, "{stops:?}");
    assert_eq!(stops[0]["line"], 4);
    assert_eq!(stops[0]["kind"], "M0");
    assert_eq!(stops[0]["action"], "end");
    assert!(String::from_utf8_lossy(&o.stdout).contains("M0 at line 4: the program ended there"));

    // With optional stop on, M1 is a program stop too (the same policy applies to both).
    let (_, v) = run_ok_with_report(
        &prog,
        "stops-m1.json",
        &["--at-stop", "continue", "--optional-stop"],
    );
    let lines: Vec<(u64, String)> = v["stops"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            (
                s["line"].as_u64().unwrap(),
                s["kind"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    assert_eq!(lines, vec![(4, "M0".to_string()), (6, "M1".to_string())]);
}

#[test]
fn m0_with_continue_runs_to_the_end_and_m1_passes_without_optional_stop() {
    let prog =
        stops_program("m0_with_continue_runs_to_the_end_and_m1_passes_without_optional_stop");
    // No --at-stop and stdin not a terminal: continue, and stderr says why.
    let (o, v) = run_ok_with_report(&prog, "stops-continue.json", &[]);
    let err = stderr(&o);
    assert!(err.contains("no operator terminal is attached"), "{err}");
    assert!(err.contains("stops.nc:4"), "{err}");
    assert_eq!(v["ok"], true);
    assert_at(&v, [4.0, 7.0, 2.0]);
    let stops = v["stops"].as_array().unwrap();
    assert_eq!(
        stops.len(),
        1,
        "M1 passes with optional stop off: {stops:?}"
    );
    assert_eq!(stops[0]["action"], "continue");
    assert_eq!(stops[0]["waited_s"], 0.0);
}

fn spawn_wait(report: &Path, extra: &[&str]) -> std::process::Child {
    let test = report.file_stem().unwrap().to_str().unwrap();
    let prog = stops_program(test);
    cnc402_piped("warn")
        .args([
            "run",
            prog.to_str().unwrap(),
            "--at-stop",
            "wait",
            "--report",
        ])
        .arg(report)
        .args(extra)
        .spawn()
        .unwrap()
}

#[test]
fn m0_with_wait_holds_until_enter_and_the_report_shows_the_pause() {
    let (_, v) = run_ok_with_report(
        &stops_program("m0_with_wait_holds_until_enter_and_the_report_shows_the_pause"),
        "stops-wait-ref.json",
        &["--at-stop", "continue"],
    );
    let t_cont = v["program_time_s"].as_f64().unwrap();

    let report = tmp("stops-wait.json");
    let mut child = spawn_wait(&report, &[]);
    let mut stdin = child.stdin.take().unwrap();
    let mut child = WatchedChild::new(child);
    // The operator reads the prompt, then presses Enter 0.6 s later.
    child.wait_for("stops.nc:4 — press Enter to continue");
    std::thread::sleep(std::time::Duration::from_millis(600));
    {
        use std::io::Write as _;
        stdin.write_all(b"\n").unwrap();
        // Kept open until the end: the newline alone resumes.
        let (status, err) = child.finish();
        drop(stdin);
        assert_eq!(status.code(), Some(0), "{err}");
        assert!(err.contains("M0 at "), "{err}");
    }
    let v = read_json(&report);
    assert_eq!(v["ok"], true);
    assert_at(&v, [4.0, 7.0, 2.0]);
    let stops = v["stops"].as_array().unwrap();
    assert_eq!(stops.len(), 1, "{stops:?}");
    assert_eq!(stops[0]["line"], 4);
    assert_eq!(stops[0]["action"], "wait");
    let w = stops[0]["waited_s"].as_f64().unwrap();
    assert!(w > 0.3 && w < 5.0, "waited {w} s");
    // Virtual time goes on (held ticks) during the pause: program time includes it.
    let t = v["program_time_s"].as_f64().unwrap();
    assert!(
        t > t_cont + 0.2,
        "program time {t} s, without the pause {t_cont} s"
    );
}

#[test]
fn sigint_during_a_pause_stops_the_machine_and_exits_1() {
    let report = tmp("stops-sigint.json");
    let mut child = spawn_wait(&report, &[]);
    // The operator's terminal stays open (no end of input) while Ctrl-C is pressed.
    let stdin = child.stdin.take().unwrap();
    let mut child = WatchedChild::new(child);
    child.wait_for("press Enter to continue");
    std::thread::sleep(std::time::Duration::from_millis(200));
    sigint(&child.pid());
    let (status, err) = child.finish();
    drop(stdin);
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(err.contains("operator stop (SIGINT)"), "{err}");
    assert!(
        err.contains("press Enter to continue"),
        "paused first: {err}"
    );
    let v = read_json(&report);
    assert_eq!(v["ok"], false);
    assert_eq!(v["stop"]["cause"], "operator stop (SIGINT)");
    assert_at(&v, [10.0, 5.0, 5.0]);
}

#[test]
fn a_drive_fault_during_a_pause_still_stops_the_machine() {
    let report = tmp("stops-fault.json");
    // M0 is reached at ~0.76 s of program time; the fault comes while the machine holds
    // there (virtual time runs on at the wall clock's pace during the pause).
    let mut child = spawn_wait(&report, &["--inject-fault", "1:8611@1.2"]);
    let stdin = child.stdin.take().unwrap();
    let o = child.wait_with_output().unwrap();
    drop(stdin);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("press Enter to continue"),
        "paused first: {err}"
    );
    assert!(err.contains("EMCY 0x8611"), "{err}");
    let v = read_json(&report);
    assert_eq!(v["ok"], false);
    assert_eq!(v["stop"]["node"], 1);
    assert_eq!(v["stops"][0]["line"], 4);
    assert!(
        v["stops"][0]["waited_s"].is_null(),
        "never resumed: {}",
        v["stops"]
    );
    assert_at(&v, [10.0, 5.0, 5.0]);
}

/// In `dir`: a fresh (absent) variables file `<name>.vars` and a copy of the shipped config
/// `<name>.toml` that names it.
fn config_with_fresh_vars(dir: &Path, name: &str) -> (PathBuf, PathBuf) {
    let vars = dir.join(format!("{name}.vars"));
    let _ = std::fs::remove_file(&vars);
    let cfg = dir.join(format!("{name}.toml"));
    config_with_vars_file(&vars, &cfg);
    (vars, cfg)
}

/// A copy of the shipped config whose non-volatile variables file is `vars`.
fn config_with_vars_file(vars: &Path, cfg: &Path) {
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("config/machine.toml"))
            .unwrap();
    let text: String = text
        .lines()
        .map(|l| {
            if l.starts_with("variables_file") {
                format!("variables_file = {:?}\n", vars.to_str().unwrap())
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    assert!(
        text.contains(vars.to_str().unwrap()),
        "the shipped config names a variables file"
    );
    std::fs::write(cfg, text).unwrap();
}

/// Regression: the interpreter ran ahead past an M0, so a program that ended at the stop (by
/// `--at-stop end`, or the operator ending it there) had already executed the blocks after
/// it, here a durable write of a non-volatile variable. M0 is now a buffer stop, as on a
/// Fanuc control: nothing after it is interpreted until the run resumes.
#[test]
fn a_program_stop_is_a_buffer_stop_and_what_follows_it_is_not_run_when_the_program_ends_there() {
    let dir = test_dir("buffer-stop");
    let prog = write_program(
        &dir,
        "write-after-stop.nc",
        "G21 G90 G17\nG0 X0 Y0 Z5\nG1 X10 F1200\nM0\n#500=1\nG1 X20\nM30\n",
    );
    for (policy, want_x, want_500) in [
        ("end", 10.0, None),
        ("wait", 10.0, None),
        ("continue", 20.0, Some(1.0)),
    ] {
        let (vars, cfg) = config_with_fresh_vars(&dir, policy);
        let report = dir.join(format!("{policy}.json"));
        // stdin is empty: `wait` reads end of input and ends the program at the stop.
        let o = cnc402(&[
            "run",
            prog.to_str().unwrap(),
            "--config",
            cfg.to_str().unwrap(),
            "--at-stop",
            policy,
            "--report",
            report.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{policy}: {}", stderr(&o));
        let v = read_json(&report);
        assert_eq!(v["ok"], true, "{policy}: {v}");
        assert_at(&v, [want_x, 0.0, 5.0]);
        let got = cnc402_interp::NvTable::load(&vars)
            .ok()
            .and_then(|t| t.get(500));
        assert_eq!(got, want_500, "{policy}: #500 after the run");
    }
    // The dry run (program errors before motion) ends at a stop that ends the program, too.
    let alarm = write_program(
        &dir,
        "alarm-after-stop.nc",
        "G21 G90 G17\nG0 X0 Y0 Z5\nG1 X10 F1200\nM0\n#3000=7(PAST THE STOP)\nM30\n",
    );
    let o = cnc402(&["run", alarm.to_str().unwrap(), "--at-stop", "end"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = cnc402(&["run", alarm.to_str().unwrap(), "--at-stop", "continue"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("alarm 3007") && stderr(&o).contains("PAST THE STOP"),
        "{}",
        stderr(&o)
    );
    // Past a stop that holds, an error that cannot change during the stop (it reads no
    // variable the operator can set) is refused before motion, as any program error.
    let o = cnc402(&["run", alarm.to_str().unwrap(), "--at-stop", "wait"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("PAST THE STOP"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("press Enter"), "{}", stderr(&o));
    // One that reads a non-volatile variable there does not keep the machine from starting
    // (the operator may set it while the machine holds): it is a warning, and the run raises
    // the alarm only if it still happens after the resume.
    let (_vars, cfg) = config_with_fresh_vars(&dir, "ask");
    let ask = write_program(
        &dir,
        "ask-after-stop.nc",
        "G21 G90 G17\nG0 X0 Y0 Z5\nG1 X10 F1200\nM0 (SET #500=1)\n\
         IF [#500 NE 1] THEN #3000=7(PAST THE STOP)\nM30\n",
    );
    let args = [
        "run",
        ask.to_str().unwrap(),
        "--config",
        cfg.to_str().unwrap(),
        "--at-stop",
        "wait",
    ];
    let o = cnc402(&args);
    let err = stderr(&o);
    assert_eq!(
        o.status.code(),
        Some(0),
        "end of input ends it at the stop: {err}"
    );
    assert!(
        err.contains("ask-after-stop.nc:4: the program, run on past this stop"),
        "{err}"
    );
    let mut child = cnc402_piped("warn").args(args).spawn().unwrap();
    {
        use std::io::Write as _;
        // Enter, read when the stop is reached, #500 still vacant: the run resumes into the
        // alarm.
        let mut stdin = child.stdin.take().unwrap();
        stdin.write_all(b"\n").unwrap();
        let o = child.wait_with_output().unwrap();
        drop(stdin);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains("press Enter to continue"), "{err}");
        assert!(err.contains("PAST THE STOP"), "{err}");
    }
}

#[test]
fn m99_at_the_end_of_a_main_program_repeats_it_in_run_and_segments_shows_one_pass() {
    let dir = test_dir("m99-repeat");
    let prog = write_program(
        &dir,
        "loop.nc",
        "O0100 (PART LOOP)\nG21 G90 G17\n#100 = [#100 + 1]\nG0 X[#100 * 2] Y0 Z5\n\
         IF [#100 GE 3] GOTO 90\nM99\nN90 M30\n",
    );
    let report = dir.join("loop.json");
    let o = cnc402(&[
        "run",
        prog.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("loop.nc:6: M99 in the main program: it starts over"),
        "{}",
        stderr(&o)
    );
    let v = read_json(&report);
    assert_eq!(v["ok"], true);
    // Three passes: X2, X4, X6, then the branch to M30.
    assert_at(&v, [6.0, 0.0, 5.0]);
    // sqrt(2² + 5²) + 2 + 2 mm (summed from the 1 ms setpoints).
    assert!((v["path_length_mm"].as_f64().unwrap() - 9.385164807134504).abs() < 1e-4);

    let o = cnc402(&["segments", prog.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let lines: Vec<Value> = String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 1, "one pass: {lines:?}");
    assert_eq!(lines[0]["end"]["X"], 2.0);
    assert!(stderr(&o).contains("M99 at line 6"), "{}", stderr(&o));
}

/// The Fanuc idiom of filling a parameter during a program stop: the program holds at M0, the
/// operator sets #500 (here with `cnc402 vars set`, as on the control's variable page), and
/// the blocks after the stop read the new value, because nothing past the stop was interpreted
/// and the variables are read again at the resume.
#[test]
fn variables_set_during_a_program_stop_are_what_the_program_reads_after_it() {
    let dir = test_dir("vars-during-stop");
    let (vars, cfg) = config_with_fresh_vars(&dir, "vars");
    let prog = write_program(
        &dir,
        "ask.nc",
        "G21 G90 G17\n#500=3\nG0 X#500 Y0 Z5\nM0 (SET #500 TO THE NEXT X)\nG0 X#500\nM30\n",
    );
    let report = dir.join("ask.json");
    let child = cnc402_piped("warn")
        .args([
            "run",
            prog.to_str().unwrap(),
            "--config",
            cfg.to_str().unwrap(),
        ])
        .args(["--at-stop", "wait", "--report", report.to_str().unwrap()])
        .spawn()
        .unwrap();
    let mut child = child;
    let mut stdin = child.stdin.take().unwrap();
    let mut child = WatchedChild::new(child);
    child.wait_for("press Enter to continue");
    let o = cnc402(&["vars", "--config", cfg.to_str().unwrap(), "set", "500=12.5"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    {
        use std::io::Write as _;
        stdin.write_all(b"\n").unwrap();
    }
    let (status, err) = child.finish();
    drop(stdin);
    assert_eq!(status.code(), Some(0), "{err}");
    let v = read_json(&report);
    assert_eq!(v["ok"], true);
    assert_at(&v, [12.5, 0.0, 5.0]);
    let table = cnc402_interp::NvTable::load(&vars).unwrap();
    assert_eq!(table.get(500), Some(12.5));
}

#[test]
fn coolant_left_on_by_a_program_ended_at_a_stop_is_turned_off() {
    let dir = test_dir("coolant-end");
    let prog = write_program(&dir, "coolant.nc", "G21 G90\nG0 X1 M8\nM0\nG0 X2\nM30\n");
    let o = cnc402_logging(&["run", prog.to_str().unwrap(), "--at-stop", "end"], "info");
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    let on = err.find("line 2: coolant flood").expect(&err);
    let off = err
        .find("coolant off: the run ended with it on")
        .expect(&err);
    assert!(on < off, "{err}");
    // M30 turns it off itself: no second "off" at the end.
    let o = cnc402_logging(
        &["run", prog.to_str().unwrap(), "--at-stop", "continue"],
        "info",
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("coolant off"), "{err}");
    assert!(!err.contains("the run ended with it on"), "{err}");
}

/// Regression: a variables file removed during a program stop read as all vacant at the
/// resume, so the program went on with its #500 gone (and a word with a vacant value is left
/// out of its block). It is an error at the stop's line now.
#[test]
fn a_variables_file_removed_during_a_stop_stops_the_program_at_the_resume() {
    let dir = test_dir("vars-removed-during-stop");
    let (vars, cfg) = config_with_fresh_vars(&dir, "vars");
    let prog = write_program(
        &dir,
        "ask.nc",
        "G21 G90 G17\n#500=7\nG0 X1 Y0 Z5\nM0\nG0 X#500\nM30\n",
    );
    let mut child = cnc402_piped("warn")
        .args([
            "run",
            prog.to_str().unwrap(),
            "--config",
            cfg.to_str().unwrap(),
        ])
        .args(["--at-stop", "wait"])
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let mut child = WatchedChild::new(child);
    child.wait_for("press Enter to continue");
    std::fs::remove_file(&vars).unwrap();
    {
        use std::io::Write as _;
        stdin.write_all(b"\n").unwrap();
    }
    let (status, err) = child.finish();
    drop(stdin);
    assert_eq!(status.code(), Some(2), "{err}");
    assert!(err.contains("ask.nc:4"), "{err}");
    assert!(err.contains("was removed during the stop"), "{err}");
}

#[test]
fn report_trace_and_plot_replace_old_files_whole_and_leave_no_temp_files() {
    let dir = test_dir("durable-outputs");
    let (report, trace, plot) = (dir.join("r.json"), dir.join("t.csv"), dir.join("p.svg"));
    for p in [&report, &trace, &plot] {
        std::fs::write(p, "old").unwrap();
    }
    let o = cnc402(&[
        "run",
        "examples/peck-tap.nc",
        "--report",
        report.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
        "--plot",
        plot.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(read_json(&report)["ok"], true);
    assert!(
        std::fs::read_to_string(&trace)
            .unwrap()
            .starts_with("t,line,")
    );
    assert!(std::fs::read_to_string(&plot).unwrap().contains("<svg"));
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["p.svg", "r.json", "t.csv"], "temporary files left");
}

/// Bad path-mode words exit 2 with file:line:col before anything moves.
#[test]
fn bad_path_mode_words_exit_2_with_file_line_col() {
    let dir = test_dir("bad_path_mode");
    for (name, text, at) in [
        ("p-neg.nc", "G21 G90\nG64 P-1\nM30\n", ":2:5"),
        (
            "q-alone.nc",
            "G21 G90\nG1 X1 F100\nG64 Q0.01\nM30\n",
            ":3:5",
        ),
        ("p-max.nc", "G21 G90\nG64 P5\nM30\n", ":2:5"),
    ] {
        let p = write_program(&dir, name, text);
        let o = cnc402(&["run", p.to_str().unwrap()]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{name}: {err}");
        assert!(
            err.contains(&format!("{}{at}", p.display())),
            "{name}: {err}"
        );
    }
}

/// A G64 program of fine blocks runs at its feed on the embedded simulator: 2000 blocks of
/// 0.01 mm along a circle at F3000 take about 0.4 s at the feed (80 s with exact stops).
#[test]
fn fine_blocks_under_g64_run_at_the_feed() {
    let dir = test_dir("g64_feed");
    let mut text = String::from("G21 G90 G17 G64 P0.01\nG0 X10 Y0 Z0\nG1 F3000\n");
    for i in 1..=2000 {
        let a = f64::from(i) * 0.001;
        text += &format!("X{:.4} Y{:.4}\n", 10.0 * a.cos(), 10.0 * a.sin());
    }
    text += "M30\n";
    let p = write_program(&dir, "circle.nc", &text);
    let report = dir.join("r.json");
    let o = cnc402(&[
        "run",
        p.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout).to_string();
    let secs: f64 = out
        .split("program time ")
        .nth(1)
        .and_then(|s| s.split(" s").next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no program time in {out}"));
    // The 10 mm rapid (about 0.2 s) plus 20 mm at 50 mm/s.
    assert!(secs < 1.0, "{secs} s: {out}");
    // Regression (virtual_time_loop_ticked_ahead_of_the_feeder): on the embedded simulator the
    // loop waits for the feeder, so a fine G64 path never pauses for want of a move, however
    // slow the feeder thread (a debug build's is slow): no starved tick, no exact stop.
    let r = read_json(&report);
    assert_eq!(r["starved_ticks"], 0, "{r}");
    assert_eq!(r["exact_stops"], 0, "{r}");
}

/// `G64 P… Q…` merges noisy collinear CAM steps; the report's largest path deviation counts
/// how far merging moved the path off the programmed corners (≤ Q), and is 0 without Q.
#[test]
fn g64_q_merging_shows_in_the_reports_path_deviation() {
    let dir = test_dir("g64_q");
    for (mode, merged) in [("G64 P0.01 Q0.01", true), ("G64 P0.01", false)] {
        let mut text = format!("G21 G90 G17 {mode}\nG0 X0 Y0 Z0\nG1 F3000\n");
        for i in 1..=300 {
            let y = if i % 2 == 0 { 0.004 } else { -0.004 };
            text += &format!("X{:.3} Y{y:.3}\n", f64::from(i) * 0.1);
        }
        text += "Y0\nM30\n";
        let p = write_program(&dir, "noisy.nc", &text);
        let report = dir.join("r.json");
        let o = cnc402(&[
            "run",
            p.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{mode}: {}", stderr(&o));
        let dev = read_json(&report)["max_path_deviation_mm"]
            .as_f64()
            .unwrap();
        if merged {
            assert!((0.003..=0.01).contains(&dev), "{mode}: {dev}");
        } else {
            assert!(dev < 1e-9, "{mode}: {dev}");
        }
    }
}

/// The report's path figures on one path run in both modes: G61 comes to rest at each of
/// the four junctions of five collinear blocks, G64 at none (and G05.1 Q1 is G64); the feed
/// time is the path length over the feed; the setpoints stay on the programmed path.
#[test]
fn report_path_figures_count_exact_stops_and_the_feed_time() {
    let dir = test_dir("path-figures");
    for (mode, stops) in [("G61", 4), ("G64", 0), ("G05.1 Q1", 0), ("G05.1 Q0", 4)] {
        let text = format!("G21 G90 G17 {mode}\nG1 X10 F600\nX20\nX30\nX40\nX50\nM30\n");
        let prog = write_program(&dir, "p.nc", &text);
        let report = dir.join("p.json");
        let o = cnc402(&[
            "run",
            prog.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{mode}: {}", stderr(&o));
        let v = read_json(&report);
        assert_eq!(v["exact_stops"], stops, "{mode}");
        let feed_time = v["feed_time_s"].as_f64().unwrap();
        assert!(
            (feed_time - 5.0).abs() < 1e-9,
            "{mode}: 50 mm at 10 mm/s: {feed_time}"
        );
        let program_time = v["program_time_s"].as_f64().unwrap();
        assert!(program_time > feed_time, "{mode}: {program_time}");
        assert!(
            v["max_path_deviation_mm"].as_f64().unwrap() < 1e-9,
            "{mode}"
        );
    }
}

/// The captions of the plot's path panels, and of the panels only a tapping program gets.
const PATH_PANELS: [&str; 4] = [
    "toolpath XY (from above)",
    "toolpath XZ (side view)",
    "commanded velocity per axis",
    "following error per axis",
];
const TAP_PANELS: [&str; 2] = [
    "rigid tapping: Z and C setpoints",
    "rigid-tap coupling error",
];

/// A contour program's plot: the toolpath from above and from the side, coloured by path
/// speed (several colours), per-axis velocity and following error; no tapping panels.
#[test]
fn plot_of_a_contour_has_the_toolpath_velocity_and_following_error_panels() {
    let plot = tmp("contour.svg");
    let o = cnc402(&[
        "run",
        "examples/contour-arcs.nc",
        "--plot",
        plot.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(svg.trim_end().ends_with("</svg>"));
    for panel in PATH_PANELS {
        assert!(svg.contains(panel), "no {panel:?} panel");
    }
    for panel in TAP_PANELS {
        assert!(!svg.contains(panel), "{panel:?} without a tap");
    }
    // Slow arcs and fast rapids: the toolpath is drawn in more than a few speed colours.
    let colours: std::collections::HashSet<&str> = svg
        .match_indices("stroke=\"#")
        .map(|(i, _)| &svg[i + 9..i + 15])
        .collect();
    // (Black and the four axis colours of the time panels are among them.)
    assert!(colours.len() >= 10, "{colours:?}");
}
