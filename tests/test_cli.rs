//! `cnc402 test PROGRAM…` end to end (issue 15, source 000's regression-test method as a
//! tool): PASS and FAIL lines with the error's `file:line:col`, the exit code of a mixed run,
//! the JUnit XML read back by a strict parser (nasty names and messages included), the
//! program-time limit on an endless program, Ctrl-C, stops without an operator, and the AxiOMA
//! examples.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const SHIPPED: &str = include_str!("../config/machine.toml");

fn cnc402() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_cnc402"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("RUST_LOG", "warn");
    c
}

fn test(args: &[&str]) -> Output {
    cnc402()
        .arg("test")
        .args(args)
        .output()
        .expect("run cnc402")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A fresh folder of the test's own.
fn temp(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cnc402-test-cmd-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes `text` as `dir/name` and gives its path as a string.
fn program(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

/// The shipped config with `machine` as its `[machine]` section and its variables file in
/// `dir`, written into `dir`.
fn config(dir: &Path, machine: &str) -> String {
    let root = env!("CARGO_MANIFEST_DIR");
    let text = SHIPPED
        .replace("\"../examples", &format!("\"{root}/examples"))
        .replace(
            "\"../var/macro_variables.txt\"",
            &format!("{:?}", dir.join("vars.txt")),
        )
        .replacen("[bus]", &format!("[machine]\n{machine}\n\n[bus]"), 1);
    let p = dir.join("machine.toml");
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

/// The program time `cnc402 run` prints for `program` ("ok: … program time 12.345 s, …").
fn run_program_time(program: &str) -> String {
    let o = cnc402().args(["run", program]).output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = stdout(&o);
    let t = out
        .split("program time ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .unwrap_or_else(|| panic!("no program time in {out}"));
    t.to_string()
}

#[test]
fn passing_programs_print_pass_with_the_program_time_run_reports_and_exit_0() {
    let o = test(&["examples/peck-tap.nc", "examples/m10x1.5-rigid-tap.nc"]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(0), "{out}{}", stderr(&o));
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 3, "{out}");
    // The same run as `cnc402 run`: the same program time to the millisecond.
    let t = run_program_time("examples/peck-tap.nc");
    assert_eq!(
        lines[0],
        format!("PASS examples/peck-tap.nc (program time {t} s, 9 blocks)")
    );
    let t = run_program_time("examples/m10x1.5-rigid-tap.nc");
    assert_eq!(
        lines[1],
        format!("PASS examples/m10x1.5-rigid-tap.nc (program time {t} s, 11 blocks)")
    );
    assert!(
        lines[2]
            .starts_with("test result: ok. 2 passed; 0 failed; 0 could not run; 2 programs in "),
        "{out}"
    );
}

#[test]
fn failures_name_file_line_col_and_the_rest_still_run() {
    let dir = temp("fail");
    let syntax = program(&dir, "syntax.nc", "G0 X1\nG1 X10 Y\nM30\n");
    let soft = program(&dir, "soft.nc", "G0 X10\nG0 X500\nM30\n");
    let zero_feed = program(&dir, "zero-feed.nc", "G0 X1\nG1 X10 F0\nM30\n");
    let missing = dir.join("missing.nc").to_str().unwrap().to_string();
    let good = program(&dir, "good.nc", "G1 X5 F600\nG0 X0\nM30\n");
    let o = test(&[&syntax, &soft, &missing, &zero_feed, &good]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(1), "{out}{}", stderr(&o));
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(
        lines[0],
        format!(
            "FAIL {syntax}: {syntax}:2:8: no value after address Y (expected a number, \
             `[expression]` or `=expression` after Y)"
        )
    );
    assert_eq!(
        lines[1],
        format!(
            "FAIL {soft}: {soft}:2:4: X 500 is outside the soft limits -300..300 (machine \
             coordinates) (expected a target inside -300..300)"
        )
    );
    // Missing: the OS error, and the programs after it still run.
    assert_eq!(
        lines[2],
        format!("FAIL {missing}: {missing}: No such file or directory (os error 2)")
    );
    assert!(
        lines[3].starts_with(&format!(
            "FAIL {zero_feed}: {zero_feed}:2:8: zero feed in a motion block"
        )),
        "{out}"
    );
    assert!(
        lines[4].starts_with(&format!("PASS {good} (program time ")),
        "{out}"
    );
    assert!(lines[4].ends_with(", 3 blocks)"), "{out}");
    assert!(
        lines[5]
            .starts_with("test result: FAILED. 1 passed; 3 failed; 1 could not run; 5 programs"),
        "{out}"
    );
    assert!(
        stderr(&o).contains("4 of 5 programs did not pass"),
        "{}",
        stderr(&o)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_drive_fault_fails_the_program_naming_node_emcy_and_line() {
    let o = test(&[
        "examples/m10x1.5-rigid-tap.nc",
        "--inject-fault",
        "3:8611@0.5",
    ]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(1), "{out}{}", stderr(&o));
    let first = out.lines().next().unwrap();
    assert!(first.starts_with("FAIL examples/m10x1.5-rigid-tap.nc: drive fault on node 3"));
    assert!(first.contains("EMCY 0x8611"), "{first}");
    assert!(
        first.contains("examples/m10x1.5-rigid-tap.nc:11:"),
        "{first}"
    );
}

/// The JUnit document of a run, parsed by a strict XML parser (a malformed document, an
/// unescaped `<` or `&`, a character XML 1.0 cannot hold: the test fails here).
fn parse(xml: &str) -> roxmltree::Document<'_> {
    roxmltree::Document::parse(xml).unwrap_or_else(|e| panic!("not well-formed XML ({e}):\n{xml}"))
}

fn attr<'a>(n: roxmltree::Node<'a, '_>, name: &str) -> &'a str {
    n.attribute(name)
        .unwrap_or_else(|| panic!("no {name} on {n:?}"))
}

#[test]
fn junit_names_messages_and_counts_read_back_exactly_whatever_they_hold() {
    let dir = temp("junit");
    // A name and an alarm text with every markup character and non-ASCII.
    let nasty = program(
        &dir,
        "a<&\"'>ø 工件.nc",
        "G0 X1\n#3000=7 (TOO <DEEP> & \"WIDE\" 'Ø12' 深)\nM30\n",
    );
    let good = program(&dir, "good.nc", "G1 X5 F600\nG0 X0\nM30\n");
    let missing = dir.join("gone.nc").to_str().unwrap().to_string();
    let junit = dir.join("results.xml");
    let o = test(&[&nasty, &good, &missing, "--junit", junit.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}{}", stdout(&o), stderr(&o));
    let xml = std::fs::read_to_string(&junit).unwrap();
    let doc = parse(&xml);
    let root = doc.root_element();
    assert_eq!(root.tag_name().name(), "testsuites");
    let suite = root
        .children()
        .find(|n| n.has_tag_name("testsuite"))
        .expect("a testsuite");
    assert_eq!(
        ["tests", "failures", "errors", "skipped"].map(|a| attr(suite, a)),
        ["3", "1", "1", "0"]
    );
    assert!(attr(suite, "time").parse::<f64>().unwrap() >= 0.0);
    let cases: Vec<_> = suite
        .children()
        .filter(|n| n.has_tag_name("testcase"))
        .collect();
    assert_eq!(cases.len(), 3);
    let folder = dir.to_str().unwrap();
    assert_eq!(attr(cases[0], "classname"), folder);
    assert_eq!(attr(cases[0], "name"), "a<&\"'>ø 工件.nc");
    assert!(attr(cases[0], "time").parse::<f64>().is_ok());
    let failure = cases[0]
        .children()
        .find(|n| n.has_tag_name("failure"))
        .expect("a failure");
    assert_eq!(attr(failure, "type"), "program");
    assert_eq!(
        attr(failure, "message"),
        format!("{nasty}:2:1: alarm 3007: TOO <DEEP> & \"WIDE\" 'Ø12' 深")
    );
    // The body: the message and the block as written.
    assert_eq!(
        failure.text().unwrap(),
        format!(
            "{nasty}:2:1: alarm 3007: TOO <DEEP> & \"WIDE\" 'Ø12' 深\n    \
             #3000=7 (TOO <DEEP> & \"WIDE\" 'Ø12' 深)"
        )
    );
    assert_eq!(attr(cases[1], "name"), "good.nc");
    assert_eq!(cases[1].children().filter(|n| n.is_element()).count(), 1);
    let out = cases[1]
        .children()
        .find(|n| n.has_tag_name("system-out"))
        .unwrap();
    assert!(
        out.text()
            .unwrap()
            .starts_with(&format!("PASS {good} (program time "))
    );
    let error = cases[2]
        .children()
        .find(|n| n.has_tag_name("error"))
        .expect("an error");
    assert_eq!(attr(error, "type"), "io");
    assert_eq!(
        attr(error, "message"),
        format!("{missing}: No such file or directory (os error 2)")
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn junit_to_stdout_keeps_stdout_for_the_xml_and_the_lines_go_to_stderr() {
    let o = test(&["examples/peck-tap.nc", "--junit", "-"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let xml = stdout(&o);
    let doc = parse(&xml);
    let suite = doc.root_element().first_element_child().unwrap();
    assert_eq!(attr(suite, "tests"), "1");
    assert_eq!(attr(suite, "failures"), "0");
    assert!(stderr(&o).contains("PASS examples/peck-tap.nc (program time "));
    assert!(stderr(&o).contains("test result: ok. 1 passed"));
}

#[test]
fn an_endless_m99_main_program_fails_on_the_program_time_limit_and_the_next_runs() {
    let dir = temp("m99");
    let endless = program(&dir, "endless.nc", "G91 G1 X1 F6000\nG1 X-1\nM99\n");
    let good = program(&dir, "good.nc", "G1 X5 F600\nM30\n");
    let o = test(&[&endless, &good, "--max-time", "3"]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(1), "{out}{}", stderr(&o));
    let first = out.lines().next().unwrap();
    assert!(
        first.starts_with(&format!("FAIL {endless}: {endless}:")),
        "{first}"
    );
    assert!(
        first.ends_with(
            "still running after 3 s of program time (--max-time) (the main program's M99 at \
             line 3 starts it over endlessly)"
        ),
        "{first}"
    );
    assert!(
        out.lines()
            .nth(1)
            .unwrap()
            .starts_with(&format!("PASS {good}")),
        "{out}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn stops_without_an_operator_go_on_and_the_pass_line_says_so() {
    let dir = temp("stops");
    let cfg = config(&dir, "tool_change = \"manual\"");
    let p = program(&dir, "stops.nc", "G1 X2 F600\nM0\nT7 M6\nG1 X0\nM30\n");
    let o = test(&["--config", &cfg, &p]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(0), "{out}{}", stderr(&o));
    let first = out.lines().next().unwrap();
    assert!(
        first.ends_with(
            ", 5 blocks); M0 at line 2 passed (no operator terminal); manual tool change M6 at \
             line 3 taken as done (no operator)"
        ),
        "{first}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_axioma_examples_pass_on_their_machine() {
    let o = test(&[
        "--config",
        "examples/axioma/machine.toml",
        "examples/axioma/source_000_main.nc",
        "examples/axioma/multipass_tap.nc",
    ]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(0), "{out}{}", stderr(&o));
    assert!(out.contains("PASS examples/axioma/source_000_main.nc (program time "));
    assert!(out.contains("PASS examples/axioma/multipass_tap.nc (program time "));
}

#[test]
fn ctrl_c_ends_the_whole_run_and_reports_what_was_done() {
    let dir = temp("sigint");
    let quick = program(&dir, "quick.nc", "G1 X5 F600\nM30\n");
    // Endless with motion: only Ctrl-C (or a week of program time) ends it.
    let endless = program(&dir, "endless.nc", "G91 G1 X1 F6000\nG1 X-1\nM99\n");
    let junit = dir.join("results.xml");
    let mut child = cnc402()
        .args([
            "test",
            &quick,
            &endless,
            &quick,
            "--max-time",
            "604800",
            "--junit",
        ])
        .arg(&junit)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let first = lines.next().unwrap().unwrap();
    assert!(first.starts_with(&format!("PASS {quick}")), "{first}");
    // The run's warning that the endless program starts over comes after its dry run, when
    // its run is under way: the signal reaches that run (a Ctrl-C between two programs would
    // leave the next one unrun instead).
    let mut log = BufReader::new(child.stderr.take().unwrap()).lines();
    let warned = log.any(|l| l.unwrap().contains("M99 in the main program"));
    assert!(warned, "no warning about the endless program");
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let rest: Vec<String> = lines.map(|l| l.unwrap()).collect();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(1), "{rest:?}");
    assert!(
        rest[0].starts_with(&format!("FAIL {endless}: "))
            && rest[0].ends_with("interrupted by Ctrl-C"),
        "{rest:?}"
    );
    assert_eq!(
        rest[1],
        format!("SKIP {quick}: not run (interrupted by Ctrl-C)")
    );
    assert!(
        rest[2].starts_with(
            "test result: FAILED. 1 passed; 1 failed; 0 could not run; 1 not run (interrupted \
             by Ctrl-C); 3 programs"
        ),
        "{rest:?}"
    );
    // The JUnit file is written with what was done.
    let xml = std::fs::read_to_string(&junit).unwrap();
    let doc = parse(&xml);
    let suite = doc.root_element().first_element_child().unwrap();
    assert_eq!(
        ["tests", "failures", "errors", "skipped"].map(|a| attr(suite, a)),
        ["3", "1", "0", "1"]
    );
    let failure = doc
        .descendants()
        .find(|n| n.has_tag_name("failure"))
        .unwrap();
    assert_eq!(attr(failure, "type"), "interrupted");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_usage_config_junit_path_and_can_interface_exit_with_their_codes_before_anything_runs() {
    // No program: usage.
    assert_eq!(test(&[]).status.code(), Some(64));
    for bad in ["0", "-1", "nan", "inf", "1e9"] {
        let o = test(&["examples/peck-tap.nc", "--max-time", bad]);
        assert_eq!(o.status.code(), Some(64), "{bad}: {}", stderr(&o));
    }
    // A config that does not parse: 3, as every command.
    let dir = temp("usage");
    let cfg = dir.join("bad.toml");
    std::fs::write(&cfg, "[bus]\ninterface = 7\n").unwrap();
    let o = test(&["--config", cfg.to_str().unwrap(), "examples/peck-tap.nc"]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    // A JUnit file in a folder that does not exist: 4, and nothing ran.
    let junit = dir.join("no/such/folder/results.xml");
    let o = test(&["examples/peck-tap.nc", "--junit", junit.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(stderr(&o).contains("--junit"), "{}", stderr(&o));
    assert!(stdout(&o).is_empty(), "{}", stdout(&o));
    // A CAN interface that cannot be opened: 4 at once, not a FAIL for every program.
    let cfg = config(&dir, "");
    let text = std::fs::read_to_string(&cfg).unwrap();
    std::fs::write(
        &cfg,
        text.replacen("interface = \"sim\"", "interface = \"nosuchcan7\"", 1),
    )
    .unwrap();
    let o = test(&["--config", &cfg, "examples/peck-tap.nc"]);
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(stderr(&o).contains("nosuchcan7"), "{}", stderr(&o));
    assert!(stdout(&o).is_empty(), "{}", stdout(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

/// On a multi-channel machine a program runs on channel 0 as `cnc402 run` runs it there, so
/// the seed's regression test really drives channel 1: it passes, and its variant with a
/// part program that fails on purpose fails with terminate 5558 at its line (a one-channel
/// run would have let every channel call succeed without running anything).
#[test]
fn the_seeds_regression_test_runs_on_the_two_channel_machine() {
    let o = cnc402()
        .args(["--config", "examples/axioma/two-channel.toml", "test"])
        .args(["examples/axioma/regression_test.nc"])
        .args(["examples/axioma/regression_test_fails.nc"])
        .output()
        .expect("run cnc402");
    let out = stdout(&o);
    assert!(out.contains("1 passed; 1 failed; 0 could not run"), "{out}");
    assert_eq!(o.status.code(), Some(1), "{out}{}", stderr(&o));
    assert!(
        out.contains("PASS examples/axioma/regression_test.nc"),
        "{out}"
    );
    assert!(
        out.contains("FAIL examples/axioma/regression_test_fails.nc: examples/axioma/regression_test_fails.nc:47:13")
            && out.contains("terminate 5558"),
        "{out}"
    );
}
