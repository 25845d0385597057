//! drivectl keeps the convention of all binaries (issue 17, docs/exit-codes.md): the shared
//! exit codes for a bad config, a missing CAN interface and a bad argument (clap's own errors
//! included), `--version`, `--help`, and `RUST_LOG` on stderr. cnc402 and simdrive run the
//! same causes against the same constants (tests/exit_codes.rs, hil-tests/tests/convention.rs).

use std::path::PathBuf;
use std::process::{Command, Output};

use cnc402_config::exit;

fn drivectl(args: &[&str], rust_log: Option<&str>) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_drivectl"));
    c.args(args)
        .current_dir(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(".."))
        .env_remove("RUST_LOG");
    if let Some(l) = rust_log {
        c.env("RUST_LOG", l);
    }
    c.output().expect("run drivectl")
}

#[test]
fn drivectl_ends_with_the_shared_codes() {
    let dir = std::env::temp_dir().join(format!("drivectl-convention-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "[bus]\ninterface = \"sim\"\nbogus = 1\n").unwrap();
    let cases: [(&[&str], u8); 7] = [
        (&["--config", bad.to_str().unwrap(), "scan"], exit::CONFIG),
        (&["--config", "no/such/machine.toml", "scan"], exit::CONFIG),
        (&["--iface", "nonexist0", "scan"], exit::IO),
        (&["--no-such-option"], exit::USAGE),
        (&["sdo"], exit::USAGE),
        (&["--version"], exit::OK),
        (&["--help"], exit::OK),
    ];
    for (args, want) in cases {
        let o = drivectl(args, None);
        assert_eq!(
            o.status.code(),
            Some(i32::from(want)),
            "drivectl {args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let v = drivectl(&["--version"], None);
    assert!(String::from_utf8_lossy(&v.stdout).starts_with("drivectl "));
}

#[test]
fn drivectl_honours_rust_log() {
    let args = ["--iface", "sim", "scan"];
    let debug = drivectl(&args, Some("debug"));
    assert!(debug.status.success());
    let err = String::from_utf8_lossy(&debug.stderr);
    assert!(
        err.contains(" DEBUG ") && err.contains("interface sim"),
        "{err}"
    );
    let quiet = drivectl(&args, None);
    assert!(!String::from_utf8_lossy(&quiet.stderr).contains(" DEBUG "));
}
