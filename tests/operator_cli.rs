//! The operator's controls end to end on the embedded simulator (issue 14): breakpoints and
//! single block driven by a command file (`--commands`), in Macro B loops, sub-program files,
//! the C-like language and around rigid taps; the hold (setpoints constant); `stop`, bad
//! commands and missing blocks; messages; block search (`--from`/`--to`) against a full run.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

/// `cnc402 ARGS` from the repository, without `RUST_LOG` (what an operator sees).
fn cnc402(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env_remove("RUST_LOG")
        .stdin(std::process::Stdio::null())
        .output()
        .expect("run cnc402")
}

/// A folder of the test's own.
fn test_dir(test: &str) -> PathBuf {
    let dir = std::env::temp_dir()
        .join(format!("cnc402-operator-{}", std::process::id()))
        .join(test);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs `program` with `commands` (one a line) and `extra` arguments; the exit code, the
/// report and stderr.
fn run(dir: &Path, program: &str, commands: &str, extra: &[&str]) -> (Option<i32>, Value, String) {
    let cmds = write(dir, "commands.txt", commands);
    let report = dir.join("report.json");
    let _ = std::fs::remove_file(&report);
    let mut args = vec![
        "run",
        program,
        "--commands",
        &cmds,
        "--report",
        report.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = cnc402(&args);
    let v = std::fs::read_to_string(&report)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or(Value::Null);
    (o.status.code(), v, stderr(&o))
}

/// [`run`] that must exit 0: the report and stderr.
fn run_ok(dir: &Path, program: &str, commands: &str, extra: &[&str]) -> (Value, String) {
    let (code, v, err) = run(dir, program, commands, extra);
    assert_eq!(code, Some(0), "{err}");
    (v, err)
}

/// `"LINE REASON"` of every break the report lists.
fn breaks(v: &Value) -> Vec<String> {
    v["breaks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| format!("{} {}", b["line"], b["reason"].as_str().unwrap()))
        .collect()
}

/// `"LINE: TEXT"` of every message the report lists.
fn messages(v: &Value) -> Vec<String> {
    v["messages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| format!("{}: {}", m["line"], m["text"].as_str().unwrap()))
        .collect()
}

fn final_pos(v: &Value, axis: &str) -> f64 {
    v["axes"][axis]["final_position"].as_f64().unwrap()
}

const WHILE_LOOP: &str = "%\nO0001\nN10 G21 G90 G17 G54\nN20 G0 X0 Y0 Z5\nN30 #1=0\n\
N40 WHILE [#1 LT 3] DO1\nN50 G1 X[#1*10+10] F1000\n#1=#1+1\nEND1\nN60 G0 Z10\nN70 M30\n%\n";

#[test]
fn a_break_inside_a_while_loop_holds_at_every_pass_in_order() {
    let dir = test_dir("while");
    let p = write(&dir, "loop.nc", WHILE_LOOP);
    let (v, err) = run_ok(
        &dir,
        &p,
        "continue\ncontinue\ncontinue\ncontinue\n",
        &["--break", "N50", "--break", "N60"],
    );
    assert_eq!(breaks(&v), ["7 break", "7 break", "7 break", "10 break"]);
    // Ticks rise; each hold is announced with its place, block and position.
    let ticks: Vec<u64> = v["breaks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b["at_tick"].as_u64().unwrap())
        .collect();
    assert!(ticks.windows(2).all(|w| w[0] < w[1]), "{ticks:?}");
    assert_eq!(err.matches("break at ").count(), 4, "{err}");
    assert!(
        err.contains("loop.nc:7 N50: N50 G1 X[#1*10+10] F1000 | X10.000 Y0.000 Z5.000"),
        "{err}"
    );
    assert_eq!(v["commands"].as_array().unwrap().len(), 4);
    assert_eq!(final_pos(&v, "X"), 30.0);
}

#[test]
fn step_holds_before_each_following_block_and_next_runs_to_the_next_break() {
    let dir = test_dir("step");
    let p = write(&dir, "loop.nc", WHILE_LOOP);
    // At the first pass: step twice (passes 2 and 3), then next: to N60's break.
    let (v, _) = run_ok(
        &dir,
        &p,
        "step\nstep\nnext\ncontinue\n",
        &["--break", "N50", "--break", "N60"],
    );
    assert_eq!(breaks(&v), ["7 break", "7 step", "7 step", "10 break"]);
    // Single block: a hold before every block after the first one that makes motion.
    let (v, err) = run_ok(&dir, &p, &"\n".repeat(10), &["--single-block"]);
    assert_eq!(
        breaks(&v),
        ["7 step", "7 step", "7 step", "10 step", "11 step"],
        "{err}"
    );
    // `next` passes the single-block holds up to the next breakpoint.
    let (v, _) = run_ok(
        &dir,
        &p,
        "next\ncontinue\ncontinue\n",
        &["--single-block", "--break", "N60"],
    );
    assert_eq!(breaks(&v), ["7 step", "10 break", "11 step"]);
}

#[test]
fn breaks_in_a_subprogram_file_hold_at_each_call_and_skip_passes_the_rest() {
    let dir = test_dir("sub");
    let main = write(
        &dir,
        "main.nc",
        "O0100\nN10 G21 G90 G17 G0 X0 Y0 Z5\nN20 M98 P1000 L3\nN30 G0 Z20\nN40 M30\n",
    );
    write(
        &dir,
        "O1000.nc",
        "O1000\nN100 G91 G1 X5 F1000\nN110 Y5\nN120 G90\nN130 M99\n",
    );
    let sub = dir.join("O1000.nc");
    let at = format!("{}:3", sub.display());
    let (v, _) = run_ok(
        &dir,
        &main,
        &"\n".repeat(5),
        &["--break", &at, "--break", "N30"],
    );
    let files: Vec<String> = v["breaks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| {
            let f = b["file"].as_str().unwrap();
            format!(
                "{}:{}",
                Path::new(f).file_name().unwrap().to_str().unwrap(),
                b["line"]
            )
        })
        .collect();
    assert_eq!(
        files,
        ["O1000.nc:3", "O1000.nc:3", "O1000.nc:3", "main.nc:4"]
    );
    // skip at the first call's N110: the other calls' N110 pass, N30 still holds.
    let (v, _) = run_ok(
        &dir,
        &main,
        "skip\ncontinue\n",
        &["--break", "N110", "--break", "N30"],
    );
    assert_eq!(breaks(&v), ["3 break", "4 break"]);
    assert_eq!(final_pos(&v, "Y"), 15.0);
}

#[test]
fn a_c_like_statement_is_a_block() {
    let dir = test_dir("clike");
    let p = write(
        &dir,
        "c.nc",
        "G21 G90 G17\nG0 X0 Y0 Z5\nint nI = 0;\nwhile (nI < 3) {\n  G1 X=(nI * 10 + 10) F1000\n  \
         MSG(\"pass \" + nI);\n  nI = nI + 1;\n}\nG0 Z10\nM02\n",
    );
    let (v, err) = run_ok(
        &dir,
        &p,
        "step\ncontinue\ncontinue\ncontinue\n",
        &["--break", "c.nc:5"],
    );
    // The break on the G-code line holds at each pass; `step` holds at the MSG statement.
    assert_eq!(breaks(&v), ["5 break", "6 step", "5 break", "5 break"]);
    let msgs = messages(&v);
    assert_eq!(msgs, ["6: pass 0", "6: pass 1", "6: pass 2"]);
    assert!(err.contains("c.nc:6: MSG: pass 2"), "{err}");
}

/// Trace rows: (tick, commanded X, Y, Z).
fn trace_rows(path: &Path) -> Vec<(u64, [f64; 3])> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| head.iter().position(|h| *h == n).unwrap();
    let (x, y, z) = (col("X_cmd"), col("Y_cmd"), col("Z_cmd"));
    lines
        .enumerate()
        .map(|(i, l)| {
            let f: Vec<&str> = l.split(',').collect();
            let v = |c: usize| f[c].parse::<f64>().unwrap();
            (i as u64, [v(x), v(y), v(z)])
        })
        .collect()
}

#[test]
fn a_step_never_ends_inside_a_rigid_tap_and_the_machine_holds_still() {
    let dir = test_dir("tap");
    // A programmed rigid tap in two blocks (tap in, tap out), then a G84 peck cycle.
    let p = write(
        &dir,
        "tap.nc",
        "G21 G90 G17\nN10 G0 X0 Y0 Z5\nN20 M29 S500\nN30 G1 Z-10 C2880 F400\nN40 G1 Z5 C0\n\
         N50 G0 X10\nN55 M29 S500\nN60 G95 G84 Z-12 R2 Q4 F1.25\nN70 G80 G94 G0 Z20\nN80 M30\n",
    );
    let trace = dir.join("t.csv");
    let (v, err) = run_ok(
        &dir,
        &p,
        &"step\n".repeat(10),
        &[
            "--single-block",
            "--break",
            "N40",
            "--trace",
            trace.to_str().unwrap(),
        ],
    );
    let b = v["breaks"].as_array().unwrap();
    let lines: Vec<u64> = b.iter().map(|b| b["line"].as_u64().unwrap()).collect();
    // No hold at N40 (the tap out): the hold due there is made at N50, after the tap.
    assert_eq!(lines, vec![4, 6, 8, 9, 10]);
    assert_eq!(b[1]["after_tap"], true);
    assert!(err.contains("held after the tap out"), "{err}");
    let rows = trace_rows(&trace);
    for brk in b {
        let t = brk["at_tick"].as_u64().unwrap() as usize;
        let held = rows[t].1;
        // At rest when it holds (the tick before has the same setpoints).
        assert_eq!(rows[t - 1].1, held, "hold at tick {t}");
        // Never inside a tap: at every hold Z is above the work (tap start / end level).
        assert!(held[2] >= 2.0 - 1e-9, "hold at tick {t} at Z {}", held[2]);
    }
}

#[test]
fn stop_ends_the_program_at_the_hold_with_exit_0() {
    let dir = test_dir("stop");
    let p = write(&dir, "loop.nc", WHILE_LOOP);
    let (v, _) = run_ok(&dir, &p, "continue\nstop\n", &["--break", "N50"]);
    assert_eq!(v["ok"], true);
    assert_eq!(v["stopped_by_operator"], true);
    assert_eq!(final_pos(&v, "X"), 10.0);
    assert_eq!(final_pos(&v, "Z"), 5.0);
    // End of the command input ends it there too.
    let (v, err) = run_ok(&dir, &p, "", &["--break", "N50"]);
    assert!(err.contains("end of input"), "{err}");
    assert_eq!(final_pos(&v, "X"), 0.0);
}

#[test]
fn an_unknown_command_from_a_file_is_exit_64_at_its_line_and_nothing_moves() {
    let dir = test_dir("badcmd");
    let p = write(&dir, "loop.nc", WHILE_LOOP);
    let (code, v, err) = run(&dir, &p, "# first\ncontinue\njump\n", &["--break", "N50"]);
    assert_eq!(code, Some(64), "{err}");
    assert!(
        err.contains("commands.txt:3: unknown command \"jump\""),
        "{err}"
    );
    assert!(v["command_error"].as_str().unwrap().contains(":3:"));
    // Held at the second pass's start: the machine stayed at X10.
    assert_eq!(final_pos(&v, "X"), 10.0);
}

#[test]
fn an_unknown_command_on_stdin_is_asked_again_and_the_held_machine_stands_still() {
    use std::io::{BufRead as _, Write as _};
    let dir = test_dir("stdin");
    let p = write(&dir, "loop.nc", WHILE_LOOP);
    let report = dir.join("r.json");
    let trace = dir.join("t.csv");
    let mut child = Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(["run", &p, "--break", "N60", "--commands", "-", "--report"])
        .arg(&report)
        .arg("--trace")
        .arg(&trace)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env_remove("RUST_LOG")
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let mut err = std::io::BufReader::new(child.stderr.take().unwrap());
    let mut seen = String::new();
    while !seen.contains("break at") {
        let mut l = String::new();
        if err.read_line(&mut l).unwrap() == 0 {
            break;
        }
        seen.push_str(&l);
    }
    // The operator takes a while (the held ticks run at the wall clock's pace).
    std::thread::sleep(std::time::Duration::from_millis(300));
    stdin.write_all(b"fly\ncontinue\n").unwrap();
    drop(stdin);
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut err, &mut rest).unwrap();
    let o = child.wait_with_output().unwrap();
    let err = seen + &rest;
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("stdin:1: unknown command \"fly\""), "{err}");
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(v["commands"][0]["command"], "continue");
    assert_eq!(v["commands"][0]["input_line"], 2);
    assert_eq!(final_pos(&v, "Z"), 10.0);
    // Setpoints constant through the hold: at least the 300 ms the operator took.
    let t = v["breaks"][0]["at_tick"].as_u64().unwrap() as usize;
    let rows = trace_rows(&trace);
    let held = rows[t].1;
    let still = rows[t..].iter().take_while(|r| r.1 == held).count();
    assert!(still >= 250, "held {still} ticks");
    assert_eq!(held, [30.0, 0.0, 5.0]);
}

#[test]
fn a_break_on_a_missing_block_warns_with_the_nearest_and_the_run_starts() {
    let dir = test_dir("missing");
    let p = write(&dir, "loop.nc", WHILE_LOOP);
    let (v, err) = run_ok(
        &dir,
        &p,
        "",
        &[
            "--break",
            "N55",
            "--break",
            "loop.nc:8000",
            "--break",
            "loop.nc:2",
        ],
    );
    assert!(
        err.contains("N55 is no block") && err.contains("nearest: N50, N60"),
        "{err}"
    );
    assert!(err.contains("loop.nc:8000 holds no block"), "{err}");
    // Line 2 (O0001) is a block: no warning for it.
    assert!(!err.contains("loop.nc:2 holds"), "{err}");
    assert_eq!(final_pos(&v, "Z"), 10.0);
}

#[test]
fn messages_reach_the_operator_with_their_lines() {
    let dir = test_dir("msg");
    let p = write(
        &dir,
        "m.nc",
        "G21 G90 G0 X0 Y0 Z5\n(MSG, CHECK THE CLAMP)\n#3006=1 (INSERT PART)\nG0 X5\nM30\n",
    );
    let (v, err) = run_ok(&dir, &p, "\n", &[]);
    let msgs = messages(&v);
    assert_eq!(msgs, ["2: CHECK THE CLAMP", "3: INSERT PART"]);
    assert!(err.contains("m.nc:2: MSG: CHECK THE CLAMP"), "{err}");
    // #3006 stops like M0: with a command stream it waits for the (empty = continue) line.
    assert_eq!(v["stops"][0]["line"], 3);
    assert_eq!(v["stops"][0]["action"], "wait");
    assert_eq!(final_pos(&v, "X"), 5.0);
}

const SEARCH: &str = "%\nO0200\nN10 G21 G90 G17 G55\nN20 T2 M6\nN30 G43 H2 Z50\nN40 S1200 M3\n\
N50 G0 X10 Y10\nN60 Z190\nN70 G91\nN80 G1 X5 F600\nN90 Y5\nN100 X-5\nN110 G90 G0 Z200\nN120 Y30\nN130 M5\nN140 M30\n%\n";

#[test]
fn block_search_runs_the_range_in_the_state_the_blocks_before_set_up() {
    let dir = test_dir("search");
    let p = write(&dir, "s.nc", SEARCH);
    // The full program, stopped after N110 by a break, against the search N90..N110.
    let (full, _) = run_ok(&dir, &p, "stop\n", &["--break", "N120"]);
    let trace = dir.join("s.csv");
    let (part, _) = run_ok(
        &dir,
        &p,
        "",
        &[
            "--from",
            "N90",
            "--to",
            "N110",
            "--trace",
            trace.to_str().unwrap(),
        ],
    );
    assert_eq!(part["search"], "N90 to N110");
    for a in ["X", "Y", "Z"] {
        // G55 (X+100), G91 from N70, tool length H2 (-165.52) from N30.
        assert!(
            (final_pos(&full, a) - final_pos(&part, a)).abs() < 1e-6,
            "{a}: {full} {part}"
        );
    }
    assert_eq!(
        (final_pos(&part, "X"), final_pos(&part, "Y")),
        (110.0, 15.0)
    );
    // The approach: Z rose first (never below the range's start level while moving across)
    // and the spindle turned (M3 S1200 of N40) before the range's feed moves.
    let rows = trace_rows(&trace);
    let start_z = 190.0 - 165.52;
    for (_, [x, _, z]) in &rows {
        if *x > 0.0 && *x < 110.0 {
            assert!((z - start_z).abs() < 1e-6, "crossed at Z {z}");
        }
    }
    assert!(part["axes"]["C"]["final_position"].as_f64().unwrap() > 1000.0);
}

#[test]
fn block_search_errors_name_the_nearest_block_or_the_order() {
    let dir = test_dir("search-bad");
    let p = write(&dir, "s.nc", SEARCH);
    let o = cnc402(&["run", &p, "--from", "N95"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("nearest: N90, N100"), "{}", stderr(&o));
    let o = cnc402(&["run", &p, "--from", "N110", "--to", "N90"]);
    assert_eq!(o.status.code(), Some(64), "{}", stderr(&o));
    assert!(stderr(&o).contains("comes before --from"), "{}", stderr(&o));
    let o = cnc402(&["run", &p, "--to", "N90"]);
    assert_eq!(o.status.code(), Some(64), "{}", stderr(&o));
}

#[test]
fn breaks_in_a_linuxcnc_o_word_sub_and_a_step_from_m0() {
    let dir = test_dir("oword");
    let p = write(
        &dir,
        "lc.ngc",
        "o100 sub\n  G91 G1 X5 F1000\n  G90\no100 endsub\nG21 G90 G17 G0 X0 Y0 Z5\n\
         o100 call\no100 call\nM0\nG0 X0\nG0 Z9\nM2\n",
    );
    let (v, _) = run_ok(
        &dir,
        &p,
        "continue\ncontinue\nstep\ncontinue\n",
        &["--dialect", "linuxcnc", "--break", "lc.ngc:2"],
    );
    // At M0 the operator steps: the hold comes before the next block.
    assert_eq!(breaks(&v), ["2 break", "2 break", "9 step"]);
    assert_eq!(v["stops"][0]["line"], 8);
    assert_eq!(v["stops"][0]["action"], "wait");
    assert!(v["stops"][0]["waited_s"].as_f64().unwrap() >= 0.0);
    let cmds: Vec<&str> = v["commands"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["command"].as_str().unwrap())
        .collect();
    assert_eq!(cmds, ["continue", "continue", "step", "continue"]);
    assert_eq!(final_pos(&v, "Z"), 9.0);
}

#[test]
fn step_holds_before_each_repetition_of_a_cycle_and_skip_passes_the_rest() {
    let dir = test_dir("repeat");
    let p = write(
        &dir,
        "cyc.nc",
        "G21 G90 G17\nN10 G0 X0 Y0 Z10\nN20 M3 S1000\nN30 G91 G99 G81 X10 Y0 Z-5 R-8 K4 F300\n\
         N40 G80 G90 G0 Z20\nN50 G0 X0\nN60 M30\n",
    );
    let trace = dir.join("t.csv");
    let (v, err) = run_ok(
        &dir,
        &p,
        "step\nstep\nskip\ncontinue\n",
        &[
            "--break",
            "N30",
            "--break",
            "N50",
            "--trace",
            trace.to_str().unwrap(),
        ],
    );
    // The break before the cycle, a hold before holes 2 and 3; skip runs holes 3 and 4 and
    // the program on to the break at N50.
    assert_eq!(
        breaks(&v),
        ["4 break", "4 repeat", "4 repeat", "6 break"],
        "{err}"
    );
    let rows = trace_rows(&trace);
    let at = |i: usize| rows[v["breaks"][i]["at_tick"].as_u64().unwrap() as usize].1;
    // Each repetition holds at the R level above the last hole, never in a hole.
    assert_eq!(at(1), [10.0, 0.0, 2.0]);
    assert_eq!(at(2), [20.0, 0.0, 2.0]);
    assert_eq!(at(3), [40.0, 0.0, 20.0]);
}
