//! `cnc402 run MAIN --channel 1=FILE` on the two-channel example machine: both programs in
//! one loop, the report per channel, and the errors (a bad `--channel`, a program error in
//! the second channel, a drive fault stopping every channel) with their channel.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

const TWO: &str = "examples/axioma/two-channel.toml";

fn cnc402(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("RUST_LOG", "warn")
        .output()
        .expect("run cnc402")
}

/// A folder of the test's own.
fn dir(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cnc402-channels-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn program(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn final_position(report: &Value, channel: usize, axis: &str) -> f64 {
    report["channels"][channel]["report"]["axes"][axis]["final_position"]
        .as_f64()
        .unwrap()
}

/// `cnc402 run A --channel 1=B --report d/r.json EXTRA…` on the two-channel machine; its
/// output and report.
fn run_two(d: &Path, a: &str, b: &str, extra: &[&str]) -> (Output, Value) {
    let r = d.join("r.json");
    let channel = format!("1={b}");
    let mut args = vec!["--config", TWO, "run", a, "--channel", &channel];
    args.extend(["--report", r.to_str().unwrap()]);
    args.extend(extra);
    let o = cnc402(&args);
    let rep = std::fs::read_to_string(&r)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or(Value::Null);
    (o, rep)
}

#[test]
fn two_channels_run_their_programs_concurrently_with_a_report_per_channel() {
    let d = dir("ok");
    let a = program(&d, "a.nc", "G90 G0 X10 Y5\nG1 X20 F600\nM30\n");
    let b = program(&d, "b.nc", "G90 G1 U20 W-5 F1200\nG0 U-3\nM30\n");
    let trace = d.join("t.csv");
    let (o, rep) = run_two(&d, &a, &b, &["--trace", trace.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    let trace = std::fs::read_to_string(d.join("t.csv")).unwrap();
    let mut rows = trace.lines();
    let header = rows.next().unwrap();
    assert!(
        header.starts_with("t,line,line_ch1,X_cmd,X_act,"),
        "{header}"
    );
    assert!(
        header.contains(",U_cmd,U_act,V_cmd,V_act,W_cmd,W_act,"),
        "{header}"
    );
    let last: Vec<&str> = rows.last().unwrap().split(',').collect();
    // Channel 0 ended at line 3 (M30), channel 1 at line 3; U at -3.
    assert_eq!((last[1], last[2]), ("3", "3"), "{last:?}");
    assert_eq!(last[11], "-3", "{last:?}");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("== channel 0 (main): ") && out.contains("== channel 1 (sub): "));
    assert_eq!(rep["ok"], true);
    assert_eq!(final_position(&rep, 0, "X"), 20.0);
    assert_eq!(final_position(&rep, 0, "Y"), 5.0);
    assert_eq!(final_position(&rep, 1, "U"), -3.0);
    assert_eq!(final_position(&rep, 1, "W"), -5.0);
    // One loop: both channels' cyclic phases share one clock, so neither waited for the other.
    let ticks = |k: usize| rep["channels"][k]["report"]["ticks"].as_u64().unwrap();
    let (t0, t1) = (ticks(0), ticks(1));
    assert!(t0.max(t1) < t0 + t1 - 100, "{t0} {t1}");
}

#[test]
fn a_bad_channel_option_is_a_usage_error() {
    let d = dir("usage");
    let a = program(&d, "a.nc", "G0 X1\nM30\n");
    for (config, arg, want) in [
        (TWO, format!("5={a}"), "this machine has 2 channel"),
        (TWO, format!("0={a}"), "channel 0 runs PROGRAM"),
        (TWO, "1".to_string(), "expected N=FILE"),
        (
            "config/machine.toml",
            format!("1={a}"),
            "this machine has 1 channel",
        ),
    ] {
        let o = cnc402(&["--config", config, "run", &a, "--channel", &arg]);
        assert_eq!(o.status.code(), Some(64), "{arg}: {}", text(&o));
        // miette wraps long messages: compare the words.
        let words = text(&o).replace('│', " ");
        let words: Vec<&str> = words.split_whitespace().collect();
        assert!(words.join(" ").contains(want), "{arg}: {}", text(&o));
    }
}

#[test]
fn a_program_error_in_channel_1_names_the_channel_and_the_line_before_motion() {
    let d = dir("program-error");
    let a = program(&d, "a.nc", "G0 X1\nM30\n");
    let b = program(&d, "b.nc", "G0 U1\nG0 X5\nM30\n");
    let o = cnc402(&["--config", TWO, "run", &a, "--channel", &format!("1={b}")]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let t = text(&o);
    assert!(t.contains("channel 1 (sub)") && t.contains("b.nc:2"), "{t}");
}

#[test]
fn a_drive_fault_in_channel_1_stops_both_channels_and_says_where() {
    let d = dir("fault");
    let a = program(&d, "a.nc", "G90 G1 X100 F600\nM30\n");
    let b = program(&d, "b.nc", "G90 G1 U100 F600\nM30\n");
    let (o, rep) = run_two(&d, &a, &b, &["--inject-fault", "5:8611@0.5"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert_eq!(rep["ok"], false);
    for k in 0..2 {
        assert_eq!(rep["channels"][k]["ok"], false, "channel {k}");
    }
    let err = rep["error"].as_str().unwrap();
    assert!(err.starts_with("channel "), "{err}");
    assert!(final_position(&rep, 0, "X") < 50.0);
    assert!(final_position(&rep, 1, "U") < 50.0);
}

#[test]
fn two_channels_run_in_real_time_too_with_the_same_setpoints() {
    let d = dir("realtime");
    let a = program(&d, "a.nc", "G90 G0 X10 Y5\nG1 X20 F600\nM30\n");
    let b = program(&d, "b.nc", "G90 G1 U20 W-5 F1200\nG0 U-3\nM30\n");
    let mut rows = Vec::new();
    for (name, rt) in [("v.csv", false), ("rt.csv", true)] {
        let trace = d.join(name);
        let mut args = vec![
            "--config".to_string(),
            TWO.to_string(),
            "run".to_string(),
            a.clone(),
            "--channel".to_string(),
            format!("1={b}"),
            "--trace".to_string(),
            trace.display().to_string(),
        ];
        if rt {
            args.push("--realtime".into());
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = cnc402(&args);
        assert!(o.status.success(), "{}", text(&o));
        let t = std::fs::read_to_string(&trace).unwrap();
        // Each channel's setpoints are the same whatever the clock; in real time a channel
        // may start a tick later than in virtual time (its feeder is not waited for), so the
        // channels are compared each on its own, repeats (ticks at rest) left out.
        let column = |i: usize| {
            let mut v: Vec<String> = t
                .lines()
                .skip(1)
                .map(|l| l.split(',').nth(i).unwrap().to_string())
                .collect();
            v.dedup();
            // Ticks at the start position before the channel's first move.
            let moved = v.iter().position(|x| x != "0").unwrap_or(v.len());
            v.split_off(moved)
        };
        rows.push((column(3), column(11)));
    }
    assert_eq!(rows[0], rows[1]);
    assert_eq!(rows[0].1.last().map(String::as_str), Some("-3"));
}

/// hil-tests/scenarios/15-two-channels.sh in process: the same programs on the embedded
/// simulator (the example machine the scenario's config is made from), in real time as on
/// vcan, with the scenario's run assertions.
#[test]
fn hil_15_two_channels_in_process() {
    let d = dir("hil15");
    let r = d.join("r.json");
    let o = cnc402(&[
        "--config",
        TWO,
        "run",
        "hil-tests/scenarios/programs/two-channel-main.nc",
        "--channel",
        "1=hil-tests/scenarios/programs/two-channel-sub.nc",
        "--realtime",
        "--report",
        r.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let rep: Value = serde_json::from_str(&std::fs::read_to_string(&r).unwrap()).unwrap();
    assert_eq!(rep["ok"], true);
    assert_eq!(rep["channels"][0]["ok"], true);
    assert_eq!(rep["channels"][1]["ok"], true);
    for (k, axis, want) in [
        (0, "X", 40.0),
        (0, "Y", 20.0),
        (1, "U", 25.0),
        (1, "W", 0.0),
    ] {
        let got = final_position(&rep, k, axis);
        assert!((got - want).abs() < 0.001, "{axis}: {got}");
    }
}

/// Source 000's regression-test program, as printed (typos fixed), on channel 0: it checks
/// channel 1 is in Auto and ready, then loads and runs 01.nc and 02.nc there; channel 1's
/// U V W end where 02.nc leaves them, and the run passes.
#[test]
fn the_seeds_regression_test_runs_its_part_programs_on_channel_1() {
    let d = dir("seed");
    let r = d.join("r.json");
    let o = cnc402(&[
        "--config",
        TWO,
        "run",
        "examples/axioma/regression_test.nc",
        "--report",
        r.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let all = text(&o);
    assert_eq!(all.matches("MSG: Kanal zapuwen").count(), 2, "{all}");
    let rep: Value = serde_json::from_str(&std::fs::read_to_string(&r).unwrap()).unwrap();
    assert_eq!(rep["ok"], true, "{rep}");
    let programs = rep["channels"][1]["programs"].to_string();
    assert!(
        programs.contains("01.nc") && programs.contains("02.nc"),
        "{programs}"
    );
    assert!((final_position(&rep, 1, "W") - 5.0).abs() < 1e-3, "{rep}");
    assert!(final_position(&rep, 1, "U").abs() < 1e-3, "{rep}");
}

/// The variant with a part program that fails on purpose (zero feed): channel_run fails,
/// the retry after channel_reset fails too, and the test program ends with terminate 5558
/// at its line; channel 1 stops as the other channel's error, not as an operator's stop.
#[test]
fn the_seeds_regression_test_with_a_failing_program_ends_in_terminate_5558() {
    let o = cnc402(&[
        "--config",
        TWO,
        "run",
        "examples/axioma/regression_test_fails.nc",
    ]);
    let all = text(&o);
    assert_eq!(o.status.code(), Some(2), "{all}");
    assert!(
        all.contains("regression_test_fails.nc:47:13") && all.contains("terminate 5558"),
        "{all}"
    );
    assert!(
        all.matches("03_zero_feed.nc:5:5: zero feed").count() >= 2,
        "{all}"
    );
    assert!(all.contains("another channel stopped"), "{all}");
    // Each channel's stop names its own axes (was "all axes stopped" for every channel).
    assert!(all.contains("this channel's axes stopped (U V W)"), "{all}");
    assert!(!all.contains("SIGINT"), "{all}");
}

/// Fanuc's multi-path wait: `M100 P12` in both programs; channel 1 reaches it first (a
/// short move) and waits at rest until channel 0 gets there, then both go on together.
#[test]
fn m100_p12_holds_the_first_channel_until_the_other_reaches_it() {
    let d = dir("m100");
    let a = program(&d, "a.nc", "G90 G1 X30 F600\nM100 P12\nG1 Y10 F600\nM30\n");
    let b = program(&d, "b.nc", "G90 G1 U1 F600\nM100 P12\nG1 U5 F600\nM30\n");
    let trace = d.join("t.csv");
    let (o, rep) = run_two(&d, &a, &b, &["--trace", trace.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(rep["ok"], true, "{rep}");
    let trace = std::fs::read_to_string(trace).unwrap();
    let mut rows = trace.lines();
    let header: Vec<&str> = rows.next().unwrap().split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let (x, u) = (col("X_cmd"), col("U_cmd"));
    let rows: Vec<Vec<f64>> = rows
        .map(|r| {
            r.split(',')
                .map(|v| v.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    // U leaves 1 only once X has reached 30.
    let u_moves = rows.iter().position(|r| r[u] > 1.0 + 1e-6).unwrap();
    assert!(
        (rows[u_moves][x] - 30.0).abs() < 1e-6,
        "{:?}",
        rows[u_moves]
    );
    assert!(
        rows[..u_moves]
            .iter()
            .any(|r| (r[u] - 1.0).abs() < 1e-9 && r[x] < 29.0)
    );
}

/// Waits that can never all be met (channel 0 at M100, channel 1 at M101): both channels
/// stop, and the error names each channel's line.
#[test]
fn wait_marks_that_disagree_are_a_deadlock_naming_both_lines() {
    let d = dir("deadlock");
    let a = program(&d, "a.nc", "G90 G1 X5 F600\nM100 P12\nM30\n");
    let b = program(&d, "b.nc", "G90 G1 U5 F600\nM101 P12\nM30\n");
    let (o, _) = run_two(&d, &a, &b, &[]);
    let all = text(&o);
    assert!(!o.status.success(), "{all}");
    assert!(all.contains("deadlock"), "{all}");
    assert!(all.contains("a.nc:2") && all.contains("b.nc:2"), "{all}");
}

/// Channels exchange flags through the shared `$` globals: channel 1's program sets `$flag`,
/// channel 0 reads it after `channel_run`. The dry run (which runs nothing on channel 1)
/// would see the old value: it only warns, and the run decides.
#[test]
fn a_shared_flag_set_by_channel_1_is_read_by_channel_0() {
    let d = dir("flag");
    let main = program(
        &d,
        "main.nc",
        "bool ok;\n$flag = 0;\nok = channel_run(1, \"setflag.nc\");\n\
         if (ok == false) { terminate(1, \"run failed\"); }\n\
         if ($flag != 7) { terminate(2, \"flag not seen\"); }\nMSG(\"flag seen\");\n",
    );
    program(&d, "setflag.nc", "G90 G1 U5 F600;\n$flag = 7;\n");
    let o = cnc402(&["--config", TWO, "run", &main]);
    let all = text(&o);
    assert!(o.status.success(), "{all}");
    assert!(all.contains("MSG: flag seen"), "{all}");
    assert!(all.contains("checked again when it gets there"), "{all}");
}

/// The plot of a run of several channels, parsed by a strict XML parser (a malformed file or
/// an unescaped program name fails here); the run's title and each channel's section.
fn plot_sections(svg: &str) -> (roxmltree::Document<'_>, Vec<String>) {
    let doc = roxmltree::Document::parse(svg).unwrap_or_else(|e| panic!("not well-formed: {e}"));
    let ids = doc
        .root_element()
        .children()
        .filter(|n| n.has_tag_name("g"))
        .map(|n| n.attribute("id").unwrap_or("").to_string())
        .collect();
    (doc, ids)
}

/// The `<g id=…>` section of `doc`.
fn section<'a, 'i>(doc: &'a roxmltree::Document<'i>, id: &str) -> roxmltree::Node<'a, 'i> {
    doc.descendants()
        .find(|n| n.has_tag_name("g") && n.attribute("id") == Some(id))
        .unwrap_or_else(|| panic!("no section {id}"))
}

/// Every text drawn in `node`, trimmed.
fn texts(node: roxmltree::Node) -> Vec<String> {
    node.descendants()
        .filter(|n| n.has_tag_name("text"))
        .filter_map(|n| n.text().map(|t| t.trim().to_string()))
        .collect()
}

/// The points of every polyline of `stroke_width` in `node` with more than `min` points.
fn polylines(node: roxmltree::Node, stroke_width: &str, min: usize) -> Vec<Vec<(f64, f64)>> {
    node.descendants()
        .filter(|n| n.has_tag_name("polyline") && n.attribute("stroke-width") == Some(stroke_width))
        .map(|n| {
            n.attribute("points")
                .unwrap()
                .split_whitespace()
                .map(|p| {
                    let (x, y) = p.split_once(',').unwrap();
                    (x.parse().unwrap(), y.parse().unwrap())
                })
                .collect::<Vec<(f64, f64)>>()
        })
        .filter(|l| l.len() > min)
        .collect()
}

/// `--plot` of two channels: one section per channel in channel order, each headed by its
/// channel, program and outcome, with its own axes' toolpath (channel 1's in U V W), time
/// panels and (channel 0 taps) tapping panels; both time axes span the whole run, so channel
/// 0's series, which ends after about 2 s of about 6 s, ends a third of the way across.
#[test]
fn plot_of_two_channels_has_a_section_per_channel_on_one_time_axis() {
    let d = dir("plot");
    let a = program(
        &d,
        "main & <1>.nc",
        "G90 G0 X10 Y5 Z10\nM29 S600\nG95 G99 G84 X10 Y5 Z-5 R2 F1.25\nG80 G94\nG0 Z20\nM30\n",
    );
    let b = program(&d, "sub.nc", "G90 G1 U100 V20 F1200\nG1 W5\nM30\n");
    let plot = d.join("p.svg");
    let (o, rep) = run_two(&d, &a, &b, &["--plot", plot.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(!text(&o).contains("--plot"), "{}", text(&o));
    let svg = std::fs::read_to_string(&plot).unwrap();
    let (doc, ids) = plot_sections(&svg);
    assert_eq!(ids, ["channel-0", "channel-1"]);
    let title = texts(doc.root_element());
    assert!(title[0].contains("2 channels, one time axis"), "{title:?}");

    let (ch0, ch1) = (section(&doc, "channel-0"), section(&doc, "channel-1"));
    let (t0, t1) = (texts(ch0), texts(ch1));
    assert_eq!(t0[0], format!("channel 0 (main): {a} — finished"));
    assert_eq!(t1[0], format!("channel 1 (sub): {b} — finished"));
    assert_eq!(t1[1], format!("programs run: {b}: ok"));
    let has = |t: &[String], s: &str| t.iter().any(|x| x.starts_with(s));
    for panel in [
        "toolpath XY (from above)",
        "toolpath XZ (side view)",
        "commanded velocity per axis",
        "following error per axis",
        "rigid tapping: Z and C setpoints",
        "rigid-tap coupling error",
    ] {
        assert!(has(&t0, panel), "channel 0: no {panel:?} in {t0:?}");
    }
    for panel in [
        "toolpath UV (from above)",
        "toolpath UW (side view)",
        "commanded velocity per axis",
        "following error per axis",
    ] {
        assert!(has(&t1, panel), "channel 1: no {panel:?} in {t1:?}");
    }
    assert!(!has(&t1, "toolpath X") && !has(&t1, "rigid"), "{t1:?}");
    // Each channel's legends name its own axes only.
    let legend = |t: &[String], c: &str| t.iter().filter(|x| *x == c).count();
    for c in ["X", "Y", "Z", "C"] {
        assert_eq!((legend(&t0, c), legend(&t1, c)), (2, 0), "{c}");
    }
    for c in ["U", "V", "W"] {
        assert_eq!((legend(&t0, c), legend(&t1, c)), (0, 2), "{c}");
    }
    // Each toolpath is its channel's: channel 1's fastest is its F1200 (20 mm/s).
    assert!(has(
        &t1,
        "toolpath UV (from above), path speed blue 0 → red 20.0 mm/s"
    ));
    let path1: usize = polylines(ch1, "2", 1).iter().map(Vec::len).sum();
    assert!(path1 > 100, "channel 1's toolpath has {path1} points");

    // One time axis: the series start at the same pixel; channel 0's ends where its program
    // time falls on the run's.
    let time = |k: usize| {
        rep["channels"][k]["report"]["program_time_s"]
            .as_f64()
            .unwrap()
    };
    let span = |node| {
        let lines = polylines(node, "1", 10);
        let xs = lines.iter().flatten().map(|p| p.0);
        let lo = xs.clone().fold(f64::INFINITY, f64::min);
        (lo, xs.fold(f64::NEG_INFINITY, f64::max))
    };
    let ((lo0, hi0), (lo1, hi1)) = (span(ch0), span(ch1));
    assert_eq!(lo0, lo1, "time 0 at one pixel");
    let (expected, drawn) = (time(0) / time(1), (hi0 - lo0) / (hi1 - lo1));
    assert!(time(0) < 0.5 * time(1), "{} {}", time(0), time(1));
    assert!((drawn - expected).abs() < 0.02, "{drawn} vs {expected}");
}

/// The seed's regression test with `--plot`: channel 0's section names the test program,
/// channel 1's the part programs it ran there; a run that ends in a deadlock still writes
/// its plot, the deadlock under the channels.
#[test]
fn plot_of_the_seeds_regression_test_and_of_a_deadlock() {
    let d = dir("plot-seed");
    let plot = d.join("p.svg");
    let o = cnc402(&[
        "--config",
        TWO,
        "run",
        "--plot",
        plot.to_str().unwrap(),
        "examples/axioma/regression_test.nc",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let svg = std::fs::read_to_string(&plot).unwrap();
    let (doc, ids) = plot_sections(&svg);
    assert_eq!(ids, ["channel-0", "channel-1"]);
    // Channel 0 only runs channel 1's programs: said, not drawn as empty panels.
    let t0 = texts(section(&doc, "channel-0"));
    assert!(t0.iter().any(|t| t == "no axis moved: no panels"), "{t0:?}");
    assert!(polylines(section(&doc, "channel-0"), "2", 1).is_empty());
    let t1 = texts(section(&doc, "channel-1"));
    assert_eq!(t1[0], "channel 1 (sub): (none) — finished");
    assert_eq!(
        t1[1],
        "programs run: examples/axioma/01.nc: ok; examples/axioma/02.nc: ok"
    );
    let path1: usize = polylines(section(&doc, "channel-1"), "2", 1)
        .iter()
        .map(Vec::len)
        .sum();
    assert!(path1 > 100, "channel 1's toolpath has {path1} points");

    let a = program(&d, "a.nc", "G90 G1 X5 F600\nM100 P12\nM30\n");
    let b = program(&d, "b.nc", "G90 G1 U5 F600\nM101 P12\nM30\n");
    let (o, _) = run_two(&d, &a, &b, &["--plot", plot.to_str().unwrap()]);
    assert!(!o.status.success(), "{}", text(&o));
    let svg = std::fs::read_to_string(&plot).unwrap();
    let (doc, ids) = plot_sections(&svg);
    assert_eq!(ids, ["channel-0", "channel-1", "deadlock"]);
    let t = texts(section(&doc, "deadlock"));
    let said = t[1..].concat();
    assert!(said.contains("a.nc:2") && said.contains("b.nc:2"), "{t:?}");
}

/// A channel whose program fails while running (its report is the error) gets its heading
/// with the error and no panels; the other channel, stopped by it, its panels; the plot is
/// written although the run exits 2.
#[test]
fn plot_of_a_run_where_a_channels_program_fails_shows_the_error_in_its_section() {
    let d = dir("plot-error");
    let main = program(
        &d,
        "main.nc",
        "bool ok;\n$flag = 0;\nok = channel_run(1, \"setflag.nc\");\n\
         if ($flag != 7) { terminate(2, \"flag not seen\"); }\n",
    );
    program(&d, "setflag.nc", "G90 G1 U5 F600;\n$flag = 6;\n");
    let plot = d.join("p.svg");
    let o = cnc402(&[
        "--config",
        TWO,
        "run",
        &main,
        "--plot",
        plot.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let svg = std::fs::read_to_string(&plot).unwrap();
    let (doc, ids) = plot_sections(&svg);
    assert_eq!(ids, ["channel-0", "channel-1"]);
    let t0 = texts(section(&doc, "channel-0")).concat();
    assert!(t0.starts_with("channel 0 (main): "), "{t0}");
    assert!(
        t0.contains("— error:") && t0.contains("main.nc:4:19: "),
        "{t0}"
    );
    assert!(!t0.contains("toolpath"), "{t0}");
    let t1 = texts(section(&doc, "channel-1"));
    assert!(
        t1[0].contains("— stopped: another channel stopped"),
        "{t1:?}"
    );
    assert!(
        t1.iter().any(|t| t.starts_with("toolpath UV (from above)")),
        "{t1:?}"
    );
}
