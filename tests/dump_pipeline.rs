//! `cnc402 segments` and `canon` interpret on one thread and write on another (src/dump.rs):
//! the bytes are those of the one-threaded library path, a program error still comes after
//! everything before it is printed, and a reader that goes away (`| head -1`) ends the run
//! with the write error, as before.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use cnc402_config::MachineConfig;

fn cnc402(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run cnc402")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `text` written as `name` in a folder of this test's own.
fn program(test: &str, name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cnc402-pipe-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// `blocks` G1 moves (and a message every 100) after a preamble, as a CAM program writes.
fn moves(blocks: usize) -> String {
    let mut t = String::from("G21 G90 G17\nG64 P0.01\nG0 X10 Y0 Z0\nF3000\n");
    for i in 1..=blocks {
        let a = i as f64 * 0.001;
        t.push_str(&format!(
            "G1 X{:.4} Y{:.4}\n",
            10.0 * a.cos(),
            10.0 * a.sin()
        ));
        if i % 100 == 0 {
            t.push_str(&format!("(MSG, pass {i} \"done\" \\ ok)\n"));
        }
    }
    t
}

/// The segments of `path` as the library gives them one by one on this thread, as JSON Lines.
fn one_thread(path: &Path) -> String {
    let cfg =
        MachineConfig::load(Path::new(env!("CARGO_MANIFEST_DIR")).join("config/machine.toml"))
            .unwrap();
    let mut interp = cnc402_interp::host_fs::interpreter(
        &cfg,
        cnc402_interp::Options::default(),
        cnc402_interp::host_fs::VarsAccess::ReadOnly,
    );
    let file = std::fs::File::open(path).unwrap();
    interp
        .load_stream(
            path.display().to_string(),
            Box::new(BufReader::new(file)),
            None,
        )
        .unwrap();
    let mut segs = Vec::new();
    while let Some(s) = interp.next_segment().unwrap() {
        segs.push(s);
    }
    cnc402_interp::dump::segments_to_jsonl(&segs, &cfg)
}

#[test]
fn segments_prints_the_bytes_of_the_one_threaded_library_path() {
    // Several batches and several written pieces; a file name that JSON must escape.
    let mut text = moves(3_000);
    text.push_str("M2\n");
    let p = program("bytes", "a \"q\" b.nc", &text);
    let o = cnc402(&["segments", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let want = one_thread(&p);
    assert_eq!(want.lines().count(), 3_000 + 30 + 2);
    assert!(String::from_utf8(o.stdout.clone()).unwrap() == want);
    assert_eq!(stderr(&o), "");
}

#[test]
fn a_program_error_is_printed_after_every_line_before_it() {
    // Past the first batches and written pieces, so the error is found while the writer
    // still has lines to write.
    let mut text = moves(5_000);
    text.push_str("G2 X50 Y50 R1\n");
    let p = program("error", "bad.nc", &text);
    let bad_line = text.lines().count();
    for what in ["segments", "canon"] {
        let o = cnc402(&[what, p.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(2), "{what}: {}", stderr(&o));
        let out = String::from_utf8(o.stdout.clone()).unwrap();
        let lines: Vec<serde_json::Value> = out
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        // The rapid, 5,000 moves and 50 messages, the last the line before the bad one.
        assert_eq!(lines.len(), 1 + 5_000 + 50, "{what}");
        assert_eq!(lines.last().unwrap()["line"], bad_line - 1, "{what}");
        assert!(out.ends_with('\n'));
        assert!(
            stderr(&o).contains(&format!("bad.nc:{bad_line}:")),
            "{what}: {}",
            stderr(&o)
        );
    }
}

#[test]
fn a_reader_that_goes_away_ends_the_run_with_the_write_error() {
    // `cnc402 segments long.nc | head -1`: the writer's next write fails; the run ends with
    // exit 4 (an I/O error) instead of interpreting the rest, as with one thread.
    let mut text = moves(20_000);
    text.push_str("M2\n");
    let p = program("head", "long.nc", &text);
    let mut child = Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(["segments", p.to_str().unwrap()])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    assert!(first.starts_with("{\"kind\":\"rapid\""), "{first}");
    // The read end is closed here (the reader dropped).
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(stderr(&o).contains("Broken pipe"), "{}", stderr(&o));
}

#[test]
fn the_m99_note_comes_after_a_whole_pass_is_written() {
    let mut text = moves(1_000);
    text.push_str("M99\n");
    let p = program("m99", "loop.nc", &text);
    let m99_line = text.lines().count();
    let o = cnc402(&["segments", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(String::from_utf8(o.stdout.clone()).unwrap(), one_thread(&p));
    assert!(
        stderr(&o).contains(&format!("M99 at line {m99_line} ends the main program")),
        "{}",
        stderr(&o)
    );
}
