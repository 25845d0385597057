//! The round-trip proof: the posted program is read back by cnc402's own interpreter (Fanuc
//! dialect) and its segments compared with the job's: the same kinds in the same order,
//! positions and arc centres within [`TOLERANCE_MM`], the same feeds (within
//! [`FEED_TOLERANCE`]), spindle, tools, dwells and stops, and the same coolant at every move.
//! Messages are not compared; coolant events count by the state they leave.

use cnc402_config::MachineConfig;
use cnc402_lang::{Dialect, SourceFile};
use cnc402_motion::segment::{AxisPos, MAX_AXES, Segment, SegmentEnd, SegmentKind, SpindleDir};

use crate::PostError;
use crate::input::MAX_OPERATIONS;
use crate::rules::Rules;

/// How far a posted position may lie from the job's (1 µm).
pub const TOLERANCE_MM: f64 = 0.001;
/// How far a posted feed may lie from the job's (mm/min; F has 3 decimals).
pub const FEED_TOLERANCE: f64 = 0.001;

/// A segment as compared: what it does, the coolant it runs with, where it comes from.
#[derive(Debug)]
struct Step {
    kind: SegmentKind,
    exact_stop: bool,
    coolant: (bool, bool),
    line: u32,
    file: String,
}

/// The segments of `text`, read in `dialect` (`None`: as its header or the config says).
pub fn segments(
    cfg: &MachineConfig,
    name: &str,
    text: &str,
    dialect: Option<Dialect>,
) -> Result<Vec<Segment>, PostError> {
    if cnc402_lang::heidenhain::is_heidenhain(name, text.lines().next().unwrap_or("")) {
        // A Heidenhain job: through the reader, as a posted iTNC program is read back.
        return read_back(cfg, name, text);
    }
    let src = SourceFile::new(name, text);
    let program = cnc402_interp::parse_program(cfg, &src, dialect).map_err(PostError::Job)?;
    let mut it = interpreter(cfg);
    it.load(src, program);
    drain(it)
}

/// An interpreter with the file system, variables read-only (a proof writes nothing).
fn interpreter(cfg: &MachineConfig) -> cnc402_interp::Interpreter {
    cnc402_interp::host_fs::interpreter(
        cfg,
        cnc402_interp::Options::default(),
        cnc402_interp::host_fs::VarsAccess::ReadOnly,
    )
}

/// Every segment `it` gives, or an error past [`MAX_OPERATIONS`] × 4 (a program that would
/// not end: the proof does not compare a part).
fn drain(mut it: cnc402_interp::Interpreter) -> Result<Vec<Segment>, PostError> {
    let mut out = Vec::new();
    while let Some(s) = it.next_segment().map_err(PostError::Job)? {
        if out.len() == 4 * MAX_OPERATIONS {
            return Err(PostError::Target {
                target: "any",
                source: Some(s.source),
                message: format!(
                    "more than {} segments: too long to prove",
                    4 * MAX_OPERATIONS
                ),
            });
        }
        out.push(s);
    }
    Ok(out)
}

/// The segments of a posted program, read line by line as `cnc402 segments` reads a file
/// (so a Heidenhain program goes through its reader; an ISO one is read as Fanuc).
pub fn read_back(cfg: &MachineConfig, name: &str, posted: &str) -> Result<Vec<Segment>, PostError> {
    let mut it = interpreter(cfg);
    let input = std::io::Cursor::new(posted.as_bytes().to_vec());
    let heidenhain =
        cnc402_lang::heidenhain::is_heidenhain(name, posted.lines().next().unwrap_or(""));
    let dialect = (!heidenhain).then_some(Dialect::Fanuc);
    it.load_stream(name, Box::new(input), dialect)
        .map_err(PostError::Job)?;
    drain(it)
}

/// Checks that `posted` moves as the job `text` does.
pub fn same_motion(
    cfg: &MachineConfig,
    rules: &Rules,
    name: &str,
    text: &str,
    posted: &str,
) -> Result<(), PostError> {
    same_as(cfg, rules, segments(cfg, name, text, None)?, name, posted)
}

/// The segments `ops` lower to (a CL job's: it has no program text to run).
pub fn lowered(cfg: &MachineConfig, ops: &[cnc402_interp::canon::CanonOp]) -> Vec<Segment> {
    let xyz = cnc402_interp::lower::xyz_indices(cfg);
    let mut out = Vec::new();
    for op in ops {
        cnc402_interp::lower::lower(op, xyz, &mut out);
    }
    out
}

/// Checks that `posted` moves as the job's segments `job` do.
pub fn same_as(
    cfg: &MachineConfig,
    rules: &Rules,
    job: Vec<Segment>,
    name: &str,
    posted: &str,
) -> Result<(), PostError> {
    let job = steps(job);
    let posted_name = format!("{name}.{}", rules.name);
    let back = read_back(cfg, &posted_name, posted).map_err(|e| {
        PostError::target(
            rules,
            None,
            format!("the posted program does not read back: {e}"),
        )
    })?;
    let back = steps(back);
    for (i, (a, b)) in job.iter().zip(&back).enumerate() {
        if !same(a, b) {
            return Err(differs(rules, a, b, i));
        }
    }
    if job.len() != back.len() {
        let (more, which) = if job.len() > back.len() {
            (&job[back.len()], "the job")
        } else {
            (&back[job.len()], "the posted program")
        };
        return Err(PostError::target(
            rules,
            None,
            format!(
                "the posted program has {} steps and the job {}: {which} goes on with {:?} \
                 ({}:{})",
                back.len(),
                job.len(),
                more.kind,
                more.file,
                more.line
            ),
        ));
    }
    Ok(())
}

fn differs(rules: &Rules, a: &Step, b: &Step, i: usize) -> PostError {
    PostError::Target {
        target: rules.name,
        source: Some(cnc402_motion::segment::Source {
            file: a.file.as_str().into(),
            line: a.line,
            n: None,
        }),
        message: format!(
            "the posted program moves differently at step {i}: the job {:?} (exact stop {}, \
             coolant {:?}), the posted line {} {:?} (exact stop {}, coolant {:?})",
            a.kind, a.exact_stop, a.coolant, b.line, b.kind, b.exact_stop, b.coolant
        ),
    }
}

/// Segments without messages and coolant events, each with the coolant it runs under.
fn steps(segments: Vec<Segment>) -> Vec<Step> {
    let mut coolant = (false, false);
    let mut at: Option<AxisPos> = None;
    let mut spindle = (0.0, SpindleDir::Stop, 0);
    let mut out = Vec::with_capacity(segments.len());
    for s in segments {
        let before = at;
        if let Some(end) = segment_end(&s.kind) {
            at = Some(end);
        }
        match s.kind {
            SegmentKind::Coolant { mist, flood } => coolant = (mist, flood),
            SegmentKind::Message { .. } => {}
            // A rapid to where the tool is moves nothing: a Macro B body's positioning
            // writes one where the job's cycle leaves it out (either side: not compared).
            SegmentKind::Rapid { end } if before.is_some_and(|b| same_point(&b, &end)) => {}
            // A speed and direction the spindle already has changes nothing: the iTNC's
            // `TOOL CALL Z S` then `M3` sets one where the job's `S M3` block is one.
            SegmentKind::Spindle {
                rpm,
                dir,
                spindle: n,
            } if (rpm, dir, n) == spindle => {}
            SegmentKind::Spindle {
                rpm,
                dir,
                spindle: n,
            } => {
                spindle = (rpm, dir, n);
                out.push(step(s.kind, s.ends, coolant, &s.source));
            }
            kind => out.push(step(kind, s.ends, coolant, &s.source)),
        }
    }
    out
}

fn step(
    kind: SegmentKind,
    ends: SegmentEnd,
    coolant: (bool, bool),
    source: &cnc402_motion::segment::Source,
) -> Step {
    Step {
        kind,
        exact_stop: ends == SegmentEnd::ExactStop,
        coolant,
        line: source.line,
        file: source.file.to_string(),
    }
}

/// Where a segment leaves the tool, if it moves it.
fn segment_end(kind: &SegmentKind) -> Option<AxisPos> {
    match kind {
        SegmentKind::Arc { end, .. } => Some(*end),
        k => k.line_end().copied(),
    }
}

fn same_point(a: &AxisPos, b: &AxisPos) -> bool {
    (0..MAX_AXES).all(|i| (a[i] - b[i]).abs() <= 1e-9)
}

fn near(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

fn near_pos(a: &AxisPos, b: &AxisPos) -> bool {
    (0..MAX_AXES).all(|i| near(a[i], b[i], TOLERANCE_MM))
}

fn same(a: &Step, b: &Step) -> bool {
    if a.exact_stop != b.exact_stop || a.coolant != b.coolant {
        return false;
    }
    use SegmentKind as K;
    match (&a.kind, &b.kind) {
        (K::Rapid { end: e1 }, K::Rapid { end: e2 }) => near_pos(e1, e2),
        (K::Linear { end: e1, feed: f1 }, K::Linear { end: e2, feed: f2 }) => {
            near_pos(e1, e2) && near(*f1, *f2, FEED_TOLERANCE)
        }
        (K::Tap(t1), K::Tap(t2)) => {
            near_pos(&t1.end, &t2.end)
                && near(t1.feed, t2.feed, FEED_TOLERANCE)
                && (t1.tool, t1.spindle) == (t2.tool, t2.spindle)
                && near(t1.pitch, t2.pitch, 1e-6 * t1.pitch.abs().max(1.0))
        }
        (
            K::Arc {
                end: e1,
                center: c1,
                plane: p1,
                dir: d1,
                turns: n1,
                feed: f1,
            },
            K::Arc {
                end: e2,
                center: c2,
                plane: p2,
                dir: d2,
                turns: n2,
                feed: f2,
            },
        ) => {
            near_pos(e1, e2)
                && c1.iter().zip(c2).all(|(x, y)| near(*x, *y, TOLERANCE_MM))
                && (p1, d1, n1) == (p2, d2, n2)
                && near(*f1, *f2, FEED_TOLERANCE)
        }
        (K::Dwell { seconds: s1 }, K::Dwell { seconds: s2 }) => near(*s1, *s2, 0.0005),
        (
            K::Spindle {
                rpm: r1,
                dir: d1,
                spindle: s1,
            },
            K::Spindle {
                rpm: r2,
                dir: d2,
                spindle: s2,
            },
        ) => (d1, s1) == (d2, s2) && near(*r1, *r2, 1e-9),
        (
            K::SpindleOrient {
                angle: a1,
                program: p1,
                spindle: s1,
            },
            K::SpindleOrient {
                angle: a2,
                program: p2,
                spindle: s2,
            },
        ) => s1 == s2 && near(*a1, *a2, 1e-9) && p1.is_some() == p2.is_some(),
        (x, y) => x == y,
    }
}
