//! `cnc402 post` end to end: the posted file is written and reads back as the job
//! (`cnc402 segments` of both agree), and each cause of failure ends with its exit code:
//! a job the target cannot express 2 (naming block and target), a wrong job 2, a missing
//! job 4, an unknown target 64.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use cnc402_config::exit;

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn cnc402(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(args)
        .current_dir(repo())
        .env_remove("RUST_LOG")
        .output()
        .expect("run cnc402")
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cnc402-post-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The segments of a program, one JSON line each, with file and line taken out.
fn segments(program: &str) -> Vec<serde_json::Value> {
    let o = cnc402(&["segments", program]);
    assert!(o.status.success(), "{}", stderr(&o));
    String::from_utf8(o.stdout)
        .unwrap()
        .lines()
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
            let m = v.as_object_mut().unwrap();
            for k in ["file", "line", "n"] {
                m.remove(k);
            }
            v
        })
        .collect()
}

#[test]
fn a_posted_program_is_written_and_segments_as_the_job() {
    let out = tmp("bolt.fanuc18.nc");
    let job = "examples/bolt-circle-drilling.nc";
    let o = cnc402(&[
        "post",
        "--target",
        "fanuc18",
        job,
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.starts_with("%\nO1000 (CNC402 POST FANUC18)\nN10 "),
        "{text}"
    );
    assert_same_segments(out.to_str().unwrap(), job);
}

/// Source 003's slot-milling cycle, the job's own Macro B program: posted for a Fanuc as
/// two `G65` calls and the program once, it segments as the job.
#[test]
fn the_slot_milling_cycle_posts_as_a_macro_call_and_segments_as_the_job() {
    let out = tmp("slot.fanuc16.nc");
    let job = "examples/slot-milling.nc";
    let o = cnc402(&[
        "post",
        "--target",
        "fanuc16",
        job,
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(text.matches(" G65 P8000 ").count(), 2, "{text}");
    assert_eq!(text.matches("\nO8000 ").count(), 1, "{text}");
    assert_same_segments(out.to_str().unwrap(), job);
}

/// `cnc402 post --target TARGET JOB -o <tmp>/OUT`, which must succeed: the file and its text.
fn posted(target: &str, job: &str, out: &str) -> (PathBuf, String) {
    let out = tmp(out);
    let o = cnc402(&["post", "--target", target, job, "-o", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).unwrap();
    (out, text)
}

/// `cnc402 segments` of the posted program and of the job agree within 1 µm (a spindle
/// segment that sets the speed and direction the spindle has changes nothing: not
/// compared, as in the post's proof).
fn assert_same_segments(posted: &str, job: &str) {
    let (back, want) = (changes(segments(posted)), changes(segments(job)));
    assert_eq!(back.len(), want.len());
    for (b, w) in back.iter().zip(&want) {
        assert!(close(b, w), "posted {b}, job {w}");
    }
}

/// `segments` without spindle segments that repeat the spindle's state.
fn changes(segments: Vec<serde_json::Value>) -> Vec<serde_json::Value> {
    let mut spindle = None;
    segments
        .into_iter()
        .filter(|s| {
            if s["kind"] != "spindle" {
                return true;
            }
            let now = Some((s["rpm"].clone(), s["dir"].clone()));
            std::mem::replace(&mut spindle, now.clone()) != now
        })
        .collect()
}

/// JSON values equal but for numbers, which may differ by 1 µm (the posted words' rounding).
fn close(a: &serde_json::Value, b: &serde_json::Value) -> bool {
    use serde_json::Value as V;
    match (a, b) {
        (V::Number(x), V::Number(y)) => (x.as_f64().unwrap() - y.as_f64().unwrap()).abs() <= 1e-3,
        (V::Object(x), V::Object(y)) => {
            x.len() == y.len() && x.iter().all(|(k, v)| y.get(k).is_some_and(|w| close(v, w)))
        }
        (V::Array(x), V::Array(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(v, w)| close(v, w))
        }
        _ => a == b,
    }
}

#[test]
fn standard_output_with_dash() {
    let o = cnc402(&[
        "post",
        "--target",
        "fanuc0",
        "examples/peck-tap.nc",
        "-o",
        "-",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains(" G84 "), "{text}");
}

#[test]
fn what_the_target_cannot_express_is_exit_2_naming_block_and_target() {
    let out = tmp("arcs.arumatik.nc");
    let o = cnc402(&[
        "post",
        "--target",
        "arumatik",
        "examples/contour-arcs.nc",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(exit::PROGRAM.into()));
    let e = stderr(&o);
    assert!(e.contains("block N190"), "{e}");
    assert!(e.contains("helical"), "{e}");
    assert!(e.contains("(target arumatik)"), "{e}");
    assert!(!out.exists(), "nothing is written for a refused job");
}

#[test]
fn a_wrong_job_a_missing_job_and_an_unknown_target() {
    let bad = tmp("bad.nc");
    std::fs::write(&bad, "G1 X10\n").unwrap();
    let o = cnc402(&[
        "post",
        "--target",
        "fanuc16",
        bad.to_str().unwrap(),
        "-o",
        "-",
    ]);
    assert_eq!(
        o.status.code(),
        Some(exit::PROGRAM.into()),
        "{}",
        stderr(&o)
    );
    assert!(stderr(&o).contains("zero feed"), "{}", stderr(&o));
    let o = cnc402(&["post", "--target", "fanuc16", "no/such.nc", "-o", "-"]);
    assert_eq!(o.status.code(), Some(exit::IO.into()), "{}", stderr(&o));
    let o = cnc402(&[
        "post",
        "--target",
        "fanuc15",
        "examples/peck-tap.nc",
        "-o",
        "-",
    ]);
    assert_eq!(o.status.code(), Some(exit::USAGE.into()), "{}", stderr(&o));
}

#[test]
fn an_itnc530_program_is_read_by_segments_through_the_heidenhain_reader() {
    let job = "post/tests/fixtures/contour.nc";
    let (out, text) = posted("itnc530", job, "contour.h");
    assert!(
        text.starts_with("0 BEGIN PGM CNC402 MM\n1 TOOL CALL 1 Z\n"),
        "{text}"
    );
    assert_same_segments(out.to_str().unwrap(), job);
}

#[test]
fn sub_programs_posted_as_itnc_labels_run_as_the_job_through_segments() {
    let job = "post/tests/fixtures/subprograms.nc";
    let (out, text) = posted("itnc530", job, "subprograms.h");
    assert!(text.contains("CALL LBL 3 REP 2\n"), "{text}");
    assert_same_segments(out.to_str().unwrap(), job);
}

#[test]
fn g83_posted_as_cycl_def_205_runs_as_the_job_through_segments() {
    let job = "post/tests/fixtures/pecking.nc";
    let (out, _) = posted("itnc530", job, "pecking.h");
    assert_same_segments(out.to_str().unwrap(), job);
}

/// `cnc402 which` and `view` parsed a program whole, so a Heidenhain program was a syntax
/// error at `0 BEGIN PGM`; they read it through the Heidenhain reader now, as `segments`.
#[test]
fn which_and_view_refused_a_heidenhain_program_as_a_syntax_error() {
    let h = tmp("which.h");
    let job = "post/tests/fixtures/contour.nc";
    let o = cnc402(&[
        "post",
        "--target",
        "itnc530",
        job,
        "-o",
        h.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = cnc402(&["which", h.to_str().unwrap(), "40", "-5", "-3"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8(o.stdout).unwrap();
    // The nearest block is named by its line and shown as the Heidenhain text.
    let first = out.lines().nth(1).unwrap_or("");
    assert!(
        first.contains("which.h:11") && first.ends_with("| 10 L X+40"),
        "{out}"
    );
    let page = tmp("which.html");
    let o = cnc402(&["view", h.to_str().unwrap(), "-o", page.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&page).unwrap().contains("which.h"));
}

#[test]
fn a_heidenhain_block_outside_the_subset_is_an_error_at_its_line() {
    let bad = tmp("bad.h");
    std::fs::write(
        &bad,
        "0 BEGIN PGM BAD MM\n1 TOOL CALL 1 Z S100\n2 CYCL DEF 203 UNIVERSAL DRILLING\n",
    )
    .unwrap();
    let o = cnc402(&["segments", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(exit::PROGRAM.into()));
    let e = stderr(&o);
    assert!(e.contains("bad.h:3:1"), "{e}");
    assert!(e.contains("cycle 203 is not in the subset"), "{e}");
}

#[test]
fn cl_data_with_a_tool_table() {
    let tools = "post/tests/fixtures/tools.toml";
    let job = "post/tests/fixtures/pocket.cl";
    let o = cnc402(&[
        "post", "--target", "fanuc32", "--tools", tools, job, "-o", "-",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("S4775 M3"), "{text}");
    // Without the table the cutting speed cannot be turned into rpm: exit 2 at its line.
    let o = cnc402(&["post", "--target", "fanuc32", job, "-o", "-"]);
    assert_eq!(o.status.code(), Some(exit::PROGRAM.into()));
    assert!(stderr(&o).contains("pocket.cl:7"), "{}", stderr(&o));
    // A wrong table is a usage error naming the file.
    let bad = tmp("tools.toml");
    std::fs::write(&bad, "[tool.1]\ndiameter = -1.0\nteeth = 2\n").unwrap();
    let o = cnc402(&[
        "post",
        "--target",
        "fanuc32",
        "--tools",
        bad.to_str().unwrap(),
        job,
        "-o",
        "-",
    ]);
    assert_eq!(o.status.code(), Some(exit::USAGE.into()));
    assert!(
        stderr(&o).contains("tool.1: diameter must be > 0"),
        "{}",
        stderr(&o)
    );
}

/// A Heidenhain program is a job too (iTNC → Fanuc conversion): read through the
/// Heidenhain reader (RND, CHF, CT, CR, Q parameters resolved to plain moves), posted for
/// every target and proven; `segments` of each result is the job's (it was a syntax error
/// at `0 BEGIN PGM`).
#[test]
fn a_heidenhain_job_posts_for_every_target_and_runs_as_the_job() {
    let job = "examples/heidenhain/contour.h";
    for (target, out) in [
        ("fanuc0", "hh-fanuc0.nc"),
        ("fanuc16", "hh-fanuc16.nc"),
        ("fanuc32", "hh-fanuc32.nc"),
        ("arumatik", "hh-arumatik.nc"),
        ("itnc530", "hh-itnc.h"),
    ] {
        let (out, _) = posted(target, job, out);
        assert_same_segments(out.to_str().unwrap(), job);
    }
}
