//! The result of a run as data ([`RunReport`]), its JSON form (the keys `cnc402 run --report`
//! promises) and the human summary; the SVG plot is drawn by [`crate::plot`].

use std::fmt::Write as _;

use serde_json::{Value, json};

use crate::link::DriveStop;
use crate::recorder::{PlotPoint, TapWindow};
use crate::rt::LatencySummary;

/// Per-axis figures.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisReport {
    pub name: char,
    /// Largest |setpoint − actual| (mm / degrees).
    pub max_following_error: f64,
    /// Actual position at the end (mm / degrees).
    pub final_position: f64,
    /// Whether the axis had its machine reference (homed, or an absolute encoder); `None`
    /// when the config gives it no `homing` key (its positions count from power-on).
    pub homed: Option<bool>,
}

/// The safety reaction that ended a run, located in the program.
#[derive(Clone, Debug, PartialEq)]
pub struct StopReport {
    pub stop: DriveStop,
    /// Axis name of the drive, if it is one.
    pub axis: Option<char>,
    /// `file:line` being executed.
    pub location: String,
    /// The text of that line.
    pub block: String,
}

/// Everything `cnc402 run` reports.
#[derive(Clone, Debug, PartialEq)]
pub struct RunReport {
    pub ok: bool,
    /// Why not ok, as one line of text.
    pub error: Option<String>,
    pub stop: Option<StopReport>,
    pub period_us: u32,
    /// Ticks of the cyclic phase.
    pub ticks: u64,
    /// Time of the program's motion (ticks before settling, times the period).
    pub program_time_s: f64,
    pub path_length_mm: f64,
    /// The time the feed alone would need: Σ over the path moves run of length / the move's
    /// programmed feed (a rapid: the rapid rate), as capped by the axes' velocity limits
    /// along the move and, on arcs, the centripetal acceleration (see README "Run report").
    pub feed_time_s: f64,
    /// Largest distance of a commanded setpoint from the programmed path (mm).
    pub max_path_deviation_mm: f64,
    /// Largest distance of the drives' actual positions from the programmed path (mm): the
    /// contour error their lags make.
    pub max_path_deviation_mm_act: f64,
    /// Junctions where the path speed went to zero between two path motions.
    pub exact_stops: u64,
    pub axes: Vec<AxisReport>,
    pub tapping: Vec<TapWindow>,
    pub bus_frames: u64,
    /// Measured: the bits the bus carried over the run's wall (or virtual) time.
    pub bus_load_percent: f64,
    /// Planned worst case at config load (`cnc402_config::busload`): SYNC, PDOs, heartbeats
    /// and the SDO reserve, worst-case bit stuffing.
    pub bus_planned_percent: f64,
    /// Wake-up latency of the real-time loop (real-time runs only).
    pub wakeup_latency: Option<LatencySummary>,
    /// Which real-time privileges were granted (real-time runs only).
    pub realtime_grant: Option<String>,
    pub starved_ticks: u64,
    /// Status records the loop could not hand out (status ring full).
    pub dropped_status: u64,
    /// False when status records were lost: the tap windows' coupling figures (and the
    /// trace) then miss ticks, or whole windows. A run with rigid-tap moves is not `ok` then;
    /// without, `ok` stands. The following-error maxima are exact either way (the loop keeps
    /// them).
    pub coupling_complete: bool,
    /// Wall-clock time of the cyclic phase, and program time over it.
    pub wall_time_s: f64,
    pub realtime_factor: f64,
    /// Coupling bound at setpoint level (µm of the tool axis): one count of the tool axis or
    /// the tool-axis equivalent of one spindle count, whichever is larger (per window: the
    /// largest over the windows' pitches).
    pub coupling_bound_um: f64,
    /// The plot series (decimated), not part of the JSON.
    pub plot: Vec<PlotPoint>,
    /// The program stops (M0, M1 with optional stop on) in order, with what was done and how
    /// long the machine held there. `program_time_s` includes these waits.
    pub stops: Vec<crate::program_stop::StopRecord>,
    /// Breaks hit, operator commands, program messages, block search
    /// ([`crate::operator::OperatorLog`]; its keys are merged into the JSON).
    pub operator: crate::operator::OperatorLog,
    /// Machine output changes (`[machine] outputs`: coolant, spindle enable, tool clamp) as
    /// the loop made them, at most [`MAX_OUTPUT_CHANGES`]; `outputs_lost` counts the rest.
    pub outputs: Vec<OutputChange>,
    pub outputs_lost: u64,
}

/// The report keeps at most this many output changes (a main program repeated by M99
/// switches the coolant without end).
pub const MAX_OUTPUT_CHANGES: usize = 10_000;

/// One machine output switched by the program.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputChange {
    /// `coolant_flood`, `coolant_mist`, `spindle_enable` or `tool_clamp`.
    pub output: &'static str,
    pub on: bool,
    /// Program time, s.
    pub t_s: f64,
    pub file: String,
    pub line: u32,
}

impl RunReport {
    /// The report of a run that never moved (a program error found before motion, an I/O
    /// error): `ok` false, `error` the message, every figure zero.
    pub fn not_run(period_us: u32, axes: &[char], error: String) -> RunReport {
        RunReport {
            ok: false,
            error: Some(error),
            stop: None,
            period_us,
            ticks: 0,
            program_time_s: 0.0,
            path_length_mm: 0.0,
            feed_time_s: 0.0,
            max_path_deviation_mm: 0.0,
            max_path_deviation_mm_act: 0.0,
            exact_stops: 0,
            axes: axes
                .iter()
                .map(|&name| AxisReport {
                    name,
                    max_following_error: 0.0,
                    final_position: 0.0,
                    homed: None,
                })
                .collect(),
            tapping: Vec::new(),
            bus_frames: 0,
            bus_load_percent: 0.0,
            bus_planned_percent: 0.0,
            wakeup_latency: None,
            realtime_grant: None,
            starved_ticks: 0,
            dropped_status: 0,
            coupling_complete: true,
            wall_time_s: 0.0,
            realtime_factor: 0.0,
            coupling_bound_um: 0.0,
            plot: Vec::new(),
            stops: Vec::new(),
            operator: Default::default(),
            outputs: Vec::new(),
            outputs_lost: 0,
        }
    }

    /// The JSON report.
    pub fn to_json(&self) -> Value {
        let mut axes = serde_json::Map::new();
        for a in &self.axes {
            let mut axis = json!({
                "max_following_error": a.max_following_error,
                "final_position": a.final_position,
            });
            if let Some(h) = a.homed {
                axis["homed"] = json!(h);
            }
            axes.insert(a.name.to_string(), axis);
        }
        let tapping: Vec<Value> = self
            .tapping
            .iter()
            .map(|t| {
                json!({
                    "file": t.file,
                    "line": t.line,
                    "pitch_mm": t.pitch_mm,
                    "pitch_observed_mm": t.pitch_observed_mm,
                    "max_coupling_error_um_cmd": t.max_coupling_error_um_cmd,
                    "max_coupling_error_um_act": t.max_coupling_error_um_act,
                })
            })
            .collect();
        let mut v = json!({
            "ok": self.ok,
            "error": self.error,
            "period_us": self.period_us,
            "ticks": self.ticks,
            "program_time_s": self.program_time_s,
            "path_length_mm": self.path_length_mm,
            "feed_time_s": self.feed_time_s,
            "max_path_deviation_mm": self.max_path_deviation_mm,
            "max_path_deviation_mm_act": self.max_path_deviation_mm_act,
            "exact_stops": self.exact_stops,
            "axes": Value::Object(axes),
            "tapping": tapping,
            "bus": {
                "frames": self.bus_frames,
                "load_percent": self.bus_load_percent,
                "planned_percent": self.bus_planned_percent,
            },
            "coupling_bound_um": self.coupling_bound_um,
            "starved_ticks": self.starved_ticks,
            "dropped_status": self.dropped_status,
            "coupling_complete": self.coupling_complete,
            "wall_time_s": self.wall_time_s,
            "realtime_factor": self.realtime_factor,
        });
        if let Some(l) = &self.wakeup_latency {
            v["wakeup_latency_us"] = json!({
                "p50": l.p50_us, "p99": l.p99_us, "max": l.max_us, "late": l.late,
                "skipped": l.skipped,
                "samples": l.samples,
            });
        }
        if let Some(g) = &self.realtime_grant {
            v["realtime_grant"] = json!(g);
        }
        v["stops"] = Value::Array(
            self.stops
                .iter()
                .map(|r| {
                    json!({
                        "line": r.line,
                        "kind": r.kind,
                        "action": r.action,
                        "waited_s": r.waited_s,
                    })
                })
                .collect(),
        );
        if !self.outputs.is_empty() {
            v["outputs"] = Value::Array(
                self.outputs
                    .iter()
                    .map(|o| {
                        json!({"output": o.output, "on": o.on, "t_s": o.t_s,
                               "file": o.file, "line": o.line})
                    })
                    .collect(),
            );
            v["outputs_lost"] = json!(self.outputs_lost);
        }
        if let Value::Object(op) = self.operator.to_json() {
            for (k, val) in op {
                v[k] = val;
            }
        }
        if let Some(s) = &self.stop {
            v["stop"] = json!({
                "cause": s.stop.cause_text(),
                "node": s.stop.node,
                "axis": s.axis.map(|c| c.to_string()),
                "statusword": format!("0x{:04x}", s.stop.statusword),
                "emcy": s.stop.emcy.map(|c| format!("0x{c:04x}")),
                "location": s.location,
            });
        }
        v
    }

    /// "machine reference: homed X Y; NOT homed Z (…)" for the axes with a `homing` key.
    fn reference_line(&self) -> Option<String> {
        let list = |want: bool| -> String {
            self.axes
                .iter()
                .filter(|a| a.homed == Some(want))
                .map(|a| a.name.to_string())
                .collect::<Vec<_>>()
                .join(" ")
        };
        let (homed, not) = (list(true), list(false));
        match (homed.is_empty(), not.is_empty()) {
            (true, true) => None,
            (false, true) => Some(format!("  machine reference: homed {homed}")),
            (h, false) => Some(format!(
                "  machine reference: {}NOT homed {not} (positions count from power-on: soft \
                 limits and G28 are not the machine's; `cnc402 home` or \
                 [machine] require_homing)",
                if h {
                    String::new()
                } else {
                    format!("homed {homed}; ")
                }
            )),
        }
    }

    /// The summary for a person, several lines.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{}: {} ticks of {} µs, program time {:.3} s, path length {:.3} mm",
            if self.ok { "ok" } else { "STOPPED" },
            self.ticks,
            self.period_us,
            self.program_time_s,
            self.path_length_mm
        );
        let _ = writeln!(
            s,
            "  path: the feed alone would need {:.3} s (program time {:.2}× that), largest \
             deviation from the programmed path {:.2e} mm (actual positions {:.4} mm), {} exact \
             stops",
            self.feed_time_s,
            if self.feed_time_s > 0.0 {
                self.program_time_s / self.feed_time_s
            } else {
                0.0
            },
            self.max_path_deviation_mm,
            self.max_path_deviation_mm_act,
            self.exact_stops
        );
        for a in &self.axes {
            let _ = writeln!(
                s,
                "  axis {}: max following error {:.4}, final position {:.4}",
                a.name, a.max_following_error, a.final_position
            );
        }
        if let Some(line) = self.reference_line() {
            let _ = writeln!(s, "{line}");
        }
        for r in &self.stops {
            let _ = match (r.action, r.waited_s) {
                ("end", _) => writeln!(
                    s,
                    "  {} at line {}: the program ended there",
                    r.kind, r.line
                ),
                (a, Some(w)) => writeln!(s, "  {} at line {}: {a}, held {w:.3} s", r.kind, r.line),
                (a, None) => writeln!(s, "  {} at line {}: {a}", r.kind, r.line),
            };
        }
        if self.tapping.is_empty() {
            let _ = writeln!(s, "  tapping: none");
        }
        if !self.coupling_complete {
            let _ = writeln!(
                s,
                "  {} status records lost: coupling figures and trace incomplete",
                self.dropped_status
            );
        }
        for t in &self.tapping {
            let _ = writeln!(
                s,
                "  tap at {}:{}: pitch {:.4} mm, coupling error {:.4} µm (setpoints), {:.4} µm (actual)",
                t.file.as_deref().unwrap_or("line"),
                t.line,
                t.pitch_mm,
                t.max_coupling_error_um_cmd,
                t.max_coupling_error_um_act
            );
        }
        if let Some(w) = self
            .tapping
            .iter()
            .map(|t| t.max_coupling_error_um_cmd)
            .reduce(f64::max)
        {
            let _ = writeln!(
                s,
                "  worst coupling error {:.4} µm at setpoint level (bound {:.4} µm)",
                w, self.coupling_bound_um
            );
        }
        let _ = writeln!(
            s,
            "  bus: {} frames, load {:.1} % (planned worst case {:.1} %)",
            self.bus_frames, self.bus_load_percent, self.bus_planned_percent
        );
        if let Some(g) = &self.realtime_grant {
            let _ = writeln!(s, "  {g}");
        }
        if let Some(l) = &self.wakeup_latency {
            let _ = writeln!(
                s,
                "  wake-up latency: p50 {:.0} µs, p99 {:.0} µs, max {:.0} µs, {} late, {} deadlines skipped",
                l.p50_us, l.p99_us, l.max_us, l.late, l.skipped
            );
        }
        let _ = writeln!(
            s,
            "  ran in {:.3} s wall time ({:.0}× real time)",
            self.wall_time_s, self.realtime_factor
        );
        if let Some(e) = &self.error {
            let _ = writeln!(s, "  error: {e}");
        }
        s
    }
}
