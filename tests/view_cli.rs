//! `cnc402 which` (point → block) and `cnc402 view` (the toolpath page) from the command
//! line: lines, arcs, helices, canned cycles and taps, sub-programs in other files, work and
//! machine coordinates, errors part-way, breakpoints, traces, exit codes. The page's picking
//! in a browser is tests/view_browser.rs.

use std::path::PathBuf;
use std::process::{Command, Output};

fn cnc402(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("RUST_LOG", "warn")
        .output()
        .expect("run cnc402")
}

fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cnc402-view-cli-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn out(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// The block (`file:line N…`) and distance of each line `which` printed, nearest first.
fn hits(stdout: &str) -> Vec<(String, f64)> {
    stdout
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            let block =
                if f[3].starts_with('N') && f[3].len() > 1 && f[3][1..].parse::<u32>().is_ok() {
                    format!("{} {}", f[2], f[3])
                } else {
                    f[2].to_string()
                };
            (block, f[0].parse().unwrap())
        })
        .collect()
}

#[test]
fn which_finds_the_wrong_z_of_the_lab_example() {
    let o = cnc402(&[
        "which",
        "examples/lab-contour/contour.nc",
        "-10.8",
        "44",
        "40",
        "-n",
        "2",
    ]);
    let (so, se) = out(&o);
    assert_eq!(o.status.code(), Some(0), "{se}");
    assert!(
        so.starts_with("blocks nearest X-10.8 Y44 Z40 (work coordinates"),
        "{so}"
    );
    let h = hits(&so);
    assert_eq!(h[0].0, "examples/lab-contour/contour.nc:1984 N1981", "{so}");
    assert!(h[0].1 < 0.02, "{so}");
    // Down again from the spike: N1982 starts where N1981 ends.
    assert_eq!(h[1].0, "examples/lab-contour/contour.nc:1985 N1982", "{so}");
    assert!(so.contains("| N1981 G1 X-10.803 Y43.983 Z40.524"), "{so}");
}

#[test]
fn which_far_from_every_path_says_how_far_and_exits_5() {
    let o = cnc402(&["which", "examples/contour-arcs.nc", "200", "0", "-2"]);
    let (so, se) = out(&o);
    assert_eq!(o.status.code(), Some(5), "{se}");
    // (miette wraps long messages: the test reads them in pieces.)
    assert!(
        se.contains("no path passes within 1 mm of the point"),
        "{se}"
    );
    assert!(se.contains("N220 at 90.000 mm"), "{se}");
    // N220 G0 Z50 rises at X110 through Z-2: 90 mm; the helix N200 passes X110 at Z-1.5.
    assert_eq!(hits(&so)[0].0, "examples/contour-arcs.nc:28 N220");
    assert_eq!(hits(&so)[1].0, "examples/contour-arcs.nc:26 N200");
    assert!((hits(&so)[1].1 - 90.0f64.hypot(0.5)).abs() < 1e-3, "{so}");
    let o = cnc402(&[
        "which",
        "examples/contour-arcs.nc",
        "200",
        "0",
        "-2",
        "--within",
        "100",
    ]);
    assert_eq!(o.status.code(), Some(0));
}

#[test]
fn which_measures_arcs_and_helices_exactly() {
    // N190: full CCW turn around X100 Y0 from X110, Z 0 → -1.5: halfway it is at X90 Z-0.75.
    let o = cnc402(&[
        "which",
        "examples/contour-arcs.nc",
        "90",
        "0",
        "-0.75",
        "-n",
        "3",
    ]);
    let (so, se) = out(&o);
    assert_eq!(o.status.code(), Some(0), "{se}");
    let h = hits(&so);
    assert_eq!(h[0].0, "examples/contour-arcs.nc:25 N190", "{so}");
    assert!(h[0].1 < 1e-3, "{so}");
    // The next turn is 1.5 mm lower (N200, at Z-2.25 there).
    assert_eq!(h[1].0, "examples/contour-arcs.nc:26 N200", "{so}");
    assert!((h[1].1 - 1.5).abs() < 1e-3, "{so}");
    // 0.5 mm outside the N80 bulge (centre X60 Y20, R5, CCW through X65).
    let o = cnc402(&[
        "which",
        "examples/contour-arcs.nc",
        "65.5",
        "20",
        "-2",
        "-n",
        "1",
    ]);
    let (so, _) = out(&o);
    assert_eq!(hits(&so)[0].0, "examples/contour-arcs.nc:14 N80", "{so}");
    assert!((hits(&so)[0].1 - 0.5).abs() < 1e-6, "{so}");
}

#[test]
fn which_sees_cycles_expanded_and_taps() {
    let o = cnc402(&[
        "which",
        "examples/m10x1.5-rigid-tap.nc",
        "20",
        "20",
        "-10",
        "-n",
        "1",
    ]);
    let (so, se) = out(&o);
    assert_eq!(o.status.code(), Some(0), "{se}");
    assert!(
        so.contains("examples/m10x1.5-rigid-tap.nc:11 N40  tap"),
        "{so}"
    );
    // A hole of the Macro B bolt circle, drilled by a G81 repeated in a WHILE loop (line 19).
    let o = cnc402(&[
        "which",
        "examples/bolt-circle-drilling.nc",
        "70",
        "64.641",
        "-0.5",
        "-n",
        "1",
    ]);
    let (so, se) = out(&o);
    assert_eq!(o.status.code(), Some(0), "{se}");
    assert!(so.contains("examples/bolt-circle-drilling.nc:19 "), "{so}");
    // A tap of the C-like cycle language, in its `#use` file (a statement is a block).
    let o = cnc402(&[
        "which",
        "examples/axioma/multipass_tap.nc",
        "0",
        "0",
        "-11",
        "-n",
        "1",
    ]);
    let (so, se) = out(&o);
    assert_eq!(o.status.code(), Some(0), "{se}");
    assert!(
        so.contains("examples/axioma/metch_cycles.c:38  tap"),
        "{so}"
    );
}

#[test]
fn which_uses_each_blocks_work_offsets_or_machine_coordinates() {
    let d = scratch("offsets");
    let p = d.join("offsets.nc");
    // G55 puts the work zero at machine X100; G43 H1 adds tool 1's length -180 to Z.
    std::fs::write(
        &p,
        "N1 G90 G55 G0 X0 Y0\nN2 G43 H1 Z10.\nN3 G1 Z-1. F100.\nN4 G1 X20.\nN5 G54 G49 G0 Z0\nN6 M30\n",
    )
    .unwrap();
    let prog = p.to_str().unwrap();
    let o = cnc402(&["which", prog, "15", "0", "-1", "-n", "1"]);
    let (so, se) = out(&o);
    assert_eq!(o.status.code(), Some(0), "{se}");
    assert!(
        so.contains("offsets.nc:4 N4") && so.contains("at X15.000 Y0.000 Z-1.000"),
        "{so}"
    );
    let o = cnc402(&["which", prog, "115", "0", "-181", "-n", "1", "--machine"]);
    let (so, se) = out(&o);
    assert_eq!(o.status.code(), Some(0), "{se}");
    assert!(
        so.contains("(machine coordinates)") && so.contains("offsets.nc:4 N4"),
        "{so}"
    );
    // The same numbers as machine coordinates are nowhere near the path.
    let o = cnc402(&["which", prog, "15", "0", "-100", "--machine"]);
    assert_eq!(o.status.code(), Some(5));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn which_names_the_file_of_a_sub_program() {
    let d = scratch("sub");
    std::fs::write(
        d.join("main.nc"),
        "N1 G90 G0 X0 Y0 Z5\nN2 M98 P1234\nN3 M30\n",
    )
    .unwrap();
    std::fs::write(
        d.join("O1234.nc"),
        "O1234\nN10 G1 Z-1 F100\nN20 G1 X7\nM99\n",
    )
    .unwrap();
    let main = d.join("main.nc");
    let o = cnc402(&["which", main.to_str().unwrap(), "3.5", "0", "-1", "-n", "1"]);
    let (so, se) = out(&o);
    assert_eq!(o.status.code(), Some(0), "{se}");
    assert!(
        so.contains("O1234.nc:3 N20") && so.contains("| N20 G1 X7"),
        "{so}"
    );
    // The dialect may be chosen as for every command.
    let o = cnc402(&[
        "which",
        "--dialect",
        "haas",
        main.to_str().unwrap(),
        "0",
        "0",
        "3",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", out(&o).1);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn which_answers_for_what_ran_before_a_program_error_then_exits_2() {
    let d = scratch("error");
    let p = d.join("bad.nc");
    std::fs::write(
        &p,
        "N10 G90 G0 X0 Y0 Z5\nN20 G1 X10 F100\nN30 G1 X400\nN40 M30\n",
    )
    .unwrap();
    let o = cnc402(&["which", p.to_str().unwrap(), "5", "0", "5"]);
    let (so, se) = out(&o);
    assert_eq!(o.status.code(), Some(2), "{se}");
    assert!(so.contains("bad.nc:2 N20"), "{so}");
    assert!(se.contains("bad.nc:3:8: X 400 is outside the soft"), "{se}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn which_refuses_bad_usage() {
    for args in [
        &["which", "examples/contour-arcs.nc", "1", "2"][..],
        &["which", "examples/contour-arcs.nc", "1", "2", "x"],
        &[
            "which",
            "examples/contour-arcs.nc",
            "1",
            "2",
            "3",
            "--within",
            "-1",
        ],
        &[
            "which",
            "examples/contour-arcs.nc",
            "1",
            "2",
            "3",
            "-n",
            "0",
        ],
    ] {
        assert_eq!(cnc402(args).status.code(), Some(64), "{args:?}");
    }
    assert_eq!(
        cnc402(&["which", "no-such.nc", "1", "2", "3"])
            .status
            .code(),
        Some(4)
    );
}

#[test]
fn view_writes_a_self_contained_page_with_breakpoints_and_warns_on_missing_ones() {
    let d = scratch("page");
    let page = d.join("p.html");
    let o = cnc402(&[
        "view",
        "examples/lab-contour/contour.nc",
        "-o",
        page.to_str().unwrap(),
        "--break",
        "N1700",
        "--break",
        "contour.nc:2203",
        "--break",
        "N9999",
    ]);
    let (_, se) = out(&o);
    assert_eq!(o.status.code(), Some(0), "{se}");
    assert!(
        se.contains("warning: breakpoint N9999: no block N9999 in the program; nearest: N2408 (examples/lab-contour/contour.nc:2411 N2408), N2409"),
        "{se}"
    );
    assert!(!se.contains("N1700:") && !se.contains("2203:"), "{se}");
    let html = std::fs::read_to_string(&page).unwrap();
    // One file: no script, style, image or font from anywhere else.
    for bad in ["src=", "href=", "http://", "https://", "@import", "url("] {
        assert!(!html.contains(bad), "the page refers outside itself: {bad}");
    }
    assert!(
        html.contains("\"spec\":\"N1700\",\"warning\":null"),
        "N1700 marked"
    );
    assert!(
        !html.contains("\"blocks\":[],\"spec\":\"N1700\""),
        "N1700 marked"
    );
    assert!(
        html.contains("\"blocks\":[],\"spec\":\"N9999\""),
        "N9999 not marked"
    );
    assert!(html.contains("N1981 G1 X-10.803 Y43.983 Z40.524"));
    let o = cnc402(&[
        "view",
        "examples/contour-arcs.nc",
        "-o",
        page.to_str().unwrap(),
        "--break",
        "N12x",
    ]);
    assert_eq!(o.status.code(), Some(64));
    assert!(
        out(&o)
            .1
            .contains("expected N<number> (N1700) or FILE:LINE")
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn view_overlays_a_runs_trace() {
    let d = scratch("trace");
    let trace = d.join("t.csv");
    let page = d.join("t.html");
    let o = cnc402(&[
        "run",
        "examples/contour-arcs.nc",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", out(&o).1);
    let o = cnc402(&[
        "view",
        "examples/contour-arcs.nc",
        "-o",
        page.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", out(&o).1);
    let html = std::fs::read_to_string(&page).unwrap();
    let trace_at = html
        .find("\"trace\":{\"act\":[")
        .expect("the trace is on the page");
    assert!(html[trace_at..].contains("\"cmd\":["));
    std::fs::write(&trace, "not,a,trace\n").unwrap();
    let o = cnc402(&[
        "view",
        "examples/contour-arcs.nc",
        "-o",
        page.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(4));
    assert!(
        out(&o).1.contains("the trace header has no `line`"),
        "{}",
        out(&o).1
    );
    let _ = std::fs::remove_dir_all(&d);
}
