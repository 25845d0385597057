//! Where cnc402 looks for files: a program's own folder however its path is written, and a
//! config's relative paths from the config file's folder (issue: one CLI convention).

use std::path::PathBuf;
use std::process::Command;

fn temp(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cnc402-paths-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Regression (bare_program_name_missed_its_subprogram): in a folder holding `m.nc` and
/// `O9401.nc`, `cnc402 segments m.nc` said O9401 was not found "next to the main program"
/// while `./m.nc` found it.
#[test]
fn a_bare_program_name_finds_the_subprogram_next_to_it() {
    let dir = temp("bare");
    std::fs::write(dir.join("m.nc"), "G0 X1\nM98 P9401\nM30\n").unwrap();
    std::fs::write(dir.join("O9401.nc"), "O9401\nG0 Y2\nM99\n").unwrap();
    let cfg = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("config/machine.toml");
    for name in ["m.nc", "./m.nc"] {
        let o = Command::new(env!("CARGO_BIN_EXE_cnc402"))
            .args(["segments", name, "--config", cfg.to_str().unwrap()])
            .current_dir(&dir)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(0), "{name}: {err}");
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(out.contains("\"Y\":2"), "{name}: the subprogram ran: {out}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A config outside the repository keeps its variables next to itself, whatever the working
/// directory (it used to put them in the parent of its folder).
#[test]
fn a_configs_relative_variables_file_is_next_to_the_config() {
    let dir = temp("cfg");
    std::fs::create_dir_all(dir.join("etc/cnc402")).unwrap();
    let shipped =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/config/machine.toml"))
            .unwrap();
    let text = shipped.replace(
        "variables_file = \"../var/macro_variables.txt\"",
        "variables_file = \"var/vars.txt\"",
    );
    assert_ne!(text, shipped);
    let cfg = dir.join("etc/cnc402/machine.toml");
    std::fs::write(&cfg, text).unwrap();
    std::fs::write(dir.join("p.nc"), "#500=7\nM30\n").unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(["run", "p.nc", "--config", cfg.to_str().unwrap()])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        dir.join("etc/cnc402/var/vars.txt").is_file(),
        "next to the config"
    );
    assert!(
        !dir.join("etc/var").exists(),
        "not in the parent of its folder"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
