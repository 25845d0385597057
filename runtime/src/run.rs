//! Running a whole program: a dry run first (program errors before anything moves), then the
//! drives are started, and the cycle controller runs either in virtual time on the calling
//! thread (as fast as the CPU allows) or in real time on a thread of its own with absolute
//! deadlines. The feeder and the recorder stay on the calling thread in both cases.

use std::io::Write;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use cnc402_config::{MAX_AXES, MachineConfig};
use cnc402_drives::Instant;
use cnc402_lang::ast::Program;
use cnc402_lang::{NcError, SourceFile};
use cnc402_motion::{AxisPos, MoveEvent};

use crate::controller::{AxisTable, CycleController, Step, start_position};
use crate::feeder::{Feeder, dry_run, motion_error_to_nc, source_for};
use crate::link::{DriveLink, DriveStop, FaultPlan, Startup};
use crate::master_link::{LinkTimeouts, MasterLink};
use crate::program_stop::{AtStop, StopGate, StopRecord, kind_name};
use crate::recorder::Recorder;
use crate::report::{AxisReport, RunReport, StopReport};
use crate::ring::{
    Consumer, MOVE_RING, MoveProducer, Observer, STATUS_RING, StatusConsumer, move_ring,
    status_ring,
};
use crate::rt::{
    LatencyHistogram, LatencySummary, monotonic_ns, request_realtime, sleep_until, tick_deadline,
};
use crate::sim_machine::SimLink;
use crate::socket_machine::SocketLink;
use crate::status::{Outcome, Status};
use crate::sync::{SyncShared, spawn_feeder};

/// How time advances.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Timing {
    /// Each tick right after the last: virtual time, as fast as the CPU allows.
    Virtual,
    /// Against CLOCK_MONOTONIC at the configured period, on a thread of its own.
    RealTime,
}

/// What a run needs besides the program.
pub struct RunOptions {
    pub timing: Timing,
    /// A fault to inject into the simulated drives (tests, demos).
    pub fault: Option<FaultPlan>,
    /// Where to write the CSV trace.
    pub trace: Option<Box<dyn Write>>,
    /// Raised by the caller (SIGINT) to stop the machine the way a fault does.
    pub stop_request: Arc<AtomicBool>,
    /// Use the bus-less `testing::ModelLink` (pure delay) instead of the configured bus: a
    /// test and benchmark double, only with the `testing` feature.
    #[cfg(any(test, feature = "testing"))]
    pub model_link: bool,
    /// Capacity of the status ring instead of [`STATUS_RING`] (tests of a full ring; only
    /// with the `testing` feature). The virtual-time driver still drains at
    /// `STATUS_RING / 2`, so a smaller ring loses records as a slow reporter would.
    #[cfg(any(test, feature = "testing"))]
    pub status_ring: Option<usize>,
    /// Boot and enable limits; `None`: [`LinkTimeouts::default`] on the simulator,
    /// [`LinkTimeouts::real_bus`] on a CAN interface.
    pub timeouts: Option<LinkTimeouts>,
    /// What M0 (and M1 with `optional_stop`) does; default `Continue` (log and go on).
    pub at_stop: AtStop,
    /// M1 stops like M0 (off: M1 passes).
    pub optional_stop: bool,
    /// `Continue` was chosen only because no operator terminal is attached: each stop passed
    /// says so on stderr.
    pub no_operator_terminal: bool,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            timing: Timing::Virtual,
            fault: None,
            trace: None,
            stop_request: Arc::new(AtomicBool::new(false)),
            #[cfg(any(test, feature = "testing"))]
            model_link: false,
            #[cfg(any(test, feature = "testing"))]
            status_ring: None,
            timeouts: None,
            at_stop: AtStop::Continue,
            optional_stop: false,
            no_operator_terminal: false,
        }
    }
}

/// Why a run could not produce a report.
#[derive(Debug)]
pub enum RunError {
    /// The program is wrong (found by the dry run, or while running: then the machine was
    /// stopped first).
    Program(NcError),
    /// A file or device could not be used.
    Io(String),
    /// The real-time loop's clock failed (`clock_nanosleep` returned an error other than
    /// EINTR): the run was stopped and the drives disabled. The text says why.
    Clock(String),
}

impl RunError {
    fn clock(e: nix::errno::Errno) -> RunError {
        RunError::Clock(format!("real-time clock failed: clock_nanosleep: {e}"))
    }
}

/// Progress as the reporting side sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    pub tick: u64,
    /// Ticks the dry run expects (spindle ramps excluded, so `tick` may pass it).
    pub expected_ticks: u64,
    pub line: u32,
}

/// The drive link for `cfg`'s bus: the embedded simulated machine for `interface = "sim"`,
/// otherwise the master on that SocketCAN interface ([`SocketLink`]; an interface that cannot
/// be opened is `RunError::Io` naming it and why). `fault` needs simulated drives.
pub fn make_link(
    cfg: &MachineConfig,
    fault: Option<FaultPlan>,
    timeouts: Option<LinkTimeouts>,
) -> Result<Box<dyn DriveLink>, RunError> {
    if !cfg.bus.is_sim() {
        if fault.is_some() {
            return Err(RunError::Io(format!(
                "bus interface {:?}: faults can only be injected into the simulated drives \
                 (interface = \"sim\"); on a CAN bus use simdrive --fault",
                cfg.bus.interface
            )));
        }
        let link = SocketLink::socket(cfg, timeouts.unwrap_or_else(LinkTimeouts::real_bus))
            .map_err(RunError::Io)?;
        return Ok(Box::new(link));
    }
    let machine = crate::sim_machine::SimMachine::new(cfg, None)
        .map_err(|e| RunError::Io(format!("simulated bus: {e}")))?;
    let mut link: SimLink = MasterLink::with_timeouts(cfg, machine, timeouts.unwrap_or_default())
        .map_err(|e| RunError::Io(format!("simulated bus: {e}")))?;
    if let Some(f) = fault {
        link = link.with_fault(f);
    }
    Ok(Box::new(link))
}

impl<L: DriveLink + ?Sized> DriveLink for Box<L> {
    fn startup(&mut self, now: Instant) -> Startup {
        (**self).startup(now)
    }
    fn cycle(
        &mut self,
        now: Instant,
        commands: &[f64; MAX_AXES],
        feedback: &mut [crate::link::DriveFeedback; MAX_AXES],
    ) -> Result<(), DriveStop> {
        (**self).cycle(now, commands, feedback)
    }
    fn quick_stop(
        &mut self,
        now: Instant,
        feedback: &mut [crate::link::DriveFeedback; MAX_AXES],
    ) -> bool {
        (**self).quick_stop(now, feedback)
    }
    fn counters(&self) -> cnc402_drives::bus::BusCounters {
        (**self).counters()
    }
    fn bitrate(&self) -> u32 {
        (**self).bitrate()
    }
    fn shutdown(&mut self) -> Result<(), String> {
        (**self).shutdown()
    }
}

/// Which drive link a run uses (see [`make_link`]).
#[derive(Clone, Copy, Debug)]
struct LinkSpec {
    fault: Option<FaultPlan>,
    /// The bus-less test double (only ever set with the `testing` feature).
    #[cfg(any(test, feature = "testing"))]
    model: bool,
    timeouts: Option<LinkTimeouts>,
}

/// The link of a run: [`make_link`], or the test double when asked for (feature `testing`).
fn link_for(cfg: &MachineConfig, spec: &LinkSpec) -> Result<Box<dyn DriveLink>, RunError> {
    #[cfg(any(test, feature = "testing"))]
    if spec.model {
        return Ok(Box::new(crate::testing::model_link(cfg, spec.fault)));
    }
    make_link(cfg, spec.fault, spec.timeouts)
}

/// Start-up may take this long (boot, SDO configuration, enable) before it is a fault.
const STARTUP_LIMIT: Duration = Duration::from_secs(10);

/// What the loop side hands back at the end.
struct LoopEnd {
    outcome: Outcome,
    ticks: u64,
    starved: u64,
    dropped: u64,
    /// Per axis, from the controller (exact even when status records were dropped).
    max_following_error: [f64; MAX_AXES],
    /// Rigid-tap moves the controller started.
    tap_moves: u64,
    counters: cnc402_drives::bus::BusCounters,
    bitrate: u32,
    elapsed: Duration,
    latency: Option<LatencySummary>,
    grant: Option<String>,
    wall: Duration,
    /// The drives could not be taken to rest after the run.
    shutdown_error: Option<String>,
}

/// The reporting side: recorder, progress callback, and what the feeder thread needs to know.
struct Side<'a> {
    cfg: &'a MachineConfig,
    shared: Arc<SyncShared>,
    feeder: Option<JoinHandle<Option<NcError>>>,
    idle_ticks: u32,
    recorder: Recorder,
    progress: &'a mut dyn FnMut(&Progress),
    expected: u64,
    program_error: Option<NcError>,
    program_ticks: u64,
    /// The program stops (M0/M1) of this run and the gate the loop holds at.
    gate: Arc<StopGate>,
    stops: Vec<StopRecord>,
    no_operator_terminal: bool,
    src_name: String,
    /// Coolant on as the last coolant event left it (turned off at the end of the run when a
    /// stop, fault or end at a program stop left it on; M2/M30 turn it off themselves).
    coolant_on: bool,
}

impl Side<'_> {
    /// Starts the feeder thread for a machine standing at `start`.
    fn start_feeder(
        &mut self,
        src: SourceFile,
        program: Program,
        start: &[f64; MAX_AXES],
        ring: MoveProducer,
        stop: &Arc<AtomicBool>,
    ) -> Result<(), RunError> {
        let axes = AxisTable::new(self.cfg);
        let feeder = Feeder::new(self.cfg, src, program, start_position(&axes, start));
        let h = spawn_feeder(
            feeder,
            ring,
            self.shared.clone(),
            stop.clone(),
            Some(self.gate.clone()),
        )
        .map_err(|e| RunError::Io(format!("cannot start the feeder thread: {e}")))?;
        self.feeder = Some(h);
        Ok(())
    }

    /// Ends the feeder thread and keeps its program error, if any.
    fn stop_feeder(&mut self) {
        self.shared.end();
        if let Some(h) = self.feeder.take() {
            match h.join() {
                Ok(Some(e)) => self.program_error = Some(e),
                Ok(None) => {}
                Err(_) => log::error!("the feeder thread panicked"),
            }
        }
    }

    /// A program stop reached by the loop: record it, and with `Wait` prompt the operator and
    /// resume (Enter) or end (end of input) through the gate from a thread of its own.
    fn program_stop(&mut self, s: &Status, kind: cnc402_motion::StopKind) {
        let name = kind_name(kind);
        if !self.gate.applies(kind) {
            // M2/M30 end the program on their own and are not program stops.
            if kind == cnc402_motion::StopKind::Optional {
                log::info!("line {}: {name} passed (optional stop off)", s.line);
            }
            return;
        }
        let file = self
            .shared
            .file_of(s.moves_started)
            .map_or_else(|| self.src_name.clone(), |f| f.to_string());
        let (action, waited_s) = match self.gate.policy() {
            AtStop::Continue => {
                if self.no_operator_terminal {
                    eprintln!(
                        "{name} at {file}:{} passed: no operator terminal is attached (stdin \
                         is not a terminal; --at-stop wait or end to stop there)",
                        s.line
                    );
                }
                log::info!("{file}:{}: {name} (continuing)", s.line);
                ("continue", Some(0.0))
            }
            AtStop::End => {
                log::info!("{file}:{}: {name}: the program ends here", s.line);
                ("end", None)
            }
            AtStop::Wait => {
                eprintln!(
                    "{name} at {file}:{} — press Enter to continue, Ctrl-C to stop",
                    s.line
                );
                let gate = self.gate.clone();
                let t0 = std::time::Instant::now();
                let spawned = std::thread::Builder::new()
                    .name("cnc402-operator".into())
                    .spawn(move || {
                        let mut buf = String::new();
                        match std::io::stdin().read_line(&mut buf) {
                            Ok(n) if n > 0 => gate.resume(t0.elapsed().as_secs_f64()),
                            _ => {
                                // A Ctrl-C closes a piped input too: let the stop win.
                                std::thread::sleep(Duration::from_millis(50));
                                if crate::rt::sigint_seen() {
                                    return;
                                }
                                eprintln!(
                                    "no operator input (end of input): the program ends at \
                                     this stop"
                                );
                                gate.end_here(t0.elapsed().as_secs_f64());
                            }
                        }
                    });
                if let Err(e) = spawned {
                    log::error!("cannot wait for the operator ({e}): the program ends here");
                    self.gate.end_here(0.0);
                }
                ("wait", None)
            }
        };
        self.stops.push(StopRecord {
            line: s.line,
            kind: name,
            waited_s,
            action,
        });
    }

    fn drain(&mut self, ring: &mut StatusConsumer) {
        let mut last: Option<Status> = None;
        while let Some(s) = ring.try_pop() {
            match s.event {
                Some(MoveEvent::Message) => {
                    if let Some(text) = self.shared.take_message() {
                        log::info!("line {}: {}", s.line, text);
                    }
                }
                Some(MoveEvent::ProgramStop { kind }) => self.program_stop(&s, kind),
                Some(MoveEvent::ToolChange { tool }) => {
                    log::info!("line {}: tool change to T{tool}", s.line);
                }
                Some(MoveEvent::Coolant { mist, flood }) => {
                    let state = match (mist, flood) {
                        (false, false) => "off",
                        (true, false) => "mist",
                        (false, true) => "flood",
                        (true, true) => "mist and flood",
                    };
                    log::info!("line {}: coolant {state}", s.line);
                    self.coolant_on = mist || flood;
                }
                None => {}
            }
            if s.phase != crate::status::Phase::Settling
                && s.phase != crate::status::Phase::QuickStop
            {
                self.program_ticks = s.tick + 1;
            }
            self.recorder.record(&s);
            self.idle_ticks = if s.idle {
                self.idle_ticks.saturating_add(1)
            } else {
                0
            };
            last = Some(s);
        }
        if let Some(s) = last {
            let n = self.cfg.axes.len().min(MAX_AXES);
            self.shared
                .publish(&s, self.idle_ticks, n, self.recorder.path_length);
            (self.progress)(&Progress {
                tick: s.tick,
                expected_ticks: self.expected,
                line: s.line,
            });
        }
    }
}

/// Runs `program` on the machine `cfg` describes and reports. Program errors found before
/// motion are `Err(RunError::Program)`; faults and stops are reports with `ok == false`.
pub fn run_program(
    cfg: &MachineConfig,
    src: SourceFile,
    program: Program,
    opts: RunOptions,
    progress: &mut dyn FnMut(&Progress),
) -> Result<RunReport, RunError> {
    let gate = Arc::new(StopGate::new(opts.at_stop, opts.optional_stop));
    let dry =
        dry_run(cfg, &src, &program, AxisPos::default(), Some(&gate)).map_err(RunError::Program)?;
    if let Some((line, e)) = &dry.after_hold {
        log::warn!(
            "{}:{line}: the program, run on past this stop as it stands, would fail at {}:{}:{}: \
             {} (checked again when it gets there: the operator may change what it reads)",
            src.name,
            e.file,
            e.line,
            e.col,
            e.message
        );
    }
    if let Some(line) = dry.repeats_at {
        log::warn!(
            "{}:{line}: M99 in the main program: it starts over from its first block, endlessly \
             (as on a Fanuc control), until M2/M30, an alarm or Ctrl-C ends it",
            src.name
        );
    }
    let spec = LinkSpec {
        fault: opts.fault,
        #[cfg(any(test, feature = "testing"))]
        model: opts.model_link,
        timeouts: opts.timeouts,
    };
    #[cfg(any(test, feature = "testing"))]
    let model = spec.model;
    #[cfg(not(any(test, feature = "testing")))]
    let model = false;
    #[cfg(any(test, feature = "testing"))]
    let status_cap = opts.status_ring.unwrap_or(STATUS_RING).max(2);
    #[cfg(not(any(test, feature = "testing")))]
    let status_cap = STATUS_RING;
    if !cfg.bus.is_sim() && !model {
        // Fail before anything else when the interface cannot be opened (or a fault is asked
        // of drives that are not simulated).
        make_link(cfg, opts.fault, opts.timeouts)?;
    }
    let mut recorder = Recorder::new(cfg, dry.ticks);
    let RunOptions {
        timing,
        trace,
        stop_request,
        no_operator_terminal,
        ..
    } = opts;
    if let Some(t) = trace {
        recorder = recorder.with_trace(t);
    }
    let mut side = Side {
        cfg,
        shared: Arc::new(SyncShared::default()),
        feeder: None,
        idle_ticks: 0,
        recorder,
        progress,
        expected: dry.ticks,
        program_error: None,
        program_ticks: 0,
        gate,
        stops: Vec::new(),
        no_operator_terminal,
        src_name: src.name.to_string(),
        coolant_on: false,
    };
    let src_keep = src.clone();
    let end = match timing {
        Timing::Virtual => {
            run_virtual(cfg, src, program, spec, status_cap, stop_request, &mut side)
        }
        Timing::RealTime => {
            run_realtime(cfg, src, program, spec, status_cap, stop_request, &mut side)
        }
    };
    side.stop_feeder();
    let end = end?;
    let trace_result = side.recorder.finish();
    if let Some(e) = side.program_error.take() {
        return Err(RunError::Program(e));
    }
    if let Outcome::MotionFailed { error } = &end.outcome {
        return Err(RunError::Program(motion_error_to_nc(&src_keep, error)));
    }
    trace_result.map_err(|e| RunError::Io(format!("trace: {e}")))?;
    Ok(build_report(cfg, &src_keep, &side, &end))
}

fn build_report(cfg: &MachineConfig, src: &SourceFile, side: &Side, end: &LoopEnd) -> RunReport {
    let rec = &side.recorder;
    let period_s = cfg.bus.period_s();
    let axes = cfg
        .axes
        .iter()
        .take(MAX_AXES)
        .enumerate()
        .map(|(i, a)| AxisReport {
            name: a.name,
            max_following_error: end.max_following_error[i],
            final_position: rec.last.map_or(0.0, |s| s.act[i]),
        })
        .collect();
    let (ok, error, stop) = match end.outcome.clone() {
        Outcome::Finished => match &end.shutdown_error {
            None => (true, None, None),
            Some(e) => (
                false,
                Some(format!(
                    "the drives could not be disabled after the program: {e}"
                )),
                None,
            ),
        },
        Outcome::StartupFailed(m) => (false, Some(format!("start-up failed: {m}")), None),
        Outcome::Stopped {
            stop,
            line,
            move_index,
        } => {
            let axis = cfg
                .axes
                .iter()
                .find(|a| stop.node != 0 && a.node == Some(stop.node))
                .map(|a| a.name);
            let file = side.shared.file_of(move_index);
            let text = source_for(file.as_deref().unwrap_or(&src.name), src);
            let location = format!("{}:{}", text.name, line);
            let block = text.line_text(line).trim().to_string();
            let mut msg = stop.cause.describe().to_string();
            if stop.node != 0 {
                msg.push_str(&format!(" on node {}", stop.node));
                if let Some(a) = axis {
                    msg.push_str(&format!(" (axis {a})"));
                }
                msg.push_str(&format!(", statusword 0x{:04x}", stop.statusword));
                match stop.emcy {
                    Some(c) => msg.push_str(&format!(", EMCY 0x{c:04x}")),
                    None => msg.push_str(", no EMCY"),
                }
            }
            msg.push_str(&format!(
                ", while executing {location}: {block}; all axes stopped"
            ));
            (
                false,
                Some(msg),
                Some(StopReport {
                    stop,
                    axis,
                    location,
                    block,
                }),
            )
        }
        Outcome::MotionFailed { .. } => (false, Some("motion error".into()), None),
    };
    // Lost status records leave holes in what the recorder saw: the coupling figures (and
    // the trace) are incomplete, the following-error maxima are not (the controller keeps
    // them). A run with rigid taps is then not ok: its pass criterion may have been missed
    // (the controller counts the tap moves: a window lost whole leaves no trace in `taps`).
    let coupling_complete = end.dropped == 0;
    let tapped = end.tap_moves > 0 || !rec.taps.is_empty();
    let (ok, error) = if ok && !coupling_complete && tapped {
        (false, Some(incomplete_coupling(end.dropped)))
    } else {
        (ok, error)
    };
    let program_time_s = side.program_ticks as f64 * period_s;
    if side.coolant_on {
        log::warn!("coolant off: the run ended with it on");
    }
    let waits = side.gate.waits();
    let mut wi = 0;
    let stops = side
        .stops
        .iter()
        .map(|r| {
            let mut r = r.clone();
            if r.action == "wait" {
                r.waited_s = waits.get(wi).copied();
                wi += 1;
                if r.waited_s.is_some() && side.gate.end_requested() && wi == waits.len() {
                    r.action = "end";
                }
            }
            r
        })
        .collect();
    let wall = end.wall.as_secs_f64();
    let axes_t = AxisTable::new(cfg);
    RunReport {
        ok,
        error,
        stop,
        period_us: cfg.bus.period_us,
        ticks: end.ticks,
        program_time_s,
        path_length_mm: rec.path_length,
        axes,
        tapping: rec
            .taps
            .iter()
            .map(|t| {
                let mut t = t.clone();
                let file = side.shared.file_of(t.move_index);
                t.file = Some(file.as_deref().unwrap_or(&src.name).to_string());
                t
            })
            .collect(),
        bus_frames: end.counters.bus_frames,
        bus_load_percent: end.counters.load_percent(end.bitrate, end.elapsed),
        wakeup_latency: end.latency,
        realtime_grant: end.grant.clone(),
        starved_ticks: end.starved,
        dropped_status: end.dropped,
        coupling_complete,
        wall_time_s: wall,
        realtime_factor: if wall > 0.0 {
            end.ticks as f64 * period_s / wall
        } else {
            0.0
        },
        coupling_bound_um: coupling_bound_um(&axes_t, &rec.taps),
        plot: rec.plot_points().to_vec(),
        stops,
    }
}

/// The error of a tapping run whose status records were partly lost.
fn incomplete_coupling(dropped: u64) -> String {
    format!(
        "{dropped} status records were lost (status ring full): the rigid-tap coupling \
         figures are incomplete"
    )
}

/// One count of the tool axis or the tool-axis equivalent of one spindle count, whichever is
/// larger, over all windows (µm). With no spindle or taps: one count of Z (or of the first
/// linear axis).
pub fn coupling_bound_um(axes: &AxisTable, taps: &[crate::recorder::TapWindow]) -> f64 {
    let tool_count = (0..axes.n)
        .filter(|&i| axes.linear[i])
        .map(|i| 1.0 / axes.counts_per_unit[i])
        .fold(0.0, f64::max);
    let spindle_count = axes.spindle.map_or(0.0, |c| 1.0 / axes.counts_per_unit[c]);
    let pitch = taps.iter().map(|t| t.pitch_mm).fold(0.0, f64::max);
    tool_count.max(spindle_count * pitch / 360.0) * 1000.0
}

fn startup_failed(why: String) -> Outcome {
    Outcome::StartupFailed(why)
}

fn startup_timeout() -> String {
    format!(
        "the drives were not enabled within {} s",
        STARTUP_LIMIT.as_secs()
    )
}

fn run_virtual(
    cfg: &MachineConfig,
    src: SourceFile,
    program: Program,
    spec: LinkSpec,
    status_cap: usize,
    stop_request: Arc<AtomicBool>,
    side: &mut Side,
) -> Result<LoopEnd, RunError> {
    let wall0 = std::time::Instant::now();
    let period = Duration::from_micros(cfg.bus.period_us as u64);
    let mut link = link_for(cfg, &spec)?;
    let mut now = Instant::ZERO;
    let start = loop {
        match link.startup(now) {
            Startup::Pending if now.nanos() < STARTUP_LIMIT.as_nanos() as u64 => now += period,
            Startup::Pending => {
                return Ok(failed_end(
                    startup_failed(startup_timeout()),
                    &*link,
                    now,
                    wall0,
                ));
            }
            Startup::Ready(p) => break p,
            Startup::Failed(s) => return Ok(failed_end(startup_failed(s), &*link, now, wall0)),
        }
    };
    let (mprod, mcons) = move_ring(MOVE_RING);
    let (sprod, mut scons) = status_ring(status_cap);
    side.start_feeder(src, program, &start, mprod, &stop_request)?;
    let c0 = link.counters();
    let now0 = now;
    let mut ctrl = CycleController::new(cfg, start, link, mcons, sprod, stop_request.clone())
        .with_stop_gate(side.gate.clone());
    let mut spins = 0u32;
    let mut held_since: Option<(std::time::Instant, u32)> = None;
    let outcome = loop {
        // Virtual time only runs while there is something to do: a move, a stop, the end, or
        // an interpreter waiting for the motion before a position read. Otherwise the feeder
        // thread is still planning, and we wait for it (so results do not depend on speed).
        let waiting = side.shared.waiting.load(Ordering::SeqCst);
        if !ctrl.has_work() && (!waiting || side.shared.motion_done()) {
            if side.feeder.as_ref().is_some_and(|h| h.is_finished()) {
                // The feeder ended without `End` (an error): stop the machine.
                stop_request.store(true, Ordering::SeqCst);
            }
            spins += 1;
            if spins > 64 {
                std::thread::sleep(Duration::from_micros(50));
            } else {
                std::thread::yield_now();
            }
            if crate::rt::sigint_seen() {
                stop_request.store(true, Ordering::SeqCst);
            }
            continue;
        }
        spins = 0;
        if ctrl.is_held() {
            // Held at a program stop: virtual time advances at the wall clock's pace (the
            // drives hold position and stay monitored) until the operator resumes. Deadlines
            // are absolute from the start of the hold, so a slow machine's long sleeps do not
            // make the pause shorter in program time than it was on the clock.
            let (since, n) = held_since.get_or_insert_with(|| (std::time::Instant::now(), 0));
            *n += 1;
            let due = *since + period * *n;
            if let Some(left) = due.checked_duration_since(std::time::Instant::now()) {
                std::thread::sleep(left);
            }
            if crate::rt::sigint_seen() {
                stop_request.store(true, Ordering::SeqCst);
            }
        } else {
            held_since = None;
        }
        now += period;
        let step = ctrl.step(now);
        if waiting
            || ctrl.is_held()
            || scons.occupied_len() >= STATUS_RING / 2
            || step != Step::Continue
        {
            side.drain(&mut scons);
            if crate::rt::sigint_seen() {
                stop_request.store(true, Ordering::SeqCst);
            }
        }
        if let Step::Done(o) = step {
            break o;
        }
    };
    side.drain(&mut scons);
    let wall = wall0.elapsed();
    Ok(cyclic_end(
        &mut ctrl,
        outcome,
        c0,
        now.saturating_since(now0),
        wall,
    ))
}

/// The end of a cyclic phase that ran: the controller's counters, the cyclic phase's bus
/// traffic since `c0` (disabling afterwards is not part of the bus load), then the drives
/// disabled. `latency` and `grant` are the real-time loop's to fill in.
fn cyclic_end(
    ctrl: &mut CycleController<Box<dyn DriveLink>>,
    outcome: Outcome,
    c0: cnc402_drives::bus::BusCounters,
    elapsed: Duration,
    wall: Duration,
) -> LoopEnd {
    let counters = counters_since(ctrl.link().counters(), c0);
    let shutdown_error = ctrl.link_mut().shutdown().err();
    LoopEnd {
        outcome,
        ticks: ctrl.ticks(),
        starved: ctrl.starved_ticks(),
        dropped: ctrl.dropped_status(),
        max_following_error: ctrl.max_following_error(),
        tap_moves: ctrl.tap_moves(),
        counters,
        bitrate: ctrl.link().bitrate(),
        elapsed,
        latency: None,
        grant: None,
        wall,
        shutdown_error,
    }
}

fn failed_end(
    outcome: Outcome,
    link: &dyn DriveLink,
    now: Instant,
    wall0: std::time::Instant,
) -> LoopEnd {
    LoopEnd {
        outcome,
        ticks: 0,
        starved: 0,
        dropped: 0,
        max_following_error: [0.0; MAX_AXES],
        tap_moves: 0,
        counters: link.counters(),
        bitrate: link.bitrate(),
        elapsed: Duration::from_nanos(now.nanos()),
        latency: None,
        grant: None,
        wall: wall0.elapsed(),
        shutdown_error: None,
    }
}

/// Counters of the cyclic phase only (boot traffic left out of the bus load).
fn counters_since(
    end: cnc402_drives::bus::BusCounters,
    start: cnc402_drives::bus::BusCounters,
) -> cnc402_drives::bus::BusCounters {
    cnc402_drives::bus::BusCounters {
        tx_frames: end.tx_frames.saturating_sub(start.tx_frames),
        rx_frames: end.rx_frames.saturating_sub(start.rx_frames),
        bus_frames: end.bus_frames.saturating_sub(start.bus_frames),
        bus_bits: end.bus_bits.saturating_sub(start.bus_bits),
        dropped: end.dropped.saturating_sub(start.dropped),
    }
}

/// Messages from the loop thread before the cyclic phase.
enum Hello {
    Ready([f64; MAX_AXES]),
}

fn run_realtime(
    cfg: &MachineConfig,
    src: SourceFile,
    program: Program,
    spec: LinkSpec,
    status_cap: usize,
    stop_request: Arc<AtomicBool>,
    side: &mut Side,
) -> Result<LoopEnd, RunError> {
    let (mprod, mcons) = move_ring(MOVE_RING);
    let (sprod, mut scons) = status_ring(status_cap);
    let (hello_tx, hello_rx) = std::sync::mpsc::sync_channel::<Hello>(1);
    let cfg_t = cfg.clone();
    let stop_t = stop_request.clone();
    let gate_t = side.gate.clone();
    let period_ns = cfg.bus.period_us as u64 * 1000;
    let handle = std::thread::Builder::new()
        .name("cnc402-loop".into())
        .spawn(move || -> Result<LoopEnd, RunError> {
            let grant = request_realtime();
            if grant.mlockall.is_ok() && grant.fifo.is_ok() {
                log::info!("{}", grant.describe());
            } else {
                log::warn!(
                    "{} — running anyway, expect more late wake-ups",
                    grant.describe()
                );
            }
            let wall0 = std::time::Instant::now();
            let mut link = link_for(&cfg_t, &spec)?;
            let t0 = monotonic_ns();
            let mut next = t0;
            let start = loop {
                let now = Instant::from_nanos(monotonic_ns().saturating_sub(t0));
                match link.startup(now) {
                    Startup::Pending if now.nanos() < STARTUP_LIMIT.as_nanos() as u64 => {}
                    Startup::Pending => {
                        return Ok(failed_end(
                            startup_failed(startup_timeout()),
                            &*link,
                            now,
                            wall0,
                        ));
                    }
                    Startup::Ready(p) => break p,
                    Startup::Failed(s) => {
                        // Start-up blocks (boot over a real bus): the bus load of its traffic
                        // is over the time it took, not over the instant it began.
                        let now = Instant::from_nanos(monotonic_ns().saturating_sub(t0));
                        return Ok(failed_end(startup_failed(s), &*link, now, wall0));
                    }
                }
                next += period_ns;
                if let Err(e) = sleep_until(next) {
                    let _ = link.shutdown();
                    return Err(RunError::clock(e));
                }
            };
            let _ = hello_tx.send(Hello::Ready(start));
            // Start-up on a real bus blocks for seconds (boot, SDO, enable): the cyclic
            // deadlines start from now, not from before it (no burst of catch-up ticks).
            next = next.max(monotonic_ns());
            let c0 = link.counters();
            let t_cyclic = monotonic_ns();
            let mut ctrl = CycleController::new(&cfg_t, start, link, mcons, sprod, stop_t)
                .with_stop_gate(gate_t);
            let mut hist = LatencyHistogram::new(5000, period_ns / 2);
            let wall_cyclic = std::time::Instant::now();
            let mut skipped = 0u64;
            let outcome = loop {
                next += period_ns;
                if let Err(e) = sleep_until(next) {
                    // No clock, no ticks: nothing can be timed, so the drives are disabled
                    // at once (they stop on their own disable reaction) and the run ends.
                    let _ = ctrl.link_mut().shutdown();
                    return Err(RunError::clock(e));
                }
                let woke = monotonic_ns();
                hist.record(woke.saturating_sub(next));
                // Missed whole deadlines: this tick runs now and the next is a period later
                // (see LatencySummary::skipped).
                let (at, missed) = tick_deadline(next, woke, period_ns);
                next = at;
                skipped += missed;
                // The cycle's time is its deadline (the master's contract); lateness is measured.
                if let Step::Done(o) = ctrl.step(Instant::from_nanos(next.saturating_sub(t0))) {
                    break o;
                }
            };
            let wall = wall_cyclic.elapsed();
            let elapsed = Duration::from_nanos(monotonic_ns().saturating_sub(t_cyclic));
            Ok(LoopEnd {
                latency: Some(LatencySummary {
                    skipped,
                    ..hist.summary()
                }),
                grant: Some(grant.describe()),
                ..cyclic_end(&mut ctrl, outcome, c0, elapsed, wall)
            })
        })
        .map_err(|e| RunError::Io(format!("cannot start the loop thread: {e}")))?;

    match hello_rx.recv() {
        Ok(Hello::Ready(start)) => {
            if let Err(e) = side.start_feeder(src, program, &start, mprod, &stop_request) {
                stop_request.store(true, Ordering::SeqCst);
                let _ = handle.join();
                return Err(e);
            }
        }
        Err(_) => {
            // The thread ended during start-up; its result says why.
            return handle
                .join()
                .map_err(|_| RunError::Io("the loop thread panicked".into()))?;
        }
    }
    while !handle.is_finished() {
        side.drain(&mut scons);
        if crate::rt::sigint_seen() {
            stop_request.store(true, Ordering::SeqCst);
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let end = handle
        .join()
        .map_err(|_| RunError::Io("the loop thread panicked".into()))??;
    side.drain(&mut scons);
    Ok(end)
}

#[cfg(test)]
mod clock_tests {
    use super::RunError;

    #[test]
    fn a_failing_real_time_clock_says_so() {
        match RunError::clock(nix::errno::Errno::EINVAL) {
            RunError::Clock(m) => {
                assert!(m.starts_with("real-time clock failed: "), "{m}");
                assert!(m.contains("EINVAL"), "{m}");
            }
            other => panic!("{other:?}"),
        }
    }
}
