//! drivectl's commissioning commands against the embedded simulator: objects by name
//! (standard, from `--eds`, from the config's DCF; unknown and ambiguous names), and `store`
//! with its confirmation.

use std::path::PathBuf;
use std::process::Command;

struct Out {
    code: i32,
    all: String,
    stdout: String,
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn sim(args: &[&str]) -> Out {
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .current_dir(repo())
        .arg("--iface")
        .arg("sim")
        .args(args)
        .output()
        .expect("drivectl runs");
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    Out {
        code: o.status.code().unwrap_or(-1),
        all: format!("{stdout}{}", String::from_utf8_lossy(&o.stderr)),
        stdout,
    }
}

fn check(o: &Out, code: i32, needle: &str) {
    assert_eq!(o.code, code, "exit code; output:\n{}", o.all);
    assert!(
        o.all.contains(needle),
        "`{needle}` missing from:\n{}",
        o.all
    );
}

#[test]
fn sdo_read_and_write_by_standard_name() {
    check(
        &sim(&["sdo", "read", "3", "controlword"]),
        0,
        "0x6040:00 controlword = 0",
    );
    check(
        &sim(&["sdo", "read", "3", "Statusword"]),
        0,
        "0x6041:00 statusword",
    );
    check(
        &sim(&["sdo", "read", "3", "Store parameters.Save all parameters"]),
        0,
        "0x1010:01 save all parameters = 1",
    );
    check(
        &sim(&["sdo", "write", "3", "Producer heartbeat time", "100"]),
        0,
        "0x1017:00 producer heartbeat time ← 100 [UNSIGNED16]",
    );
    // The hex form still works, and so does a type given with a name.
    check(&sim(&["sdo", "read", "3", "0x6040:0"]), 0, "controlword");
    check(
        &sim(&["sdo", "write", "3", "modes of operation", "i8", "8"]),
        0,
        "← 8 [INTEGER8]",
    );
    let o = sim(&["--json", "sdo", "read", "3", "CONTROLWORD"]);
    let v: serde_json::Value = serde_json::from_str(o.stdout.trim()).unwrap();
    assert_eq!(
        (v["index"].as_u64(), v["sub"].as_u64()),
        (Some(0x6040), Some(0))
    );
}

#[test]
fn unknown_and_ambiguous_names_are_usage_errors_listing_candidates() {
    check(
        &sim(&["sdo", "read", "3", "controlwrd"]),
        64,
        "nearest: \"controlword\" (0x6040:00)",
    );
    check(
        &sim(&["sdo", "read", "3", "number of mapped objects"]),
        64,
        "several objects have this name",
    );
    check(&sim(&["sdo", "read", "3", "6041:1ff"]), 64, "sub-index");
}

#[test]
fn vendor_names_come_from_the_eds_or_the_configs_dcf() {
    let dir = std::env::temp_dir().join(format!("drivectl-names-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let eds = dir.join("drive.eds");
    std::fs::write(
        &eds,
        "[6065]\nParameterName=Following Error Window\nDataType=0x0007\nAccessType=rw\n",
    )
    .unwrap();
    let e = eds.to_str().unwrap();
    check(
        &sim(&["--eds", e, "sdo", "read", "3", "following error window"]),
        0,
        "0x6065:00 Following Error Window =",
    );
    // The config's `dcf` for the node gives the names without --eds.
    let shipped = std::fs::read_to_string(repo().join("config/machine.toml")).unwrap();
    let cfg = dir.join("machine.toml");
    std::fs::write(
        &cfg,
        shipped
            .replace("\"../examples", &format!("\"{}/examples", repo().display()))
            .replace("\"../var", &format!("\"{}/var", repo().display()))
            .replacen("node = 1\n", "node = 1\ndcf = \"drive.eds\"\n", 1),
    )
    .unwrap();
    let c = cfg.to_str().unwrap();
    check(
        &sim(&[
            "--config",
            c,
            "sdo",
            "write",
            "1",
            "FOLLOWING ERROR WINDOW",
            "777",
        ]),
        0,
        "← 777 [UNSIGNED32]",
    );
}

#[test]
fn store_needs_a_confirmation_and_writes_the_signature() {
    // Not a terminal (the test's stdin): refused without --yes, nothing written.
    check(&sim(&["store", "3"]), 64, "without --yes");
    check(&sim(&["store", "3", "--yes"]), 0, "parameters stored");
    check(
        &sim(&["store", "3", "--restore", "--yes"]),
        0,
        "factory defaults restored",
    );
    let o = sim(&["--json", "store", "3", "--yes"]);
    assert!(o.stdout.contains("\"done\":true"), "{}", o.all);
    // A node that is not there: the SDO times out.
    let o = sim(&["--timeout-ms", "20", "store", "9", "--yes"]);
    assert_ne!(o.code, 0, "{}", o.all);
}

/// Regression (eds_compact_sub_objects_were_skipped): drivectl's own EDS reader skipped
/// `CompactSubObj` arrays, so their sub-objects had no names or types; it now uses the
/// master's reader, which expands them.
#[test]
fn eds_compact_sub_objects_were_skipped() {
    let dir = std::env::temp_dir().join(format!("drivectl-compact-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let eds = dir.join("compact.eds");
    std::fs::write(
        &eds,
        "[1A00]\nParameterName=TPDO1 mapping\nObjectType=0x8\nDataType=0x0007\n\
         AccessType=rw\nCompactSubObj=2\n[1A00Value]\nNrOfEntries=2\n1=0x60410010\n\
         2=0x60640020\n[1A00Name]\nNrOfEntries=1\n2=Position entry\n",
    )
    .unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .args(["--json", "eds", eds.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let objects = v["objects"].as_array().unwrap();
    let sub = |s: u64| {
        objects
            .iter()
            .find(|e| e["index"] == 0x1A00 && e["sub"] == s)
            .unwrap_or_else(|| panic!("no 0x1a00:{s} in {objects:?}"))
    };
    assert_eq!(sub(0)["default"], "2");
    assert_eq!(sub(1)["value"], "0x60410010");
    assert!(sub(2)["name"].as_str().unwrap().contains("Position entry"));
}
