//! Choosing the dialect a program is read in: `--dialect` over the program's header over the
//! config's `interp.dialect`; unknown names refused where they are written.

use std::path::PathBuf;
use std::process::{Command, Output};

fn cnc402(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("RUST_LOG", "warn")
        .output()
        .expect("run cnc402")
}

fn program(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cnc402-dialect-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn unknown_dialect_in_a_header_is_a_program_error_at_its_name() {
    let p = program("bad-header.nc", "%\n(dialect: sinumerik)\nG0 X1\n%\n");
    for cmd in ["segments", "canon", "run"] {
        let o = cnc402(&[cmd, p.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(2), "{cmd}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("bad-header.nc:2:11: unknown dialect \"sinumerik\""), "{cmd}: {e}");
        assert!(e.contains("fanuc, haas or linuxcnc"), "{cmd}: {e}");
    }
}

#[test]
fn unknown_dialect_on_the_command_line_is_a_usage_error() {
    let p = program("plain.nc", "G0 X1\n");
    let o = cnc402(&["segments", "--dialect", "heidenhain", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(64), "{}", stderr(&o));
    assert!(stderr(&o).contains("unknown dialect \"heidenhain\""), "{}", stderr(&o));
}

#[test]
fn command_line_dialect_overrides_a_valid_header() {
    let p = program("header.nc", "(dialect: haas)\nG0 X1\n");
    for d in ["fanuc", "haas", "linuxcnc"] {
        let o = cnc402(&["segments", "--dialect", d, p.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(0), "{d}: {}", stderr(&o));
    }
}

#[test]
fn unknown_dialect_in_the_config_names_the_key() {
    let shipped = std::fs::read_to_string(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("config/machine.toml"),
    )
    .unwrap();
    let cfg = program(
        "machine.toml",
        &shipped.replacen("dialect = \"fanuc\"", "dialect = \"mazatrol\"", 1),
    );
    let p = program("plain2.nc", "G0 X1\n");
    let o = cnc402(&["--config", cfg.to_str().unwrap(), "segments", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("interp.dialect"), "{}", stderr(&o));
}
