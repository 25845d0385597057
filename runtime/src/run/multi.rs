//! A run of several channels (`[[channel]]`): each channel's program is dry-run on its own
//! axes, then every channel gets its feeder thread, move ring, status ring and reporting side,
//! and one [`ChannelSet`] ticks them all in one loop on one link, in virtual time. The run
//! ends when every channel has ended; the report is per channel.

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use cnc402_config::{ChannelView, MAX_AXES, MachineConfig};
use cnc402_drives::Instant;
use cnc402_lang::{NcError, SourceFile};

use super::cyclic::{CycleClock, LoopState};
use super::cyclic::{LoopEnd, STARTUP_LIMIT, controller_end, counters_since};
use super::prompt::OperatorPrompt;
use super::real_time::RealTimeClock;
use super::report::build_report;
use super::side::{FeederStart, Side};
use super::trace::{MachineTrace, TraceRows};
use super::{LinkSpec, Progress, RunError, RunOptions, Timing, link_for};
use crate::channel_set::{ChannelPort, ChannelSet, Deadlock, Member};
use crate::channels::{ChannelBoard, DryChannels, Resident, spawn_resident};
use crate::controller::{AxisTable, CycleController, start_position};
use crate::feeder::{ProgramInput, dry_run_channel, motion_error_to_nc};
use crate::link::{DriveLink, Startup};
use crate::operator::{CommandInput, OperatorShared, Panel};
use crate::program_stop::StopGate;
use crate::recorder::Recorder;
use crate::report::RunReport;
use crate::ring::{MOVE_RING, STATUS_RING, StatusConsumer, move_ring, status_ring};
use crate::status::Outcome;

/// How one channel's program ended.
#[derive(Debug)]
pub struct ChannelRun {
    pub index: usize,
    pub name: String,
    /// The program's name (`(none)` for a channel that had none).
    pub program: String,
    /// A resident channel's programs (given and started by `channel_run`), each with how
    /// it ended: `name: ok` or `name: error`.
    pub programs: Vec<String>,
    /// Its report, or the program error that stopped it.
    pub result: Result<RunReport, RunError>,
}

impl ChannelRun {
    /// The channel, its program and how it ended, as one line
    /// (`channel 1 (sub): b.nc — finished`).
    pub fn headline(&self) -> String {
        let outcome = match &self.result {
            Ok(r) if r.ok => "finished".to_string(),
            Ok(r) => format!("stopped: {}", r.error.as_deref().unwrap_or("not ok")),
            Err(e) => format!("error: {}", run_error_line(e)),
        };
        format!(
            "channel {} ({}): {} — {outcome}",
            self.index, self.name, self.program
        )
    }
}

/// The report of a run of several channels.
#[derive(Debug)]
pub struct ChannelsReport {
    pub channels: Vec<ChannelRun>,
    /// The channels waited for each other at marks that could never all be reached: what
    /// each stood at.
    pub deadlock: Option<String>,
}

impl ChannelsReport {
    /// The run as one program's run of channel 0 (`cnc402 test`): a program error of any
    /// channel (channel 0's first) is the error; otherwise channel 0's report, ok only when
    /// every channel ended well, its error the run's first.
    pub fn into_main(self) -> Result<RunReport, RunError> {
        let (ok, error) = (self.ok(), self.error());
        let mut main = None;
        for c in self.channels {
            match c.result {
                Err(e) => return Err(e),
                Ok(r) if main.is_none() => main = Some(r),
                Ok(_) => {}
            }
        }
        let mut main =
            main.ok_or_else(|| RunError::Io("the run has no channel 0 report".into()))?;
        main.ok = ok;
        if !ok && main.error.is_none() {
            main.error = error;
        }
        Ok(main)
    }

    /// Every channel ran its program to its end.
    pub fn ok(&self) -> bool {
        self.deadlock.is_none()
            && self
                .channels
                .iter()
                .all(|c| matches!(&c.result, Ok(r) if r.ok))
    }

    /// The first error, with its channel, as one line.
    pub fn error(&self) -> Option<String> {
        if let Some(d) = &self.deadlock {
            return Some(d.clone());
        }
        self.channels.iter().find_map(|c| match &c.result {
            Ok(r) if r.ok => None,
            Ok(r) => Some(format!(
                "channel {} ({}): {}",
                c.index,
                c.name,
                r.error.as_deref().unwrap_or("not ok")
            )),
            Err(e) => Some(format!(
                "channel {} ({}): {}",
                c.index,
                c.name,
                run_error_line(e)
            )),
        })
    }

    /// The summary: each channel's program, outcome and report.
    pub fn summary(&self) -> String {
        let mut out = String::new();
        for c in &self.channels {
            out.push_str(&format!("== {}\n", c.headline()));
            if !c.programs.is_empty() {
                out.push_str(&format!("  programs run: {}\n", c.programs.join("; ")));
            }
            if let Ok(r) = &c.result {
                out.push_str(&r.summary());
            }
        }
        if let Some(d) = &self.deadlock {
            out.push_str(&format!("{d}\n"));
        }
        out
    }

    /// The JSON report: one entry per channel (its run report, or its error).
    pub fn to_json(&self) -> serde_json::Value {
        let channels: Vec<serde_json::Value> = self
            .channels
            .iter()
            .map(|c| {
                let (ok, error, report) = match &c.result {
                    Ok(r) => (r.ok, r.error.clone(), r.to_json()),
                    Err(e) => (false, Some(run_error_line(e)), serde_json::Value::Null),
                };
                serde_json::json!({
                    "channel": c.index,
                    "name": c.name,
                    "program": c.program,
                    "programs": c.programs,
                    "ok": ok,
                    "error": error,
                    "report": report,
                })
            })
            .collect();
        serde_json::json!({
            "ok": self.ok(),
            "error": self.error(),
            "deadlock": self.deadlock,
            "channels": channels,
        })
    }
}

/// A run error as one line.
fn run_error_line(e: &RunError) -> String {
    match e {
        RunError::Program(e) => format!("{}:{}:{}: {}", e.file, e.line, e.col, e.message),
        RunError::Io(m) | RunError::Clock(m) => m.clone(),
    }
}

/// `e` said of channel `k` of `n`.
fn in_channel(mut e: NcError, view: &ChannelView) -> NcError {
    e.message = format!("channel {} ({}): {}", view.index, view.name, e.message);
    e
}

/// One channel being run: its view of the machine, its program (channel 0's always; another
/// channel's from the command line, or none) and what it needs on the reporting side.
struct Lane {
    view: ChannelView,
    input: Option<ProgramInput>,
    src: SourceFile,
    expected: u64,
    gate: Arc<StopGate>,
}

/// Runs `programs[k]` on channel `k` of `cfg`, all channels in one loop on one link, in
/// virtual time. Channel 0 runs its program (it must have one); every other channel is
/// resident: it runs the program given for it, then the ones programs start on it
/// (`channel_run`), holding position in between, until channel 0 has ended and it is idle.
/// Program errors found before motion are `Err(RunError::Program)` naming the channel;
/// whatever happens during the run is in the per-channel report.
pub fn run_channels(
    cfg: &MachineConfig,
    mut programs: Vec<Option<ProgramInput>>,
    opts: RunOptions,
    progress: &mut dyn FnMut(&Progress),
) -> Result<ChannelsReport, RunError> {
    let count = cfg.channel_count();
    if programs.len() > count || programs.first().is_none_or(Option::is_none) {
        return Err(RunError::Io(format!(
            "one program for channel 0 and at most one for each other channel: this machine \
             has {count} channel(s) ([[channel]] in the config)"
        )));
    }
    programs.resize_with(count, || None);
    let board = ChannelBoard::new(cfg);
    let mut lanes = Vec::with_capacity(count);
    for (k, input) in programs.into_iter().enumerate() {
        let view = cfg
            .channel(k)
            .ok_or_else(|| RunError::Io(format!("channel {k} is not configured")))?;
        let gate = Arc::new(
            StopGate::new(opts.at_stop, opts.optional_stop).with_manual_tool_change(
                view.config.machine.tool_change == cnc402_config::ToolChange::Manual,
            ),
        );
        let mut expected = 0;
        if let Some(input) = &input {
            let calls = Arc::new(std::sync::atomic::AtomicU64::new(0));
            let host = Box::new(DryChannels::new(board.clone(), k).counting(calls.clone()));
            let globals = cnc402_interp::SharedGlobals::default();
            let dry = dry_run_channel(&view.config, input, Some(&gate), host, globals, &calls)
                .map_err(|e| RunError::Program(in_channel(e, &view)))?;
            if let Some(e) = &dry.after_channel_call {
                log::warn!(
                    "channel {k}: the program, checked without running what it starts on other \
                     channels, would fail at {}:{}:{}: {} (checked again when it gets there: \
                     the other channels' programs may change what it reads)",
                    e.file,
                    e.line,
                    e.col,
                    e.message
                );
            }
            expected = dry.ticks;
        }
        lanes.push(Lane {
            src: input
                .as_ref()
                .map_or_else(|| SourceFile::new("(none)", ""), ProgramInput::source),
            expected,
            view,
            input,
            gate,
        });
    }
    let spec = LinkSpec::of(&opts);
    run_lanes(cfg, lanes, spec, opts, progress, board)
}

/// What every lane of a run shares.
struct Common {
    board: Arc<ChannelBoard>,
    commands: Arc<CommandInput>,
    panel: Arc<Panel>,
    no_operator_terminal: bool,
    stop_request: Arc<std::sync::atomic::AtomicBool>,
}

/// Channel `lane`'s reporting side (its feeder started), status ring and loop member, the
/// drives standing at `start`. Channel 0 gets the operator's options and `schedule`.
fn open_lane<'a>(
    lane: &'a Lane,
    common: &Common,
    start: &[f64; MAX_AXES],
    tell: &'a mut dyn FnMut(&Progress),
    operator: Option<crate::operator::OperatorOptions>,
) -> Result<(Side<'a>, StatusConsumer, Member), RunError> {
    let k = lane.view.index;
    let vcfg = &lane.view.config;
    let prompt = OperatorPrompt::new(
        lane.gate.clone(),
        common.no_operator_terminal,
        common.commands.clone(),
        Arc::new(OperatorShared::default()),
        common.panel.clone(),
    );
    let recorder = Recorder::new(vcfg, lane.expected);
    let mut side = Side::new(vcfg, recorder, tell, lane.expected, prompt, &lane.src.name);
    side.main = Some(lane.src.clone());
    side.label = format!("channel {k} ({}): ", lane.view.name);
    let local = local_start(&lane.view, start);
    let (moves_tx, moves_rx) = move_ring(MOVE_RING);
    let (status_tx, status_rx) = status_ring(STATUS_RING);
    let stop = common.stop_request.clone();
    let ctrl = CycleController::new(
        vcfg,
        local,
        ChannelPort::default(),
        moves_rx,
        status_tx,
        stop,
    )
    .with_stop_gate(lane.gate.clone());
    let member;
    if let (0, Some(input), Some(operator)) = (k, &lane.input, operator) {
        let ctrl = ctrl.with_panel(common.panel.clone(), operator.schedule);
        // Its program's error stops this channel (and the others per `on_error`).
        let failed = Arc::new(std::sync::atomic::AtomicBool::new(false));
        member = Member::new(ctrl, &lane.view)
            .signalled(common.board.signal(0))
            .with_failure_flag(failed.clone());
        let feed = FeederStart {
            input: input.clone(),
            moves: moves_tx,
            stop_request: failed,
            operator,
            channels: Some(common.board.host(0)),
        };
        side.start_feeder(feed, &local)?;
    } else {
        member = Member::new(ctrl, &lane.view).resident(common.board.signal(k));
        if let Some(input) = &lane.input {
            common.board.queue_first(k, input.clone());
        }
        let resident = Resident {
            board: common.board.clone(),
            k,
            ring: moves_tx,
            shared: side.shared.clone(),
            gate: Some(lane.gate.clone()),
            start: start_position(&AxisTable::new(vcfg), &local),
            first_from_command_line: lane.input.is_some(),
        };
        let h = spawn_resident(resident)
            .map_err(|e| RunError::Io(format!("cannot start channel {k}'s thread: {e}")))?;
        side.feeder = Some(h);
    }
    Ok((side, status_rx, member))
}

/// The reporting sides, rings and controllers of `lanes`, the loop in `opts.timing`, then
/// the report.
fn run_lanes(
    cfg: &MachineConfig,
    lanes: Vec<Lane>,
    spec: LinkSpec,
    #[allow(unused_mut)] mut opts: RunOptions,
    progress: &mut dyn FnMut(&Progress),
    board: Arc<ChannelBoard>,
) -> Result<ChannelsReport, RunError> {
    #[cfg(any(test, feature = "testing"))]
    let hook = opts.channels_hook.take();
    #[cfg(not(any(test, feature = "testing")))]
    let hook: Option<Hook> = None;
    let RunOptions {
        timing,
        trace,
        stop_request,
        no_operator_terminal,
        operator,
        require_rt,
        ..
    } = opts;
    let common = Common {
        board,
        commands: operator
            .commands
            .clone()
            .unwrap_or_else(|| Arc::new(CommandInput::stdin())),
        panel: Arc::new(Panel::default()),
        no_operator_terminal,
        stop_request,
    };
    let mut rows = trace.map(|t| TraceRows::new(MachineTrace::new(cfg, t)));
    let setup = Setup {
        cfg,
        lanes: &lanes,
        common: &common,
        spec,
        operator,
        hook,
    };
    let mut quiet = vec![no_progress as fn(&Progress); lanes.len()];
    let ran = match timing {
        Timing::Virtual => run_virtual_lanes(setup, progress, &mut quiet, rows.as_mut()),
        Timing::RealTime => {
            run_realtime_lanes(setup, progress, &mut quiet, rows.as_mut(), require_rt)
        }
    };
    common.board.close();
    let (mut sides, members, deadlock, end) = match ran {
        Ran::NotStarted(why) => return Ok(not_started(&lanes, &why)),
        Ran::Failed(sides, e) => {
            finish_sides(sides);
            return Err(e);
        }
        Ran::Done {
            sides,
            members,
            deadlock,
            end,
        } => (sides, members, deadlock, end),
    };
    sides.iter_mut().for_each(|o| o.stop());
    if let Some(Err(e)) = rows.map(|r| r.trace.finish()) {
        return Err(RunError::Io(format!("trace: {e}")));
    }
    let mut plain: Vec<Side> = sides.into_iter().map(|o| o.side).collect();
    let report = channels_report(
        cfg,
        &lanes,
        &mut plain,
        &members,
        deadlock.as_ref(),
        &common.board,
        end,
    );
    Ok(report)
}

/// A test's stand-in for channel 0's program (see `RunOptions::channels_hook`).
#[cfg(not(any(test, feature = "testing")))]
type Hook = Box<dyn FnOnce(Box<dyn cnc402_interp::Channels>) + Send>;
#[cfg(any(test, feature = "testing"))]
type Hook = super::ChannelsHook;

/// What both timings start from.
struct Setup<'a> {
    cfg: &'a MachineConfig,
    lanes: &'a [Lane],
    common: &'a Common,
    spec: LinkSpec,
    operator: crate::operator::OperatorOptions,
    hook: Option<Hook>,
}

/// A channel's reporting side with its status ring (and the test hook's thread on
/// channel 0's).
struct Opened<'a> {
    side: Side<'a>,
    ring: StatusConsumer,
    hook: Option<std::thread::JoinHandle<()>>,
}

impl Opened<'_> {
    /// Ends the feeder thread (and the hook's), after a last drain.
    fn stop(&mut self) {
        self.side.drain(&mut self.ring);
        self.side.stop_feeder();
        if let Some(h) = self.hook.take() {
            let _ = h.join();
        }
    }
}

fn finish_sides(mut sides: Vec<Opened>) {
    sides.iter_mut().for_each(Opened::stop);
}

/// How the loop part of a run of several channels ended.
enum Ran<'a> {
    NotStarted(String),
    Failed(Vec<Opened<'a>>, RunError),
    Done {
        sides: Vec<Opened<'a>>,
        members: Vec<Member>,
        deadlock: Option<Deadlock>,
        end: RunEnd,
    },
}

/// Every lane's side (feeders started), ring and loop member, the drives standing at
/// `start`; the test hook started. On an error the sides opened so far are handed back
/// (`Ran::Failed`).
fn open_all<'a>(
    setup: &mut Setup<'a>,
    start: &[f64; MAX_AXES],
    progress: &'a mut dyn FnMut(&Progress),
    quiet: &'a mut [fn(&Progress)],
) -> Result<(Vec<Opened<'a>>, Vec<Member>), Ran<'a>> {
    let mut operator = Some(std::mem::take(&mut setup.operator));
    let mut progress = Some(progress);
    let mut sides = Vec::with_capacity(setup.lanes.len());
    let mut members = Vec::with_capacity(setup.lanes.len());
    for (lane, q) in setup.lanes.iter().zip(quiet.iter_mut()) {
        let tell: &mut dyn FnMut(&Progress) = match progress.take() {
            Some(p) => p,
            None => q,
        };
        match open_lane(lane, setup.common, start, tell, operator.take()) {
            Ok((side, ring, member)) => {
                sides.push(Opened {
                    side,
                    ring,
                    hook: None,
                });
                members.push(member);
            }
            Err(e) => return Err(Ran::Failed(sides, e)),
        }
    }
    if let (Some(h), Some(first)) = (setup.hook.take(), sides.first_mut()) {
        let (host, _) = setup.common.board.host(0);
        first.hook = Some(std::thread::spawn(move || h(host)));
    }
    Ok((sides, members))
}

/// The no-op progress of every channel but channel 0.
fn no_progress(_: &Progress) {}

/// Start-up and the loop on the calling thread in virtual time.
fn run_virtual_lanes<'a>(
    mut setup: Setup<'a>,
    progress: &'a mut dyn FnMut(&Progress),
    quiet: &'a mut [fn(&Progress)],
    rows: Option<&mut TraceRows>,
) -> Ran<'a> {
    let wall0 = std::time::Instant::now();
    let period = Duration::from_micros(setup.cfg.bus.period_us as u64);
    let mut link = match link_for(setup.cfg, &setup.spec) {
        Ok(l) => l,
        Err(e) => return Ran::Failed(Vec::new(), e),
    };
    let mut now = Instant::ZERO;
    let start = loop {
        match link.startup(now) {
            Startup::Ready(p) => break p,
            Startup::Pending if now.nanos() < STARTUP_LIMIT.as_nanos() as u64 => now += period,
            Startup::Pending => return Ran::NotStarted("the drives were not enabled".into()),
            Startup::Failed(s) => return Ran::NotStarted(s),
        }
    };
    let (mut sides, members) = match open_all(&mut setup, &start, progress, quiet) {
        Ok(o) => o,
        Err(failed) => {
            let _ = link.shutdown();
            return failed;
        }
    };
    let c0 = link.counters();
    let mut set = ChannelSet::new(link, members, start);
    let mut io = TickIo {
        sides: &mut sides,
        rows,
        common: setup.common,
    };
    let looped = tick_all(&mut set, &mut io, now, period);
    let counters = counters_since(set.link().counters(), c0);
    let shutdown_error = set.link_mut().shutdown().err();
    let end = RunEnd {
        bus: (counters, set.link().bitrate(), set.link().homed()),
        elapsed: looped.saturating_since(now),
        wall: wall0.elapsed(),
        shutdown_error,
    };
    let (_, members, deadlock) = set.into_parts();
    Ran::Done {
        sides,
        members,
        deadlock,
        end,
    }
}

/// What the real-time loop thread hands back.
enum LoopOut {
    NotStarted(String),
    Done {
        members: Vec<Member>,
        deadlock: Option<Deadlock>,
        end: RunEnd,
    },
}

/// Start-up and the loop on a thread of its own in real time (as the one-channel run),
/// while the calling thread starts the channels once the drives are enabled and drains
/// their status rings every 2 ms.
fn run_realtime_lanes<'a>(
    mut setup: Setup<'a>,
    progress: &'a mut dyn FnMut(&Progress),
    quiet: &'a mut [fn(&Progress)],
    mut rows: Option<&mut TraceRows>,
    require_rt: bool,
) -> Ran<'a> {
    let (start_tx, start_rx) = std::sync::mpsc::sync_channel::<[f64; MAX_AXES]>(1);
    let (members_tx, members_rx) = std::sync::mpsc::sync_channel::<Option<Vec<Member>>>(1);
    let cfg = setup.cfg.clone();
    let spec = setup.spec.clone();
    let stop_request = setup.common.stop_request.clone();
    let handle = std::thread::Builder::new()
        .name("cnc402-loop".into())
        .spawn(move || -> Result<LoopOut, RunError> {
            let grant = super::realtime_grant(require_rt)?;
            let link = link_for(&cfg, &spec)?;
            let period_ns = cfg.bus.period_us as u64 * 1000;
            let counters = Arc::new(super::stats::LoopCounters::default());
            let clock = RealTimeClock::new(period_ns, grant, counters);
            realtime_loop(clock, link, start_tx, members_rx, &stop_request)
        });
    let handle = match handle {
        Ok(h) => h,
        Err(e) => {
            return Ran::Failed(
                Vec::new(),
                RunError::Io(format!("cannot start the loop thread: {e}")),
            );
        }
    };
    let joined = |h: std::thread::JoinHandle<Result<LoopOut, RunError>>| {
        h.join()
            .map_err(|_| RunError::Io("the loop thread panicked".into()))
            .and_then(|r| r)
    };
    let Ok(start) = start_rx.recv() else {
        return match joined(handle) {
            Ok(LoopOut::NotStarted(why)) => Ran::NotStarted(why),
            Ok(_) => Ran::Failed(
                Vec::new(),
                RunError::Io("the loop ended before start-up".into()),
            ),
            Err(e) => Ran::Failed(Vec::new(), e),
        };
    };
    let (mut sides, members) = match open_all(&mut setup, &start, progress, quiet) {
        Ok(o) => o,
        Err(failed) => {
            let _ = members_tx.send(None);
            let _ = joined(handle);
            return failed;
        }
    };
    let _ = members_tx.send(Some(members));
    while !handle.is_finished() {
        drain_lanes(&mut sides, rows.as_deref_mut(), &setup.common.board);
        if crate::rt::sigint_seen() {
            setup.common.stop_request.store(true, Ordering::SeqCst);
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    drain_lanes(&mut sides, rows, &setup.common.board);
    match joined(handle) {
        Ok(LoopOut::Done {
            members,
            deadlock,
            end,
        }) => Ran::Done {
            sides,
            members,
            deadlock,
            end,
        },
        Ok(LoopOut::NotStarted(why)) => {
            finish_sides(sides);
            Ran::NotStarted(why)
        }
        Err(e) => Ran::Failed(sides, e),
    }
}

/// The real-time loop thread's work: start-up on `clock`, the start position out, the
/// channels in, then one set step per tick until every channel has ended.
fn realtime_loop(
    mut clock: RealTimeClock,
    mut link: Box<dyn DriveLink>,
    start_tx: std::sync::mpsc::SyncSender<[f64; MAX_AXES]>,
    members_rx: std::sync::mpsc::Receiver<Option<Vec<Member>>>,
    stop_request: &std::sync::atomic::AtomicBool,
) -> Result<LoopOut, RunError> {
    let start = loop {
        let now = clock.now();
        match link.startup(now) {
            Startup::Ready(p) => break p,
            Startup::Pending if now.nanos() < STARTUP_LIMIT.as_nanos() as u64 => {}
            Startup::Pending => {
                return Ok(LoopOut::NotStarted("the drives were not enabled".into()));
            }
            Startup::Failed(s) => return Ok(LoopOut::NotStarted(s)),
        }
        if let Err(e) = clock.wait_startup() {
            let _ = link.shutdown();
            return Err(RunError::clock(e));
        }
    };
    let _ = start_tx.send(start);
    let Ok(Some(members)) = members_rx.recv() else {
        let _ = link.shutdown();
        return Err(RunError::Io("the channels could not be started".into()));
    };
    clock.start_cyclic();
    let c0 = link.counters();
    let mut set = ChannelSet::new(link, members, start);
    let state = LoopState {
        has_work: true,
        held: false,
    };
    loop {
        let now = match clock.next_tick(state) {
            Ok(Some(now)) => now,
            Ok(None) => continue,
            Err(e) => {
                let _ = set.link_mut().shutdown();
                return Err(RunError::clock(e));
            }
        };
        if crate::rt::sigint_seen() {
            stop_request.store(true, Ordering::SeqCst);
        }
        if set.step(now) {
            break;
        }
    }
    let t = clock.finish();
    let counters = counters_since(set.link().counters(), c0);
    let shutdown_error = set.link_mut().shutdown().err();
    let end = RunEnd {
        bus: (counters, set.link().bitrate(), set.link().homed()),
        elapsed: t.elapsed,
        wall: t.wall,
        shutdown_error,
    };
    let (_, members, deadlock) = set.into_parts();
    Ok(LoopOut::Done {
        members,
        deadlock,
        end,
    })
}

/// Drains every channel's status ring into its side, and the trace's rows.
fn drain_lanes(sides: &mut [Opened], mut rows: Option<&mut TraceRows>, board: &ChannelBoard) {
    for (k, o) in sides.iter_mut().enumerate() {
        o.side.drain_with(&mut o.ring, |s| {
            if let Some(r) = rows.as_deref_mut() {
                r.push(k, s);
            }
        });
    }
    if let Some(r) = rows {
        r.flush(|k| board.signal(k).dead.load(Ordering::SeqCst));
    }
}

/// What the whole run measured, for every channel's report.
struct RunEnd {
    bus: (cnc402_drives::bus::BusCounters, u32, [bool; MAX_AXES]),
    elapsed: Duration,
    wall: Duration,
    shutdown_error: Option<String>,
}

/// The report of each channel (and the deadlock, if one stopped them).
fn channels_report(
    cfg: &MachineConfig,
    lanes: &[Lane],
    sides: &mut [Side],
    members: &[Member],
    deadlock: Option<&Deadlock>,
    board: &ChannelBoard,
    run: RunEnd,
) -> ChannelsReport {
    let deadlock = deadlock.map(|d| deadlock_text(d, lanes));
    let planned = cnc402_config::busload::BusLoad::of_machine(cfg).percent();
    let mut channels = Vec::with_capacity(lanes.len());
    for ((lane, side), m) in lanes.iter().zip(sides.iter_mut()).zip(members) {
        let outcome = m.outcome.clone().unwrap_or(Outcome::Finished);
        let mut end = controller_end(&m.ctrl, outcome, run.bus, run.elapsed, run.wall);
        end.shutdown_error = run.shutdown_error.clone();
        channels.push(ChannelRun {
            index: lane.view.index,
            name: lane.view.name.clone(),
            program: lane.src.name.to_string(),
            programs: board.history(lane.view.index),
            result: channel_result(lane, side, &end).map(|mut r| {
                // The bus is the machine's, not the channel's.
                r.bus_planned_percent = planned;
                r.error = r.error.map(|e| whose_stop(cfg, lane, &end.outcome, e));
                r
            }),
        });
    }
    ChannelsReport { channels, deadlock }
}

/// Ticks `set` in virtual time from `now` until every channel has ended; returns the time
/// of the last tick. A tick runs only when every running channel has something to do (so
/// the result does not depend on how fast the feeders plan), as the one-channel loop does.
fn tick_all(
    set: &mut ChannelSet<Box<dyn DriveLink>>,
    io: &mut TickIo,
    mut now: Instant,
    period: Duration,
) -> Instant {
    let stop_request = &io.common.stop_request;
    let board = &io.common.board;
    let mut ended_seen = vec![false; io.sides.len()];
    let mut spins = 0u32;
    loop {
        if crate::rt::sigint_seen() {
            stop_request.store(true, Ordering::SeqCst);
        }
        let mut ready = true;
        let mut held = false;
        for (k, m) in set.members().iter().enumerate() {
            if m.outcome.is_some() {
                continue;
            }
            let sh = &io.sides[k].side.shared;
            let waiting = sh.waiting.load(Ordering::SeqCst);
            held |= m.ctrl.is_held() || m.ctrl.is_feed_held();
            // Blocked in a channel wait, or resident without a program: time runs on.
            let sig = board.signal(k);
            let idle =
                sig.blocked.load(Ordering::SeqCst) || (k > 0 && !sig.busy.load(Ordering::SeqCst));
            // A failed program is the step's to stop (as a program error).
            if idle || m.ctrl.has_work() || m.program_failed() || (waiting && !sh.motion_done()) {
                continue;
            }
            ready = false;
            // A feeder that ended without `End` (an error): looked at once more, then stop.
            if io.sides[k]
                .side
                .feeder
                .as_ref()
                .is_some_and(|h| h.is_finished())
            {
                if ended_seen[k] {
                    stop_request.store(true, Ordering::SeqCst);
                }
                ended_seen[k] = true;
            }
        }
        if !ready {
            drain_lanes(io.sides, io.rows.as_deref_mut(), board);
            spins += 1;
            if spins > 64 {
                std::thread::sleep(Duration::from_micros(50));
            } else {
                std::thread::yield_now();
            }
            continue;
        }
        spins = 0;
        if held {
            // At a program stop for the operator: time runs at the wall clock's pace.
            std::thread::sleep(period);
        }
        now += period;
        let done = set.step(now);
        drain_lanes(io.sides, io.rows.as_deref_mut(), board);
        if done {
            return now;
        }
    }
}

/// What the loop of several channels reads and writes besides the set.
struct TickIo<'r, 'a> {
    sides: &'r mut [Opened<'a>],
    rows: Option<&'r mut TraceRows>,
    common: &'r Common,
}

/// The drives' start position as channel `view`'s axes see it.
fn local_start(view: &ChannelView, machine: &[f64; MAX_AXES]) -> [f64; MAX_AXES] {
    let mut p = [0.0; MAX_AXES];
    for (k, &a) in view.axes.iter().take(MAX_AXES).enumerate() {
        p[k] = machine[a];
    }
    start_position(&AxisTable::new(&view.config), &p).0
}

/// A channel's result: its program error (found while running) or its report.
fn channel_result(lane: &Lane, side: &mut Side, end: &LoopEnd) -> Result<RunReport, RunError> {
    let _ = side.recorder.finish();
    if let Some(e) = side.program_error.take() {
        return Err(RunError::Program(in_channel(e, &lane.view)));
    }
    if let Outcome::MotionFailed { error } = &end.outcome {
        let text = crate::feeder::line_source(&lane.src.name, error.line, &lane.src);
        let e = motion_error_to_nc(&text, error);
        return Err(RunError::Program(in_channel(e, &lane.view)));
    }
    Ok(build_report(&lane.view.config, &lane.src, side, end))
}

/// A stop raised by another channel's drive says so: `error` prefixed with that channel.
fn whose_stop(cfg: &MachineConfig, lane: &Lane, outcome: &Outcome, error: String) -> String {
    let Outcome::Stopped { stop, .. } = outcome else {
        return error;
    };
    let owner = (0..cfg.channel_count())
        .filter_map(|k| cfg.channel(k))
        .find(|v| v.config.axes.iter().any(|a| a.node == Some(stop.node)));
    match owner {
        Some(v) if stop.node != 0 && v.index != lane.view.index => {
            format!("stopped with channel {} ({}): {error}", v.index, v.name)
        }
        _ => error,
    }
}

/// The report of a run whose drives never got enabled: every channel says why.
fn not_started(lanes: &[Lane], why: &str) -> ChannelsReport {
    let channels = lanes
        .iter()
        .map(|l| {
            let axes: Vec<char> = l.view.config.axes.iter().map(|a| a.name).collect();
            let msg = format!("start-up failed: {why}");
            ChannelRun {
                index: l.view.index,
                name: l.view.name.clone(),
                program: l.src.name.to_string(),
                programs: Vec::new(),
                result: Ok(RunReport::not_run(l.view.config.bus.period_us, &axes, msg)),
            }
        })
        .collect();
    ChannelsReport {
        channels,
        deadlock: None,
    }
}

/// The deadlock as one line naming every channel's file:line and what it waited for.
fn deadlock_text(d: &Deadlock, lanes: &[Lane]) -> String {
    let parts: Vec<String> = lanes
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let at = format!("{}:{}", l.src.name, d.lines[k]);
            let what = match d.marks[k] {
                Some((mark, 0)) => format!("waits at mark {mark} for every channel"),
                Some((mark, bits)) => {
                    format!("waits at mark {mark} for channels {}", bits_text(bits))
                }
                None if d.ended[k] => "has ended".into(),
                None => "runs".into(),
            };
            format!("channel {k} ({}) at {at} {what}", l.view.name)
        })
        .collect();
    format!(
        "channel wait deadlock: {}; every channel was stopped",
        parts.join("; ")
    )
}

/// Channel bits as `0, 2`.
fn bits_text(bits: u16) -> String {
    let v: Vec<String> = (0..16)
        .filter(|b| bits & (1 << b) != 0)
        .map(|b| b.to_string())
        .collect();
    v.join(", ")
}
