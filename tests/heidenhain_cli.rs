//! Heidenhain contour programs through `cnc402 segments` and `run` (issue 16): RND, CHF,
//! CT, CR and Q parameters give the paths computed by hand, the example runs and matches
//! its reviewed dump, and what cannot be read is an error at `file:line:col`.
//! `UPDATE_GOLDEN=1 cargo test --test heidenhain_cli` rewrites the dump: review it.

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

fn tmp(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cnc402-heid-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn segments(program: &Path) -> Vec<serde_json::Value> {
    let o = cnc402(&["segments", program.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    String::from_utf8(o.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn xy(v: &serde_json::Value) -> (f64, f64) {
    (v["X"].as_f64().unwrap(), v["Y"].as_f64().unwrap())
}

fn near(a: (f64, f64), b: (f64, f64)) -> bool {
    (a.0 - b.0).abs() < 1e-6 && (a.1 - b.1).abs() < 1e-6
}

/// A feed move: `line`, `cw` or `ccw`, its end and an arc's centre.
type Step = (String, (f64, f64), Option<(f64, f64)>);

fn path(segs: &[serde_json::Value]) -> Vec<Step> {
    segs.iter()
        .filter(|s| s["kind"] == "linear" || s["kind"] == "arc")
        .map(|s| {
            let centre = (s["kind"] == "arc").then(|| xy(&s["center"]));
            let kind = match s["dir"].as_str() {
                Some(d) => d.to_string(),
                None => "line".into(),
            };
            (kind, xy(&s["end"]), centre)
        })
        .collect()
}

#[test]
fn rnd_chf_ct_cr_and_q_parameters_give_the_path_computed_by_hand() {
    let p = tmp(
        "shapes.h",
        "0 BEGIN PGM SHAPES MM\n\
         1 Q5 = +5\n\
         2 FN 3: Q6 = +Q5 * +2\n\
         3 L X+0 Y+0 Z+0 R0 FMAX\n\
         4 L X+20 F200\n\
         5 RND R+Q5\n\
         6 L Y+20\n\
         7 CHF 4\n\
         8 L X-Q6\n\
         9 CT X-20 Y+0\n\
         10 CR X+0 Y-20 R+20 DR+\n\
         11 M30\n\
         12 END PGM SHAPES MM\n",
    );
    let got = path(&segments(&p));
    // By hand: the square corner at (20,0) rounded with R5 (legs cut by 5, centre 5 in);
    // the corner at (20,20) chamfered 4 on each leg; from (-10,20) going -X, the arc
    // tangent to it to (-20,0) has its centre on x = -10 at (-10,7.5) (as far from both
    // ends); CR R+20 counter-clockwise from (-20,0) to (0,-20): the short arc about (0,0).
    let want = [
        ("line", (15.0, 0.0), None),
        ("ccw", (20.0, 5.0), Some((15.0, 5.0))),
        ("line", (20.0, 16.0), None),
        ("line", (16.0, 20.0), None),
        ("line", (-10.0, 20.0), None),
        ("ccw", (-20.0, 0.0), Some((-10.0, 7.5))),
        ("ccw", (0.0, -20.0), Some((0.0, 0.0))),
    ];
    assert_eq!(got.len(), want.len(), "{got:?}");
    for (g, w) in got.iter().zip(want) {
        assert_eq!(g.0, w.0, "{got:?}");
        assert!(near(g.1, w.1), "{g:?} vs {w:?}");
        match (g.2, w.2) {
            (Some(a), Some(b)) => assert!(near(a, b), "{g:?} vs {w:?}"),
            (None, None) => {}
            _ => panic!("{g:?} vs {w:?}"),
        }
    }
}

#[test]
fn an_rnd_read_across_the_readers_buffer_is_the_same_as_any_other() {
    // Enough corners that some L, RND and L lines straddle the end of the reader's
    // 64 KiB buffer: the L looks ahead past it.
    let mut text = String::from("0 BEGIN PGM MANY MM\n1 L X+0 Y+0 Z+0 R0 FMAX\n");
    let corners = 3000;
    for i in 0..corners {
        text.push_str(&format!(
            "{} L X+20 Y+0 F500 ; padding that moves the lines along the buffer {i}\n\
             RND R5\nL X+20 Y+20\nL X+0 Y+0\n",
            i + 2
        ));
    }
    text.push_str("M30\nEND PGM MANY MM\n");
    assert!(text.len() > 3 << 16);
    let got = path(&segments(&tmp("many.h", &text)));
    let arcs: Vec<_> = got.iter().filter(|s| s.2.is_some()).collect();
    assert_eq!(arcs.len(), corners);
    assert!(
        arcs.iter()
            .all(|a| near(a.1, (20.0, 5.0)) && near(a.2.unwrap(), (15.0, 5.0))),
        "{arcs:?}"
    );
}

#[test]
fn contour_blocks_that_cannot_be_read_are_errors_at_their_line() {
    for (body, at, why) in [
        (
            "1 TOOL CALL 1 Z S1000\n2 RND R5\n3 L X+9 Y+9\n",
            ":3:1",
            "RND after a block that is not a straight L",
        ),
        (
            "1 L X+0 Y+0 FMAX\n2 CR X+10 Y+0 R+4 DR+ F100\n",
            ":3:1",
            "CR radius 4 is smaller than half the chord",
        ),
        (
            "1 L X+0 Y+0 Z+5 FMAX\n2 CT X+10 Y+10 F100\n",
            ":3:1",
            "CT with no previous contour direction",
        ),
    ] {
        let p = tmp("bad.h", &format!("0 BEGIN PGM BAD MM\n{body}"));
        let o = cnc402(&["segments", p.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(exit::PROGRAM.into()), "{body}");
        // The message as one line (the report wraps it).
        let e = stderr(&o).replace('│', " ");
        let e = e.split_whitespace().collect::<Vec<_>>().join(" ");
        assert!(
            e.contains(&format!("bad.h{at}")) && e.contains(why),
            "{body}: {e}"
        );
    }
}

#[test]
fn the_heidenhain_contour_example_runs_and_matches_its_reviewed_dump() {
    let example = "examples/heidenhain/contour.h";
    let o = cnc402(&["segments", example]);
    assert!(o.status.success(), "{}", stderr(&o));
    let got = String::from_utf8(o.stdout).unwrap();
    let golden = repo().join("examples/heidenhain/contour.segments.jsonl");
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        std::fs::write(&golden, &got).unwrap();
    }
    let want = std::fs::read_to_string(&golden).expect("the reviewed dump");
    assert_eq!(got, want);
    let o = cnc402(&["run", example]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).starts_with("ok:"));
}

/// The load pass read the lines in file order, so a Q parameter that a label body called
/// before the block sets had no value yet there: the program was refused at load although
/// it runs. Now the block reads the value the run has; with none, the run stops there.
#[test]
fn a_q_parameter_a_called_label_sets_was_refused_before_the_call_ran() {
    let p = tmp(
        "sub.h",
        "0 BEGIN PGM SUB MM
1 L X+0 Y+0 Z+0 R0 FMAX
2 CALL LBL 1
3 L X+Q5 F100
\
         4 M30
5 LBL 1
6 Q5 = 10
7 LBL 0
8 END PGM SUB MM
",
    );
    let got = path(&segments(&p));
    assert_eq!(got.len(), 1);
    assert!(near(got[0].1, (10.0, 0.0)), "{got:?}");
    let p = tmp(
        "unset.h",
        "0 BEGIN PGM U MM
1 L X+0 Y+0 Z+0 R0 FMAX
2 L X+Q5 F100
3 M30
",
    );
    let o = cnc402(&["segments", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(exit::PROGRAM.into()));
    let e = stderr(&o);
    assert!(
        e.contains("unset.h:3:1") && e.contains("Q5 HAS NO VALUE"),
        "{e}"
    );
}
