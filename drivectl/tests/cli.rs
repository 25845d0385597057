//! drivectl end to end against the embedded simulator (`--iface sim`): every command, its
//! failure paths (absent node, SDO aborts, wrong type, a drive in FAULT, a refused mode, a
//! missing interface) and the exit codes; `--json` output parses.

use std::path::PathBuf;
use std::process::Command;

use serde_json::Value;

struct Out {
    code: i32,
    stdout: String,
    stderr: String,
}

impl Out {
    fn all(&self) -> String {
        format!("{}{}", self.stdout, self.stderr)
    }
    fn json(&self) -> Value {
        serde_json::from_str(self.stdout.trim())
            .unwrap_or_else(|e| panic!("not one JSON document ({e}):\n{}", self.stdout))
    }
    fn json_lines(&self) -> Vec<Value> {
        self.stdout
            .lines()
            .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("bad JSON line {l}: {e}")))
            .collect()
    }
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn dc(args: &[&str]) -> Out {
    let o = Command::new(env!("CARGO_BIN_EXE_drivectl"))
        .current_dir(repo())
        .args(args)
        .output()
        .expect("drivectl runs");
    Out {
        code: o.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&o.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
    }
}

fn sim(args: &[&str]) -> Out {
    let mut v = vec!["--iface", "sim"];
    v.extend_from_slice(args);
    dc(&v)
}

fn check(o: &Out, code: i32, needle: &str) {
    assert_eq!(o.code, code, "exit code; output:\n{}", o.all());
    assert!(
        o.all().contains(needle),
        "`{needle}` missing from:\n{}",
        o.all()
    );
}

#[test]
fn scan_finds_every_configured_drive_with_identity() {
    let o = sim(&["scan"]);
    check(&o, 0, "4 node(s) answered SDO");
    assert!(o.stdout.contains("node 3 (Z)"));
    assert!(o.stdout.contains("CiA 402 drive"));
    assert!(o.stdout.contains("\"cnc402 simdrive C\""));
    let j = sim(&["--json", "scan"]).json();
    let nodes = j["nodes"].as_array().unwrap();
    assert_eq!(
        nodes
            .iter()
            .map(|n| n["node"].as_u64().unwrap())
            .collect::<Vec<_>>(),
        vec![1, 2, 3, 4]
    );
    assert_eq!(nodes[1]["vendor"], 0x00C4_0402);
    assert_eq!(nodes[1]["serial"], 2);
    assert_eq!(nodes[1]["cia402"], true);
    assert_eq!(nodes[1]["nmt"], "PRE-OPERATIONAL"); // from its boot-up
}

#[test]
fn scan_of_absent_nodes_times_out_naming_them() {
    let o = sim(&["scan", "--nodes", "9,10"]);
    check(&o, 7, "no node answered on sim (probed 2 node id(s)");
}

#[test]
fn info_decodes_identity_modes_state_and_pdos() {
    let o = sim(&["info", "3"]);
    check(
        &o,
        0,
        "supported modes   0x000000a0: homing (6), cyclic synchronous position (8)",
    );
    assert!(o.stdout.contains("SWITCH ON DISABLED"), "{}", o.stdout);
    assert!(
        o.stdout.contains("TPDO1: COB-ID 0x183 valid"),
        "{}",
        o.stdout
    );
    let j = sim(&["--json", "info", "3"]).json();
    assert_eq!(j["device_type"], 0x0002_0192);
    assert_eq!(j["supported_modes"]["raw"], 0xA0); // CSP and homing (issue 17)
    assert_eq!(j["statusword"]["state"], "SWITCH ON DISABLED");
    assert_eq!(j["pdos"][4]["mapping"][0]["index"], 0x6041);
    assert_eq!(j["nmt"], "PRE-OPERATIONAL (boot-up seen)");
    // A faulted drive: error register, error code and history decoded.
    let j = sim(&["--json", "--sim-setup", "fault:3:0x7300", "info", "3"]).json();
    assert_eq!(j["statusword"]["state"], "FAULT");
    assert_eq!(j["error_code"], 0x7300);
    assert_eq!(j["error_history"][0]["code"], 0x7300);
}

#[test]
fn info_of_an_absent_node_times_out_naming_it() {
    let o = sim(&["info", "9"]);
    check(
        &o,
        7,
        "node 9: SDO read of 0x1000:00: no response within 100 ms",
    );
    let o = sim(&["--json", "--timeout-ms", "30", "info", "9"]);
    assert_eq!(o.code, 7);
    let j = o.json();
    assert_eq!(j["error"]["kind"], "timeout");
    assert!(j["error"]["message"].as_str().unwrap().contains("30 ms"));
}

#[test]
fn sdo_read_expedited_segmented_and_typed() {
    let o = sim(&["sdo", "read", "3", "0x6041"]);
    check(&o, 0, "0x6041:00 statusword = 576 (0x0240) [UNSIGNED16]");
    // 0x1008 is longer than 4 bytes: a segmented upload.
    check(
        &sim(&["sdo", "read", "3", "1008"]),
        0,
        "\"cnc402 simdrive Z\"",
    );
    let j = sim(&["--json", "sdo", "read", "2", "1018:4", "u32"]).json();
    assert_eq!(j["value"], 2);
    assert_eq!(j["type"], "UNSIGNED32");
    let j = sim(&["--json", "sdo", "read", "2", "0x6064", "i32"]).json();
    assert_eq!(j["value"], 0);
}

#[test]
fn sdo_errors_name_abort_codes_and_types() {
    let o = sim(&["sdo", "read", "3", "0x2000"]);
    check(
        &o,
        6,
        "aborted by the drive with 0x06020000 (object does not exist",
    );
    let o = sim(&["sdo", "write", "3", "0x6041", "u16", "1"]);
    check(&o, 6, "0x06010002 (attempt to write a read-only object)");
    let o = sim(&["sdo", "read", "3", "0x6041", "u32"]);
    check(&o, 8, "wrong data type: the drive returned 2 byte(s)");
    let o = sim(&["sdo", "write", "3", "0x6065", "u8", "300"]);
    check(&o, 64, "outside 0..=255");
    let o = sim(&["sdo", "read", "3", "0x6041", "float128"]);
    check(&o, 64, "unknown data type `float128`");
    // A segmented download (string > 4 bytes) to a read-only object: the abort comes back.
    let o = sim(&["sdo", "write", "3", "0x1008", "string", "new name"]);
    check(&o, 6, "SDO write of 0x1008:00");
    let o = sim(&["--json", "sdo", "read", "3", "0x2000"]);
    assert_eq!(o.json()["error"]["kind"], "sdo_abort");
}

#[test]
fn sdo_write_then_the_value_is_there() {
    // One invocation per command (fresh simulator each time): write and check via JSON.
    let o = sim(&["--json", "sdo", "write", "3", "0x6065", "u32", "0x1388"]);
    assert_eq!(o.code, 0, "{}", o.all());
    let j = o.json();
    assert_eq!(j["written"], "88130000");
    assert_eq!(j["segmented"], false);
    // Writing the mode and reading its display in one go is what `mode` does.
    check(&sim(&["mode", "3", "csp"]), 0, "confirmed by 0x6061");
}

#[test]
fn eds_names_and_types_are_used() {
    let eds = repo().join("drivectl/tests/data/vendor.eds");
    let e = eds.to_str().unwrap();
    let o = sim(&["--eds", e, "sdo", "read", "3", "0x6041"]);
    check(&o, 0, "Status word (ACME)");
    // The EDS says 0x2100 is an INTEGER16 named "Drive temperature"; the sim lacks it.
    let o = sim(&["--eds", e, "sdo", "read", "3", "0x2100"]);
    check(&o, 6, "0x06020000");
    let o = dc(&["eds", e]);
    check(&o, 0, "ACME Servo 9");
    assert!(o.stdout.contains("Drive temperature"));
    assert!(o.stdout.contains("INTEGER16"));
    let j = dc(&["--json", "eds", e]).json();
    assert!(j["objects"].as_array().unwrap().len() >= 5);
    let o = dc(&["eds", "drivectl/tests/data/broken.eds"]);
    check(&o, 3, "broken.eds:3: expected KEY=VALUE");
}

#[test]
fn nmt_reset_waits_for_the_boot_up() {
    let o = sim(&["nmt", "reset-comm", "2"]);
    check(&o, 0, "node 2 (Y): BOOT-UP");
    let j = sim(&["--json", "nmt", "reset", "all"]).json();
    assert_eq!(j["seen"].as_array().unwrap().len(), 4);
    let o = sim(&["nmt", "reset", "9"]);
    check(&o, 7, "node 9: no boot-up within");
    check(
        &sim(&["nmt", "start", "3"]),
        0,
        "NMT start sent to node 3 (Z)",
    );
    check(
        &sim(&["nmt", "stop", "all"]),
        0,
        "NMT stop sent to all nodes",
    );
}

#[test]
fn state_machine_commands_print_each_transition() {
    let o = sim(&["enable", "2"]);
    check(&o, 0, "reached 0x0237 (OPERATION ENABLED)");
    for step in ["(shutdown)", "(switch on)", "(enable operation)"] {
        assert!(o.stdout.contains(step), "{step} missing:\n{}", o.stdout);
    }
    let j = sim(&["--json", "enable", "2"]).json();
    assert_eq!(j["reached"], true);
    assert_eq!(j["steps"].as_array().unwrap().len(), 3);
    let j = sim(&["--json", "state", "2"]).json();
    assert_eq!(j["state"], "SWITCH ON DISABLED");
    let o = sim(&["--sim-setup", "enable:2", "disable", "2"]);
    check(&o, 0, "reached 0x0240 (SWITCH ON DISABLED)");
    assert!(
        o.stdout
            .contains("0x0237 (OPERATION ENABLED) → controlword 0x0000 (disable voltage)")
    );
    let o = sim(&["--sim-setup", "enable:2", "quick-stop", "2"]);
    check(&o, 0, "controlword 0x0002 (quick stop)");
}

#[test]
fn a_drive_in_fault() {
    let o = sim(&["--sim-setup", "fault:2:0x2310", "state", "2"]);
    check(&o, 0, "FAULT: error code 0x603F = 0x2310 (current)");
    let o = sim(&["--sim-setup", "fault:2:0x2310", "enable", "2"]);
    check(&o, 1, "drive in 0x0208 (FAULT) (error code 0x603F = 0x2310");
    let o = sim(&["--sim-setup", "fault:2:0x2310", "fault-reset", "2"]);
    check(&o, 0, "fault reset → 0x0240 (SWITCH ON DISABLED)");
    let o = sim(&["--sim-setup", "fault:2", "enable", "2", "--fault-reset"]);
    check(&o, 0, "controlword 0x0080 (fault reset)");
    assert!(o.stdout.contains("reached 0x0237"));
    // A cause that persists: the reset does not clear it, and the message says so.
    let o = sim(&[
        "--sim-setup",
        "fault-persistent:2:0x4310",
        "fault-reset",
        "2",
        "--within-ms",
        "100",
    ]);
    check(
        &o,
        1,
        "stuck in FAULT: fault reset edge sent, the fault persists",
    );
    assert!(o.stderr.contains("0x4310 (temperature)"), "{}", o.stderr);
    let o = sim(&[
        "--sim-setup",
        "fault-persistent:2",
        "enable",
        "2",
        "--fault-reset",
        "--within-ms",
        "100",
    ]);
    check(&o, 1, "stuck in FAULT");
    assert!(o.stderr.contains("fault persists"), "{}", o.stderr);
}

#[test]
fn a_drive_that_stops_answering_sdo_times_out_naming_it() {
    let o = sim(&["--sim-setup", "sdo:2", "enable", "2"]);
    check(&o, 7, "node 2: SDO read of 0x6041:00: no response");
}

#[test]
fn a_mode_the_drive_refuses() {
    let o = sim(&["mode", "2", "pp"]);
    check(
        &o,
        1,
        "does not support profile position (1): 0x6502 = 0x000000a0",
    );
    // Written anyway: the drive itself refuses with an abort. (The simulated drive supports
    // homing since issue 17, so the refused mode is profile velocity.)
    let o = sim(&["mode", "2", "pv", "--force"]);
    check(&o, 6, "refused profile velocity (3)");
    assert!(o.stderr.contains("0x06090030"), "{}", o.stderr);
    let j = sim(&["--json", "mode", "2", "csp"]).json();
    assert_eq!(j["mode"], 8);
    assert_eq!(j["confirmed"], true);
}

#[test]
fn move_and_jog_follow_a_jerk_limited_profile() {
    let j = sim(&["--json", "move", "1", "10"]).json();
    assert_eq!(j["error"], Value::Null);
    assert!(
        (j["command_end"].as_f64().unwrap() - 10.0).abs() < 1e-9,
        "{j}"
    );
    assert!(
        (j["actual_end"].as_f64().unwrap() - 10.0).abs() < 1e-3,
        "{j}"
    );
    // 10 mm at 2000 mm/s² and 50000 mm/s³ cannot take less than 2·sqrt(d/a) = 0.141 s.
    assert!(j["seconds"].as_f64().unwrap() > 0.14, "{j}");
    let j = sim(&["--json", "jog", "3", "--velocity", "-20", "--for", "0.2"]).json();
    let end = j["command_end"].as_f64().unwrap();
    // 0.2 s at -20 mm/s plus the ramps: about -4 mm, and negative.
    assert!(end < -3.0 && end > -6.0, "{j}");
    check(
        &sim(&["move", "1", "1000"]),
        64,
        "outside the soft limits -300..300",
    );
    check(&sim(&["jog", "1", "--velocity", "900"]), 64, "outside ±250");
    check(&sim(&["move", "9", "1"]), 64, "node 9 is not an axis");
    // A drive whose TPDOs never come cannot be enabled through the cyclic master.
    let o = sim(&["--sim-setup", "tpdo:1", "move", "1", "1"]);
    assert_eq!(o.code, 1, "{}", o.all());
}

#[test]
fn jog_stops_before_the_soft_limit() {
    // Z max is +50 mm: jogging up at 200 mm/s must stop short of it.
    let j = sim(&["--json", "jog", "3", "--velocity", "200", "--for", "5"]).json();
    assert_eq!(j["soft_limit_stop"], true, "{j}");
    let end = j["command_end"].as_f64().unwrap();
    assert!(end <= 50.0 && end > 40.0, "{j}");
}

#[test]
fn monitor_logs_candump_format_and_emcy_decodes() {
    let dir = std::env::temp_dir().join(format!("drivectl-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("bus.log");
    let o = sim(&[
        "--sim-setup",
        "fault:2:0x7300",
        "monitor",
        "--duration",
        "0.05",
        "--log",
        log.to_str().unwrap(),
    ]);
    check(&o, 0, "EMCY 0x7300");
    assert!(
        o.stdout.contains("node 1 (X)       boot-up"),
        "{}",
        o.stdout
    );
    let text = std::fs::read_to_string(&log).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 5, "{text}");
    for l in &lines {
        let (ts, rest) = l.split_once(") ").unwrap();
        assert!(
            ts.starts_with('(') && ts[1..].split_once('.').unwrap().1.len() == 6,
            "{l}"
        );
        assert!(rest.starts_with("sim ") && rest.contains('#'), "{l}");
    }
    assert!(lines[4].ends_with("082#0073210000000000"), "{}", lines[4]);
    let o = sim(&[
        "--json",
        "--sim-setup",
        "fault:4:0x8611",
        "emcy",
        "--duration",
        "0.02",
    ]);
    assert_eq!(o.code, 0);
    let v = o.json_lines();
    assert_eq!(v[0]["node"], 4);
    assert_eq!(v[0]["emcy"]["code"], 0x8611);
    assert_eq!(v[0]["emcy"]["text"], "following error");
    let o = sim(&[
        "--json",
        "monitor",
        "--duration",
        "0.03",
        "--stats-every",
        "0.01",
    ]);
    let v = o.json_lines();
    assert!(v.iter().any(|l| l.get("stats").is_some()));
    assert!(v.last().unwrap().get("summary").is_some());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_missing_interface_is_a_transport_error() {
    let o = dc(&["--iface", "nosuchcan0", "scan"]);
    assert_eq!(o.code, 4, "{}", o.all());
    assert!(
        o.stderr.contains("no CAN support (AF_CAN, errno 97)")
            || o.stderr.contains("nosuchcan0: no such interface"),
        "{}",
        o.stderr
    );
    check(
        &dc(&["--iface", "can0", "--sim-setup", "enable:1", "scan"]),
        64,
        "--sim-setup only applies",
    );
}

#[test]
fn help_has_examples_exit_codes_and_completions() {
    let o = dc(&["--help"]);
    check(&o, 0, "Exit codes (");
    // The shared table, whole (docs/exit-codes.md).
    for (code, name, _) in cnc402_config::exit::TABLE {
        assert!(
            o.stdout.lines().any(|l| l.split_whitespace().next() == Some(&code.to_string())
                && l.contains(name)),
            "exit {code} ({name}) missing from --help:\n{}",
            o.stdout
        );
    }
    assert!(o.stdout.contains("--iface sim runs the embedded simulator"));
    for sub in [
        "scan",
        "info",
        "nmt",
        "state",
        "enable",
        "disable",
        "quick-stop",
        "fault-reset",
        "mode",
        "jog",
        "move",
        "monitor",
        "emcy",
        "eds",
        "completions",
    ] {
        let o = dc(&[sub, "--help"]);
        assert!(
            o.stdout.contains("Example"),
            "{sub} --help has no example:\n{}",
            o.stdout
        );
    }
    for sub in ["read", "write"] {
        assert!(dc(&["sdo", sub, "--help"]).stdout.contains("Example"));
    }
    let o = dc(&["completions", "bash"]);
    check(&o, 0, "_drivectl()");
    assert_eq!(dc(&["info", "300"]).code, 64);
    assert_eq!(dc(&["bogus"]).code, 64);
}

#[test]
fn ctrl_c_during_a_move_ramps_to_standstill() {
    // --interrupt-after stands in for Ctrl-C at a known time.
    let j = sim(&["--json", "move", "1", "100", "--interrupt-after", "0.1"]).json();
    assert_eq!(j["interrupted"], true, "{j}");
    assert_eq!(j["error"], Value::Null, "{j}");
    let end = j["command_end"].as_f64().unwrap();
    // Well short of 100 mm, but past where it was at 0.1 s: it braked, it did not jump.
    assert!(end > 2.0 && end < 60.0, "{j}");
    assert!(
        (j["actual_end"].as_f64().unwrap() - end).abs() < 1e-3,
        "{j}"
    );
}

#[test]
fn monitor_reads_pdo_mappings_from_the_drives() {
    let o = sim(&["monitor", "--read-mapping", "--duration", "0.01"]);
    // Each simulated drive has RPDO1 and TPDO1 valid at power-on.
    check(&o, 0, "8 PDO mapping(s) read from the drives");
    // The SDO traffic of reading them is not what monitor shows afterwards.
    let o = sim(&[
        "--sim-setup",
        "sdo:3",
        "--timeout-ms",
        "20",
        "monitor",
        "--read-mapping",
        "--duration",
        "0.01",
    ]);
    check(&o, 0, "note: PDO mapping of node 3 (Z) not read");
    assert!(o.stdout.contains("6 PDO mapping(s)"), "{}", o.stdout);
}

#[test]
fn json_errors_are_one_document_with_the_exit_code() {
    let cases: [(&[&str], i32, &str); 6] = [
        (&["--json", "--iface", "sim", "info", "9"], 7, "timeout"),
        (
            &["--json", "--iface", "sim", "sdo", "read", "3", "0x2000"],
            6,
            "sdo_abort",
        ),
        (
            &[
                "--json", "--iface", "sim", "sdo", "read", "3", "0x6041", "u32",
            ],
            8,
            "protocol",
        ),
        (
            &[
                "--json",
                "--iface",
                "sim",
                "--sim-setup",
                "fault-persistent:2",
                "enable",
                "2",
                "--fault-reset",
                "--within-ms",
                "50",
            ],
            1,
            "drive_state",
        ),
        (
            &[
                "--json",
                "--iface",
                "sim",
                "--sim-setup",
                "tpdo:1",
                "move",
                "1",
                "1",
            ],
            1,
            "drive_state",
        ),
        (&["--json", "--iface", "nosuchcan0", "scan"], 4, "bus"),
    ];
    for (args, code, kind) in cases {
        let o = dc(args);
        assert_eq!(o.code, code, "{args:?}: {}", o.all());
        let j = o.json();
        assert_eq!(j["error"]["kind"], kind, "{args:?}");
        assert_eq!(j["error"]["exit"], code, "{args:?}");
    }
}

#[test]
fn unreadable_files_are_file_errors() {
    check(
        &sim(&["--config", "no/such/machine.toml", "scan"]),
        3,
        "no/such/machine.toml",
    );
    check(
        &sim(&["--eds", "no/such.eds", "scan"]),
        3,
        "cannot read EDS no/such.eds",
    );
    check(
        &sim(&["monitor", "--duration=-1"]),
        64,
        "--duration -1 is not a time",
    );
}

#[test]
fn sub_index_10_is_hex_as_the_help_says_not_decimal() {
    // It read 0x1018:0a; `:ff` was refused as a number above 255... of decimal digits.
    check(
        &sim(&["sdo", "read", "1", "0x1018:10"]),
        6,
        "SDO read of 0x1018:10",
    );
    check(
        &sim(&["sdo", "read", "1", "0x1018:ff"]),
        6,
        "SDO read of 0x1018:ff",
    );
    check(
        &sim(&["sdo", "read", "1", "1018:04", "u32"]),
        0,
        "0x1018:04",
    );
    check(&sim(&["sdo", "read", "1", "1018:100"]), 64, "sub-index");
}

#[test]
fn timeout_ms_and_listen_ms_beyond_a_minute_are_usage_errors() {
    // 2^64 - 1 ms waited for ever (the simulator's virtual clock never got there).
    for args in [
        &[
            "--timeout-ms",
            "18446744073709551615",
            "sdo",
            "read",
            "9",
            "0x1000",
        ][..],
        &["--timeout-ms", "60001", "sdo", "read", "9", "0x1000"],
        &["--timeout-ms", "0", "sdo", "read", "9", "0x1000"],
        &[
            "scan",
            "--listen-ms",
            "18446744073709551615",
            "--nodes",
            "1",
        ],
        &["enable", "1", "--within-ms", "18446744073709551615"],
        &["enable", "1", "--step-ms", "60001"],
    ] {
        let o = sim(args);
        assert_eq!(o.code, 64, "{args:?}: {}", o.all());
        assert!(o.stderr.contains("not in"), "{args:?}: {}", o.all());
    }
    check(
        &sim(&[
            "--timeout-ms",
            "60000",
            "scan",
            "--listen-ms",
            "0",
            "--nodes",
            "1",
        ]),
        0,
        "node 1",
    );
}

#[test]
fn durations_beyond_a_week_are_usage_errors() {
    check(
        &sim(&["emcy", "--duration", "1e18"]),
        64,
        "--duration 1000000000000000000 is too long",
    );
    check(
        &sim(&["monitor", "--stats-every", "1e300", "--duration", "0.01"]),
        64,
        "--stats-every",
    );
    check(
        &sim(&["jog", "3", "--velocity", "1", "--for", "1e12"]),
        64,
        "--for 1000000000000 is not a time in seconds",
    );
}

#[test]
fn move_4_1e12_is_beyond_the_drives_32_bit_position() {
    // The spindle has no soft limits: the move was taken and ran for 2.7e7 s.
    check(
        &sim(&["move", "4", "1e12"]),
        64,
        "beyond the drive's 32-bit position",
    );
    check(&sim(&["move", "4", "-6e6"]), 64, "32-bit position");
    check(&sim(&["move", "1", "1e12"]), 64, "outside the soft limits");
}
