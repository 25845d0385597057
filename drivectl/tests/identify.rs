//! `drivectl identify` against the embedded simulator: over a range of simulated truths
//! (dead time, bandwidth, encoder resolution, velocity feedforward, the documented feed axis
//! and spindle sets) it finds the drive's equivalent model within 20 %; and it refuses,
//! moving nothing, a drive that is not enabled, in FAULT, or a stroke beyond the limits.

use std::path::{Path, PathBuf};
use std::process::Command;

use cnc402_config::MachineConfig;
use serde_json::Value;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The shipped machine with the `sim` table of the axis on `node` replaced by `sim`.
fn config_with(node: u8, sim: &str, tag: &str) -> PathBuf {
    let shipped = std::fs::read_to_string(repo().join("config/machine.toml")).unwrap();
    let at = shipped.find(&format!("node = {node}\n")).unwrap();
    let from = at + shipped[at..].find("sim = {").unwrap();
    let to = from + shipped[from..].find('\n').unwrap();
    let text = format!("{}{sim}{}", &shipped[..from], &shipped[to..]);
    let dir = std::env::temp_dir().join(format!("drivectl-identify-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{tag}.toml"));
    std::fs::write(&path, text).unwrap();
    path
}

fn drivectl(config: &Path, args: &[&str]) -> (i32, String, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .current_dir(repo())
        .arg("--config")
        .arg(config)
        .args(["--iface", "sim"])
        .args(args)
        .output()
        .unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn identify_finds_the_simulated_truth_within_20_percent() {
    // (node, sim table, extra args)
    let cases: &[(u8, &str, &[&str])] = &[
        (3, "sim = { delay_cycles = 1, bandwidth_hz = 150.0 }", &[]),
        (3, "sim = { delay_cycles = 2, bandwidth_hz = 40.0 }", &[]),
        (3, "sim = { delay_cycles = 3, bandwidth_hz = 20.0 }", &[]),
        (3, "sim = { delay_cycles = 0, bandwidth_hz = 300.0 }", &[]),
        // 1 µm encoder steps on a 0.5 mm stroke.
        (
            3,
            "sim = { delay_cycles = 2, bandwidth_hz = 40.0, encoder_resolution = 0.001 }",
            &[],
        ),
        // Half feedforward: half the ramp lag, the equivalent of 40 Hz.
        (
            3,
            "sim = { delay_cycles = 1, bandwidth_hz = 20.0, velocity_feedforward = 0.5 }",
            &[],
        ),
        (
            3,
            "sim = { delay_cycles = 2, kv = 150.0, velocity_feedforward = 0.3, encoder_resolution = 0.0005 }",
            &[],
        ),
        // The documented feed axis and spindle (docs/config.md).
        (
            1,
            "sim = { delay_cycles = 1, kv = 100.0, velocity_feedforward = 0.7, max_velocity = 300.0, max_acceleration = 10000.0, encoder_resolution = 0.0001 }",
            &[],
        ),
        (
            4,
            "sim = { delay_cycles = 2, kv = 250.0, max_velocity = 40000.0, max_acceleration = 60000.0, encoder_resolution = 0.02197265625 }",
            &["--amplitude", "20"],
        ),
        (4, "sim = { delay_cycles = 2, bandwidth_hz = 40.0 }", &[]),
    ];
    let mut table = String::new();
    eprintln!("| node | sim | truth | identified |\n|---|---|---|---|");
    for (k, &(node, sim, extra)) in cases.iter().enumerate() {
        let path = config_with(node, sim, &format!("case{k}"));
        let cfg = MachineConfig::load(&path).unwrap();
        let axis = cfg.axes.iter().find(|a| a.node == Some(node)).unwrap();
        let truth = axis.sim.equivalent_model();
        let setup = format!("enable:{node}");
        let n = node.to_string();
        let mut args = vec!["--sim-setup", &setup, "--json", "identify", &n];
        args.extend_from_slice(extra);
        let (code, out, err) = drivectl(&path, &args);
        assert_eq!(code, 0, "{sim}: {out}{err}");
        let j: Value = serde_json::from_str(out.trim()).unwrap();
        assert_eq!(j["node"], node);
        let (d, f) = (
            j["delay_cycles"].as_u64().unwrap() as u32,
            j["bandwidth_hz"].as_f64().unwrap(),
        );
        table += &format!(
            "| {node} | `{sim}` | {} / {:.1} Hz | {d} / {f:.1} Hz |\n",
            truth.delay_cycles, truth.bandwidth_hz
        );
        eprintln!("{}", table.lines().last().unwrap_or(""));
        if axis.sim.velocity_feedforward == 0.0 {
            assert_eq!(d, truth.delay_cycles, "{sim}: {j}");
            assert!(
                (f / truth.bandwidth_hz - 1.0).abs() <= 0.2,
                "{sim}: {f} Hz vs {} Hz",
                truth.bandwidth_hz
            );
        } else {
            // Feedforward leads: the drive is not first order, and the nearest first-order
            // model may take a cycle less dead time and a lower bandwidth. What matching
            // needs, the lag at constant velocity (dead time + time constant), is the drive's.
            let lag = |d: u32, f: f64| d as f64 * 1e-3 + 1.0 / (2.0 * std::f64::consts::PI * f);
            let (found, true_lag) = (lag(d, f), lag(truth.delay_cycles, truth.bandwidth_hz));
            assert!(d.abs_diff(truth.delay_cycles) <= 1, "{sim}: {j}");
            assert!(
                (found / true_lag - 1.0).abs() <= 0.2,
                "{sim}: lag {found} s vs {true_lag} s"
            );
        }
    }
}

#[test]
fn identify_refuses_and_moves_nothing() {
    let path = repo().join("config/machine.toml");
    // Not enabled: exit 1 (drive state), named.
    let (code, _, err) = drivectl(&path, &["identify", "3"]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("not OPERATION ENABLED") && err.contains("nothing moved"),
        "{err}"
    );
    // In FAULT: exit 1 with the error code.
    let (code, _, err) = drivectl(&path, &["--sim-setup", "fault:3:0x2310", "identify", "3"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("FAULT") && err.contains("0x2310"), "{err}");
    // Beyond the soft limits (Z max is +50 from 0): exit 64 (usage), before the bus is asked anything.
    let (code, _, err) = drivectl(
        &path,
        &[
            "--sim-setup",
            "enable:3",
            "identify",
            "3",
            "--amplitude",
            "60",
        ],
    );
    assert_eq!(code, 64, "{err}");
    assert!(err.contains("soft limits"), "{err}");
    for bad in [
        ["--amplitude", "0"],
        ["--duration", "11"],
        ["--amplitude", "nan"],
    ] {
        let (code, _, err) = drivectl(
            &path,
            &["--sim-setup", "enable:3", "identify", "3", bad[0], bad[1]],
        );
        assert_eq!(code, 64, "{bad:?}: {err}");
    }
    // Not an axis of the config.
    let (code, _, err) = drivectl(&path, &["identify", "9"]);
    assert_eq!(code, 64, "{err}");
    // A human run prints the line to paste.
    let (code, out, err) = drivectl(&path, &["--sim-setup", "enable:3", "identify", "3"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("dynamics = { delay_cycles = 1, bandwidth_hz = 150."),
        "{out}"
    );
}
