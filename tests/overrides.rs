//! Feed hold, resume, feed override and spindle override end to end on the embedded
//! simulator in virtual time, driven by a command file with triggers (`at 1.2s hold`,
//! `at N40 feed 50`): what the trace shows (velocities to 0 and back, every axis within its
//! limits, the path and the end as without the hold), a rigid tap that is neither held nor
//! overridden (Fanuc) and stays coupled, the report's `panel` list, and bad input.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use cnc402_config::MachineConfig;
use serde_json::Value;

fn cnc402(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env_remove("RUST_LOG")
        .stdin(std::process::Stdio::null())
        .output()
        .expect("run cnc402")
}

fn test_dir(test: &str) -> PathBuf {
    let dir = std::env::temp_dir()
        .join(format!("cnc402-overrides-{}", std::process::id()))
        .join(test);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

/// A run's exit code, report, stderr and trace (commanded X Y Z C per tick).
struct Run {
    code: Option<i32>,
    report: Value,
    stderr: String,
    cmd: Vec<[f64; 4]>,
}

/// Runs `program` with the command file `commands` (none when empty).
fn run(dir: &Path, program: &str, commands: &str) -> Run {
    run_with(dir, program, commands, &[])
}

/// [`run`] with further arguments.
fn run_with(dir: &Path, program: &str, commands: &str, extra: &[&str]) -> Run {
    let report = dir.join("report.json");
    let trace = dir.join("trace.csv");
    let _ = std::fs::remove_file(&report);
    let _ = std::fs::remove_file(&trace);
    let mut args = vec![
        "run".to_string(),
        program.to_string(),
        "--report".into(),
        report.to_str().unwrap().into(),
        "--trace".into(),
        trace.to_str().unwrap().into(),
    ];
    args.extend(extra.iter().map(|a| a.to_string()));
    if !commands.is_empty() {
        args.push("--commands".into());
        args.push(write(dir, "commands.txt", commands));
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = cnc402(&args);
    let report = std::fs::read_to_string(&report)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or(Value::Null);
    Run {
        code: o.status.code(),
        report,
        stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
        cmd: std::fs::read_to_string(&trace)
            .map(|t| trace_cmd(&t))
            .unwrap_or_default(),
    }
}

fn run_ok(dir: &Path, program: &str, commands: &str) -> Run {
    let r = run(dir, program, commands);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    r
}

fn trace_cmd(text: &str) -> Vec<[f64; 4]> {
    let mut lines = text.lines();
    let Some(head) = lines.next() else {
        return Vec::new();
    };
    let head: Vec<&str> = head.split(',').collect();
    let col = |n: &str| head.iter().position(|h| *h == n).unwrap();
    let cols = [col("X_cmd"), col("Y_cmd"), col("Z_cmd"), col("C_cmd")];
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            cols.map(|c| f[c].parse::<f64>().unwrap())
        })
        .collect()
}

/// Path speed over X Y Z (mm/s) between row k−1 and k.
fn speed(cmd: &[[f64; 4]], k: usize) -> f64 {
    let d: f64 = (0..3).map(|i| (cmd[k][i] - cmd[k - 1][i]).powi(2)).sum();
    d.sqrt() / 0.001
}

/// Every axis within its velocity, acceleration and (with `jerk`) jerk limit on every tick,
/// by finite differences of the trace's commanded positions (printed to 1e-7: the n-th
/// difference carries up to 2^n · 0.5e-7 / Pⁿ of rounding).
fn check_limits(cmd: &[[f64; 4]], jerk: bool) {
    let cfg = MachineConfig::default_machine();
    let p = 0.001;
    for (i, ax) in cfg.axes.iter().enumerate() {
        let mut d: Vec<f64> = cmd.iter().map(|r| r[i]).collect();
        let lims = [ax.max_velocity, ax.max_acceleration, ax.max_jerk];
        let orders = if jerk { 3 } else { 2 };
        for (n, lim) in lims.iter().enumerate().take(orders) {
            d = d.windows(2).map(|w| (w[1] - w[0]) / p).collect();
            let noise = 2f64.powi(n as i32 + 1) * 0.5e-7 / p.powi(n as i32 + 1);
            let allowed = lim * (1.0 + 1e-6) + noise;
            let worst = d.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(
                worst <= allowed,
                "axis {} derivative {}: {worst} > {allowed}",
                ax.name,
                n + 1
            );
        }
    }
}

fn panel(v: &Value) -> Vec<String> {
    v["panel"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| {
            format!(
                "{} {} t={} line={} input={}",
                e["action"].as_str().unwrap(),
                e["percent"],
                e["at_s"],
                e["line"],
                e["input_line"]
            )
        })
        .collect()
}

/// Exact-stop lines (G61): N20 is a long diagonal at 50 mm/s.
const LINES: &str = "G21 G90 G17 G94 G61\nG0 X0 Y0 Z5\nN10 G1 Z0 F1000\n\
                     N20 G1 X80 Y20 F3000\nN30 G1 Y40\nN40 G1 X0\nN50 G0 Z5\nM30\n";

/// Distance from (x, y) to the segment a–b.
fn off_segment(x: f64, y: f64, a: [f64; 2], b: [f64; 2]) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let u = (((x - a[0]) * d[0] + (y - a[1]) * d[1]) / (d[0] * d[0] + d[1] * d[1])).clamp(0.0, 1.0);
    ((a[0] + u * d[0] - x).powi(2) + (a[1] + u * d[1] - y).powi(2)).sqrt()
}

#[test]
fn a_feed_hold_mid_move_stops_on_the_path_and_resume_ends_where_the_plain_run_does() {
    let dir = test_dir("hold");
    let prog = write(&dir, "lines.nc", LINES);
    let plain = run_ok(&dir, &prog, "");
    let held = run_ok(
        &dir,
        &prog,
        "# feed hold mid N20\nat 1.2s hold\nat 2.5s resume\n",
    );
    check_limits(&held.cmd, true);
    assert_eq!(held.cmd.last(), plain.cmd.last(), "the same end");
    assert!(
        speed(&held.cmd, 1200) > 45.0,
        "at speed when the hold comes"
    );
    let still = &held.cmd[1700..2500];
    assert!(
        still.iter().all(|r| r == &still[0]),
        "at rest, setpoints held"
    );
    assert!(
        (2600..3000).any(|k| speed(&held.cmd, k) > 45.0),
        "back at speed"
    );
    // On N20's line at every tick of it (exact stop: no corner to round).
    let on_n20 = held.cmd[1000..3000]
        .iter()
        .map(|r| off_segment(r[0], r[1], [0.0, 0.0], [80.0, 20.0]))
        .fold(0.0, f64::max);
    assert!(on_n20 < 1e-6, "{on_n20} mm off N20");
    let dev = held.report["max_path_deviation_mm"].as_f64().unwrap();
    assert!(dev <= 0.01, "path deviation {dev} mm");
    assert_eq!(
        panel(&held.report),
        [
            "hold null t=1.2 line=4 input=2",
            "resume null t=2.5 line=4 input=3"
        ]
    );
    let text = std::fs::read_to_string(dir.join("trace.csv")).unwrap();
    let marked: Vec<&str> = text.lines().filter(|l| !l.ends_with(',')).skip(1).collect();
    assert_eq!(marked.len(), 2, "the trace marks the hold and the resume");
    assert!(marked[0].starts_with("1.200000,4,") && marked[0].ends_with(",hold"));
    assert!(marked[1].starts_with("2.500000,4,") && marked[1].ends_with(",resume"));
    let t_plain = plain.report["program_time_s"].as_f64().unwrap();
    let t_held = held.report["program_time_s"].as_f64().unwrap();
    assert!(t_held > t_plain + 0.9, "{t_plain} s → {t_held} s");
}

#[test]
fn feed_override_ramps_to_the_new_speed_and_zero_stops_like_a_hold() {
    let dir = test_dir("feed");
    let prog = write(&dir, "lines.nc", LINES);
    let half = run_ok(&dir, &prog, "at N20 feed 50\n");
    check_limits(&half.cmd, true);
    // N20 runs at 25 mm/s once the ramp is done.
    let mid = speed(&half.cmd, 1500);
    assert!((mid - 25.0).abs() < 0.05, "{mid} mm/s");
    let fast = run_ok(&dir, &prog, "feed 150\n");
    check_limits(&fast.cmd, true);
    let top = (1..fast.cmd.len())
        .map(|k| speed(&fast.cmd, k))
        .fold(0.0, f64::max);
    assert!((top - 75.0).abs() < 0.1, "N20 at 150 %: {top} mm/s");
    let zero = run_ok(&dir, &prog, "at 1.0s feed 0\nat 2.0s feed 100\n");
    check_limits(&zero.cmd, true);
    let still = &zero.cmd[1500..2000];
    assert!(still.iter().all(|r| r == &still[0]), "feed 0 holds");
    assert_eq!(zero.cmd.last(), half.cmd.last());
    assert_eq!(
        panel(&zero.report),
        [
            "feed 0 t=1.0 line=4 input=1",
            "feed 100 t=2.0 line=4 input=2"
        ]
    );
}

/// Fanuc's G84: feed hold during the tap takes effect after the return to R, and feed
/// override does not act; Z and C stay coupled within one count throughout.
#[test]
fn a_rigid_tap_finishes_before_a_hold_and_ignores_feed_override() {
    let dir = test_dir("tap");
    let prog = "examples/m10x1.5-rigid-tap.nc";
    let plain = run_ok(&dir, prog, "");
    // The first tap runs from about 0.63 s (Z3 → Z-16 → Z3 at 12.5 mm/s).
    let held = run_ok(&dir, prog, "at 1.2s hold\nat 6s resume\n");
    let first_tap = 600..3500;
    assert_eq!(
        held.cmd[first_tap.clone()],
        plain.cmd[first_tap],
        "the tap is not held"
    );
    let at_r = &held.cmd[4000..6000];
    assert!(
        at_r.iter()
            .all(|r| r == &at_r[0] && (r[2] - 3.0).abs() < 1e-9),
        "held at R (Z3) after the tap out"
    );
    assert_eq!(held.cmd.last(), plain.cmd.last());
    check_limits(&held.cmd, true);
    for cmds in [
        "feed 50\n",
        "feed 200\n",
        "at 1.0s feed 0\nat 8s feed 100\n",
    ] {
        let r = run_ok(&dir, prog, cmds);
        let taps = r.report["tapping"].as_array().unwrap();
        assert_eq!(
            taps.len(),
            plain.report["tapping"].as_array().unwrap().len()
        );
        for t in taps {
            let e = t["max_coupling_error_um_cmd"].as_f64().unwrap();
            assert!(e <= 0.1, "{cmds}: coupling {e} µm (one count: 0.1 µm)");
        }
        let window = 600..3500;
        assert_eq!(
            r.cmd[window.clone()],
            plain.cmd[window],
            "{cmds}: the tap at 100 %"
        );
    }
}

#[test]
fn spindle_override_ramps_the_spindle_speed() {
    let dir = test_dir("spindle");
    let prog = write(
        &dir,
        "spindle.nc",
        "G21 G90 G94\nS1000 M3\nG4 P1000\nN20 G4 P2000\nM5\nM30\n",
    );
    let r = run_ok(&dir, &prog, "at N20 spindle 120\n");
    check_limits(&r.cmd, true);
    // C in deg per tick: 1000 rpm = 6°/ms before, 7.2°/ms after the ramp.
    let c = |k: usize| (r.cmd[k][3] - r.cmd[k - 1][3]) * 60.0 / 360.0 / 0.001;
    let rpm_before = c(1000);
    let rpm_after = c(2500);
    assert!((rpm_before - 1000.0).abs() < 0.1, "{rpm_before}");
    assert!((rpm_after - 1200.0).abs() < 0.1, "{rpm_after}");
}

#[test]
fn an_override_out_of_range_in_a_command_file_is_exit_64_at_its_line_and_nothing_moves() {
    let dir = test_dir("bad");
    let prog = write(&dir, "lines.nc", LINES);
    for (cmds, line, want) in [
        ("feed 250\n", 1, "0–200"),
        ("continue\nspindle 40\n", 2, "50–120"),
        ("# c\nfeed -1\n", 2, "0–200"),
        ("at 2x hold\n", 1, "expected a time"),
        ("at 1s fly\n", 1, "panel command"),
        (
            "at 1s hold\nat 2s feed 0\nat 3s resume\nat 4s hold\n",
            4,
            "for ever",
        ),
    ] {
        let r = run(&dir, &prog, cmds);
        assert_eq!(r.code, Some(64), "{cmds}: {}", r.stderr);
        assert!(
            r.stderr.contains(&format!("commands.txt:{line}: ")) && r.stderr.contains(want),
            "{cmds}: {}",
            r.stderr
        );
        assert!(r.cmd.is_empty(), "{cmds}: nothing ran");
    }
}

/// From stdin (`--commands -`, as from the terminal) a panel command acts when read and a
/// bad one is refused with a message; the run goes on.
#[test]
fn panel_commands_on_stdin_act_at_once_and_bad_ones_are_refused() {
    use std::io::Write;
    let dir = test_dir("stdin");
    let prog = write(&dir, "lines.nc", LINES);
    let report = dir.join("report.json");
    let mut child = Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(["run", &prog, "--commands", "-", "--report"])
        .arg(&report)
        .env_remove("RUST_LOG")
        .stdin(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    stdin.write_all(b"feed 250\nat 1s hold\nfeed 80\n").unwrap();
    drop(stdin);
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(
        err.contains("stdin:1: feed override 250 % out of range: 0–200 %"),
        "{err}"
    );
    assert!(
        err.contains("stdin:2: `at …` triggers belong in a command file"),
        "{err}"
    );
    assert!(
        err.contains("feed: feed 80 %, spindle 100 %, rapid 100 %"),
        "{err}"
    );
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let p = panel(&v);
    assert_eq!(p.len(), 1, "{p:?}");
    assert!(
        p[0].starts_with("feed 80 ") && p[0].ends_with("input=3"),
        "{p:?}"
    );
}

/// `rapid 25` runs rapids at a quarter of their speed (four times as long) and leaves feed
/// moves alone; `feed 50` leaves rapids alone.
#[test]
fn rapid_override_scales_rapids_only() {
    let dir = test_dir("rapid");
    let prog = write(&dir, "lines.nc", LINES);
    // The first move is the rapid to Z5: the ticks until Z first reaches 5.
    let up = |r: &Run| r.cmd.iter().position(|c| c[2] >= 5.0 - 1e-9).unwrap();
    let plain = run_ok(&dir, &prog, "");
    let quarter = run_ok(&dir, &prog, "rapid 25\n");
    check_limits(&quarter.cmd, true);
    let (a, b) = (up(&plain), up(&quarter));
    assert!((b as f64 - 4.0 * a as f64).abs() <= 4.0, "{a} ticks → {b}");
    let half_feed = run_ok(&dir, &prog, "feed 50\n");
    assert_eq!(up(&half_feed), a, "feed override leaves rapids alone");
    assert_eq!(quarter.cmd.last(), plain.cmd.last());
    assert_eq!(panel(&quarter.report), ["rapid 25 t=0.0 line=0 input=1"]);
}

/// A feed hold typed on stdin whose input then ends: nobody can resume, so the program ends
/// there with a controlled stop (exit 1, the machine stopped) instead of holding for ever.
#[test]
fn end_of_input_in_a_feed_hold_ends_the_program_there() {
    use std::io::Write;
    let dir = test_dir("eof");
    let prog = write(&dir, "lines.nc", LINES);
    let mut child = Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(["run", &prog, "--commands", "-"])
        .env_remove("RUST_LOG")
        .stdin(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    stdin.write_all(b"hold\n").unwrap();
    drop(stdin);
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("end of input) in a feed hold"), "{err}");
}

/// In a feed hold the drives stay enabled and monitored: a drive fault still stops the run
/// (and names the drive), the held setpoints unchanged up to it.
#[test]
fn a_fault_during_a_feed_hold_still_stops_the_machine() {
    let dir = test_dir("fault");
    let prog = write(&dir, "lines.nc", LINES);
    let r = run_with(
        &dir,
        &prog,
        "at 1.2s hold\nat 4s resume\n",
        &["--inject-fault", "1:8611@2.0"],
    );
    assert_eq!(r.code, Some(1), "{}", r.stderr);
    assert_eq!(r.report["ok"], false);
    let err = r.report["error"].as_str().unwrap_or("");
    assert!(err.contains("0x8611") || err.contains("8611"), "{err}");
    let held = &r.cmd[1700..1990];
    assert!(
        held.iter().all(|c| c == &held[0]),
        "held still until the fault"
    );
}
