//! simdrive: simulated CiA 402 drives on a real CAN interface, one per configured node (the
//! same `SimDrive` model as `cnc402 run` with `bus.interface = "sim"`), in real time. It checks
//! rigid-tapping coupling from the bus, measures the SYNC period, counts protocol errors,
//! injects faults on command and writes a JSON report when it ends (SIGTERM, SIGINT,
//! `--duration`).
//!
//! Exit codes (shared by all binaries, docs/exit-codes.md): 0 every check passed; 9 a check
//! failed (see the report); 3 the config is wrong or lacks a node asked for; 4 the interface
//! could not be opened or failed, or the report could not be written; 64 bad arguments.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use clap::Parser;
use cnc402_config::{MachineConfig, exit};
use cnc402_drives::bus::{BusError, CanBus, CanDevice};
use cnc402_drives::master::TimedBus;
use cnc402_drives::socketcan::SocketCanBus;
use cnc402_hil::rt;
use cnc402_hil::simdrive::{
    BusFigures, DriveHost, FaultClock, FaultSpec, HostOptions, parse_boot_delay,
    parse_start_in_fault,
};

/// The example of `--help` (`--help` adds the exit codes).
const EXAMPLE: &str = "Example:\n  simdrive --config config/machine.toml --iface vcan0 --report drive.json \\\n      --fault 3:fault:0x7300@2.5 --boot-delay 2:1.5 --start-in-fault 1";

/// Command line of simdrive.
#[derive(Parser, Debug)]
#[command(
    name = "simdrive",
    version,
    about = "Simulated CiA 402 drives on a CAN interface, with coupling, SYNC and protocol checks",
    after_help = EXAMPLE,
    after_long_help = format!("{EXAMPLE}\n\n{}", exit::help_table())
)]
struct Args {
    /// Machine description (one drive per axis with a node id) [default: as cnc402 finds it:
    /// $CNC402_CONFIG, ./config/machine.toml, ~/.config/cnc402/machine.toml,
    /// /etc/cnc402/machine.toml, else the built-in machine].
    #[arg(long)]
    config: Option<PathBuf>,
    /// CAN interface.
    #[arg(long, default_value = "vcan0")]
    iface: String,
    /// Write the JSON report here on exit.
    #[arg(long, value_name = "FILE.json")]
    report: Option<PathBuf>,
    /// Inject a fault: KIND = fault[:CODE] (FAULT + EMCY), fault-persistent[:CODE],
    /// heartbeat (silence), sdo (no SDO answers), tpdo (drop TPDOs). SECONDS count from the
    /// first SYNC (see --fault-clock). Repeatable.
    #[arg(long, value_name = "NODE:KIND@SECONDS")]
    fault: Vec<FaultSpec>,
    /// Where --fault's SECONDS start: `sync` (first SYNC seen), `start` (power-on) or `tap`
    /// (the first SYNC on which Z and C move together: inside the first tap).
    #[arg(long, default_value = "sync", value_parser = ["sync", "start", "tap"])]
    fault_clock: String,
    /// A drive that boots late: its boot-up message comes SECONDS after power-on. Repeatable.
    #[arg(long, value_name = "NODE:SECONDS", value_parser = parse_boot_delay)]
    boot_delay: Vec<(u8, f64)>,
    /// A drive in FAULT at power-on (EMCY CODE, default 0x1000). Repeatable.
    #[arg(long, value_name = "NODE[:CODE]", value_parser = parse_start_in_fault)]
    start_in_fault: Vec<(u8, u16)>,
    /// Simulate only these nodes of the config (comma-separated; default: every node). Two
    /// simdrive processes on one node id are a duplicate node id on the bus.
    #[arg(long, value_name = "NODE,..", value_delimiter = ',')]
    nodes: Vec<u8>,
    /// Judge each tap window's actual-position coupling against UM micrometres (default:
    /// reported only). When the config's Z and spindle `dynamics` differ, the master shapes
    /// their setpoints apart on purpose (dynamic matching): the setpoint windows are then
    /// reported only, and this is the tap's judgement.
    #[arg(long, value_name = "UM")]
    actual_limit_um: Option<f64>,
    /// Stop after this many seconds (default: run until SIGTERM/SIGINT).
    #[arg(long, value_name = "S")]
    duration: Option<f64>,
    /// Every S seconds print one `simdrive: stats` line on stderr: SYNCs and frames so far,
    /// the interval's longest SYNC interval and its SYNC intervals over 1.5 periods.
    #[arg(long, value_name = "S")]
    stats_every: Option<f64>,
    /// Do not ask for mlockall and SCHED_FIFO.
    #[arg(long)]
    no_rt: bool,
    /// SCHED_FIFO priority (below the master's, which paces the bus).
    #[arg(long, default_value_t = 70, value_parser = clap::value_parser!(i32).range(1..=99))]
    fifo_priority: i32,
}

static STOP: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    STOP.store(true, Ordering::SeqCst);
}

fn install_signals() {
    // SAFETY: the handler only stores to an atomic (async-signal-safe). No SA_RESTART, so a
    // blocking receive returns EINTR and the loop sees STOP at once.
    unsafe {
        let mut sa: libc::sigaction = std::mem::zeroed();
        sa.sa_sigaction = on_signal as *const () as usize;
        libc::sigemptyset(&mut sa.sa_mask);
        sa.sa_flags = 0;
        libc::sigaction(libc::SIGTERM, &sa, std::ptr::null_mut());
        libc::sigaction(libc::SIGINT, &sa, std::ptr::null_mut());
    }
}

fn grants(no_rt: bool, prio: i32) -> String {
    if no_rt {
        return "not asked (--no-rt)".into();
    }
    let m = match rt::lock_memory() {
        Ok(()) => "mlockall granted".to_string(),
        Err(e) => format!("mlockall refused ({e})"),
    };
    let f = match rt::set_fifo(prio) {
        Ok(()) => format!("SCHED_FIFO {prio} granted"),
        Err(e) => format!("SCHED_FIFO refused ({e})"),
    };
    format!("{m}, {f}")
}

/// The `--stats-every` line for the stretch of the run that ends at `now`.
fn stats_line(host: &mut DriveHost, bus: &SocketCanBus, now: cnc402_drives::Instant) -> String {
    let w = host.take_sync_window();
    let c = bus.counters();
    format!(
        "simdrive: stats t_s={:.1} syncs={} rx={} tx={} sync_intervals={} sync_max_us={:.0} sync_long={}",
        Duration::from_nanos(now.nanos()).as_secs_f64(),
        host.counters().syncs,
        c.rx_frames,
        c.tx_frames,
        w.intervals,
        w.max_ns as f64 / 1000.0,
        w.long
    )
}

/// Answers frames and polls the drives' timers (at least every `tick`) until a signal, the
/// end of `--duration`, or a receive failure (returned); a stats line every `stats_every`.
/// The interface going down is no failure: drives outlive their master's interface, so they
/// go on (their sends fail, counted) and take frames again when it is back up; each receive
/// that found it down is counted in `down_events`.
fn serve(
    host: &mut DriveHost,
    bus: &mut SocketCanBus,
    tick: Duration,
    end: Option<cnc402_drives::Instant>,
    stats_every: Option<Duration>,
    down_events: &mut u64,
) -> Option<String> {
    let mut failure: Option<String> = None;
    host.poll(TimedBus::now(bus), bus);
    let mut next_stats = stats_every.map(|e| TimedBus::now(bus) + e);
    while !STOP.load(Ordering::SeqCst) {
        let now = TimedBus::now(bus);
        if end.is_some_and(|e| now >= e) {
            break;
        }
        if let (Some(due), Some(every)) = (next_stats, stats_every)
            && now >= due
        {
            eprintln!("{}", stats_line(host, bus, now));
            next_stats = Some(due + every);
        }
        match bus.recv_timeout(tick) {
            Ok(Some(frame)) => {
                let now = TimedBus::now(bus);
                host.on_frame(&frame, now, bus);
                // Drain what is already queued before polling timers.
                loop {
                    match bus.recv() {
                        Ok(Some(f)) => {
                            let now = TimedBus::now(bus);
                            host.on_frame(&f, now, bus);
                        }
                        Ok(None) => break,
                        Err(BusError::Down) => {
                            *down_events += 1;
                            break;
                        }
                        Err(e) => {
                            failure = Some(format!("receive failed: {e}"));
                            break;
                        }
                    }
                }
            }
            Ok(None) => {}
            Err(BusError::Down) => {
                if *down_events == 0 {
                    eprintln!("simdrive: the interface is down: waiting for it to come back");
                }
                *down_events += 1;
                std::thread::sleep(tick);
            }
            Err(e) => failure = Some(format!("receive failed: {e}")),
        }
        if failure.is_some() {
            break;
        }
        let now = TimedBus::now(bus);
        host.poll(now, bus);
    }
    failure
}

fn main() -> ExitCode {
    // RUST_LOG as in cnc402 (default: warnings only).
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let args = match Args::try_parse() {
        Ok(a) => a,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(exit::for_clap(e.use_stderr()));
        }
    };
    let cfg = match MachineConfig::locate(args.config.as_deref()) {
        Ok((c, origin)) => {
            if let Some(note) = origin.note() {
                eprintln!("simdrive: {note}");
            }
            c
        }
        Err(e) => {
            eprintln!("simdrive: {e}");
            return ExitCode::from(exit::CONFIG);
        }
    };
    log::debug!("config {}: {} axes", cfg.path.display(), cfg.axes.len());
    let opts = HostOptions {
        faults: args.fault.clone(),
        fault_clock: match args.fault_clock.as_str() {
            "start" => FaultClock::Start,
            "tap" => FaultClock::FirstTap,
            _ => FaultClock::FirstSync,
        },
        boot_delays: args.boot_delay.clone(),
        start_in_fault: args.start_in_fault.clone(),
        only_nodes: args.nodes.clone(),
        actual_limit_um: args.actual_limit_um,
    };
    let mut host = match DriveHost::new(&cfg, &opts) {
        Ok(h) => h,
        Err(e) => {
            eprintln!("simdrive: {e}");
            return ExitCode::from(exit::CONFIG);
        }
    };
    if let Some(d) = args.duration
        && !(d.is_finite() && d > 0.0)
    {
        eprintln!("simdrive: --duration must be a positive number of seconds");
        return ExitCode::from(exit::USAGE);
    }
    let stats_every = match args.stats_every {
        None => None,
        Some(s) if s.is_finite() && (0.01..=86_400.0).contains(&s) => {
            Some(Duration::from_secs_f64(s))
        }
        Some(_) => {
            eprintln!("simdrive: --stats-every must be seconds from 0.01 to 86400");
            return ExitCode::from(exit::USAGE);
        }
    };
    install_signals();
    log::debug!("opening CAN interface {}", args.iface);
    let mut bus = match SocketCanBus::open(&args.iface) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("simdrive: {e}");
            return ExitCode::from(exit::IO);
        }
    };
    let granted = grants(args.no_rt, args.fifo_priority);
    // The ready line: printed once the socket is bound (open binds it), so frames sent from
    // now on reach the drives. Scripts wait for it (hil-tests/scenarios/common.bash
    // SIMDRIVE_READY, drivectl/hil.sh): keep it after the open and keep its start.
    eprintln!(
        "simdrive: nodes {:?} on {} (period {} µs); {granted}",
        host.nodes(),
        args.iface,
        cfg.bus.period_us
    );
    let end = args
        .duration
        .map(|s| TimedBus::now(&bus) + Duration::from_secs_f64(s));
    // Timers (heartbeat, boot, following-error time-out) need a poll at least this often.
    let tick = Duration::from_micros(250);
    let mut down_events = 0;
    let failure = serve(
        &mut host,
        &mut bus,
        tick,
        end,
        stats_every,
        &mut down_events,
    );
    host.finish();
    let elapsed = Duration::from_nanos(TimedBus::now(&bus).nanos());
    let c = bus.counters();
    let figures = BusFigures {
        iface: args.iface.clone(),
        seconds: elapsed.as_secs_f64(),
        rx_frames: c.rx_frames,
        tx_frames: c.tx_frames,
        load_percent: c.load_percent(cfg.bus.bitrate, elapsed),
        error_frames: bus.error_frames(),
        down_events,
    };
    let mut report = host.report(Some(&figures));
    report["realtime_grant"] = granted.into();
    if let Some(f) = &failure {
        report["ok"] = false.into();
        report["error"] = f.clone().into();
    }
    let ok = report["ok"].as_bool() == Some(true);
    let s = &report["sync_period_us"];
    eprintln!(
        "simdrive: {}: {} frames in {:.1} s, bus load {:.1} %, SYNC {} (period p50 {} p99 {} max {} µs), protocol errors {} (frames of/for other nodes, not errors: {})",
        if ok { "ok" } else { "CHECK FAILED" },
        c.rx_frames + c.tx_frames,
        figures.seconds,
        figures.load_percent,
        s["count"],
        s["p50"],
        s["p99"],
        s["max"],
        report["protocol_errors"]["unexpected_frames"],
        report["protocol_errors"]["other_node_frames"],
    );
    if let Some(path) = &args.report {
        let text = serde_json::to_string_pretty(&report).unwrap_or_default();
        if let Err(e) = cnc402_durable::write_atomic(path, (text + "\n").as_bytes()) {
            eprintln!("simdrive: cannot write {}: {e}", path.display());
            return ExitCode::from(exit::IO);
        }
    }
    if let Some(f) = failure {
        eprintln!("simdrive: {f}");
        return ExitCode::from(exit::IO);
    }
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(exit::CHECK_FAILED)
    }
}
