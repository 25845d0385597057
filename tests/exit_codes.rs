//! One exit-code convention for `cnc402`, `drivectl` and `simdrive` (issue 17): the table in
//! docs/exit-codes.md is exactly `cnc402_config::exit::TABLE`, the READMEs point to it instead
//! of keeping copies, and `cnc402` ends with the shared code for each common cause. drivectl's
//! and simdrive's own packages run the same causes against the same constants
//! (drivectl/tests/convention.rs, hil-tests/tests/convention.rs), so the three agree.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use cnc402_config::exit;

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(repo().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

fn cnc402(args: &[&str], rust_log: Option<&str>) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_cnc402"));
    c.args(args).current_dir(repo()).env_remove("RUST_LOG");
    if let Some(l) = rust_log {
        c.env("RUST_LOG", l);
    }
    c.output().expect("run cnc402")
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cnc402-exit-codes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// The rows `| code | name | …` of the table in docs/exit-codes.md.
fn documented_rows() -> Vec<(u8, String)> {
    read("docs/exit-codes.md")
        .lines()
        .filter_map(|l| {
            let mut cells = l.strip_prefix('|')?.split('|').map(str::trim);
            let code = cells.next()?.parse().ok()?;
            Some((code, cells.next()?.to_string()))
        })
        .collect()
}

#[test]
fn the_documented_table_is_the_shared_one() {
    let shared: Vec<(u8, String)> = exit::TABLE
        .iter()
        .map(|(c, n, _)| (*c, n.to_string()))
        .collect();
    assert_eq!(documented_rows(), shared);
}

#[test]
fn the_readmes_point_to_the_one_table_and_keep_no_copy() {
    for (file, link) in [
        ("README.md", "docs/exit-codes.md"),
        ("drivectl/README.md", "../docs/exit-codes.md"),
    ] {
        let text = read(file);
        assert!(
            text.contains(&format!("({link})")),
            "{file} does not link {link}"
        );
        // A table row for a code would be a second copy that can drift.
        let copies: Vec<&str> = text
            .lines()
            .filter(|l| {
                exit::TABLE
                    .iter()
                    .any(|(c, _, _)| l.starts_with(&format!("| {c} |")))
            })
            .collect();
        assert!(copies.is_empty(), "{file} keeps exit-code rows: {copies:?}");
    }
}

#[test]
fn cnc402_ends_with_the_shared_codes() {
    let bad = tmp("bad.toml");
    std::fs::write(&bad, "[bus]\ninterface = \"sim\"\nbogus = 1\n").unwrap();
    let nocan = tmp("nocan.toml");
    let text =
        read("config/machine.toml").replace("interface = \"sim\"", "interface = \"nonexist0\"");
    std::fs::write(&nocan, text).unwrap();
    let report = tmp("nocan.json");
    let program = "examples/bolt-circle-drilling.nc";
    let cases: [(&[&str], u8); 6] = [
        (
            &["--config", bad.to_str().unwrap(), "segments", program],
            exit::CONFIG,
        ),
        (
            &[
                "--config",
                nocan.to_str().unwrap(),
                "run",
                program,
                "--report",
                report.to_str().unwrap(),
            ],
            exit::IO,
        ),
        (&["--no-such-option"], exit::USAGE),
        (&["segments"], exit::USAGE),
        (&["--version"], exit::OK),
        (&["--help"], exit::OK),
    ];
    for (args, want) in cases {
        let o = cnc402(args, None);
        assert_eq!(
            o.status.code(),
            Some(i32::from(want)),
            "cnc402 {args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let v = cnc402(&["--version"], None);
    assert!(String::from_utf8_lossy(&v.stdout).starts_with("cnc402 "));
}

#[test]
fn cnc402_honours_rust_log() {
    let args = ["run", "examples/bolt-circle-drilling.nc", "--report"];
    let report = tmp("log.json");
    let run = |log| {
        let mut a = args.to_vec();
        a.push(report.to_str().unwrap());
        let o = cnc402(&a, log);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    assert!(run(Some("info")).contains(" INFO "));
    assert!(!run(None).contains(" INFO "));
}
