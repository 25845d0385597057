//! cansmoke: proves a real kernel CAN interface works for this project and measures the
//! timing figures of the machine (or emulated guest) it runs on.
//!
//! 1. frame exchange: sends standard and extended frames of every length 0..=8 on one socket
//!    and checks that a second socket on the same interface receives each, unchanged, in order;
//! 2. real-time grants: tries `mlockall` and SCHED_FIFO and says which were granted;
//! 3. a 1 ms `clock_nanosleep(TIMER_ABSTIME)` loop that sends one SYNC frame per tick while a
//!    reader thread counts them: wake-up lateness p50/p99/max, frames lost.
//!
//! Exit codes: 0 frames exchanged correctly; 1 a frame was lost, changed or reordered in step 1;
//! 2 bad arguments; 3 the interface could not be opened or used. Timing is reported, never
//! asserted (it depends on the machine).

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Duration;

use clap::Parser;
use cnc402_hil::latency::{LatencySummary, summarize};
use cnc402_hil::rt;
use serde::Serialize;
use socketcan::{CanFrame, CanSocket, EmbeddedFrame, ExtendedId, Frame, Id, Socket, StandardId};

/// Command line of cansmoke.
#[derive(Parser, Debug)]
#[command(about = "SocketCAN smoke test and wake-up latency probe")]
struct Args {
    /// CAN interface to use.
    #[arg(long, default_value = "vcan0")]
    iface: String,
    /// Frames to exchange in the correctness check.
    #[arg(long, default_value_t = 200)]
    frames: usize,
    /// Cycles of the periodic loop (0 skips the latency probe).
    #[arg(long, default_value_t = 5000)]
    cycles: usize,
    /// Period of the loop in microseconds.
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u64).range(50..=1_000_000))]
    period_us: u64,
    /// SCHED_FIFO priority to ask for (1..=99).
    #[arg(long, default_value_t = 80, value_parser = clap::value_parser!(i32).range(1..=99))]
    fifo_priority: i32,
    /// Only the periodic-loop probe, without CAN (for a host whose kernel has none: its figures
    /// are the peer of the guest's).
    #[arg(long)]
    latency_only: bool,
    /// Write the figures as JSON here.
    #[arg(long)]
    report: Option<PathBuf>,
}

/// Outcome of the frame-exchange check.
#[derive(Debug, Default, Serialize)]
struct ExchangeReport {
    sent: usize,
    received_ok: usize,
    /// First mismatch, if any (what was expected and what came).
    error: Option<String>,
    /// Frames on the bus that were not ours (other traffic), skipped.
    foreign_frames: usize,
    /// Write-to-receive time through the kernel, ns.
    round_trip: Option<LatencySummary>,
}

/// Outcome of the periodic-loop probe.
#[derive(Debug, Serialize)]
struct LoopReport {
    period_ns: u64,
    mlockall: String,
    sched_fifo: String,
    wakeup_latency: Option<LatencySummary>,
    sync_frames_sent: usize,
    sync_frames_received: usize,
    send_errors: usize,
}

#[derive(Debug, Serialize)]
struct Report {
    iface: String,
    kernel: String,
    exchange: Option<ExchangeReport>,
    periodic_loop: Option<LoopReport>,
}

/// Test frame `i`: even numbers standard ids, odd numbers extended ids, lengths cycling 0..=8,
/// payload derived from `i` so a swapped or stale frame is detected.
fn test_frame(i: usize) -> Option<CanFrame> {
    let len = i % 9;
    let data: Vec<u8> = (0..len)
        .map(|k| (i.wrapping_mul(31).wrapping_add(k * 7)) as u8)
        .collect();
    let id: Id = if i.is_multiple_of(2) {
        StandardId::new(0x100 + (i % 0x100) as u16)?.into()
    } else {
        ExtendedId::new(0x1ABC_0000 + (i as u32 & 0xFFFF))?.into()
    };
    CanFrame::new(id, &data)
}

fn describe(f: &CanFrame) -> String {
    let data: Vec<String> = f.data().iter().map(|b| format!("{b:02X}")).collect();
    format!(
        "{}{:X}#{}",
        if f.is_extended() { "x" } else { "" },
        f.raw_id(),
        data.join("")
    )
}

const SYNC_ID: u16 = 0x080;

fn exchange(tx: &CanSocket, rx: &CanSocket, frames: usize) -> Result<ExchangeReport, String> {
    let mut rep = ExchangeReport::default();
    let mut rtt = Vec::with_capacity(frames);
    for i in 0..frames {
        let Some(frame) = test_frame(i) else {
            return Err(format!("cannot build test frame {i}"));
        };
        let t0 = rt::monotonic_ns();
        tx.write_frame(&frame)
            .map_err(|e| format!("write_frame: {e}"))?;
        rep.sent += 1;
        loop {
            let got = match rx.read_frame_timeout(Duration::from_secs(2)) {
                Ok(f) => f,
                Err(e) => {
                    rep.error = Some(format!(
                        "frame {i} ({}) not received: {e}",
                        describe(&frame)
                    ));
                    return Ok(rep);
                }
            };
            let ours = matches!(&got, CanFrame::Data(_))
                && (got.is_extended() && got.raw_id() & 0x1FFF_0000 == 0x1ABC_0000
                    || !got.is_extended() && (0x100..0x200).contains(&got.raw_id()));
            if !ours {
                rep.foreign_frames += 1;
                continue;
            }
            rtt.push(rt::monotonic_ns() - t0);
            if got.id_word() != frame.id_word() || got.data() != frame.data() {
                rep.error = Some(format!(
                    "frame {i}: sent {} but received {}",
                    describe(&frame),
                    describe(&got)
                ));
                return Ok(rep);
            }
            rep.received_ok += 1;
            break;
        }
    }
    rep.round_trip = summarize(&mut rtt, 0);
    Ok(rep)
}

fn grant(r: std::io::Result<()>) -> String {
    match r {
        Ok(()) => "granted".to_string(),
        Err(e) => format!("refused: {e}"),
    }
}

/// The periodic loop; with `tx`, one SYNC frame per tick, counted by a reader thread.
fn periodic_loop(args: &Args, tx: Option<&CanSocket>) -> Result<LoopReport, String> {
    let period_ns = args.period_us * 1000;
    let rx = match tx {
        Some(_) => {
            Some(CanSocket::open(&args.iface).map_err(|e| format!("open {}: {e}", args.iface))?)
        }
        None => None,
    };
    let stop = Arc::new(AtomicBool::new(false));
    let received = Arc::new(AtomicUsize::new(0));
    let reader = rx.map(|rx| {
        let (stop, received) = (Arc::clone(&stop), Arc::clone(&received));
        std::thread::spawn(move || {
            while !stop.load(Ordering::Relaxed) {
                if let Ok(f) = rx.read_frame_timeout(Duration::from_millis(100))
                    && !f.is_extended()
                    && f.raw_id() == u32::from(SYNC_ID)
                {
                    received.fetch_add(1, Ordering::Relaxed);
                }
            }
            // Drain what is still queued.
            while let Ok(f) = rx.read_frame_timeout(Duration::from_millis(200)) {
                if !f.is_extended() && f.raw_id() == u32::from(SYNC_ID) {
                    received.fetch_add(1, Ordering::Relaxed);
                }
            }
        })
    });

    let mlock = grant(rt::lock_memory());
    let fifo = grant(rt::set_fifo(args.fifo_priority));
    println!(
        "cansmoke: mlockall {mlock}; SCHED_FIFO {} {fifo}",
        args.fifo_priority
    );

    let sync = StandardId::new(SYNC_ID)
        .and_then(|id| CanFrame::new(id, &[]))
        .ok_or("cannot build the SYNC frame")?;
    let mut samples = Vec::with_capacity(args.cycles);
    let mut sent = 0usize;
    let mut send_errors = 0usize;
    let run = rt::measure_wakeups(period_ns, args.cycles, &mut samples, |_| {
        if let Some(tx) = tx {
            match tx.write_frame(&sync) {
                Ok(()) => sent += 1,
                Err(_) => send_errors += 1,
            }
        }
    });
    stop.store(true, Ordering::Relaxed);
    if let Some(reader) = reader {
        let _ = reader.join();
    }
    run.map_err(|e| format!("clock_nanosleep: {e}"))?;
    Ok(LoopReport {
        period_ns,
        mlockall: mlock,
        sched_fifo: fifo,
        wakeup_latency: summarize(&mut samples, period_ns),
        sync_frames_sent: sent,
        sync_frames_received: received.load(Ordering::Relaxed),
        send_errors,
    })
}

fn us(ns: u64) -> String {
    format!("{:.1} us", ns as f64 / 1000.0)
}

fn main() -> ExitCode {
    let args = match Args::try_parse() {
        Ok(a) => a,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() {
                ExitCode::from(2)
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    if args.latency_only {
        let periodic = match periodic_loop(&args, None) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("cansmoke: periodic loop: {e}");
                return ExitCode::from(3);
            }
        };
        print_loop(&args, &periodic, false);
        return finish(&args, None, Some(periodic), false);
    }
    let open = |what: &str| {
        CanSocket::open(&args.iface)
            .map_err(|e| format!("cannot open {} ({what} socket): {e}", args.iface))
    };
    let (tx, rx) = match (open("send"), open("receive")) {
        (Ok(t), Ok(r)) => (t, r),
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("cansmoke: {e}");
            return ExitCode::from(3);
        }
    };
    let exchange = match exchange(&tx, &rx, args.frames) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("cansmoke: {e}");
            return ExitCode::from(3);
        }
    };
    drop(rx);
    match &exchange.error {
        None => println!(
            "cansmoke: {} frames (standard and extended, 0-8 bytes) sent and received intact on {}",
            exchange.received_ok, args.iface
        ),
        Some(e) => println!(
            "cansmoke: FAILED after {} good frames: {e}",
            exchange.received_ok
        ),
    }
    if let Some(r) = &exchange.round_trip {
        println!(
            "cansmoke: socket-to-socket time p50 {} p99 {} max {}",
            us(r.p50_ns),
            us(r.p99_ns),
            us(r.max_ns)
        );
    }

    let periodic = if args.cycles > 0 && exchange.error.is_none() {
        match periodic_loop(&args, Some(&tx)) {
            Ok(r) => {
                print_loop(&args, &r, true);
                Some(r)
            }
            Err(e) => {
                eprintln!("cansmoke: periodic loop: {e}");
                return ExitCode::from(3);
            }
        }
    } else {
        None
    };

    let failed = exchange.error.is_some() || exchange.received_ok != args.frames;
    finish(&args, Some(exchange), periodic, failed)
}

fn print_loop(args: &Args, r: &LoopReport, with_can: bool) {
    if let Some(l) = &r.wakeup_latency {
        println!(
            "cansmoke: {} us loop, {} cycles: wake-up latency p50 {} p99 {} max {} mean {}; {} wake-ups late by a whole period",
            args.period_us,
            l.samples,
            us(l.p50_ns),
            us(l.p99_ns),
            us(l.max_ns),
            us(l.mean_ns),
            l.late_by_a_period
        );
    }
    if with_can {
        println!(
            "cansmoke: SYNC frames sent {} received {} (send errors {})",
            r.sync_frames_sent, r.sync_frames_received, r.send_errors
        );
    }
}

/// Writes the JSON report (if asked) and turns the outcome into the exit code.
fn finish(
    args: &Args,
    exchange: Option<ExchangeReport>,
    periodic: Option<LoopReport>,
    failed: bool,
) -> ExitCode {
    let report = Report {
        iface: args.iface.clone(),
        kernel: std::fs::read_to_string("/proc/sys/kernel/osrelease")
            .map(|s| s.trim().to_string())
            .unwrap_or_default(),
        exchange,
        periodic_loop: periodic,
    };
    if let Some(path) = &args.report {
        let json = match serde_json::to_string_pretty(&report) {
            Ok(j) => j,
            Err(e) => {
                eprintln!("cansmoke: cannot serialise the report: {e}");
                return ExitCode::from(3);
            }
        };
        if let Err(e) = cnc402_durable::write_atomic(path, (json + "\n").as_bytes()) {
            eprintln!("cansmoke: cannot write {}: {e}", path.display());
            return ExitCode::from(3);
        }
    }
    if failed {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_frames_cover_both_id_kinds_and_all_lengths() {
        let frames: Vec<CanFrame> = (0..18).map(|i| test_frame(i).unwrap()).collect();
        for (i, f) in frames.iter().enumerate() {
            assert_eq!(f.data().len(), i % 9);
            assert_eq!(f.is_extended(), i % 2 == 1);
        }
    }

    #[test]
    fn consecutive_test_frames_differ() {
        // A stale or repeated frame must not pass the exchange check.
        for i in 0..5000 {
            let (a, b) = (test_frame(i).unwrap(), test_frame(i + 1).unwrap());
            assert!(
                a.id_word() != b.id_word() || a.data() != b.data(),
                "frames {i} and {}",
                i + 1
            );
        }
    }

    #[test]
    fn describe_uses_candump_notation() {
        assert_eq!(describe(&test_frame(0).unwrap()), "100#");
        assert_eq!(describe(&test_frame(1).unwrap()), "x1ABC0001#1F");
    }
}
