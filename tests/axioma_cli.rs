//! The AxiOMA (source 000) tapping programs through the `cnc402` binary: the run report's
//! coupling and path length, the source's main program on its own machine config, and
//! `terminate()` in both `run` and `segments`. (Moved here from interp's tests, which started
//! the binary through a nested `cargo run` that rebuilt it with other features.)

use std::process::Command;

fn cnc402() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_cnc402"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("RUST_LOG", "warn");
    c
}

/// Z's counts per mm on the shipped machine.
fn shipped_z_counts_per_mm() -> f64 {
    let cfg = cnc402_config::MachineConfig::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/config/machine.toml"
    ))
    .unwrap();
    let z = cfg.axes.iter().find(|a| a.name == 'Z').expect("a Z axis");
    z.counts_per_unit
}

#[test]
fn run_report_shows_the_coupling_within_one_count_at_every_tick() {
    let report = std::env::temp_dir().join(format!("cnc402-hll-tap-{}.json", std::process::id()));
    let out = cnc402()
        .args(["run", "examples/axioma/multipass_tap.nc", "--report"])
        .arg(&report)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let _ = std::fs::remove_file(&report);
    assert_eq!(r["ok"], true);
    // One count of Z (10000 counts/mm) is 0.1 µm.
    let count_um = 1000.0 / shipped_z_counts_per_mm();
    let taps = r["tapping"].as_array().unwrap();
    assert!(!taps.is_empty());
    for t in taps {
        assert_eq!(t["pitch_mm"], 1.5);
        let e = t["max_coupling_error_um_cmd"].as_f64().unwrap();
        assert!(
            e <= count_um,
            "coupling error {e} µm > one count {count_um} µm"
        );
    }
    assert!((r["path_length_mm"].as_f64().unwrap() - 192.0).abs() < 1e-6);

    // The source's main program as printed, on the machine with the longer Z travel: its
    // @ITPPATH check passes against the path the simulated drives produced.
    let out = cnc402()
        .args([
            "--config",
            "examples/axioma/machine.toml",
            "run",
            "examples/axioma/source_000_main.nc",
            "--report",
        ])
        .arg(&report)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let _ = std::fs::remove_file(&report);
    let bound = r["coupling_bound_um"].as_f64().unwrap();
    for t in r["tapping"].as_array().unwrap() {
        assert!(t["max_coupling_error_um_cmd"].as_f64().unwrap() <= bound);
    }
    assert!((r["path_length_mm"].as_f64().unwrap() - 640.0).abs() < 1e-6);

    // terminate(): both commands print the code and the text and exit non-zero.
    let bad = std::env::temp_dir().join(format!("cnc402-hll-bad-{}.nc", std::process::id()));
    std::fs::write(
        &bad,
        "#use \"metch_cycles.c\"\nTapping(\"Z\", \"C\", 40, 0, 5, 30, 12, 2, 8, 0, 300, 600, 2, 40);\nM02\n",
    )
    .unwrap();
    for cmd in ["run", "segments"] {
        let out = cnc402().arg(cmd).arg(&bad).output().unwrap();
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(!out.status.success(), "{cmd}: {text}");
        // The report may wrap the message: compare without spaces and frame characters.
        let squeeze = |t: &str| -> String {
            t.chars()
                .filter(|c| !c.is_whitespace() && *c != '│')
                .collect()
        };
        assert!(
            squeeze(&text).contains(&squeeze("terminate 5561: Tapping: dPitch must be > 0")),
            "{cmd}: {text}"
        );
    }
    let _ = std::fs::remove_file(&bad);
}
