//! The result of a run as data ([`RunReport`]), its JSON form (the keys `cnc402 run --report`
//! promises), the human summary, and the SVG plot of Z and C against time with the coupling
//! error.

use std::fmt::Write as _;
use std::path::Path;

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
    /// Junctions where the path speed went to zero between two path motions.
    pub exact_stops: u64,
    pub axes: Vec<AxisReport>,
    pub tapping: Vec<TapWindow>,
    pub bus_frames: u64,
    pub bus_load_percent: f64,
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
            exact_stops: 0,
            axes: axes
                .iter()
                .map(|&name| AxisReport {
                    name,
                    max_following_error: 0.0,
                    final_position: 0.0,
                })
                .collect(),
            tapping: Vec::new(),
            bus_frames: 0,
            bus_load_percent: 0.0,
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
        }
    }

    /// The JSON report.
    pub fn to_json(&self) -> Value {
        let mut axes = serde_json::Map::new();
        for a in &self.axes {
            axes.insert(
                a.name.to_string(),
                json!({
                    "max_following_error": a.max_following_error,
                    "final_position": a.final_position,
                }),
            );
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
            "exact_stops": self.exact_stops,
            "axes": Value::Object(axes),
            "tapping": tapping,
            "bus": { "frames": self.bus_frames, "load_percent": self.bus_load_percent },
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
             deviation from the programmed path {:.2e} mm, {} exact stops",
            self.feed_time_s,
            if self.feed_time_s > 0.0 {
                self.program_time_s / self.feed_time_s
            } else {
                0.0
            },
            self.max_path_deviation_mm,
            self.exact_stops
        );
        for a in &self.axes {
            let _ = writeln!(
                s,
                "  axis {}: max following error {:.4}, final position {:.4}",
                a.name, a.max_following_error, a.final_position
            );
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
            "  bus: {} frames, load {:.1} %",
            self.bus_frames, self.bus_load_percent
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

/// Draws Z and C setpoints against time (top, two y axes) and the coupling error of the
/// setpoints and of the actual positions in µm with the one-count bound (bottom) into an SVG
/// file.
/// The file is replaced whole (drawn in memory, then written with
/// [`cnc402_durable::write_atomic`]).
pub fn write_plot(path: &Path, report: &RunReport, title: &str) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let mut svg = String::new();
    draw_plot(&mut svg, report, title, &err)?;
    cnc402_durable::write_atomic(path, svg.as_bytes()).map_err(|e| err(&e))
}

fn draw_plot(
    svg: &mut String,
    report: &RunReport,
    title: &str,
    err: &dyn Fn(&dyn std::fmt::Display) -> String,
) -> Result<(), String> {
    use plotters::prelude::*;
    let points: &[PlotPoint] = &report.plot;
    let bound = report.coupling_bound_um;
    let root = SVGBackend::with_string(svg, (1000, 700)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let (top, bottom) = root.split_vertically(430);
    let t_max = points.last().map_or(1.0, |p| p.t).max(1e-3);
    let range = |f: fn(&PlotPoint) -> f64| {
        let (lo, hi) = points
            .iter()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                (l.min(v), h.max(v))
            });
        if !lo.is_finite() {
            (-1.0, 1.0)
        } else if hi - lo < 1e-9 {
            (lo - 1.0, hi + 1.0)
        } else {
            let m = (hi - lo) * 0.05;
            (lo - m, hi + m)
        }
    };
    let (z0, z1) = range(|p| p.z);
    let (c0, c1) = range(|p| p.c);
    let mut chart = ChartBuilder::on(&top)
        .caption(title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .right_y_label_area_size(70)
        .build_cartesian_2d(0.0..t_max, z0..z1)
        .map_err(|e| err(&e))?
        .set_secondary_coord(0.0..t_max, c0..c1);
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc("Z [mm]")
        .draw()
        .map_err(|e| err(&e))?;
    chart
        .configure_secondary_axes()
        .y_desc("C [deg]")
        .draw()
        .map_err(|e| err(&e))?;
    chart
        .draw_series(LineSeries::new(points.iter().map(|p| (p.t, p.z)), &BLUE))
        .map_err(|e| err(&e))?
        .label("Z setpoint")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
    chart
        .draw_secondary_series(LineSeries::new(points.iter().map(|p| (p.t, p.c)), &RED))
        .map_err(|e| err(&e))?
        .label("C setpoint")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(&e))?;

    let e_max = points
        .iter()
        .map(|p| p.coupling_um.abs().max(p.coupling_act_um.abs()))
        .fold(bound, f64::max)
        .max(0.1)
        * 1.1;
    let mut chart2 = ChartBuilder::on(&bottom)
        .caption(
            "rigid-tap coupling error: setpoints (green), actual (purple), one count (dashed)",
            ("sans-serif", 16),
        )
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .right_y_label_area_size(70)
        .build_cartesian_2d(0.0..t_max, -e_max..e_max)
        .map_err(|e| err(&e))?;
    chart2
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc("error [µm of Z]")
        .draw()
        .map_err(|e| err(&e))?;
    chart2
        .draw_series(LineSeries::new(
            points.iter().map(|p| (p.t, p.coupling_act_um)),
            &MAGENTA.mix(0.8),
        ))
        .map_err(|e| err(&e))?;
    chart2
        .draw_series(LineSeries::new(
            points.iter().map(|p| (p.t, p.coupling_um)),
            &GREEN.mix(0.9),
        ))
        .map_err(|e| err(&e))?;
    for b in [bound, -bound] {
        chart2
            .draw_series(DashedLineSeries::new(
                [(0.0, b), (t_max, b)],
                6,
                4,
                BLACK.stroke_width(1),
            ))
            .map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}
