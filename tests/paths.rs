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

/// Regression (percent_wrapped_subprogram_file_did_nothing): a sub-program file written as
/// Fanuc punches them, `%`, `O1000`, blocks, `M99`, `%`, called by `M98 P1000` after the main
/// program had run a block, took its opening `%` for the end of the file: nothing ran and no
/// error was raised. Its block runs now, and a `%` after its blocks still ends it.
#[test]
fn percent_wrapped_subprogram_file_runs() {
    let dir = temp("percent");
    std::fs::write(
        dir.join("m.nc"),
        "O0001\nG0 X0 Y0 Z5\nM98 P1000\nM98 P1001\nG0 X5\nM30\n",
    )
    .unwrap();
    std::fs::write(dir.join("O1000.nc"), "%\nO1000\nG1 X10 Y10 F500\nM99\n%\n").unwrap();
    // No M99: the closing `%` returns.
    std::fs::write(
        dir.join("O1001.nc"),
        "\n%\n(a comment)\nO1001\nG1 Y20 F500\n%\nG1 Y99\n",
    )
    .unwrap();
    let cfg = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("config/machine.toml");
    let o = Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(["segments", "m.nc", "--config", cfg.to_str().unwrap()])
        .current_dir(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    let out = String::from_utf8_lossy(&o.stdout);
    let ends: Vec<&str> = out
        .lines()
        .filter_map(|l| l.split("\"end\":").nth(1))
        .map(|e| e.split('}').next().unwrap_or(""))
        .collect();
    assert_eq!(
        ends,
        [
            "{\"X\":0,\"Y\":0,\"Z\":5,\"C\":0",
            "{\"X\":10,\"Y\":10,\"Z\":5,\"C\":0",
            "{\"X\":10,\"Y\":20,\"Z\":5,\"C\":0",
            "{\"X\":5,\"Y\":20,\"Z\":5,\"C\":0",
        ],
        "{out}"
    );
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
