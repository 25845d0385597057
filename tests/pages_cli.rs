//! `cnc402 pages` from the outside: `--check` on every MLT980 pattern against hole positions
//! computed here from the pattern's definition (README of examples/mlt980), bad values and
//! the package's alarms exit 2 naming the field or the alarm, `--set` saves, `--start` runs,
//! `--plot` draws; and the screen in a real terminal (tmux): values typed, refused, saved,
//! the preview on the screen, start, and a power cut (kill -9) between two field saves.

use std::path::{Path, PathBuf};
use std::process::Command;

const PAGES: &str = "examples/mlt980/pages.toml";

/// A temporary folder with a machine config whose variables file is in it.
struct Machine {
    dir: PathBuf,
    config: PathBuf,
    vars: PathBuf,
}

impl Machine {
    fn new(tag: &str) -> Machine {
        let dir = std::env::temp_dir().join(format!("cnc402-pages-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let vars = dir.join("v.txt");
        let shipped = std::fs::read_to_string(root().join("config/machine.toml")).unwrap();
        let text = shipped.replace(
            "variables_file = \"../var/macro_variables.txt\"",
            &format!("variables_file = {:?}", vars.to_str().unwrap()),
        );
        assert_ne!(text, shipped);
        let config = dir.join("machine.toml");
        std::fs::write(&config, text).unwrap();
        Machine { dir, config, vars }
    }

    /// `cnc402 pages --config … PAGES args…`: exit code, stdout, stderr.
    fn pages(&self, args: &[&str]) -> (i32, String, String) {
        let out = Command::new(env!("CARGO_BIN_EXE_cnc402"))
            .arg("pages")
            .arg("--config")
            .arg(&self.config)
            .arg(PAGES)
            .args(args)
            .current_dir(root())
            .output()
            .unwrap();
        (
            out.status.code().unwrap_or(-1),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            flat(&String::from_utf8_lossy(&out.stderr)),
        )
    }

    fn file(&self) -> cnc402_interp::NvTable {
        cnc402_interp::NvTable::load(&self.vars).unwrap()
    }
}

impl Drop for Machine {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// A message as one line: miette's report wraps it at 80 columns under `×` and `│`.
fn flat(err: &str) -> String {
    err.lines()
        .map(|l| l.trim().trim_start_matches(['×', '│']).trim())
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join(" ")
}

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Process data every case shares: G81, G98, initial plane Z50, R 45 below it, 20 deeper.
const PROCESS: [&str; 9] = [
    "cycle=g81",
    "return=initial",
    "initial-z=50",
    "r=-45",
    "z=-20",
    "spindle=cw",
    "speed=800",
    "feed=150",
    "x=0",
];

fn sets(extra: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = Vec::new();
    for s in PROCESS.iter().chain(extra) {
        v.push("--set".into());
        v.push(s.to_string());
    }
    v
}

/// The `holes:` table of `--check`: (X, Y, cycle, R, bottom, return) per hole.
fn holes(out: &str) -> Vec<(f64, f64, String, f64, f64, f64)> {
    out.lines()
        .skip_while(|l| !l.starts_with("holes:"))
        .skip(2)
        .take_while(|l| !l.starts_with("alarm"))
        .map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            let n = |i: usize| w[i].parse::<f64>().unwrap();
            (n(1), n(2), w[3].to_string(), n(4), n(5), n(6))
        })
        .collect()
}

fn check_pattern(m: &Machine, extra: &[&str], want: &[(f64, f64)]) {
    let args = sets(extra);
    let args: Vec<&str> = args.iter().map(String::as_str).chain(["--check"]).collect();
    let (code, out, err) = m.pages(&args);
    assert_eq!(code, 0, "{extra:?}\n{out}{err}");
    let got = holes(&out);
    assert_eq!(got.len(), want.len(), "{extra:?}\n{out}");
    for (g, w) in got.iter().zip(want) {
        assert!(
            (g.0 - w.0).abs() < 1e-3 && (g.1 - w.1).abs() < 1e-3,
            "{extra:?}: {g:?} != {w:?}\n{out}"
        );
        // R 45 below the initial plane, bottom 20 below R, back to the initial plane.
        assert_eq!(
            (g.2.as_str(), g.3, g.4, g.5),
            ("G81", 5.0, -15.0, 50.0),
            "{out}"
        );
    }
}

fn polar(cx: f64, cy: f64, r: f64, deg: f64) -> (f64, f64) {
    let a = deg.to_radians();
    (cx + r * a.cos(), cy + r * a.sin())
}

#[test]
fn check_prints_the_holes_of_every_pattern() {
    let m = Machine::new("patterns");
    // Linear: the first hole one step from the start point, `count` holes.
    let linear: Vec<_> = (1..=4)
        .map(|k| (10.0 + 15.0 * k as f64, 20.0 + 5.0 * k as f64))
        .collect();
    check_pattern(
        &m,
        &[
            "pattern=linear",
            "y=20",
            "x=10",
            "count=4",
            "x-step=15",
            "y-step=5",
        ],
        &linear,
    );
    let arc: Vec<_> = (0..4)
        .map(|k| polar(5.0, -5.0, 20.0, 30.0 + 45.0 * k as f64))
        .collect();
    check_pattern(
        &m,
        &[
            "pattern=arc",
            "x=5",
            "y=-5",
            "radius=20",
            "start-angle=30",
            "angle-step=45",
            "holes=4",
        ],
        &arc,
    );
    let circle: Vec<_> = (0..6)
        .map(|k| polar(0.0, 0.0, 30.0, 60.0 * k as f64))
        .collect();
    check_pattern(
        &m,
        &["pattern=circle", "y=0", "radius=30", "holes=6"],
        &circle,
    );
    // By variable number too: #530 = 3, #507 = 5, #505 = 90.
    let five: Vec<_> = (0..5)
        .map(|k| polar(0.0, 0.0, 30.0, 90.0 + 72.0 * k as f64))
        .collect();
    check_pattern(&m, &["530=3", "y=0", "#504=30", "507=5", "505=90"], &five);
    // Grid: rows back and forth.
    let grid = [
        (0.0, 0.0),
        (10.0, 0.0),
        (20.0, 0.0),
        (20.0, 8.0),
        (10.0, 8.0),
        (0.0, 8.0),
    ];
    check_pattern(
        &m,
        &[
            "pattern=grid",
            "y=0",
            "rows=2",
            "count=3",
            "x-step=10",
            "y-step=8",
        ],
        &grid,
    );
    // Staggered: every second row shifted by half the pitch unless given.
    let stag = [
        (0.0, 0.0),
        (10.0, 0.0),
        (15.0, 8.0),
        (5.0, 8.0),
        (0.0, 16.0),
        (10.0, 16.0),
    ];
    let args = [
        "pattern=staggered",
        "y=0",
        "rows=3",
        "count=2",
        "x-step=10",
        "y-step=8",
    ];
    check_pattern(&m, &args, &stag);
    let shifted = [
        (0.0, 0.0),
        (10.0, 0.0),
        (13.0, 8.0),
        (3.0, 8.0),
        (0.0, 16.0),
        (10.0, 16.0),
    ];
    check_pattern(&m, &[&args[..], &["row-shift=3"]].concat(), &shifted);
    assert!(!m.vars.exists(), "--check saves nothing");
}

#[test]
fn bad_values_exit_2_naming_the_field_and_the_reason() {
    let m = Machine::new("bad");
    for (set, want) in [
        (
            "holes=0",
            "field `holes` (#507, Number of holes): 0 is out of range: >= 1 and <= 999",
        ),
        (
            "holes=2.5",
            "field `holes` (#507, Number of holes): 2.5 is not a whole number",
        ),
        (
            "pattern=hexagon",
            "field `pattern` (#530, Hole pattern): \"hexagon\" is not one of linear (1)",
        ),
        (
            "radius=-3",
            "field `radius` (#504, Radius): -3 is out of range: > 0",
        ),
        (
            "r=5",
            "field `r` (#503, R plane (from initial plane)): 5 is out of range",
        ),
        (
            "speed=",
            "field `speed` (#521, Spindle speed S): a value is required",
        ),
    ] {
        let mut args = sets(&["pattern=circle", "y=0", "radius=30", "holes=6"]);
        args.extend(["--set".into(), set.into(), "--check".into()]);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (code, _, err) = m.pages(&args);
        assert_eq!(code, 2, "{set}: {err}");
        assert!(err.contains(want), "{set}: {err}");
    }
    // A shown field left vacant.
    let args = sets(&["pattern=circle", "y=0", "holes=6"]);
    let args: Vec<&str> = args.iter().map(String::as_str).chain(["--check"]).collect();
    let (code, _, err) = m.pages(&args);
    assert_eq!(code, 2);
    assert!(
        err.contains("field `radius` (#504, Radius): a value is required"),
        "{err}"
    );
    // Values each field takes but the package refuses together: its own alarm.
    let args = sets(&[
        "pattern=circle",
        "y=0",
        "radius=30",
        "holes=6",
        "cycle=g84",
        "tap-feed=1200",
        "spindle=ccw",
    ]);
    let args: Vec<&str> = args.iter().map(String::as_str).chain(["--check"]).collect();
    let (code, out, err) = m.pages(&args);
    assert_eq!(code, 2);
    assert!(
        out.contains("alarm: examples/mlt980/O0001.CNC:79:1: alarm 504"),
        "{out}"
    );
    assert!(
        err.contains("the package stops with these values") && err.contains("alarm 504"),
        "{err}"
    );
    // Not a field, or not an assignment: usage.
    let (code, _, err) = m.pages(&["--set", "holez=6", "--check"]);
    assert_eq!(code, 64);
    assert!(
        err.contains("no field `holez`") && err.contains("holes"),
        "{err}"
    );
    let (code, _, _) = m.pages(&["--set", "holes", "--check"]);
    assert_eq!(code, 64);
    assert!(!m.vars.exists(), "nothing saved");
}

#[test]
fn set_saves_the_fields_and_check_reads_them_back() {
    let m = Machine::new("save");
    cnc402_interp::nvfile::set_vars(&m.vars, &[(600, Some(7.0)), (530, Some(1.0))]).unwrap();
    let args = sets(&["pattern=circle", "y=0", "radius=30", "530=3", "holes=6"]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let (code, out, err) = m.pages(&args);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("pattern (#530) = circle\n") && out.contains("radius (#504) = 30 mm\n"),
        "{out}"
    );
    assert!(out.contains("holes: 6"), "{out}");
    let t = m.file();
    assert_eq!(
        (t.get(530), t.get(504), t.get(507), t.get(519), t.get(600)),
        (Some(3.0), Some(30.0), Some(6.0), Some(81.0), Some(7.0))
    );
    // Saved values stand: --check with nothing set previews them; a bad --set saves nothing.
    let before = std::fs::read(&m.vars).unwrap();
    let (code, out, _) = m.pages(&["--check"]);
    assert_eq!((code, holes(&out).len()), (0, 6), "{out}");
    let (code, _, _) = m.pages(&["--set", "holes=8", "--set", "radius=0"]);
    assert_eq!(code, 2);
    assert_eq!(std::fs::read(&m.vars).unwrap(), before);
    // Saved even when the package would alarm: a page may be mid-edit; it says so.
    let (code, _, err) = m.pages(&[
        "--set",
        "spindle=ccw",
        "--set",
        "cycle=g84",
        "--set",
        "tap-feed=1200",
    ]);
    assert_eq!(code, 0);
    assert!(
        err.contains("warning: saved, but") && err.contains("alarm 504"),
        "{err}"
    );
    assert_eq!(m.file().get(519), Some(84.0));
}

#[test]
fn plot_draws_the_preview_and_start_runs_the_package() {
    let m = Machine::new("start");
    let svg = m.dir.join("holes.svg");
    let report = m.dir.join("run.json");
    let args = sets(&["pattern=circle", "y=0", "radius=30", "holes=6"]);
    let mut args: Vec<&str> = args.iter().map(String::as_str).collect();
    args.extend([
        "--start",
        "--plot",
        svg.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    let (code, out, err) = m.pages(&args);
    assert_eq!(code, 0, "{out}{err}");
    let drawing = std::fs::read_to_string(&svg).unwrap();
    assert!(drawing.starts_with("<svg") && drawing.trim_end().ends_with("</svg>"));
    assert_eq!(drawing.matches("<circle").count(), 6, "{drawing}");
    // The run's own report: the package ran, as `cnc402 run` runs it.
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(r["ok"], true, "{r}");
    assert_eq!(m.file().get(507), Some(6.0), "start saves first");
    // An alarm stops before motion: no report, exit 2.
    let _ = std::fs::remove_file(&report);
    let (code, _, err) = m.pages(&[
        "--set",
        "return=97",
        "--start",
        "--report",
        report.to_str().unwrap(),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("`return`"), "{err}");
    assert!(!report.exists());
}

#[test]
fn a_wrong_pages_file_exits_3_with_its_line_and_key() {
    let m = Machine::new("badfile");
    let bad = m.dir.join("pages.toml");
    let text = std::fs::read_to_string(root().join(PAGES)).unwrap();
    let text = text.replace(
        "main = \"O0001.CNC\"",
        &format!(
            "main = {:?}",
            root().join("examples/mlt980/O0001.CNC").to_str().unwrap()
        ),
    );
    std::fs::write(&bad, text.replace("var = 527", "var = 1527")).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args([
            "pages",
            "--config",
            m.config.to_str().unwrap(),
            bad.to_str().unwrap(),
            "--check",
        ])
        .output()
        .unwrap();
    let err = flat(&String::from_utf8_lossy(&out.stderr));
    assert_eq!(out.status.code(), Some(3), "{err}");
    let line = text.lines().position(|l| l == "var = 527").unwrap() + 1;
    assert!(
        err.contains(&format!(
            "pages.toml:{line}:7: page[3].field[2].var: #1527 is not a non-volatile variable"
        )),
        "{err}"
    );
}

/// A tmux server of its own running one command in a 150×45 terminal.
struct Terminal {
    socket: String,
}

impl Terminal {
    /// `None` when tmux is not installed (the test then says so and checks nothing else).
    fn start(tag: &str, command: &str) -> Option<Terminal> {
        if Command::new("tmux").arg("-V").output().is_err() {
            eprintln!("tmux is not installed: the terminal test is skipped");
            return None;
        }
        let t = Terminal {
            socket: format!("cnc402-pages-{tag}-{}", std::process::id()),
        };
        // The shell stays after the program so its exit code can be read from the screen.
        let status = t
            .tmux(&["new-session", "-d", "-x", "150", "-y", "45"])
            .arg(format!("{command}; echo EXIT=$?; sleep 60"))
            .status()
            .unwrap();
        assert!(status.success());
        Some(t)
    }

    fn tmux(&self, args: &[&str]) -> Command {
        let mut c = Command::new("tmux");
        c.args(["-L", &self.socket]).args(args);
        c
    }

    fn keys(&self, keys: &[&str]) {
        for k in keys {
            assert!(self.tmux(&["send-keys", k]).status().unwrap().success());
        }
    }

    fn type_text(&self, text: &str) {
        assert!(
            self.tmux(&["send-keys", "-l", text])
                .status()
                .unwrap()
                .success()
        );
    }

    fn screen(&self) -> String {
        let out = self.tmux(&["capture-pane", "-p"]).output().unwrap();
        String::from_utf8_lossy(&out.stdout).into_owned()
    }

    /// The screen once it shows `needle` (polled up to 600 times, 100 ms apart).
    fn wait_for(&self, needle: &str) -> String {
        for _ in 0..600 {
            let s = self.screen();
            if s.contains(needle) {
                return s;
            }
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
        panic!("the screen never showed {needle:?}:\n{}", self.screen());
    }
}

impl Drop for Terminal {
    fn drop(&mut self) {
        let _ = self.tmux(&["kill-server"]).status();
    }
}

fn pages_command(m: &Machine, env: &str) -> String {
    format!(
        "cd {} && {env} {} pages --config {} {PAGES} --at-stop continue",
        root().display(),
        env!("CARGO_BIN_EXE_cnc402"),
        m.config.display()
    )
}

/// The process data already on the pages (as `cnc402 vars set` would leave them).
fn preset(m: &Machine) {
    let vars = [
        (519, 81.0),
        (524, 98.0),
        (512, 50.0),
        (503, -45.0),
        (502, -20.0),
        (520, 3.0),
        (521, 800.0),
        (522, 150.0),
        (500, 0.0),
        (501, 0.0),
    ];
    let sets: Vec<_> = vars.iter().map(|&(n, v)| (n, Some(v))).collect();
    cnc402_interp::nvfile::set_vars(&m.vars, &sets).unwrap();
}

#[test]
fn the_screen_takes_typed_values_refuses_bad_ones_previews_and_starts() {
    let m = Machine::new("tui");
    preset(&m);
    let Some(t) = Terminal::start("tui", &pages_command(&m, "")) else {
        return;
    };
    // A capture may catch a frame half drawn: wait for each thing the frame shows.
    for label in [
        " F1 Pattern",
        " F2 Hole data",
        " F3 Process",
        " F4 Other",
        " F7 Default",
        " F8 Start",
    ] {
        t.wait_for(label);
    }
    t.wait_for("▶ Hole pattern                   #530");
    t.type_text("circle");
    t.keys(&["Enter"]);
    t.wait_for("saved #530 pattern = circle");
    // Hole data: X, Y, radius, first angle, holes, R, Z.
    t.keys(&["F2", "Down", "Down"]);
    t.type_text("30");
    t.keys(&["Enter"]);
    t.wait_for("saved #504 radius = 30");
    t.keys(&["Down", "Down"]);
    t.type_text("0");
    t.keys(&["Enter"]);
    t.wait_for("Number of holes (#507): 0 is out of range: >= 1 and <= 999");
    t.wait_for("Number of holes (#507, `holes`)  allowed: >= 1 and <= 999  required");
    t.type_text("6");
    t.keys(&["Enter"]);
    t.wait_for("preview: 6 holes, G81");
    t.wait_for("G81 R 5  bottom -15  return 50");
    let f = m.file();
    assert_eq!(
        (f.get(530), f.get(504), f.get(507)),
        (Some(3.0), Some(30.0), Some(6.0))
    );
    // Start: the pages leave the screen and the package runs as `cnc402 run` runs it.
    t.keys(&["F8"]);
    let s = t.wait_for("EXIT=");
    assert!(s.contains("EXIT=0"), "{s}");
    assert!(s.contains("program time"), "the run's summary\n{s}");
}

#[test]
fn a_power_cut_between_two_field_saves_leaves_each_field_old_or_new() {
    let m = Machine::new("cut");
    preset(&m);
    cnc402_interp::nvfile::set_vars(&m.vars, &[(530, Some(1.0))]).unwrap();
    let marker = m.dir.join("paused");
    let env = format!("CNC402_TEST_PAGES_PAUSE={}", marker.display());
    let Some(t) = Terminal::start("cut", &pages_command(&m, &env)) else {
        return;
    };
    t.wait_for("INPUT>");
    // First save: the pattern. The process pauses right after it (the test hook)...
    t.type_text("grid");
    t.keys(&["Enter"]);
    let mut pid = String::new();
    for _ in 0..600 {
        if let Ok(p) = std::fs::read_to_string(&marker) {
            pid = p;
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    assert!(!pid.is_empty(), "no first save:\n{}", t.screen());
    // ...the operator types the next field (the cycle), and the power goes before it is saved.
    t.keys(&["Down"]);
    t.type_text("82");
    t.keys(&["Enter"]);
    let killed = Command::new("kill")
        .args(["-9", pid.trim()])
        .status()
        .unwrap();
    assert!(killed.success());
    t.wait_for("EXIT=137");
    let f = m.file();
    assert_eq!(f.get(530), Some(4.0), "the first save is whole");
    assert_eq!(
        f.get(519),
        Some(81.0),
        "the second never happened: the old value"
    );
    assert_eq!(f.get(512), Some(50.0), "the other fields stand");
    let leftovers: Vec<_> = std::fs::read_dir(&m.dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    // The next session reads and writes the file as usual.
    let (code, out, err) = m.pages(&[
        "--set",
        "cycle=82",
        "--set",
        "rows=2",
        "--set",
        "count=2",
        "--set",
        "x-step=10",
        "--set",
        "y-step=10",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("holes: 4"), "{out}");
}
