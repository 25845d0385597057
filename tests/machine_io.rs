//! Machine outputs and the manual tool change on the embedded simulated machine (issue 17):
//! M3/M8/M9/M5 switch the configured 0x60FE bits and the report lists each change with its
//! time and line; M6 with `tool_change = "manual"` holds with "insert tool T…", releases the
//! tool clamp, and clamps when the operator continues (before the next block moves).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

const SHIPPED: &str = include_str!("../config/machine.toml");

fn temp(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cnc402-io-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The shipped config with `machine` as its `[machine]` section, written into `dir`.
fn config(dir: &Path, machine: &str) -> PathBuf {
    let root = env!("CARGO_MANIFEST_DIR");
    let text = SHIPPED
        .replace("\"../examples", &format!("\"{root}/examples"))
        .replace(
            "\"../var/macro_variables.txt\"",
            &format!("{:?}", dir.join("vars.txt")),
        )
        .replacen("[bus]", &format!("[machine]\n{machine}\n\n[bus]"), 1);
    let p = dir.join("machine.toml");
    std::fs::write(&p, text).unwrap();
    p
}

const OUTPUTS: &str = "outputs = { coolant_flood = { axis = \"Z\", bit = 16 }, \
    coolant_mist = { axis = \"Z\", bit = 17 }, spindle_enable = { axis = \"Z\", bit = 18 }, \
    tool_clamp = { axis = \"Z\", bit = 19 } }";

/// `cnc402 run program --config cfg --report r.json EXTRA`: exit code, report, stderr.
fn run(dir: &Path, cfg: &Path, program: &str, extra: &[&str]) -> (Option<i32>, Value, String) {
    let p = dir.join("p.nc");
    std::fs::write(&p, program).unwrap();
    let report = dir.join("report.json");
    let o: Output = Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .arg("run")
        .arg(&p)
        .arg("--config")
        .arg(cfg)
        .arg("--report")
        .arg(&report)
        .args(extra)
        .env_remove("RUST_LOG")
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap();
    let v = std::fs::read_to_string(&report)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or(Value::Null);
    (
        o.status.code(),
        v,
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// `"LINE OUTPUT on|off"` of every change the report lists, with the times rising.
fn changes(v: &Value) -> Vec<String> {
    let list = v["outputs"].as_array().cloned().unwrap_or_default();
    let times: Vec<f64> = list.iter().map(|c| c["t_s"].as_f64().unwrap()).collect();
    assert!(times.windows(2).all(|w| w[0] <= w[1]), "{times:?}");
    list.iter()
        .map(|c| {
            let on = if c["on"].as_bool().unwrap() {
                "on"
            } else {
                "off"
            };
            format!("{} {} {on}", c["line"], c["output"].as_str().unwrap())
        })
        .collect()
}

#[test]
fn spindle_and_coolant_codes_switch_the_outputs_and_the_report_lists_each_change() {
    let dir = temp("outputs");
    let cfg = config(&dir, OUTPUTS);
    let program = "M3 S600\nM8\nG1 X5 F600\nM7\nM9\nM5\nG1 X0\nM30\n";
    let (code, v, err) = run(&dir, &cfg, program, &[]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(
        changes(&v),
        [
            "1 spindle_enable on",
            "2 coolant_flood on",
            "4 coolant_mist on",
            "5 coolant_flood off",
            "5 coolant_mist off",
            // Off once the M5 ramp has ended: when the next move starts.
            "7 spindle_enable off",
        ]
    );
    let t = |i: usize| v["outputs"][i]["t_s"].as_f64().unwrap();
    assert!(t(2) > t(1), "M7 after the feed move");
    // Without `[machine] outputs` the same program switches nothing and lists nothing.
    let cfg = config(&dir, "");
    let (code, v, err) = run(&dir, &cfg, program, &[]);
    assert_eq!(code, Some(0), "{err}");
    assert!(v.get("outputs").is_none(), "{v}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_manual_tool_change_holds_unclamped_until_continue_then_clamps() {
    let dir = temp("manual-m6");
    let cfg = config(&dir, &format!("tool_change = \"manual\"\n{OUTPUTS}"));
    let cmds = dir.join("commands.txt");
    std::fs::write(&cmds, "continue\n").unwrap();
    let program = "G1 X2 F600\nT7 M6\nG1 X0\nM30\n";
    let (code, v, err) = run(&dir, &cfg, program, &["--commands", cmds.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("insert tool T7 ("), "{err}");
    assert!(err.contains("p.nc:2), then continue"), "{err}");
    // Clamped when the operator continues, at the M6's line, before the next block starts.
    // Regression (manual_m6_clamp_line_raced_the_feeder): it was named line 3 or line 2
    // depending on whether the next block was queued when the answer came.
    assert_eq!(changes(&v), ["2 tool_clamp off", "2 tool_clamp on"]);
    let stops = v["stops"].as_array().unwrap();
    assert_eq!(stops.len(), 1, "{v}");
    assert_eq!(stops[0]["kind"], "M6");
    assert_eq!(stops[0]["action"], "wait");
    assert!((v["axes"]["X"]["final_position"].as_f64().unwrap()).abs() < 1e-6);

    // End of input at the hold ends the program there: X stays at the tool change point.
    std::fs::write(&cmds, "").unwrap();
    let (code, v, err) = run(&dir, &cfg, program, &["--commands", cmds.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        (v["axes"]["X"]["final_position"].as_f64().unwrap() - 2.0).abs() < 1e-6,
        "{v} {err}"
    );

    // Without `tool_change`, M6 only logs: no hold, no clamp change.
    let cfg = config(&dir, OUTPUTS);
    let (code, v, err) = run(&dir, &cfg, program, &[]);
    assert_eq!(code, Some(0), "{err}");
    assert!(v["stops"].as_array().unwrap().is_empty(), "{v}");
    assert!(changes(&v).is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn output_config_errors_name_the_key() {
    let dir = temp("bad");
    for (machine, key, words) in [
        (
            "outputs = { coolant_flood = { axis = \"Z\", bit = 3 } }",
            "machine.outputs.coolant_flood.bit",
            "",
        ),
        (
            "outputs = { coolant_flood = { axis = \"Q\", bit = 16 } }",
            "machine.outputs.coolant_flood.axis",
            "is not an axis with a drive",
        ),
        (
            "outputs = { coolant_flood = { axis = \"Z\", bit = 16 }, \
             coolant_mist = { axis = \"Z\", bit = 16 } }",
            "machine.outputs.coolant_mist",
            "the same drive bit as `coolant_flood`",
        ),
        (
            "tool_change = \"robot\"",
            "machine.tool_change",
            "expected \"manual\" or \"none\"",
        ),
        (
            "estop_input = { axis = \"Z\", bit = 16, category = 3 }",
            "machine.estop_input.category",
            "",
        ),
    ] {
        let cfg = config(&dir, machine);
        let (code, _, err) = run(&dir, &cfg, "M30\n", &[]);
        assert_eq!(code, Some(3), "{machine}: {err}");
        let flat: String = err.split_whitespace().collect::<Vec<_>>().join(" ");
        assert!(flat.contains(key), "{machine}: {err}");
        assert!(flat.contains(words), "{machine}: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
