//! The reporting side of a run, on the calling thread in both timings: it starts and ends the
//! feeder thread, drains the status ring into the recorder, publishes what the loop did for
//! the interpreter's motion sync, logs the program's events and tells the caller's progress.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::thread::JoinHandle;

use cnc402_config::{MAX_AXES, MachineConfig};
use cnc402_lang::{NcError, SourceFile};
use cnc402_motion::MoveEvent;

use super::error::RunError;
use super::prompt::OperatorPrompt;
use super::stats::{Stats, StatsSample};
use crate::controller::{AxisTable, start_position};
use crate::feeder::Feeder;
use crate::recorder::Recorder;
use crate::ring::{Consumer, MoveProducer, StatusConsumer};
use crate::status::{Phase, Status};
use crate::sync::{SyncShared, spawn_feeder};

/// Progress as the reporting side sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    pub tick: u64,
    /// Ticks the dry run expects (spindle ramps excluded, so `tick` may pass it).
    pub expected_ticks: u64,
    pub line: u32,
    /// With `RunOptions::stats_every`: the interval's figures, when one has just ended.
    pub stats: Option<StatsSample>,
}

/// The program, and where the feeder that plans it sends its moves.
pub(super) struct FeederStart {
    pub(super) input: crate::feeder::ProgramInput,
    pub(super) moves: MoveProducer,
    pub(super) stop_request: Arc<AtomicBool>,
    /// Breakpoints, single block and block search.
    pub(super) operator: crate::operator::OperatorOptions,
    /// The machine's channels and the run's shared globals, for the interpreter (a run of
    /// several channels).
    pub(super) channels: Option<(
        Box<dyn cnc402_interp::Channels>,
        cnc402_interp::SharedGlobals,
    )>,
}

/// The reporting side: recorder, progress callback, and what the feeder thread needs to know.
pub(super) struct Side<'a> {
    cfg: &'a MachineConfig,
    pub(super) shared: Arc<SyncShared>,
    pub(super) feeder: Option<JoinHandle<Option<NcError>>>,
    idle_ticks: u32,
    pub(super) recorder: Recorder,
    progress: &'a mut dyn FnMut(&Progress),
    expected: u64,
    pub(super) program_error: Option<NcError>,
    pub(super) program_ticks: u64,
    /// The program stops (M0/M1) of this run, the gate the loop holds at, and the operator.
    pub(super) prompt: OperatorPrompt,
    src_name: String,
    /// Coolant on as the last coolant event left it (turned off at the end of the run when a
    /// stop, fault or end at a program stop left it on; M2/M30 turn it off themselves).
    pub(super) coolant_on: bool,
    /// Periodic figures (`RunOptions::stats_every`).
    pub(super) stats: Option<Stats>,
    /// The feeder's lookahead, for what it did to the path (`G64 Q` merging) at the end.
    lookahead: Option<Arc<std::sync::Mutex<cnc402_motion::Lookahead>>>,
    /// The main program (block texts at a break: a file read line by line is an empty
    /// window, and the block's line is read again).
    pub(super) main: Option<SourceFile>,
    /// The machine outputs of the last status record, and their changes so far.
    last_outputs: Option<u8>,
    pub(super) outputs: Vec<crate::report::OutputChange>,
    pub(super) outputs_lost: u64,
    /// Put before each event line on stderr: the channel (`channel 1 (sub): `) in a run of
    /// several, empty in a one-channel run.
    pub(super) label: String,
}

impl<'a> Side<'a> {
    /// The reporting side of a run of `src_name` that the dry run expects to take
    /// `expected` ticks.
    pub(super) fn new(
        cfg: &'a MachineConfig,
        recorder: Recorder,
        progress: &'a mut dyn FnMut(&Progress),
        expected: u64,
        prompt: OperatorPrompt,
        src_name: &str,
    ) -> Side<'a> {
        Side {
            cfg,
            shared: Arc::new(SyncShared::default()),
            feeder: None,
            idle_ticks: 0,
            lookahead: None,
            recorder,
            progress,
            expected,
            program_error: None,
            program_ticks: 0,
            prompt,
            src_name: src_name.to_string(),
            coolant_on: false,
            stats: None,
            main: None,
            last_outputs: None,
            outputs: Vec::new(),
            outputs_lost: 0,
            label: String::new(),
        }
    }

    /// Starts the feeder thread for a machine standing at `start`.
    pub(super) fn start_feeder(
        &mut self,
        feed: FeederStart,
        start: &[f64; MAX_AXES],
    ) -> Result<(), RunError> {
        let axes = AxisTable::new(self.cfg);
        let start = start_position(&axes, start);
        let mut feeder = Feeder::from_input_on(self.cfg, &feed.input, start, false, feed.channels)
            .map_err(RunError::Program)?;
        self.lookahead = Some(feeder.lookahead());
        // Feed override above 100 % is planned: the lookahead reads it per segment.
        crate::feeder::lock(&feeder.lookahead())
            .set_feed_override_source(self.prompt.panel.feed_source());
        let op = feed.operator;
        if op.watches() {
            feeder = feeder.with_watch(crate::operator::BlockWatch::new(
                op.breaks,
                op.single_block,
                op.search,
                self.prompt.shared.clone(),
                start,
                self.cfg.axis_index('Z'),
            ));
        }
        let h = spawn_feeder(
            feeder,
            feed.moves,
            self.shared.clone(),
            feed.stop_request,
            Some(self.prompt.gate().clone()),
        )
        .map_err(|e| RunError::Io(format!("cannot start the feeder thread: {e}")))?;
        self.feeder = Some(h);
        Ok(())
    }

    /// How far `G64 Q` merging moved the path off the programmed corners (mm; 0 without it).
    /// After the run only: it takes the lookahead's lock.
    pub(super) fn merge_deviation(&self) -> f64 {
        self.lookahead
            .as_ref()
            .map_or(0.0, |l| crate::feeder::lock(l).merge_deviation())
    }

    /// Ends the feeder thread and keeps its program error, if any.
    pub(super) fn stop_feeder(&mut self) {
        self.shared.end();
        if let Some(h) = self.feeder.take() {
            match h.join() {
                Ok(Some(e)) => self.program_error = Some(e),
                Ok(None) => {}
                Err(_) => log::error!("the feeder thread panicked"),
            }
        }
    }

    /// Takes every status record the loop has sent so far: events logged (program stops to
    /// the operator), records to the recorder, progress published and told.
    pub(super) fn drain(&mut self, ring: &mut StatusConsumer) {
        self.drain_with(ring, |_| {});
    }

    /// [`drain`](Self::drain), showing `each` every record too.
    pub(super) fn drain_with(&mut self, ring: &mut StatusConsumer, mut each: impl FnMut(&Status)) {
        let mut last: Option<Status> = None;
        while let Some(s) = ring.try_pop() {
            each(&s);
            self.event(&s);
            if s.phase != Phase::Settling && s.phase != Phase::QuickStop {
                self.program_ticks = s.tick + 1;
            }
            self.recorder.record(&s);
            if let Some(st) = &mut self.stats {
                st.observe(&s);
            }
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
            let stats = self
                .stats
                .as_mut()
                .and_then(|st| st.due(std::time::Instant::now(), s.tick));
            (self.progress)(&Progress {
                tick: s.tick,
                expected_ticks: self.expected,
                line: s.line,
                stats,
            });
        }
    }

    /// The source file of the move executing at `s`.
    fn file_of(&self, s: &Status) -> String {
        self.shared
            .file_of(s.moves_started)
            .map_or_else(|| self.src_name.clone(), |f| f.to_string())
    }

    /// The machine position at `s` (commanded), as `X10.000 Y0.000 …`.
    fn position(&self, s: &Status) -> String {
        let axes = self.cfg.axes.iter().take(MAX_AXES);
        let parts: Vec<String> = axes
            .zip(s.cmd)
            .map(|(a, v)| format!("{}{v:.3}", a.name))
            .collect();
        parts.join(" ")
    }

    /// The machine outputs that changed at `s`: on stderr and in the report.
    fn output_changes(&mut self, s: &Status) {
        let before = self
            .last_outputs
            .replace(s.outputs)
            .unwrap_or(crate::machine_io::initial_outputs(self.cfg));
        let changed = before ^ s.outputs;
        if changed == 0 {
            return;
        }
        let t_s = s.tick as f64 * self.cfg.bus.period_s();
        let file = self.file_of(s);
        for (_, bit) in crate::machine_io::OUTPUTS {
            if changed & bit == 0 {
                continue;
            }
            let (output, on) = (crate::machine_io::output_name(bit), s.outputs & bit != 0);
            let state = if on { "on" } else { "off" };
            let label = &self.label;
            log::info!("{label}{file}:{}: {output} {state} at {t_s:.3} s", s.line);
            if self.outputs.len() >= crate::report::MAX_OUTPUT_CHANGES {
                self.outputs_lost += 1;
                continue;
            }
            self.outputs.push(crate::report::OutputChange {
                output,
                on,
                t_s,
                file: file.clone(),
                line: s.line,
            });
        }
    }

    /// The program's event in status record `s`, if any (and the operator's panel change).
    fn event(&mut self, s: &Status) {
        self.output_changes(s);
        if let Some(a) = s.panel {
            // Where the loop applied it, for the operator (the report keeps it too).
            let pct = a.percent().map(|p| format!(" {p} %")).unwrap_or_default();
            eprintln!(
                "{}{}{pct} at {:.3} s, {}:{} | {}",
                self.label,
                a.name(),
                s.tick as f64 * self.cfg.bus.period_s(),
                self.file_of(s),
                s.line,
                self.position(s)
            );
        }
        match s.event {
            Some(MoveEvent::Message) => {
                if let Some(text) = self.shared.take_message() {
                    self.prompt.message(self.file_of(s), s.line, text);
                }
            }
            Some(MoveEvent::ProgramStop { kind }) => {
                let file = self.file_of(s);
                let main = self.main.clone();
                let block = move |f: &str, line: u32| match &main {
                    Some(m) => crate::feeder::line_source(f, line, m)
                        .line_text(line)
                        .to_string(),
                    None => String::new(),
                };
                let position = self.position(s);
                self.prompt.hold_reached(
                    (s.line, s.tick, s.moves_started),
                    kind,
                    || file,
                    block,
                    position,
                );
            }
            Some(MoveEvent::ToolChange { tool }) => {
                if self.cfg.machine.tool_change == cnc402_config::ToolChange::Manual {
                    let file = self.file_of(s);
                    self.prompt.tool_change(s.line, tool, file, s.tick);
                } else {
                    log::info!("{}line {}: tool change to T{tool}", self.label, s.line);
                }
            }
            Some(MoveEvent::Coolant { mist, flood }) => {
                let state = match (mist, flood) {
                    (false, false) => "off",
                    (true, false) => "mist",
                    (false, true) => "flood",
                    (true, true) => "mist and flood",
                };
                log::info!("{}line {}: coolant {state}", self.label, s.line);
                self.coolant_on = mist || flood;
            }
            None => {}
        }
    }
}
