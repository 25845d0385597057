//! `cnc402 home` and `[machine] require_homing` on the embedded simulated machine (issue 17):
//! the shipped axes home to their offsets, the order is the command line's, a switch that is
//! never found stops with exit 1 naming axis, node and state, a run homes first when the
//! config says so and its report says whether the machine was homed.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SHIPPED: &str = include_str!("../config/machine.toml");

fn temp(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cnc402-homing-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The shipped config with `edit` applied, written into `dir` (its relative paths made
/// absolute: they point at the repository's examples and a variables file in `dir`).
fn config(dir: &Path, edit: impl FnOnce(String) -> String) -> PathBuf {
    let root = env!("CARGO_MANIFEST_DIR");
    let text = SHIPPED
        .replace("\"../examples", &format!("\"{root}/examples"))
        .replace(
            "\"../var/macro_variables.txt\"",
            &format!("{:?}", dir.join("vars.txt")),
        );
    let p = dir.join("machine.toml");
    std::fs::write(&p, edit(text)).unwrap();
    p
}

fn cnc402(cfg: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(args)
        .arg("--config")
        .arg(cfg)
        .output()
        .unwrap()
}

/// The output as one line of words (miette wraps its messages at the terminal's width and
/// draws a margin).
fn text(b: &[u8]) -> String {
    let s = String::from_utf8_lossy(b);
    if s.contains('│') || s.contains('×') {
        let words: Vec<&str> = s.split_whitespace().filter(|w| *w != "│").collect();
        words.join(" ")
    } else {
        s.into_owned()
    }
}

/// `SHIPPED`'s first `from` replaced by `to` (which must be there).
fn with(t: String, from: &str, to: &str) -> String {
    assert!(t.contains(from), "{from}");
    t.replacen(from, to, 1)
}

#[test]
fn home_homes_every_axis_with_a_homing_key_in_config_order() {
    let dir = temp("all");
    let cfg = config(&dir, |t| t);
    let o = cnc402(&cfg, &["home"]);
    let out = text(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{out}{}", text(&o.stderr));
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 3, "{out}");
    assert!(
        lines[0].starts_with("X: homed (node 1, method 19 (positive home switch))"),
        "{out}"
    );
    assert!(lines[0].ends_with("machine position 0.0000 mm"), "{out}");
    assert!(lines[1].starts_with("Y: homed (node 2, method 34"), "{out}");
    assert!(lines[2].starts_with("Z: homed (node 3, method 18"), "{out}");
    assert!(lines[2].ends_with("machine position 50.0000 mm"), "{out}");
    // The order is the command line's.
    let o = cnc402(&cfg, &["home", "z", "X"]);
    let out = text(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let first: Vec<char> = out.lines().filter_map(|l| l.chars().next()).collect();
    assert_eq!(first, vec!['Z', 'X']);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn home_refuses_axes_it_cannot_home_as_usage() {
    let dir = temp("usage");
    let cfg = config(&dir, |t| t);
    for (arg, msg) in [
        ("C", "axis C has no `homing` key"),
        ("Q", "no axis Q"),
        ("XY", "not an axis letter"),
    ] {
        let o = cnc402(&cfg, &["home", arg]);
        assert_eq!(o.status.code(), Some(64), "{arg}");
        assert!(text(&o.stderr).contains(msg), "{arg}: {}", text(&o.stderr));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_home_switch_that_is_never_found_stops_with_axis_node_and_state() {
    let dir = temp("nohome");
    // X's simulated machine has no home switch: the search runs into the limit switch.
    let cfg = config(&dir, |t| {
        with(
            t,
            "home_switch = 0.0, limit_switches = [-305.0, 305.0]",
            "limit_switches = [-305.0, 305.0]",
        )
    });
    let o = cnc402(&cfg, &["home", "X"]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("homing axis X (node 1, method 19 (positive home switch)) failed"),
        "{err}"
    );
    assert!(err.contains("homing error"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_unsupported_method_is_a_config_error_naming_the_supported_ones() {
    let dir = temp("method");
    let cfg = config(&dir, |t| with(t, "method = 19", "method = 7"));
    let o = cnc402(&cfg, &["home"]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(err.contains("axis[0].homing.method"), "{err}");
    assert!(
        err.contains("supported: 1, 2, 17, 18, 19, 20, 21, 22, 33, 34, 35, 37"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// G53 moves in machine coordinates: with homing they are the switches', whatever the
/// power-on position; the report says the axes were homed.
#[test]
fn require_homing_homes_before_the_program_and_the_report_says_so() {
    let dir = temp("require");
    let program = dir.join("p.nc");
    std::fs::write(&program, "G53 G0 X10 Z20\nM30\n").unwrap();
    let cfg = config(&dir, |t| {
        let t = with(t, "[bus]", "[machine]\nrequire_homing = true\n\n[bus]");
        // X powers on 37 mm above its home switch, and its drive counts the other way.
        let t = with(
            t,
            "home_switch = 0.0,",
            "home_switch = 0.0, power_on_position = 37.0,",
        );
        with(
            t,
            "homing = { method = 19",
            "polarity = \"inverted\"\nhoming = { method = 21",
        )
    });
    let report = dir.join("r.json");
    let o = cnc402(
        &cfg,
        &[
            "run",
            program.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ],
    );
    let out = text(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{out}{}", text(&o.stderr));
    assert!(out.contains("machine reference: homed X Y Z"), "{out}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    for (axis, at) in [("X", 10.0), ("Z", 20.0)] {
        assert_eq!(r["axes"][axis]["homed"], true, "{r}");
        let p = r["axes"][axis]["final_position"].as_f64().unwrap();
        assert!((p - at).abs() < 1e-6, "{axis}: {p}");
    }
    assert!(r["axes"]["C"].get("homed").is_none(), "{r}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_run_without_homing_says_the_axes_are_not_homed() {
    let dir = temp("nothomed");
    let program = dir.join("p.nc");
    std::fs::write(&program, "G0 X1\nM30\n").unwrap();
    let cfg = config(&dir, |t| t);
    let report = dir.join("r.json");
    let o = cnc402(
        &cfg,
        &[
            "run",
            program.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ],
    );
    let out = text(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(out.contains("machine reference: NOT homed X Y Z"), "{out}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(r["axes"]["X"]["homed"], false, "{r}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A run that must home and cannot: exit 1 before any motion, the homing error in the
/// message.
#[test]
fn a_run_whose_homing_fails_does_not_start() {
    let dir = temp("runfail");
    let program = dir.join("p.nc");
    std::fs::write(&program, "G0 X1\nM30\n").unwrap();
    let cfg = config(&dir, |t| {
        let t = with(t, "[bus]", "[machine]\nrequire_homing = true\n\n[bus]");
        with(t, "index_pulse_counts = 20000, ", "")
    });
    let o = cnc402(&cfg, &["run", program.to_str().unwrap()]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("homing axis Y (node 2, method 34"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Machine inputs (0x60FD): a run does not start while the E-stop chain is open, and a
/// limit switch stops it naming node, axis and line.
#[test]
fn an_open_estop_refuses_the_run_and_a_limit_switch_stops_it() {
    let dir = temp("inputs");
    let program = dir.join("p.nc");
    std::fs::write(&program, "G1 X10 F1000\nG0 X0\nM30\n").unwrap();
    let estop = |closed: bool| {
        move |t: String| {
            let t = with(
                t,
                "[bus]",
                "[machine]\nestop_input = { axis = \"Z\", bit = 16 }\n\n[bus]",
            );
            // The inputs PDO needs room: 4 standard axes at 1 ms leave none.
            let t = with(t, "pdo_layout = \"standard\"", "pdo_layout = \"compact\"");
            if closed {
                with(
                    t,
                    "limit_switches = [-255.0, 52.0] }",
                    "limit_switches = [-255.0, 52.0], inputs = 0x10000 }",
                )
            } else {
                t
            }
        }
    };
    let cfg = config(&dir, estop(false));
    let o = cnc402(&cfg, &["run", program.to_str().unwrap()]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("E-stop open: axis Z (node 3) 0x60FD = 0x00000000, bit 16 is 0"),
        "{err}"
    );
    let cfg = config(&dir, estop(true));
    let o = cnc402(&cfg, &["run", program.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));

    let cfg = config(&dir, |t| {
        let t = with(t, "pdo_layout = \"standard\"", "pdo_layout = \"compact\"");
        with(
            t,
            "home_switch = 0.0, limit_switches = [-305.0, 305.0] }",
            "limit_switches = [-5.0, 5.0] }\nlimit_switch_inputs = true",
        )
    });
    let o = cnc402(&cfg, &["run", program.to_str().unwrap()]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("limit switch on node 1 (axis X)"), "{err}");
    assert!(err.contains("p.nc:1: G1 X10 F1000"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
