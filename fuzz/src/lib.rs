//! The fuzz targets and the mutator. Each target takes raw bytes and runs one part of the
//! product on them; the property is the same everywhere: no panic, a bounded amount of work,
//! and (for the interpreter) no non-finite number in any segment. `main.rs` mutates seeds and
//! runs the targets for a given time; `tests/replay.rs` replays every committed crash.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::time::Duration;

use cnc402_config::MachineConfig;
use cnc402_drives::Instant;
use cnc402_drives::bus::{BusError, CanDevice, FrameSink, SimBus};
use cnc402_drives::master::boot::TPDO1_LAYOUT;
use cnc402_drives::master::{Master, MasterOptions};
use cnc402_drives::sim::SimDrive;
use cnc402_drives::wire::{
    CanFrame, EmcyRepr, HeartbeatRepr, NmtRepr, NodeId, SdoRequest, SdoResponse, SyncRepr,
};
use cnc402_interp::Interpreter;
use cnc402_lang::SourceFile;
use cnc402_motion::segment::{Segment, SegmentKind};

/// Segments one interpreter input may produce before the target stops it (a legal endless
/// program with motion produces them forever; the interpreter's own bounds end the rest).
pub const SEGMENT_BUDGET: usize = 200_000;
/// Master cycles run after boot in the frames target.
const CYCLES: u32 = 40;

/// What a target runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// `cnc402_lang::parse` and the error's rendering.
    Parse,
    /// Parse + interpret to the end (all three languages), every segment checked.
    Interp,
    /// `MachineConfig::parse`.
    Config,
    /// Frames through every decoder, a simulated drive, and a booted master.
    Frames,
}

impl Target {
    pub const ALL: [Target; 4] = [
        Target::Parse,
        Target::Interp,
        Target::Config,
        Target::Frames,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Target::Parse => "parse",
            Target::Interp => "interp",
            Target::Config => "config",
            Target::Frames => "frames",
        }
    }

    pub fn from_name(s: &str) -> Option<Target> {
        Target::ALL.into_iter().find(|t| t.name() == s)
    }
}

/// A property the input broke.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Finding {
    Panic(String),
    NonFinite(String),
}

/// Runs `target` on `input`; `Ok` when every property held.
pub fn run(target: Target, input: &[u8]) -> Result<(), Finding> {
    let r = catch_unwind(AssertUnwindSafe(|| match target {
        Target::Parse => parse(input),
        Target::Interp => interp(input),
        Target::Config => config(input),
        Target::Frames => frames(input),
    }));
    match r {
        Ok(r) => r,
        Err(p) => Err(Finding::Panic(
            p.downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "panic".into()),
        )),
    }
}

/// Program bytes as text the way the binaries read files (UTF-8 where valid).
fn text(input: &[u8]) -> String {
    String::from_utf8_lossy(input).into_owned()
}

fn parse(input: &[u8]) -> Result<(), Finding> {
    let src = SourceFile::new("fuzz.nc", text(input));
    if let Err(e) = cnc402_lang::parse(&src) {
        let _ = e.to_string();
    }
    Ok(())
}

fn interp(input: &[u8]) -> Result<(), Finding> {
    let cfg = MachineConfig::default_machine();
    let src = SourceFile::new("fuzz.nc", text(input));
    let Ok(prog) = cnc402_lang::parse(&src) else {
        return Ok(());
    };
    let mut it = Interpreter::new(&cfg);
    it.load(src, prog);
    for _ in 0..SEGMENT_BUDGET {
        match it.next_segment() {
            Ok(Some(s)) => finite(&s)?,
            Ok(None) => break,
            Err(e) => {
                let _ = e.to_string();
                break;
            }
        }
    }
    Ok(())
}

/// Every number of a segment is finite.
pub fn finite(s: &Segment) -> Result<(), Finding> {
    let mut nums: Vec<f64> = Vec::new();
    match &s.kind {
        SegmentKind::Rapid { end } => nums.extend(end.0),
        SegmentKind::Linear { end, feed } => {
            nums.extend(end.0);
            nums.push(*feed);
        }
        SegmentKind::Tap(t) => {
            nums.extend(t.end.0);
            nums.extend([t.feed, t.pitch]);
        }
        SegmentKind::Arc {
            end, center, feed, ..
        } => {
            nums.extend(end.0);
            nums.extend(center);
            nums.push(*feed);
        }
        SegmentKind::Dwell { seconds } => nums.push(*seconds),
        SegmentKind::Spindle { rpm, .. } => nums.push(*rpm),
        SegmentKind::SpindleOrient { angle, program, .. } => {
            nums.push(*angle);
            nums.extend(*program);
        }
        _ => {}
    }
    if nums.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(Finding::NonFinite(format!(
            "line {}: {:?}",
            s.source.line, s.kind
        )))
    }
}

fn config(input: &[u8]) -> Result<(), Finding> {
    if let Err(e) = MachineConfig::parse(&text(input), Path::new("fuzz.toml")) {
        let _ = e.to_string();
    }
    Ok(())
}

/// Frames from bytes: `[id high (3 bits), id low, len (0..=8), data…]` repeated.
pub fn frames_of(input: &[u8]) -> Vec<CanFrame> {
    let mut out = Vec::new();
    let mut rest = input;
    while rest.len() >= 3 {
        let id = u16::from(rest[0] & 0x07) << 8 | u16::from(rest[1]);
        let len = usize::from(rest[2] % 9).min(rest.len() - 3);
        if let Ok(f) = CanFrame::new(id, &rest[3..3 + len]) {
            out.push(f);
        }
        rest = &rest[3 + len..];
    }
    out
}

/// Collects what a device transmits.
struct Sink(Vec<CanFrame>);

impl FrameSink for Sink {
    fn transmit(&mut self, frame: &CanFrame, _now: Instant) -> Result<(), BusError> {
        if self.0.len() < 10_000 {
            self.0.push(*frame);
        }
        Ok(())
    }
}

/// A device that puts the fuzz frames on the bus, one every 100 µs from its start.
struct Rogue {
    frames: Vec<CanFrame>,
    next: usize,
    start: Option<Instant>,
}

impl CanDevice for Rogue {
    fn on_frame(&mut self, _frame: &CanFrame, _now: Instant, _tx: &mut dyn FrameSink) {}
    fn poll(&mut self, now: Instant, tx: &mut dyn FrameSink) {
        let start = *self.start.get_or_insert(now);
        while let Some(f) = self.frames.get(self.next) {
            let due = start.nanos() + 100_000 * self.next as u64;
            if now.nanos() < due {
                break;
            }
            let _ = tx.transmit(f, now);
            self.next += 1;
        }
    }
}

fn frames(input: &[u8]) -> Result<(), Finding> {
    let fs = frames_of(input);
    for f in &fs {
        let _ = SyncRepr::parse(f);
        let _ = EmcyRepr::parse(f);
        let _ = NmtRepr::parse(f);
        let _ = HeartbeatRepr::parse(f);
        let _ = SdoRequest::parse(f);
        let _ = SdoResponse::parse(f);
        let _ = TPDO1_LAYOUT.unpack(f.data());
    }
    let cfg = MachineConfig::default_machine();
    let period = Duration::from_micros(u64::from(cfg.bus.period_us));
    // The simulated drive as a receiver.
    if let Some((i, a)) = cfg.axes.iter().enumerate().find(|(_, a)| a.node.is_some()) {
        let node = NodeId::new(a.node.unwrap_or(1)).map_err(|e| Finding::Panic(e.to_string()))?;
        let _ = i;
        let mut d = SimDrive::new(a, node, period);
        let mut sink = Sink(Vec::new());
        let mut now = Instant::ZERO;
        for f in &fs {
            now = Instant::from_nanos(now.nanos() + 50_000);
            d.on_frame(f, now, &mut sink);
            d.poll(now, &mut sink);
        }
    }
    // A master booting and cycling on a bus with the machine's drives and the fuzz frames.
    let mut bus: SimBus<Box<dyn CanDevice>> = SimBus::new(cfg.bus.bitrate);
    for a in &cfg.axes {
        if let Some(n) = a.node
            && let Ok(node) = NodeId::new(n)
        {
            bus.attach(Box::new(SimDrive::new(a, node, period)));
        }
    }
    bus.attach(Box::new(Rogue {
        frames: fs,
        next: 0,
        start: None,
    }));
    let opts = MasterOptions {
        boot_timeout: Duration::from_millis(1500),
        enable_timeout: Duration::from_millis(500),
        ..MasterOptions::default()
    };
    let Ok(mut m) = Master::with_options(&cfg, opts) else {
        return Ok(());
    };
    let Ok(report) = m.boot(&mut bus) else {
        return Ok(());
    };
    let mut now = report.enabled_at;
    let cmd = m.positions();
    for _ in 0..CYCLES {
        now = Instant::from_nanos(now.nanos() + period.as_nanos() as u64);
        bus.advance(now);
        if m.cycle(&mut bus, now, &cmd[..m.axis_count()]).is_err() {
            break;
        }
    }
    Ok(())
}

/// A small deterministic generator (xorshift64*), so a run replays from its seed.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed.max(1))
    }
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in `0..n` (`n` > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }
}

/// Tokens the mutator inserts: the words, operators and numbers that matter to each target.
const TOKENS: &[&str] = &[
    "G0 ",
    "G1 ",
    "G2 ",
    "G3 ",
    "G4 P",
    "G17",
    "G18",
    "G19",
    "G20",
    "G21",
    "G28 ",
    "G43 H1 ",
    "G49",
    "G53 ",
    "G54",
    "G61",
    "G64 P",
    "G73 ",
    "G74 ",
    "G76 ",
    "G81 ",
    "G83 ",
    "G84 ",
    "G87 ",
    "G90",
    "G91",
    "G92 ",
    "G98",
    "G99",
    "G10 L2 P1 ",
    "M3 S",
    "M4 S",
    "M5",
    "M6 T",
    "M19",
    "M29",
    "M30",
    "M98 P",
    "M99",
    "G65 P",
    "G66 P",
    "#1=",
    "#500=",
    "#5021",
    "[",
    "]",
    "+",
    "-",
    "*",
    "/",
    "SIN[",
    "SQRT[",
    "WHILE[#1LT10]DO1",
    "END1",
    "IF[#1EQ0]GOTO",
    "GOTO",
    "X",
    "Y",
    "Z",
    "C",
    "R",
    "Q",
    "F",
    "K",
    "L",
    "I",
    "J",
    "0",
    "1",
    "-1",
    ".5",
    "1e308",
    "99999999",
    "0.00001",
    "\n",
    "(",
    ")",
    "%",
    "O1000",
    "N10 ",
    "for (int i = 0; i < 3; i++) {",
    "}",
    "while (1) {",
    "MSG(\"x\");",
    "double d = ",
    ";",
    "@ITPPATH",
    "$x",
    "[axis]",
    "name = \"X\"",
    "=",
    "period_us = ",
    "counts_per_unit = ",
    "[[axis]]",
    "[bus]",
    "\u{e9}",
    "\u{ff}",
];

/// One mutation of `data` (in place): flip, insert a token, delete, duplicate or splice.
pub fn mutate(rng: &mut Rng, data: &mut Vec<u8>, other: &[u8], max_len: usize) {
    let len = data.len();
    match rng.below(8) {
        // A long run of one piece: deep nesting, long sums, huge blocks.
        7 if len > 0 && rng.below(4) == 0 => {
            let a = rng.below(len);
            let b = (a + 1 + rng.below(8)).min(len);
            let piece: Vec<u8> = data[a..b].to_vec();
            let times = 100 + rng.below(20_000);
            let at = rng.below(len + 1);
            let run: Vec<u8> = piece
                .iter()
                .copied()
                .cycle()
                .take(piece.len() * times)
                .collect();
            data.splice(at..at, run);
        }
        0 if len > 0 => {
            let i = rng.below(len);
            data[i] ^= 1 << rng.below(8);
        }
        1 | 2 => {
            let t = TOKENS[rng.below(TOKENS.len())].as_bytes();
            let at = rng.below(len + 1);
            data.splice(at..at, t.iter().copied());
        }
        3 if len > 0 => {
            let a = rng.below(len);
            let b = (a + 1 + rng.below(16)).min(len);
            data.drain(a..b);
        }
        4 if len > 0 => {
            let a = rng.below(len);
            let b = (a + 1 + rng.below(64)).min(len);
            let piece: Vec<u8> = data[a..b].to_vec();
            let at = rng.below(len + 1);
            let times = 1 + rng.below(8);
            for _ in 0..times {
                data.splice(at..at, piece.iter().copied());
            }
        }
        5 if !other.is_empty() => {
            let a = rng.below(other.len());
            let b = (a + 1 + rng.below(256)).min(other.len());
            let at = rng.below(len + 1);
            data.splice(at..at, other[a..b].iter().copied());
        }
        _ => {
            let at = rng.below(len + 1);
            data.insert(at, rng.next_u64() as u8);
        }
    }
    data.truncate(max_len);
}
