//! The real-programs corpus (`tests/real-programs/`, sources and licences in its `SOURCES.md`):
//! every program is run through cnc402's interpreter and, when LinuxCNC's `rs274` is installed,
//! through `rs274 -g`; where both run, their toolpaths (end points, arc centres and directions,
//! in machine millimetres with the offsets added back) are compared. `expected.toml` pins the
//! verdicts of today, so a change that makes a program run, stop running or disagree fails here.
//!
//! `cargo test --test real_programs -- --nocapture` prints the acceptance figures;
//! `CNC402_BLESS=1` rewrites `expected.toml` from what happens (review the diff);
//! `CNC402_REAL_PROGRAMS_DIR=DIR` also runs every program under DIR (not pinned), e.g. a local
//! copy of LinuxCNC's `nc_files`, and prints each verdict (in the dialect
//! `CNC402_REAL_PROGRAMS_DIALECT` names, default fanuc).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use cnc402_config::MachineConfig;
use cnc402_interp::Options;
use cnc402_interp::host_fs::{VarsAccess, interpreter};
use cnc402_lang::SourceFile;
use cnc402_motion::segment::{ArcDir, Plane, Segment, SegmentKind};

/// One move of a toolpath, in machine millimetres.
#[derive(Clone, Debug, PartialEq)]
struct Move {
    /// 'R' rapid, 'F' straight feed (taps too), 'A' arc.
    kind: char,
    end: [f64; 3],
    /// Arc: centre in the plane (first, second axis) and the sign of the rotation.
    arc: Option<(f64, f64, i32)>,
}

/// What one program did in one control.
#[derive(Clone, Debug, PartialEq)]
enum Run {
    Runs(Vec<Move>),
    /// The first error's first line.
    Refused(String),
}

/// The verdicts of one program, as `expected.toml` holds them.
#[derive(Clone, Debug, Default, PartialEq)]
struct Verdict {
    /// `fanuc`, `haas` or `linuxcnc`: the dialect the program is written in.
    dialect: String,
    /// `runs` or `refused`.
    cnc402: String,
    /// cnc402's first error (refused only).
    error: String,
    /// `agrees` / `differs` (both run), `runs` (only rs274), `refused`; empty without rs274.
    rs274: String,
    /// rs274's first error (refused only).
    rs274_error: String,
    /// Free text kept across a bless (why a program differs, what it exercises).
    note: String,
}

const DIALECTS: [&str; 3] = ["fanuc", "haas", "linuxcnc"];

fn corpus_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/real-programs")
}

fn config() -> MachineConfig {
    MachineConfig::load(corpus_dir().join("machine.toml"))
        .unwrap_or_else(|e| panic!("tests/real-programs/machine.toml: {e}"))
}

/// Every program file under `dir`'s subfolders (not `subprograms/`, which `M98` reads), as
/// paths relative to `dir` with `/` separators, sorted.
fn programs(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut folders = vec![dir.to_path_buf()];
    // A corpus is a few levels deep; the bound keeps a symlink loop from running forever.
    let mut visited = 0;
    while let Some(folder) = folders.pop() {
        visited += 1;
        assert!(
            visited < 10_000,
            "more than 10000 folders under {}",
            dir.display()
        );
        let Ok(entries) = std::fs::read_dir(&folder) else {
            continue;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            let name = entry.file_name().to_string_lossy().to_string();
            if path.is_dir() {
                if name != "subprograms" {
                    folders.push(path);
                }
                continue;
            }
            let ext = path
                .extension()
                .map(|e| e.to_string_lossy().to_ascii_lowercase());
            let is_program = matches!(
                ext.as_deref(),
                Some("nc" | "ngc" | "cnc" | "tap" | "gcode" | "nci" | "eia" | "min")
            );
            if is_program && folder != dir {
                let rel = path.strip_prefix(dir).expect("under the corpus folder");
                out.push(rel.to_string_lossy().replace('\\', "/"));
            }
        }
    }
    out.sort();
    out
}

fn run_cnc402(cfg: &MachineConfig, dir: &Path, rel: &str, dialect: &str) -> Run {
    let bytes = std::fs::read(dir.join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"));
    let src = SourceFile::from_bytes(rel, bytes);
    // As `cnc402 segments --dialect D` runs it: sub-programs from `program_dir`, variables
    // in memory.
    let dialect: cnc402_lang::Dialect = dialect
        .parse()
        .unwrap_or_else(|e| panic!("{rel}: expected.toml: {e}"));
    let segments = match cnc402_interp::parse_program(cfg, &src, Some(dialect)) {
        Ok(program) => {
            let mut it = interpreter(cfg, Options::default(), VarsAccess::ReadOnly);
            it.load(src.clone(), program);
            it.collect::<Result<Vec<Segment>, _>>()
        }
        Err(e) => Err(e),
    };
    match segments {
        Ok(segs) => Run::Runs(moves_of(&segs)),
        Err(e) => Run::Refused(first_line(&e.to_string())),
    }
}

fn first_line(text: &str) -> String {
    text.lines().next().unwrap_or("").trim().to_string()
}

/// cnc402's segments as moves (events left out).
fn moves_of(segs: &[Segment]) -> Vec<Move> {
    let mut v = Vec::new();
    for s in segs {
        let m = if let SegmentKind::Arc {
            end,
            center,
            plane,
            dir,
            ..
        } = &s.kind
        {
            let (c1, c2) = match plane {
                Plane::XY => (center[0], center[1]),
                Plane::ZX => (center[2], center[0]),
                Plane::YZ => (center[1], center[2]),
            };
            let rot = if *dir == ArcDir::Cw { -1 } else { 1 };
            Move {
                kind: 'A',
                end: [end[0], end[1], end[2]],
                arc: Some((c1, c2, rot)),
            }
        } else if let Some(end) = s.kind.line_end() {
            let kind = if matches!(s.kind, SegmentKind::Rapid { .. }) {
                'R'
            } else {
                'F'
            };
            Move {
                kind,
                end: [end[0], end[1], end[2]],
                arc: None,
            }
        } else {
            continue;
        };
        v.push(m);
    }
    v
}

fn find_rs274() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("rs274"))
        .find(|p| p.is_file())
}

/// `rs274 -g FILE` with the corpus's tool table (every tool of length 0), in a fresh working
/// directory of its own that is also its HOME (rs274 keeps its parameter file and its tool
/// table's shared memory file there).
fn run_rs274(exe: &Path, file: &Path) -> Run {
    let stem = file
        .file_stem()
        .map_or_else(|| "p".into(), |s| s.to_string_lossy());
    let cwd = std::env::temp_dir().join(format!(
        "cnc402-real-programs-{}-{stem}",
        std::process::id()
    ));
    std::fs::create_dir_all(&cwd).expect("a working directory for rs274");
    // rs274 shares its tool table through `$HOME/.tool.mmap`: two rs274 at once (tests in
    // parallel, other checkouts) read each other's tables unless each has a HOME of its own.
    let out = Command::new(exe)
        .current_dir(&cwd)
        .env("HOME", &cwd)
        .arg("-t")
        .arg(corpus_dir().join("tools.tbl"))
        .arg("-g")
        .arg(std::path::absolute(file).expect("an absolute program path"))
        .stdin(std::process::Stdio::null())
        .output()
        .expect("rs274 runs");
    let _ = std::fs::remove_dir_all(&cwd);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() || !stdout.contains("PROGRAM_END()") {
        // rs274 prints "executing", then the error, then the block.
        let error = stderr
            .lines()
            .map(str::trim)
            .find(|l| !l.is_empty() && *l != "executing")
            .unwrap_or("stopped before the program end");
        return Run::Refused(error.to_string());
    }
    Run::Runs(rs274_moves(&stdout))
}

fn nums(args: &str) -> Vec<f64> {
    args.split(',')
        .filter_map(|a| a.trim().parse().ok())
        .collect()
}

/// rs274's canonical offsets and units, to turn its program-unit positions into machine mm.
#[derive(Default)]
struct Rs274Frame {
    g5x: [f64; 3],
    g92: [f64; 3],
    tool: [f64; 3],
    inch: bool,
    plane: Option<Plane>,
}

impl Rs274Frame {
    fn machine(&self, axis: usize, value: f64) -> f64 {
        let mm = value + self.g5x[axis] + self.g92[axis] + self.tool[axis];
        if self.inch { mm * 25.4 } else { mm }
    }

    /// Applies a non-motion call; false when the call is not one of the frame's.
    fn apply(&mut self, call: &str, args: &str) -> bool {
        let n = nums(args);
        if call.starts_with("SET_G5X_OFFSET") && n.len() >= 4 {
            self.g5x.copy_from_slice(&n[1..4]);
        } else if call.starts_with("SET_G92_OFFSET") && n.len() >= 3 {
            self.g92.copy_from_slice(&n[0..3]);
        } else if call.starts_with("USE_TOOL_LENGTH_OFFSET") {
            let first = args.split(',').next().unwrap_or("");
            for (i, t) in first.split_whitespace().take(3).enumerate() {
                self.tool[i] = t.parse().unwrap_or(0.0);
            }
        } else if call.starts_with("USE_LENGTH_UNITS") {
            self.inch = args.contains("INCHES");
        } else if call.starts_with("SELECT_PLANE") {
            self.plane = Some(if args.contains("XZ") {
                Plane::ZX
            } else if args.contains("YZ") {
                Plane::YZ
            } else {
                Plane::XY
            });
        } else {
            return false;
        }
        true
    }
}

/// The motion calls of `rs274 -g` output as machine moves.
fn rs274_moves(text: &str) -> Vec<Move> {
    let mut frame = Rs274Frame::default();
    let mut v = Vec::new();
    for line in text.lines() {
        // "   8 N..... CALL(args)": the count, the block's N number (dots when it has none),
        // the call.
        let mut fields = line.trim_start().splitn(3, ' ');
        let (Some(_), Some(n_word), Some(call)) = (fields.next(), fields.next(), fields.next())
        else {
            continue;
        };
        if !n_word.starts_with('N') {
            continue;
        }
        let call = call.trim_start();
        let args = call
            .split_once('(')
            .map(|(_, a)| a.trim_end_matches(')'))
            .unwrap_or("");
        if frame.apply(call, args) {
            continue;
        }
        let n = nums(args);
        let traverse = call.starts_with("STRAIGHT_TRAVERSE");
        if (traverse || call.starts_with("STRAIGHT_FEED")) && n.len() >= 3 {
            v.push(Move {
                kind: if traverse { 'R' } else { 'F' },
                end: [0, 1, 2].map(|i| frame.machine(i, n[i])),
                arc: None,
            });
        } else if call.starts_with("ARC_FEED") && n.len() >= 6 {
            // (first, second, normal) axes of the plane.
            let (a, b, c) = match frame.plane.unwrap_or(Plane::XY) {
                Plane::XY => (0, 1, 2),
                Plane::ZX => (2, 0, 1),
                Plane::YZ => (1, 2, 0),
            };
            let mut end = [0.0; 3];
            end[a] = frame.machine(a, n[0]);
            end[b] = frame.machine(b, n[1]);
            end[c] = frame.machine(c, n[5]);
            let centre = (frame.machine(a, n[2]), frame.machine(b, n[3]));
            v.push(Move {
                kind: 'A',
                end,
                arc: Some((centre.0, centre.1, (n[4] as i32).signum())),
            });
        }
    }
    v
}

/// Drops moves that end where the previous one ended (both controls emit some zero-length
/// moves the other does not, e.g. a rapid to R when the tool is already there).
fn dedup(v: &[Move]) -> Vec<Move> {
    let mut out: Vec<Move> = Vec::new();
    // Both start at machine zero (the test machine's references are 0).
    let mut at = [0.0; 3];
    for m in v {
        let same = m.end.iter().zip(at).all(|(a, b)| (a - b).abs() < 1e-4);
        at = m.end;
        if !same || m.kind == 'A' {
            out.push(m.clone());
        }
    }
    out
}

/// rs274 prints 4 decimals (of an inch in G20: 2.54 µm).
fn close(a: &Move, b: &Move) -> bool {
    const TOL: f64 = 3e-3;
    let ends = a.end.iter().zip(b.end).all(|(x, y)| (x - y).abs() < TOL);
    let arcs = match (a.arc, b.arc) {
        (None, None) => true,
        (Some((a1, a2, ar)), Some((b1, b2, br))) => {
            (a1 - b1).abs() < TOL && (a2 - b2).abs() < TOL && ar == br
        }
        _ => false,
    };
    a.kind == b.kind && ends && arcs
}

/// None when the toolpaths agree, else where they first part.
fn first_difference(ours: &[Move], theirs: &[Move]) -> Option<String> {
    let (ours, theirs) = (dedup(ours), dedup(theirs));
    for (i, (a, b)) in ours.iter().zip(&theirs).enumerate() {
        if !close(a, b) {
            return Some(format!("move {i}: cnc402 {a:?}, rs274 {b:?}"));
        }
    }
    (ours.len() != theirs.len())
        .then(|| format!("cnc402 {} moves, rs274 {}", ours.len(), theirs.len()))
}

/// Runs one program in both controls.
fn judge(
    cfg: &MachineConfig,
    dir: &Path,
    rel: &str,
    dialect: &str,
    rs274: Option<&Path>,
) -> Verdict {
    let ours = run_cnc402(cfg, dir, rel, dialect);
    let theirs = rs274.map(|exe| run_rs274(exe, &dir.join(rel)));
    let mut v = Verdict {
        dialect: dialect.to_string(),
        ..Verdict::default()
    };
    match &ours {
        Run::Runs(_) => v.cnc402 = "runs".into(),
        Run::Refused(e) => {
            v.cnc402 = "refused".into();
            v.error = e.clone();
        }
    }
    match (&ours, &theirs) {
        (_, None) => {}
        (_, Some(Run::Refused(e))) => {
            v.rs274 = "refused".into();
            v.rs274_error = e.clone();
        }
        (Run::Refused(_), Some(Run::Runs(_))) => v.rs274 = "runs".into(),
        (Run::Runs(a), Some(Run::Runs(b))) => {
            v.rs274 = match first_difference(a, b) {
                None => "agrees".into(),
                Some(d) => {
                    v.note = d;
                    "differs".into()
                }
            }
        }
    }
    v
}

fn read_expected(path: &Path) -> BTreeMap<String, Verdict> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return BTreeMap::new();
    };
    let table: toml::Table =
        toml::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let field = |t: &toml::Value, k: &str| {
        t.get(k)
            .and_then(toml::Value::as_str)
            .unwrap_or("")
            .to_string()
    };
    table
        .iter()
        .map(|(name, t)| {
            let v = Verdict {
                dialect: field(t, "dialect"),
                cnc402: field(t, "cnc402"),
                error: field(t, "error"),
                rs274: field(t, "rs274"),
                rs274_error: field(t, "rs274_error"),
                note: field(t, "note"),
            };
            (name.clone(), v)
        })
        .collect()
}

fn write_expected(path: &Path, verdicts: &BTreeMap<String, Verdict>) {
    let quote = |s: &str| toml::Value::String(s.to_string()).to_string();
    let mut out = String::from(
        "# What each program of the corpus does today (tests/real_programs.rs). cnc402 = \"runs\" |\n\
         # \"refused\" (error = its first error); rs274 = \"agrees\" | \"differs\" (both run; note =\n\
         # where they first part) | \"runs\" (rs274 only) | \"refused\" (rs274_error). Rewritten by\n\
         # `CNC402_BLESS=1 cargo test --test real_programs`; dialect and a hand-written note stay.\n",
    );
    for (name, v) in verdicts {
        let _ = write!(
            out,
            "\n[{}]\ndialect = {}\ncnc402 = {}\n",
            quote(name),
            quote(&v.dialect),
            quote(&v.cnc402)
        );
        for (key, value) in [
            ("error", &v.error),
            ("rs274", &v.rs274),
            ("rs274_error", &v.rs274_error),
            ("note", &v.note),
        ] {
            if !value.is_empty() {
                let _ = writeln!(out, "{key} = {}", quote(value));
            }
        }
    }
    std::fs::write(path, out).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}

/// "cnc402 accepts X of N, rs274 accepts Y of N, both accept and agree Z".
fn summary(verdicts: &BTreeMap<String, Verdict>, with_rs274: bool) -> String {
    let n = verdicts.len();
    let count = |f: &dyn Fn(&Verdict) -> bool| verdicts.values().filter(|v| f(v)).count();
    let ours = count(&|v| v.cnc402 == "runs");
    if !with_rs274 {
        return format!("cnc402 accepts {ours} of {n} (rs274 not installed)");
    }
    let theirs = count(&|v| matches!(v.rs274.as_str(), "agrees" | "differs" | "runs"));
    let agree = count(&|v| v.rs274 == "agrees");
    let differ = count(&|v| v.rs274 == "differs");
    format!(
        "cnc402 accepts {ours} of {n}, rs274 accepts {theirs} of {n}, both accept and agree {agree} (both accept and differ {differ})"
    )
}

fn rs274_or_notice() -> Option<PathBuf> {
    let exe = find_rs274();
    if exe.is_none() {
        eprintln!(
            "NOTICE: rs274 (LinuxCNC) is not installed; the real programs run in cnc402 only. apt-get install linuxcnc-uspace"
        );
    }
    exe
}

#[test]
fn real_programs_do_what_expected_toml_says() {
    let dir = corpus_dir();
    let expected_path = dir.join("expected.toml");
    let expected = read_expected(&expected_path);
    let cfg = config();
    let exe = rs274_or_notice();
    let files = programs(&dir);
    assert!(files.len() >= 50, "the corpus has {} programs", files.len());
    let sources = std::fs::read_to_string(dir.join("SOURCES.md")).expect("SOURCES.md");
    let mut problems = Vec::new();
    let mut actual = BTreeMap::new();
    for rel in &files {
        if !sources.contains(&format!("`{rel}`")) {
            problems.push(format!("{rel}: not in SOURCES.md (origin and licence)"));
        }
        let want = expected.get(rel).cloned().unwrap_or_default();
        if !DIALECTS.contains(&want.dialect.as_str()) {
            problems.push(format!(
                "{rel}: dialect {:?} is not one of {DIALECTS:?}",
                want.dialect
            ));
        }
        let mut got = judge(&cfg, &dir, rel, &want.dialect, exe.as_deref());
        // A hand-written note stays; the note of a difference is recomputed.
        if got.note.is_empty() && want.rs274 != "differs" {
            got.note = want.note.clone();
        }
        let same = got.cnc402 == want.cnc402
            && got.error == want.error
            && (exe.is_none() || (got.rs274 == want.rs274 && got.rs274_error == want.rs274_error));
        if !same {
            problems.push(format!(
                "{rel}:\n    expected {want:?}\n    got      {got:?}"
            ));
        }
        actual.insert(rel.clone(), got);
    }
    for name in expected.keys().filter(|k| !files.contains(k)) {
        problems.push(format!("{name}: in expected.toml but not in the corpus"));
    }
    println!("real programs: {}", summary(&actual, exe.is_some()));
    if std::env::var_os("CNC402_BLESS").is_some() {
        write_expected(&expected_path, &actual);
        return;
    }
    assert!(
        problems.is_empty(),
        "{} programs changed (CNC402_BLESS=1 rewrites expected.toml; check the diff):\n{}",
        problems.len(),
        problems.join("\n")
    );
}

/// `CNC402_REAL_PROGRAMS_DIR=DIR`: every program under DIR's subfolders, verdicts printed, none
/// pinned (for programs whose licence keeps them out of the repository, or a new collection).
#[test]
fn programs_of_real_programs_dir_are_reported() {
    let Some(dir) = std::env::var_os("CNC402_REAL_PROGRAMS_DIR") else {
        return;
    };
    let dir = PathBuf::from(dir);
    let cfg = config();
    let exe = rs274_or_notice();
    let mut verdicts = BTreeMap::new();
    // `CNC402_REAL_PROGRAMS_DIALECT` (default fanuc): e.g. linuxcnc for LinuxCNC's nc_files.
    let dialect = std::env::var("CNC402_REAL_PROGRAMS_DIALECT").unwrap_or_else(|_| "fanuc".into());
    for rel in programs(&dir) {
        let v = judge(&cfg, &dir, &rel, &dialect, exe.as_deref());
        println!(
            "{rel}: cnc402 {} {} | rs274 {} {}{}",
            v.cnc402, v.error, v.rs274, v.rs274_error, v.note
        );
        verdicts.insert(rel, v);
    }
    println!("{}: {}", dir.display(), summary(&verdicts, exe.is_some()));
}
