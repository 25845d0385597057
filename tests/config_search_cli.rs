//! Which machine `cnc402` runs on without `--config`: the environment's file, the working
//! folder's `config/machine.toml`, else the built-in machine, said on stderr (an installed
//! binary run from any folder used to end with exit 3 "config/machine.toml: cannot read").

use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A fresh empty folder to run in (no config/ beside it, no user config under its HOME).
fn empty_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cnc402-cfgsearch-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(d.join("home")).expect("temp dir");
    d
}

fn cnc402(dir: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_cnc402"));
    c.args(args)
        .current_dir(dir)
        .env("HOME", dir.join("home"))
        .env_remove("XDG_CONFIG_HOME")
        .env_remove("CNC402_CONFIG")
        .env_remove("RUST_LOG");
    c
}

#[test]
fn run_outside_the_source_tree_used_to_fail_with_exit_3_and_now_runs_on_the_built_in_machine() {
    let dir = empty_dir("builtin");
    let prog = repo().join("examples/m10x1.5-rigid-tap.nc");
    let out = cnc402(&dir, &["run", prog.to_str().unwrap()])
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(err.contains("built-in machine"), "{err}");
    // Nothing written into the folder (no var/ of the shipped paths).
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().flatten().collect();
    assert_eq!(left.len(), 1, "{left:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_environment_names_the_config_and_a_missing_one_is_exit_3() {
    let dir = empty_dir("env");
    let prog = repo().join("examples/two-spindles/two-spindles.nc");
    let cfg = repo().join("examples/two-spindles/machine.toml");
    let out = cnc402(&dir, &["segments", prog.to_str().unwrap()])
        .env("CNC402_CONFIG", &cfg)
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(!err.contains("built-in machine"), "{err}");
    // Spindle 2 (U) exists only on that machine.
    assert!(String::from_utf8_lossy(&out.stdout).contains("\"U\""));
    let out = cnc402(&dir, &["segments", prog.to_str().unwrap()])
        .env("CNC402_CONFIG", dir.join("missing.toml"))
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(3));
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.toml"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_user_config_folder_is_read_before_the_built_in_machine() {
    let dir = empty_dir("user");
    let user = dir.join("home/.config/cnc402");
    std::fs::create_dir_all(&user).unwrap();
    std::fs::copy(
        repo().join("examples/two-spindles/machine.toml"),
        user.join("machine.toml"),
    )
    .unwrap();
    let prog = repo().join("examples/two-spindles/two-spindles.nc");
    let out = cnc402(&dir, &["segments", prog.to_str().unwrap()])
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(!err.contains("built-in machine"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
