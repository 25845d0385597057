//! `[mcodes]`: the machine's own M codes (issue 20). Each bad entry is refused at load with its
//! key and line; a macro whose program is missing from `program_dir` too.

use std::path::Path;

use cnc402_config::{ConfigError, MAction, MachineConfig};

const SHIPPED: &str = include_str!("../machine.toml");

fn parse(text: &str) -> Result<MachineConfig, ConfigError> {
    MachineConfig::parse(text, Path::new("m.toml"))
}

fn with_entry(entry: &str) -> String {
    let anchor = "[mcodes]\n";
    assert!(SHIPPED.contains(anchor));
    SHIPPED.replacen(anchor, &format!("{anchor}{entry}\n"), 1)
}

fn refused(text: &str, key: &str, line_text: &str) -> ConfigError {
    let e = parse(text).unwrap_err();
    assert_eq!(e.key, key, "{e}");
    let line = text.lines().position(|l| l.contains(line_text)).unwrap() + 1;
    assert_eq!(e.line, line, "{e}");
    e
}

#[test]
fn shipped_table_maps_common_machine_codes() {
    let c = parse(SHIPPED).unwrap();
    assert_eq!(c.mcodes[&13], MAction::Alias { codes: vec![3, 8] });
    assert!(matches!(c.mcodes[&10], MAction::Ignore { .. }));
    assert_eq!(
        c.mcodes[&31],
        MAction::Output {
            name: "chip_conveyor".into(),
            value: true
        }
    );
}

#[test]
fn built_in_m_code_cannot_be_remapped() {
    for code in [0, 3, 6, 19, 29, 30, 98, 99] {
        let entry = format!("{code} = {{ action = \"ignore\" }}");
        let e = refused(&with_entry(&entry), &format!("mcodes.{code}"), &entry);
        assert!(e.to_string().contains("cannot be remapped"), "{e}");
    }
}

#[test]
fn bad_entries_are_refused_with_key_and_line() {
    let cases = [
        ("66 = { action = \"blink\" }", "mcodes.66.action"),
        ("66 = { action = \"dwell\" }", "mcodes.66"),
        (
            "66 = { action = \"dwell\", seconds = -1.0 }",
            "mcodes.66.seconds",
        ),
        (
            "66 = { action = \"dwell\", seconds = 1.0, output = \"x\" }",
            "mcodes.66.output",
        ),
        (
            "66 = { action = \"wait\", input = \" \", timeout_s = 1.0 }",
            "mcodes.66.input",
        ),
        (
            "66 = { action = \"alias\", codes = [98] }",
            "mcodes.66.codes",
        ),
        ("66 = { action = \"alias\", codes = [] }", "mcodes.66.codes"),
        (
            "66 = { action = \"macro\", program = 0 }",
            "mcodes.66.program",
        ),
        ("066 = { action = \"ignore\" }", "mcodes.066"),
        ("10000 = { action = \"ignore\" }", "mcodes.10000"),
    ];
    for (entry, key) in cases {
        refused(&with_entry(entry), key, entry);
    }
    let c = parse(&with_entry(
        "66 = { action = \"wait\", input = \"door_closed\", timeout_s = 10.0 }",
    ))
    .unwrap();
    assert_eq!(
        c.mcodes[&66],
        MAction::Wait {
            name: "door_closed".into(),
            value: true,
            timeout_s: 10.0
        }
    );
}

/// A macro M code whose program is not in `program_dir` is refused at load (exit 3 with the
/// key), where the folder exists; one that is there loads.
#[test]
fn macro_m_code_with_missing_program_is_refused_at_load() {
    let root = std::env::temp_dir().join(format!("cnc402-mcodes-{}", std::process::id()));
    let progs = root.join("progs");
    std::fs::create_dir_all(&progs).unwrap();
    std::fs::create_dir_all(root.join("config")).unwrap();
    std::fs::write(progs.join("o9001.CNC"), "O9001\nM99\n").unwrap();
    let base = SHIPPED.replacen(
        "program_dir = \"../examples\"",
        "program_dir = \"../progs\"",
        1,
    );
    let cfg_path = root.join("config/m.toml");
    let entry = "101 = { action = \"macro\", program = 9002 }";
    let text = base.replacen("[mcodes]\n", &format!("[mcodes]\n{entry}\n"), 1);
    let e = MachineConfig::parse(&text, &cfg_path).unwrap_err();
    assert_eq!(e.key, "mcodes.101.program", "{e}");
    let line = text.lines().position(|l| l.contains(entry)).unwrap() + 1;
    assert_eq!(e.line, line);
    assert!(e.to_string().contains("O9002"), "{e}");
    let text = base.replacen(
        "[mcodes]\n",
        "[mcodes]\n101 = { action = \"macro\", program = 9001 }\n",
        1,
    );
    let c = MachineConfig::parse(&text, &cfg_path).unwrap();
    assert_eq!(
        c.mcodes[&101],
        MAction::Macro {
            program: 9001,
            args: false
        }
    );
    std::fs::remove_dir_all(&root).ok();
}
