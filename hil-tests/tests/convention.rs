//! simdrive keeps the convention of all binaries (issue 17, docs/exit-codes.md): the shared
//! exit codes for a bad config, a missing CAN interface and a bad argument (clap's own errors
//! included), `--version`, `--help`, and `RUST_LOG` on stderr. cnc402 and drivectl run the
//! same causes against the same constants (tests/exit_codes.rs, drivectl/tests/convention.rs).

use std::path::PathBuf;
use std::process::{Command, Output};

use cnc402_config::exit;

fn simdrive(args: &[&str], rust_log: Option<&str>) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_simdrive"));
    c.args(args)
        .current_dir(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(".."))
        .env_remove("RUST_LOG");
    if let Some(l) = rust_log {
        c.env("RUST_LOG", l);
    }
    c.output().expect("run simdrive")
}

#[test]
fn simdrive_ends_with_the_shared_codes() {
    let dir = std::env::temp_dir().join(format!("simdrive-convention-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "[bus]\ninterface = \"sim\"\nbogus = 1\n").unwrap();
    // Every case ends before the bus is used or at its opening: nothing runs for long.
    let iface = ["--iface", "nonexist0", "--no-rt", "--duration", "1"];
    let cases: [(Vec<&str>, u8); 8] = [
        (vec!["--config", bad.to_str().unwrap()], exit::CONFIG),
        (vec!["--config", "no/such/machine.toml"], exit::CONFIG),
        ([&iface[..], &["--nodes", "99"]].concat(), exit::CONFIG),
        (iface.to_vec(), exit::IO),
        (vec!["--no-such-option"], exit::USAGE),
        ([&iface[..4], &["--duration", "0"]].concat(), exit::USAGE),
        (vec!["--version"], exit::OK),
        (vec!["--help"], exit::OK),
    ];
    for (args, want) in cases {
        let o = simdrive(&args, None);
        assert_eq!(
            o.status.code(),
            Some(i32::from(want)),
            "simdrive {args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let help = String::from_utf8_lossy(&simdrive(&["--help"], None).stdout).into_owned();
    assert!(
        help.contains("Exit codes (") && help.contains("9   check failed"),
        "{help}"
    );
    let v = simdrive(&["--version"], None);
    assert!(String::from_utf8_lossy(&v.stdout).starts_with("simdrive "));
}

#[test]
fn simdrive_honours_rust_log() {
    let args = ["--iface", "nonexist0", "--no-rt", "--duration", "1"];
    let err = |log| String::from_utf8_lossy(&simdrive(&args, log).stderr).into_owned();
    let debug = err(Some("debug"));
    assert!(
        debug.contains(" DEBUG ") && debug.contains("nonexist0"),
        "{debug}"
    );
    assert!(!err(None).contains(" DEBUG "));
}
