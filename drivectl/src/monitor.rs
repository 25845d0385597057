//! `monitor` and `emcy`: receive everything on the bus, decode it, keep bus load and SYNC
//! period statistics, and optionally log in can-utils `candump -l` format. On the simulator
//! virtual time is paced to the wall clock, so the view is live there too.

use core::time::Duration;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;
use std::time::{Instant as WallInstant, SystemTime, UNIX_EPOCH};

use cnc402_drives::Instant;
use cnc402_drives::master::TimedBus;
use cnc402_drives::wire::CanFrame;
use cnc402_durable::AtomicFile;
use serde_json::json;

use crate::Ctx;
use crate::decode::{Decoded, decode};
use crate::error::{CliError, Exit, Result};
pub use crate::period::PeriodStats;

/// One line of a `candump -l` log: `(1700000000.123456) can0 601#4041600000000000`.
///
/// ```
/// use cnc402_drives::wire::CanFrame;
/// let f = CanFrame::new(0x601, &[0x40, 0x41, 0x60, 0]).unwrap();
/// assert_eq!(drivectl::monitor::candump_line(12.5, "vcan0", &f), "(12.500000) vcan0 601#40416000");
/// let r = CanFrame::new_remote(0x705, 1).unwrap();
/// assert_eq!(drivectl::monitor::candump_line(0.0, "can0", &r), "(0.000000) can0 705#R1");
/// ```
pub fn candump_line(t: f64, iface: &str, f: &CanFrame) -> String {
    let secs = t.max(0.0);
    let whole = secs.trunc() as u64;
    let usec = ((secs - secs.trunc()) * 1e6).round().min(999_999.0) as u64;
    let data = if f.is_remote() {
        if f.dlc() > 0 {
            format!("R{}", f.dlc())
        } else {
            "R".to_string()
        }
    } else {
        f.data().iter().map(|b| format!("{b:02X}")).collect()
    };
    format!("({whole}.{usec:06}) {iface} {:03X}#{data}", f.id())
}

/// The `--log` timestamp (s) of bus time `t`: virtual bus time from power-on on the
/// simulator, else wall-clock epoch seconds (`wall0` was taken at bus time `start`).
fn log_time(sim: bool, wall0: SystemTime, start: Instant, t: Instant) -> f64 {
    if sim {
        t.nanos() as f64 * 1e-9
    } else {
        wall0
            .duration_since(UNIX_EPOCH)
            .map(|d| d.as_secs_f64())
            .unwrap_or(0.0)
            + t.saturating_since(start).as_secs_f64()
    }
}

/// Creates the `--log` file (buffered, written under a temporary name and put in place whole
/// when the capture ends, however it ends); an error is an I/O error naming the path.
fn create_log(log: Option<&Path>) -> Result<Option<AtomicFile>> {
    log.map(|p| {
        AtomicFile::create(p)
            .map(AtomicFile::commit_on_drop)
            .map_err(|e| CliError::new(Exit::Io, format!("cannot create log {}: {e}", p.display())))
    })
    .transpose()
}

struct Clock {
    wall0: WallInstant,
    bus0: Instant,
    sim: bool,
}

impl Clock {
    /// On the simulator, sleep until the wall clock has caught up with bus time `t`.
    fn pace(&self, t: Instant) {
        if self.sim {
            let target = t.saturating_since(self.bus0);
            let wall = self.wall0.elapsed();
            if target > wall {
                std::thread::sleep(target - wall);
            }
        }
    }
}

fn seconds(d: Option<f64>, what: &str) -> Result<Option<Duration>> {
    match d {
        None => Ok(None),
        Some(s) if s.is_finite() && s > crate::cli::MAX_SECONDS => Err(CliError::usage(format!(
            "{what} {s} is too long (at most {} s; leave it out to run until Ctrl-C)",
            crate::cli::MAX_SECONDS
        ))),
        Some(s) if s.is_finite() && s >= 0.0 => Ok(Some(Duration::from_secs_f64(s))),
        Some(s) => Err(CliError::usage(format!(
            "{what} {s} is not a time in seconds"
        ))),
    }
}

/// What [`receive_loop`] reports.
enum Event<'a> {
    /// A frame received at this time.
    Frame(Instant, &'a CanFrame),
    /// A statistics boundary.
    Tick(Instant),
}

/// Receives frames until `end` (or Ctrl-C), calling `on(ctx, Event::Frame)` per frame and
/// `on(ctx, Event::Tick)` at every `tick` boundary.
fn receive_loop(
    ctx: &mut Ctx,
    end: Option<Instant>,
    tick: Duration,
    on: &mut dyn FnMut(&mut Ctx, Event<'_>) -> Result<()>,
) -> Result<Instant> {
    let clock = Clock {
        wall0: WallInstant::now(),
        bus0: ctx.now(),
        sim: ctx.link.sim().is_some(),
    };
    let chunk = Duration::from_millis(10);
    let mut next_tick = ctx.now() + tick;
    loop {
        if ctx.interrupted() {
            break;
        }
        let now = ctx.now();
        if let Some(e) = end
            && now >= e
        {
            break;
        }
        let mut deadline = (now + chunk).min(next_tick);
        if let Some(e) = end {
            deadline = deadline.min(e);
        }
        clock.pace(deadline);
        while let Some(f) = ctx.link.recv_until(deadline)? {
            let t = ctx.now();
            on(ctx, Event::Frame(t, &f))?;
        }
        if ctx.now() >= next_tick {
            let t = ctx.now();
            on(ctx, Event::Tick(t))?;
            next_tick += tick;
        }
    }
    Ok(ctx.now())
}

/// Reads the PDO mappings (communication COB-ID, mapping entries) of every configured drive
/// by SDO, so `monitor` decodes PDOs by what the drives really send. Drives that do not
/// answer are skipped with a note.
pub fn read_mappings(ctx: &mut Ctx) -> Result<()> {
    use cia402::objects as obj;
    use cnc402_drives::wire::{MappingEntry, PdoMap};
    let nodes: Vec<u8> = ctx.cfg.axes.iter().filter_map(|a| a.node).collect();
    let mut maps = crate::decode::PdoMaps::default();
    const KINDS: [[&str; 4]; 2] = [
        ["rpdo1", "rpdo2", "rpdo3", "rpdo4"],
        ["tpdo1", "tpdo2", "tpdo3", "tpdo4"],
    ];
    for n in nodes {
        let node = crate::node_id(n)?;
        let r = ctx.with_sdo(
            |sdo| -> core::result::Result<
                Vec<(u16, &'static str, PdoMap)>,
                cnc402_drives::master::SdoError,
            > {
                let mut found = Vec::new();
                for (t, (comm, mapping)) in [
                    (obj::RPDO_COMMUNICATION, obj::RPDO_MAPPING),
                    (obj::TPDO_COMMUNICATION, obj::TPDO_MAPPING),
                ]
                .into_iter()
                .enumerate()
                {
                    for i in 0..4u16 {
                        // A PDO the drive does not have aborts; silence is an error.
                        let cob = match sdo.read_u32(node, comm + i, 1) {
                            Ok(c) => c,
                            Err(e) if e.abort_code().is_some() => continue,
                            Err(e) => return Err(e),
                        };
                        if cob & 0x8000_0000 != 0 {
                            continue;
                        }
                        let k = sdo.read_u8(node, mapping + i, 0)?;
                        let mut entries = Vec::new();
                        for s in 1..=k.min(8) {
                            entries.push(MappingEntry::from_u32(sdo.read_u32(
                                node,
                                mapping + i,
                                s,
                            )?));
                        }
                        if let Ok(m) = PdoMap::from_entries(&entries)
                            && !m.is_empty()
                        {
                            found.push(((cob & 0x7FF) as u16, KINDS[t][i as usize], m));
                        }
                    }
                }
                Ok(found)
            },
        );
        match r {
            Ok(found) => {
                for (cob, kind, m) in found {
                    maps.insert(cob, kind, m);
                }
            }
            Err(e) => ctx.say(format!(
                "note: PDO mapping of {} not read: {e}",
                ctx.label(n)
            )),
        }
    }
    ctx.say(format!(
        "{} PDO mapping(s) read from the drives",
        maps.len()
    ));
    ctx.pdo_maps = maps;
    Ok(())
}

/// One received frame, decoded, as text or JSON.
fn say_frame(ctx: &Ctx, rel: f64, f: &CanFrame, d: &Decoded) {
    if ctx.json {
        ctx.emit_json(&json!({
            "t": rel, "id": f.id(), "data": crate::values::hex(f.data()), "kind": d.kind,
            "node": d.node, "axis": d.node.and_then(|n| ctx.names.get(n)),
            "text": d.text, "fields": d.fields,
        }));
    } else {
        let who = d.node.map(|n| ctx.label(n)).unwrap_or_default();
        ctx.say(format!(
            "{rel:>10.6}  {:03X}  {:<16} {}",
            f.id(),
            who,
            d.text
        ));
    }
}

/// The end-of-monitor summary: frames, bus load, frames by kind and the SYNC period.
fn say_summary(
    ctx: &Ctx,
    span: Duration,
    total_frames: u64,
    total_bits: u64,
    bitrate: u32,
    kinds: &BTreeMap<&'static str, u64>,
    sync: &PeriodStats,
) {
    let load = if span.is_zero() {
        0.0
    } else {
        100.0 * total_bits as f64 / (bitrate as f64 * span.as_secs_f64())
    };
    let s = sync.summary();
    if ctx.json {
        ctx.emit_json(&json!({ "summary": {
            "seconds": span.as_secs_f64(), "frames": total_frames, "load_percent": load,
            "by_kind": kinds,
            "sync_period_us": s.map(|(n, mean, p50, p99, max)| json!({ "n": n, "mean": mean, "p50": p50, "p99": p99, "max": max })),
        }}));
    } else {
        ctx.say(format!(
            "{total_frames} frames in {:.3} s, bus load {load:.1} % at {} kbit/s; {}",
            span.as_secs_f64(),
            bitrate / 1000,
            kinds
                .iter()
                .map(|(k, n)| format!("{k} {n}"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
        if let Some((n, mean, p50, p99, max)) = s {
            ctx.say(format!(
                "SYNC period: mean {mean:.1} µs, p50 {p50:.1}, p99 {p99:.1}, max {max:.1} (n={n})"
            ));
        }
    }
}

/// `drivectl monitor`.
pub fn monitor(
    ctx: &mut Ctx,
    log: Option<&Path>,
    duration: Option<f64>,
    stats_every: f64,
    quiet: bool,
) -> Result<()> {
    let duration = seconds(duration, "--duration")?;
    let every = seconds(Some(stats_every), "--stats-every")?
        .unwrap_or(Duration::from_secs(1))
        .max(Duration::from_millis(10));
    let mut log = create_log(log)?;
    let iface = ctx.link.name().to_string();
    let sim = ctx.link.sim().is_some();
    let start = ctx.now();
    let end = duration.map(|d| start + d);
    let bitrate = ctx.cfg.bus.bitrate.max(1);
    let wall0 = SystemTime::now();
    let mut total_frames = 0u64;
    let mut total_bits = 0u64;
    let mut win_bits = 0u64;
    let mut win_frames = 0u64;
    let mut win_start = start;
    let mut kinds: BTreeMap<&'static str, u64> = BTreeMap::new();
    let mut sync = PeriodStats::default();
    let mut log_err: Option<std::io::Error> = None;
    if !ctx.json {
        ctx.say(format!(
            "monitoring {iface} at {} kbit/s{} (Ctrl-C to stop)",
            bitrate / 1000,
            if sim {
                ", simulator paced to the wall clock"
            } else {
                ""
            }
        ));
    }
    let stamp = |t: Instant| log_time(sim, wall0, start, t);
    let mut stats_lines: Vec<serde_json::Value> = Vec::new();
    let mut on = |ctx: &mut Ctx, ev: Event<'_>| -> Result<()> {
        let (t, f) = match ev {
            Event::Frame(t, f) => (t, f),
            Event::Tick(t) => {
                tick(
                    ctx,
                    t,
                    &mut win_start,
                    &mut win_bits,
                    &mut win_frames,
                    bitrate,
                    start,
                    &sync,
                    &mut stats_lines,
                );
                return Ok(());
            }
        };
        total_frames += 1;
        total_bits += f.bits() as u64;
        win_bits += f.bits() as u64;
        win_frames += 1;
        let d = decode(f, &ctx.dict, &ctx.pdo_maps);
        *kinds.entry(d.kind).or_default() += 1;
        if d.kind == "sync" {
            sync.on_sync(t);
        }
        if let Some(w) = log.as_mut()
            && log_err.is_none()
            && let Err(e) = writeln!(w, "{}", candump_line(stamp(t), &iface, f))
        {
            log_err = Some(e);
        }
        if !quiet {
            say_frame(ctx, t.saturating_since(start).as_secs_f64(), f, &d);
        }
        Ok(())
    };
    let stop = receive_loop(ctx, end, every, &mut on)?;
    if let Some(w) = log
        && let Err(e) = w.commit()
    {
        log_err.get_or_insert(e);
    }
    say_summary(
        ctx,
        stop.saturating_since(start),
        total_frames,
        total_bits,
        bitrate,
        &kinds,
        &sync,
    );
    if let Some(e) = log_err {
        return Err(CliError::new(
            Exit::Io,
            format!("writing the log failed: {e}"),
        ));
    }
    Ok(())
}

/// `drivectl emcy`.
pub fn emcy(ctx: &mut Ctx, duration: Option<f64>) -> Result<()> {
    let duration = seconds(duration, "--duration")?;
    let start = ctx.now();
    let end = duration.map(|d| start + d);
    let mut count = 0u64;
    if !ctx.json {
        ctx.say(format!(
            "watching EMCY on {} (Ctrl-C to stop)",
            ctx.link.name()
        ));
    }
    let mut on = |ctx: &mut Ctx, ev: Event<'_>| -> Result<()> {
        let Event::Frame(t, f) = ev else {
            return Ok(());
        };
        let d = decode(f, &ctx.dict, &ctx.pdo_maps);
        if d.kind != "emcy" {
            return Ok(());
        }
        count += 1;
        let rel = t.saturating_since(start).as_secs_f64();
        let n = d.node.unwrap_or(0);
        if ctx.json {
            ctx.emit_json(&json!({ "t": rel, "node": n, "axis": ctx.names.get(n), "emcy": d.fields, "text": d.text }));
        } else {
            ctx.say(format!("{rel:>10.6}  {}: {}", ctx.label(n), d.text));
        }
        Ok(())
    };
    receive_loop(ctx, end, Duration::from_secs(3600), &mut on)?;
    if !ctx.json {
        ctx.say(format!("{count} EMCY message(s)"));
    }
    Ok(())
}

/// One statistics line: frames and bus load since the last one, SYNC periods so far.
#[allow(clippy::too_many_arguments)]
fn tick(
    ctx: &mut Ctx,
    t: Instant,
    win_start: &mut Instant,
    win_bits: &mut u64,
    win_frames: &mut u64,
    bitrate: u32,
    start: Instant,
    sync: &PeriodStats,
    lines: &mut Vec<serde_json::Value>,
) {
    let span = t.saturating_since(*win_start);
    let load = if span.is_zero() {
        0.0
    } else {
        100.0 * *win_bits as f64 / (bitrate as f64 * span.as_secs_f64())
    };
    let s = sync.summary();
    let v = json!({ "stats": {
        "t": t.saturating_since(start).as_secs_f64(), "frames": *win_frames,
        "load_percent": load,
        "sync_period_us": s.map(|(n, mean, p50, p99, max)| json!({ "n": n, "mean": mean, "p50": p50, "p99": p99, "max": max })),
    }});
    if ctx.json {
        ctx.emit_json(&v);
    } else {
        ctx.say(format!(
            "-- {} frames, bus load {load:.1} %{}",
            *win_frames,
            match s {
                Some((n, mean, p50, p99, max)) => format!(
                    ", SYNC period mean {mean:.1} µs p50 {p50:.1} p99 {p99:.1} max {max:.1} (n={n})"
                ),
                None => String::new(),
            }
        ));
    }
    lines.push(v);
    *win_bits = 0;
    *win_frames = 0;
    *win_start = t;
}

/// `drivectl monitor --tui`: the full-screen view until `q`, Esc, Ctrl-C or `--duration`.
pub fn monitor_tui(ctx: &mut Ctx, log: Option<&Path>, duration: Option<f64>) -> Result<()> {
    use ratatui::crossterm::event::{self, Event as TermEvent, KeyCode, KeyModifiers};
    use std::io::IsTerminal;
    use std::sync::atomic::Ordering;

    if !std::io::stdout().is_terminal() {
        return Err(CliError::usage(
            "--tui needs a terminal (use `monitor` or `monitor --json` in scripts)",
        ));
    }
    let duration = seconds(duration, "--duration")?;
    let mut log = create_log(log)?;
    let iface = ctx.link.name().to_string();
    let sim = ctx.link.sim().is_some();
    let start = ctx.now();
    let wall0 = SystemTime::now();
    let nodes: Vec<u8> = ctx.cfg.axes.iter().filter_map(|a| a.node).collect();
    let mut state = crate::tui::TuiState::new(
        &iface,
        ctx.names.clone(),
        &nodes,
        ctx.cfg.bus.bitrate,
        start,
    );
    let end = duration.map(|d| start + d);
    let mut terminal = ratatui::try_init()
        .map_err(|e| CliError::new(Exit::Io, format!("cannot start the TUI: {e}")))?;
    let ui_err = |e: std::io::Error| CliError::new(Exit::Io, format!("terminal: {e}"));
    let mut on = |ctx: &mut Ctx, ev: Event<'_>| -> Result<()> {
        match ev {
            Event::Frame(t, f) => {
                state.on_frame(t, f, &ctx.dict, &ctx.pdo_maps);
                if let Some(w) = log.as_mut() {
                    let ts = log_time(sim, wall0, start, t);
                    writeln!(w, "{}", candump_line(ts, &iface, f)).map_err(|e| {
                        CliError::new(Exit::Io, format!("writing the log failed: {e}"))
                    })?;
                }
            }
            Event::Tick(t) => {
                state.on_tick(t);
                terminal.draw(|fr| state.render(fr)).map_err(ui_err)?;
                while event::poll(Duration::ZERO).map_err(ui_err)? {
                    if let TermEvent::Key(k) = event::read().map_err(ui_err)? {
                        let ctrl_c = k.code == KeyCode::Char('c')
                            && k.modifiers.contains(KeyModifiers::CONTROL);
                        if ctrl_c || matches!(k.code, KeyCode::Char('q') | KeyCode::Esc) {
                            ctx.interrupted.store(true, Ordering::SeqCst);
                        }
                    }
                }
            }
        }
        Ok(())
    };
    let r = receive_loop(ctx, end, Duration::from_millis(100), &mut on);
    ratatui::restore();
    if let Some(w) = log {
        w.commit()
            .map_err(|e| CliError::new(Exit::Io, format!("writing the log failed: {e}")))?;
    }
    r.map(|_| ())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The old exact definition: nearest rank `round((n-1)·p)` of the sorted samples.
    fn exact(v: &[f64], p: f64) -> f64 {
        let mut v = v.to_vec();
        v.sort_by(|a, b| a.total_cmp(b));
        v[((v.len() - 1) as f64 * p).round() as usize]
    }

    fn stats(v: &[f64]) -> PeriodStats {
        let mut s = PeriodStats::default();
        for &x in v {
            s.push(x);
        }
        s
    }

    #[test]
    fn percentiles_within_half_a_bucket_of_exact() {
        // 1 ms SYNC with a deterministic ±40 µs jitter and a few late ones.
        let mut v: Vec<f64> = (0..10_000u32)
            .map(|i| 1000.0 + ((i * 7919) % 81) as f64 - 40.0 + 0.37)
            .collect();
        v.extend([1480.2, 2210.9, 3999.5]);
        let s = stats(&v);
        for p in [0.0, 0.5, 0.9, 0.99, 0.999, 1.0] {
            let (h, e) = (s.percentile(p).unwrap(), exact(&v, p));
            assert!((h - e).abs() <= 0.5, "p{p}: {h} vs exact {e}");
        }
        let (n, mean, p50, p99, max) = s.summary().unwrap();
        assert_eq!(n, v.len() as u64);
        assert!((mean - v.iter().sum::<f64>() / v.len() as f64).abs() < 1e-9);
        assert_eq!(max, 3999.5);
        assert!((s.min().unwrap() - 960.37).abs() < 1e-9);
        assert!((p50 - exact(&v, 0.5)).abs() <= 0.5);
        assert!((p99 - exact(&v, 0.99)).abs() <= 0.5);
    }

    #[test]
    fn coarse_buckets_overflow_and_edges() {
        // Above 5 ms the buckets are 1 ms wide.
        let v: Vec<f64> = (0..100).map(|i| 5_000.0 + i as f64 * 97.0).collect();
        let s = stats(&v);
        for p in [0.1, 0.5, 0.99] {
            let (h, e) = (s.percentile(p).unwrap(), exact(&v, p));
            assert!((h - e).abs() <= 500.0, "p{p}: {h} vs exact {e}");
        }
        // One value only: every percentile is that value exactly (clamped to min/max).
        let s = stats(&[1234.56]);
        assert_eq!(s.summary(), Some((1, 1234.56, 1234.56, 1234.56, 1234.56)));
        // Beyond 1 s: counted, reported through the exact max.
        let s = stats(&[1000.0, 5_000_000.0, 7_000_000.0]);
        assert_eq!(s.percentile(0.99), Some(7_000_000.0));
        assert_eq!(s.percentile(0.5), Some(7_000_000.0)); // above 1 s: the max
        assert_eq!(s.percentile(0.0), Some(1000.0));
        // Bad input neither panics nor counts; negative counts as 0.
        let mut s = stats(&[f64::NAN, f64::INFINITY]);
        assert_eq!(s.summary(), None);
        s.push(-3.0);
        assert_eq!(s.summary(), Some((1, 0.0, 0.0, 0.0, 0.0)));
    }

    #[test]
    fn periods_between_syncs() {
        let mut s = PeriodStats::default();
        let t0 = Instant::from_nanos(5_000_000);
        s.on_sync(t0);
        assert_eq!(s.summary(), None);
        s.on_sync(t0 + Duration::from_micros(1000));
        s.on_sync(t0 + Duration::from_micros(2003));
        assert_eq!(s.count(), 2);
        assert_eq!(s.min(), Some(1000.0));
        assert_eq!(s.summary().unwrap().4, 1003.0);
    }

    #[test]
    fn memory_is_bounded() {
        let mut s = PeriodStats::default();
        let len = s.hist.bucket_count();
        for i in 0..1_000_000u32 {
            s.push(900.0 + (i % 200) as f64);
        }
        assert_eq!(s.hist.bucket_count(), len);
        assert_eq!(s.count(), 1_000_000);
        let p50 = s.percentile(0.5).unwrap();
        assert!((p50 - 1000.0).abs() <= 0.5, "{p50}");
    }
}
