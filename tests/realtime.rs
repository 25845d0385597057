//! `cnc402 run --require-rt`: refused with exit 4 and the limits to raise when the loop
//! cannot lock memory or get SCHED_FIFO, as a user without real-time limits would see it.

use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A world-readable copy of the binary, the shipped config and a short program in a folder
/// the unprivileged user may write (variables file), so the run does not depend on where the
/// repository was cloned (a clone under /root is closed to other users).
fn sandbox(test: &str) -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("cnc402-rt-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("config")).unwrap();
    std::fs::create_dir_all(dir.join("examples")).unwrap();
    std::fs::create_dir_all(dir.join("var")).unwrap();
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    std::fs::copy(
        repo.join("config/machine.toml"),
        dir.join("config/machine.toml"),
    )
    .unwrap();
    std::fs::write(dir.join("short.nc"), "G21 G90\nG1 X1 F600\nM30\n").unwrap();
    let bin = dir.join("cnc402");
    std::fs::copy(env!("CARGO_BIN_EXE_cnc402"), &bin).unwrap();
    for p in [
        &dir,
        &dir.join("var"),
        &dir.join("config"),
        &dir.join("examples"),
    ] {
        std::fs::set_permissions(p, std::fs::Permissions::from_mode(0o777)).unwrap();
    }
    (dir, bin)
}

/// Runs `bin args…` with no real-time limits: RLIMIT_RTPRIO 0 and RLIMIT_MEMLOCK 64 kB, and
/// as root also as user `nobody` without capabilities (root's CAP_SYS_NICE and CAP_IPC_LOCK
/// would pass over the limits).
fn run_unprivileged(dir: &Path, bin: &Path, args: &[&str]) -> Output {
    let mut cmd = Command::new("prlimit");
    cmd.args(["--rtprio=0", "--memlock=65536"]);
    // /proc/self belongs to the process's effective user.
    let euid = std::fs::metadata("/proc/self").map_or(0, |m| m.uid());
    if euid == 0 {
        cmd.args([
            "setpriv",
            "--reuid=65534",
            "--regid=65534",
            "--clear-groups",
            "--inh-caps=-all",
            "--bounding-set=-all",
        ]);
    }
    cmd.arg(bin)
        .args(args)
        .current_dir(dir)
        .env("RUST_LOG", "warn")
        .output()
        .expect("prlimit and setpriv (util-linux) run")
}

#[test]
fn require_rt_refuses_without_realtime_limits_and_names_them() {
    let (dir, bin) = sandbox("refuse");
    let o = run_unprivileged(
        &dir,
        &bin,
        &[
            "run",
            "short.nc",
            "--config",
            "config/machine.toml",
            "--realtime",
            "--require-rt",
        ],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(4), "{err}");
    assert!(err.contains("--require-rt"), "{err}");
    assert!(err.contains("RLIMIT_MEMLOCK"), "{err}");
    assert!(err.contains("RLIMIT_RTPRIO"), "{err}");
    // Without --require-rt the same run goes on with a warning and ends normally.
    let o = run_unprivileged(
        &dir,
        &bin,
        &[
            "run",
            "short.nc",
            "--config",
            "config/machine.toml",
            "--realtime",
        ],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("running anyway"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn require_rt_on_the_virtual_time_simulator_is_a_usage_error() {
    let o = Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(["run", "examples/m10x1.5-rigid-tap.nc", "--require-rt"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(64), "{err}");
    assert!(err.contains("virtual time"), "{err}");
}
