//! The report of a run: pass criteria (a run that lost status records around a rigid tap is
//! not ok), the error text of a stop naming node, axis, EMCY and program line, and the figures
//! the recorder and the loop collected.

use cnc402_config::{MAX_AXES, MachineConfig};
use cnc402_lang::SourceFile;

use super::cyclic::LoopEnd;
use super::side::Side;
use crate::controller::AxisTable;
use crate::feeder::line_source;
use crate::link::DriveStop;
use crate::report::{AxisReport, RunReport, StopReport};
use crate::status::Outcome;

/// The report of a run from what the reporting side recorded and the loop handed back.
pub(super) fn build_report(
    cfg: &MachineConfig,
    src: &SourceFile,
    side: &Side,
    end: &LoopEnd,
) -> RunReport {
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
            homed: a.homing.is_some().then_some(end.homed[i]),
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
            let (msg, report) = stop_report(cfg, src, side, stop, line, move_index);
            (false, Some(msg), Some(report))
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
        feed_time_s: end.path.feed_time_s,
        // The setpoints against the moves planned, and the moves against the programmed
        // corners where `G64 Q` merged lines.
        max_path_deviation_mm: end.path.max_deviation.max(side.merge_deviation()),
        max_path_deviation_mm_act: end.path.max_deviation_act,
        exact_stops: end.path.exact_stops,
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
        bus_planned_percent: cnc402_config::busload::BusLoad::of_machine(cfg).percent(),
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
        stops: side.prompt.records(),
        operator: crate::operator::OperatorLog {
            panel: end.panel.events().copied().collect(),
            panel_lost: end.panel.lost,
            period_s: cfg.bus.period_s(),
            ..side.prompt.operator_log()
        },
        outputs: side.outputs.clone(),
        outputs_lost: side.outputs_lost,
    }
}

/// The error text and the report's `stop` of a run the machine stopped: what stopped it, on
/// which node and axis, and the program line it was executing.
fn stop_report(
    cfg: &MachineConfig,
    src: &SourceFile,
    side: &Side,
    stop: DriveStop,
    line: u32,
    move_index: u64,
) -> (String, StopReport) {
    let axis = cfg
        .axes
        .iter()
        .find(|a| stop.node != 0 && a.node == Some(stop.node))
        .map(|a| a.name);
    let file = side.shared.file_of(move_index);
    let text = line_source(file.as_deref().unwrap_or(&src.name), line, src);
    let location = format!("{}:{}", text.name, line);
    let block = text.line_text(line).trim().to_string();
    let mut msg = stop.cause_text();
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
    // A channel of a multi-channel run reports its own axes (the others say in their own
    // reports whether `on_error` stopped them too).
    let stopped = if cfg.channels.is_empty() {
        "all axes stopped".to_string()
    } else {
        let names: Vec<String> = cfg.axes.iter().map(|a| a.name.to_string()).collect();
        format!("this channel's axes stopped ({})", names.join(" "))
    };
    msg.push_str(&format!(", while executing {location}: {block}; {stopped}"));
    let report = StopReport {
        stop,
        axis,
        location,
        block,
    };
    (msg, report)
}

/// The error of a tapping run whose status records were partly lost.
fn incomplete_coupling(dropped: u64) -> String {
    format!(
        "{dropped} status records were lost (status ring full): the rigid-tap coupling \
         figures are incomplete"
    )
}

/// One count of the tool axis or the tool-axis equivalent of one spindle count (the coarser
/// spindle's), whichever is larger, over all windows (µm). With no spindle or taps: one
/// count of Z (or of the first linear axis).
pub fn coupling_bound_um(axes: &AxisTable, taps: &[crate::recorder::TapWindow]) -> f64 {
    let tool_count = (0..axes.n)
        .filter(|&i| axes.linear[i])
        .map(|i| 1.0 / axes.counts_per_unit[i])
        .fold(0.0, f64::max);
    let spindle_count = (axes.spindles.iter().flatten())
        .map(|&c| 1.0 / axes.counts_per_unit[c])
        .fold(0.0, f64::max);
    let pitch = taps.iter().map(|t| t.pitch_mm).fold(0.0, f64::max);
    tool_count.max(spindle_count * pitch / 360.0) * 1000.0
}
