//! Running a whole program: a dry run first (program errors before anything moves), then the
//! drives are started and the cyclic loop ([`cyclic`]) runs on its clock — virtual time on the
//! calling thread ([`virtual_time`]), or real time on a thread of its own with absolute
//! deadlines ([`real_time`]) — while the reporting side ([`side`]) and the operator at program
//! stops ([`prompt`]) stay on the calling thread; then the report ([`report`]).

mod cyclic;
mod error;
mod multi;
mod prompt;
mod real_time;
mod report;
mod side;
mod stats;
mod trace;
mod virtual_time;

use std::io::Write;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use cnc402_config::{MAX_AXES, MachineConfig};
use cnc402_lang::SourceFile;
use cnc402_lang::ast::Program;
use cnc402_motion::AxisPos;

use crate::feeder::{ProgramInput, dry_run_watched, motion_error_to_nc};
use crate::link::{DriveLink, FaultPlan};
use crate::master_link::{LinkTimeouts, MasterLink};
use crate::operator::{BlockWatch, CommandInput, OperatorShared};
use crate::program_stop::{AtStop, StopGate};
use crate::recorder::Recorder;
use crate::report::RunReport;
use crate::ring::{MOVE_RING, STATUS_RING, StatusConsumer, move_ring, status_ring};
use crate::rt::request_realtime;
use crate::sim_machine::{SimFaultPlan, SimLink};
use crate::socket_machine::SocketLink;
use crate::status::Outcome;
use cyclic::{LoopEnd, LoopIo, run_cyclic};
pub use error::RunError;
pub use multi::{ChannelRun, ChannelsReport, run_channels};
use prompt::OperatorPrompt;
use real_time::RealTimeClock;
use report::build_report;
pub use report::coupling_bound_um;
pub use side::Progress;
use side::{FeederStart, Side};
pub use stats::StatsSample;
use stats::{LoopCounters, Stats};
use virtual_time::VirtualClock;

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
    /// Further faults for the simulated machine (bus-off, a drive rebooting, an EMCY storm,
    /// corrupted frames, …; tests and demos). Refused on a CAN interface like `fault`.
    pub sim_faults: Vec<SimFaultPlan>,
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
    /// Run on a thread of its own once the channels of a run of several are started, with
    /// channel 0's `Channels`: it stands in for channel 0's program calling `channel_run`
    /// and the others (tests; only with the `testing` feature).
    #[cfg(any(test, feature = "testing"))]
    pub channels_hook: Option<ChannelsHook>,
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
    /// Hand the progress callback a [`StatsSample`] every this often (wall clock).
    pub stats_every: Option<Duration>,
    /// Refuse to run the real-time loop without locked memory and SCHED_FIFO (an error
    /// naming the limit to raise, before any drive is touched) instead of running on with a
    /// warning.
    pub require_rt: bool,
    /// Breakpoints, single block, the operator's command input, block search.
    pub operator: crate::operator::OperatorOptions,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            timing: Timing::Virtual,
            fault: None,
            sim_faults: Vec::new(),
            trace: None,
            stop_request: Arc::new(AtomicBool::new(false)),
            #[cfg(any(test, feature = "testing"))]
            model_link: false,
            #[cfg(any(test, feature = "testing"))]
            status_ring: None,
            #[cfg(any(test, feature = "testing"))]
            channels_hook: None,
            timeouts: None,
            at_stop: AtStop::Continue,
            optional_stop: false,
            no_operator_terminal: false,
            stats_every: None,
            require_rt: false,
            operator: Default::default(),
        }
    }
}

/// See [`RunOptions::channels_hook`].
#[cfg(any(test, feature = "testing"))]
pub type ChannelsHook = Box<dyn FnOnce(Box<dyn cnc402_interp::Channels>) + Send>;

/// The drive link for `cfg`'s bus: the embedded simulated machine for `interface = "sim"`,
/// otherwise the master on that SocketCAN interface ([`SocketLink`]; an interface that cannot
/// be opened is `RunError::Io` naming it and why). `fault` needs simulated drives.
pub fn make_link(
    cfg: &MachineConfig,
    fault: Option<FaultPlan>,
    timeouts: Option<LinkTimeouts>,
) -> Result<Box<dyn DriveLink>, RunError> {
    make_link_with(cfg, fault, &[], timeouts)
}

/// [`make_link`] with further simulated faults armed (power-on ones before boot).
fn make_link_with(
    cfg: &MachineConfig,
    fault: Option<FaultPlan>,
    sim_faults: &[SimFaultPlan],
    timeouts: Option<LinkTimeouts>,
) -> Result<Box<dyn DriveLink>, RunError> {
    if !cfg.bus.is_sim() {
        if fault.is_some() || !sim_faults.is_empty() {
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
    for &p in sim_faults {
        link = link.with_plan(p);
    }
    Ok(Box::new(link))
}

/// Locked memory and SCHED_FIFO for the calling (loop) thread; without them an error with
/// `require_rt`, else a warning.
fn realtime_grant(require_rt: bool) -> Result<crate::rt::RtGrant, RunError> {
    let grant = request_realtime();
    if grant.is_full() {
        log::info!("{}", grant.describe());
    } else if require_rt {
        return Err(RunError::Io(format!("--require-rt: {}", grant.describe())));
    } else {
        log::warn!(
            "{} — running anyway, expect more late wake-ups",
            grant.describe()
        );
    }
    Ok(grant)
}

/// Which drive link a run uses (see [`make_link`]).
#[derive(Clone, Debug)]
struct LinkSpec {
    fault: Option<FaultPlan>,
    sim_faults: Vec<SimFaultPlan>,
    /// The bus-less test double (only ever set with the `testing` feature).
    #[cfg(any(test, feature = "testing"))]
    model: bool,
    timeouts: Option<LinkTimeouts>,
}

impl LinkSpec {
    /// The link `opts` ask for.
    fn of(opts: &RunOptions) -> LinkSpec {
        LinkSpec {
            fault: opts.fault,
            sim_faults: opts.sim_faults.clone(),
            #[cfg(any(test, feature = "testing"))]
            model: opts.model_link,
            timeouts: opts.timeouts,
        }
    }
}

/// The link of a run: [`make_link`], or the test double when asked for (feature `testing`).
fn link_for(cfg: &MachineConfig, spec: &LinkSpec) -> Result<Box<dyn DriveLink>, RunError> {
    #[cfg(any(test, feature = "testing"))]
    if spec.model {
        return Ok(Box::new(crate::testing::model_link(cfg, spec.fault)));
    }
    make_link_with(cfg, spec.fault, &spec.sim_faults, spec.timeouts)
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
    run_input(cfg, ProgramInput::Parsed { src, program }, opts, progress)
}

/// [`run_program`] of a program from `input` (a file: read line by line, so the dry run and
/// the run hold memory bounded by the lookahead, not by the program).
pub fn run_input(
    cfg: &MachineConfig,
    input: ProgramInput,
    opts: RunOptions,
    progress: &mut dyn FnMut(&Progress),
) -> Result<RunReport, RunError> {
    let src = input.source();
    let gate = Arc::new(
        StopGate::new(opts.at_stop, opts.optional_stop)
            .with_manual_tool_change(cfg.machine.tool_change == cnc402_config::ToolChange::Manual),
    );
    let shared = Arc::new(OperatorShared::default());
    // The dry run searches as the run will (its range only), and never holds.
    let dry_watch = opts.operator.search.clone().map(|search| {
        let z = cfg.axis_index('Z');
        BlockWatch::new(
            Vec::new(),
            false,
            Some(search),
            shared.clone(),
            AxisPos::default(),
            z,
        )
        .without_holds()
    });
    let dry = dry_run_watched(cfg, &input, Some(&gate), dry_watch).map_err(RunError::Program)?;
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
    if let Some(n) = dry.checked_only {
        log::warn!(
            "{}: dry run checked the first {n} segments; the program goes on past them (the \
             rest is checked as it runs)",
            src.name
        );
    }
    if let Some(line) = dry.repeats_at {
        log::warn!(
            "{}:{line}: M99 in the main program: it starts over from its first block, endlessly \
             (as on a Fanuc control), until M2/M30, an alarm or Ctrl-C ends it",
            src.name
        );
    }
    let spec = LinkSpec::of(&opts);
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
        make_link_with(cfg, opts.fault, &opts.sim_faults, opts.timeouts)?;
    }
    let mut recorder = Recorder::new(cfg, dry.ticks);
    let RunOptions {
        timing,
        trace,
        stop_request,
        no_operator_terminal,
        stats_every,
        require_rt,
        operator,
        ..
    } = opts;
    if let Some(t) = trace {
        recorder = recorder.with_trace(t);
    }
    let commands = operator
        .commands
        .clone()
        .unwrap_or_else(|| Arc::new(CommandInput::stdin()));
    let panel = Arc::new(crate::operator::Panel::default());
    let mut schedule = operator.schedule;
    crate::operator::apply_at_start(&mut schedule, &panel);
    if operator.listen_stdin
        && let Err(e) = commands.listen(panel.clone())
    {
        log::warn!("cannot read commands during motion ({e}): only at holds");
    }
    let mut prompt = OperatorPrompt::new(gate, no_operator_terminal, commands, shared, panel);
    if let Some(search) = &operator.search {
        prompt.set_search(search.to_string());
    }
    let mut side = Side::new(cfg, recorder, progress, dry.ticks, prompt, &src.name);
    side.main = Some(src.clone());
    let counters = std::sync::Arc::new(LoopCounters::default());
    let real_time = timing == Timing::RealTime;
    side.stats = stats_every.map(|e| Stats::new(e, real_time.then(|| counters.clone())));
    let src_keep = src.clone();
    let (moves_tx, moves_rx) = move_ring(MOVE_RING);
    let (status_tx, status_rx) = status_ring(status_cap);
    let feed = FeederStart {
        input,
        moves: moves_tx,
        stop_request: stop_request.clone(),
        operator,
        channels: None,
    };
    let io = LoopIo {
        moves: moves_rx,
        status: status_tx,
        stop_request,
        gate: side.prompt.gate().clone(),
        panel: Some((side.prompt.panel.clone(), schedule)),
    };
    let end = match timing {
        Timing::Virtual => run_virtual(cfg, spec, feed, io, status_rx, &mut side),
        Timing::RealTime => {
            let rt = RealTimeSetup {
                counters,
                require_rt,
            };
            run_realtime(cfg, spec, feed, io, status_rx, &mut side, rt)
        }
    };
    side.stop_feeder();
    let end = end?;
    let trace_result = side.recorder.finish();
    if let Some(e) = side.program_error.take() {
        return Err(RunError::Program(e));
    }
    if let Outcome::MotionFailed { error } = &end.outcome {
        let text = crate::feeder::line_source(&src_keep.name, error.line, &src_keep);
        return Err(RunError::Program(motion_error_to_nc(&text, error)));
    }
    trace_result.map_err(|e| RunError::Io(format!("trace: {e}")))?;
    Ok(build_report(cfg, &src_keep, &side, &end))
}

/// The loop on the calling thread in virtual time, the reporting side draining between ticks.
fn run_virtual(
    cfg: &MachineConfig,
    spec: LinkSpec,
    feed: FeederStart,
    io: LoopIo,
    status: StatusConsumer,
    side: &mut Side,
) -> Result<LoopEnd, RunError> {
    let wall0 = std::time::Instant::now();
    let period = Duration::from_micros(cfg.bus.period_us as u64);
    let link = link_for(cfg, &spec)?;
    let mut clock = VirtualClock::new(period, wall0, side, status, io.stop_request.clone());
    run_cyclic(&mut clock, cfg, link, io, wall0, |clock, start| {
        clock.side().start_feeder(feed, start)
    })
}

/// What the real-time loop thread is given besides the loop's own inputs.
struct RealTimeSetup {
    counters: std::sync::Arc<LoopCounters>,
    /// See [`RunOptions::require_rt`].
    require_rt: bool,
}

/// The loop on a thread of its own in real time (memory locked and SCHED_FIFO where
/// permitted); the calling thread starts the feeder once the drives are enabled and drains
/// the status ring every 2 ms until the loop ends.
fn run_realtime(
    cfg: &MachineConfig,
    spec: LinkSpec,
    feed: FeederStart,
    io: LoopIo,
    mut status: StatusConsumer,
    side: &mut Side,
    rt: RealTimeSetup,
) -> Result<LoopEnd, RunError> {
    let RealTimeSetup {
        counters,
        require_rt,
    } = rt;
    let (ready_tx, ready_rx) = std::sync::mpsc::sync_channel::<[f64; MAX_AXES]>(1);
    let cfg_t = cfg.clone();
    let period_ns = cfg.bus.period_us as u64 * 1000;
    let handle = std::thread::Builder::new()
        .name("cnc402-loop".into())
        .spawn(move || -> Result<LoopEnd, RunError> {
            let grant = realtime_grant(require_rt)?;
            let wall0 = std::time::Instant::now();
            let link = link_for(&cfg_t, &spec)?;
            let mut clock = RealTimeClock::new(period_ns, grant, counters);
            run_cyclic(&mut clock, &cfg_t, link, io, wall0, |_, start| {
                let _ = ready_tx.send(*start);
                Ok(())
            })
        })
        .map_err(|e| RunError::Io(format!("cannot start the loop thread: {e}")))?;

    let stop_request = feed.stop_request.clone();
    match ready_rx.recv() {
        Ok(start) => {
            if let Err(e) = side.start_feeder(feed, &start) {
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
        side.drain(&mut status);
        if crate::rt::sigint_seen() {
            stop_request.store(true, Ordering::SeqCst);
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let end = handle
        .join()
        .map_err(|_| RunError::Io("the loop thread panicked".into()))??;
    side.drain(&mut status);
    Ok(end)
}
