//! Dynamic matching of contouring axes on the embedded simulator: X's drive slower than Y's
//! (40 Hz / 2 cycles against 150 Hz / 1 cycle, the `sim` truth) cuts a circle whose actual
//! positions leave the programmed radius; with `[planner] match_axes` and the master's
//! models saying so, both lag alike and the actual path stays on the circle (it lags along
//! the path instead). Prints the figures: `cargo test -p cnc402-runtime --test
//! contour_matching -- --nocapture`.

mod common;

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use cnc402_config::{DriveModel, MachineConfig, SimDynamics};
use cnc402_drives::Instant;
use cnc402_lang::SourceFile;
use cnc402_runtime::controller::{CycleController, Step};
use cnc402_runtime::ring::{Consumer, move_ring, status_ring};
use cnc402_runtime::{Outcome, Phase, RunOptions, RunReport, SimLink, Status, run_program};

const RADIUS: f64 = 10.0;
/// The circle's centre; it starts and ends at (CX, CY - RADIUS), entered along +X.
const CX: f64 = 10.0;
const CY: f64 = 10.0;

/// A line along +X into a full CCW circle (tangent, blended under G64) and out again.
fn circle_program(feed: u32) -> String {
    format!(
        "%\nG21 G90 G17 G94 G54 G64\nG1 X{CX:.1} Y0. F{feed}\nG3 X{CX:.1} Y0. I0. J{RADIUS:.1}\n\
         G1 X{:.1}\nM30\n%\n",
        CX + 10.0
    )
}

/// A `Write` the test keeps a handle on (the run takes the trace writer by value).
#[derive(Clone, Default)]
struct Shared(Arc<Mutex<Vec<u8>>>);
impl Write for Shared {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

struct Figures {
    /// The report's `max_path_deviation_mm_act` in µm: the largest distance of the actual
    /// positions (compared at equal sample age) from the programmed path.
    contour_um: f64,
    /// The same from the trace, ticks where an axis's sample is a cycle old (a late TPDO,
    /// seen as an unchanged position while the path moves) left out: a check of the report.
    trace_um: f64,
    /// Largest distance (µm) between the commanded and the actual XY position: the lag
    /// along the path.
    lag_um: f64,
    /// Largest |commanded − actual| of X and of Y (µm).
    axis_lag_um: [f64; 2],
    report: RunReport,
}

/// Distance of (x, y) from the program's path.
fn off_path(x: f64, y: f64) -> f64 {
    let on_line = |x0: f64, x1: f64| (x - x.clamp(x0, x1)).hypot(y);
    let circle = ((x - CX).hypot(y - CY) - RADIUS).abs();
    on_line(0.0, CX).min(on_line(CX, CX + 10.0)).min(circle)
}

fn run_circle(cfg: &MachineConfig, feed: u32) -> Figures {
    let text = circle_program(feed);
    let src = SourceFile::new("circle.nc", text.as_str());
    let ast = cnc402_lang::parse(&src).unwrap();
    let trace = Shared::default();
    let opts = RunOptions {
        trace: Some(Box::new(trace.clone())),
        ..RunOptions::default()
    };
    let r = run_program(cfg, src, ast, opts, &mut |_| {}).unwrap_or_else(|e| panic!("{e:?}"));
    assert!(r.ok, "{:?}", r.error);
    let csv = String::from_utf8(trace.0.lock().unwrap().clone()).unwrap();
    let mut rows = csv.lines();
    let head: Vec<&str> = rows.next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let (xc, xa, yc, ya) = (col("X_cmd"), col("X_act"), col("Y_cmd"), col("Y_act"));
    let (mut contour, mut lag) = (0.0f64, 0.0f64);
    let mut axis_lag = [0.0f64; 2];
    let mut prev: Option<Vec<f64>> = None;
    for row in rows {
        let v: Vec<f64> = row.split(',').map(|f| f.parse().unwrap_or(0.0)).collect();
        lag = lag.max((v[xc] - v[xa]).hypot(v[yc] - v[ya]));
        axis_lag[0] = axis_lag[0].max((v[xc] - v[xa]).abs() * 1000.0);
        axis_lag[1] = axis_lag[1].max((v[yc] - v[ya]).abs() * 1000.0);
        let stale = prev.as_ref().is_some_and(|p| {
            [(xc, xa), (yc, ya)]
                .iter()
                .any(|&(c, a)| p[a] == v[a] && p[c] != v[c])
        });
        if !stale {
            contour = contour.max(off_path(v[xa], v[ya]));
        }
        prev = Some(v);
    }
    Figures {
        contour_um: r.max_path_deviation_mm_act * 1000.0,
        trace_um: contour * 1000.0,
        lag_um: lag * 1000.0,
        axis_lag_um: axis_lag,
        report: r,
    }
}

/// The shipped machine with X's drive slow (`sim`, and a following-error window to match), the master's models saying so when
/// `modelled`, and X, Y, Z matched when `matched`.
fn slow_x(modelled: bool, matched: bool) -> MachineConfig {
    let mut cfg = MachineConfig::default_machine();
    let x = cfg.axis_index('X').unwrap();
    // A rapid at 250 mm/s lags about 2 mm behind on a 40 Hz drive: a window for such a drive.
    cfg.axes[x].following_error_window = 5.0;
    cfg.axes[x].sim = SimDynamics {
        delay_cycles: 2,
        bandwidth_hz: 40.0,
        ..SimDynamics::default()
    };
    if modelled {
        cfg.axes[x].dynamics = Some(DriveModel {
            delay_cycles: 2,
            bandwidth_hz: 40.0,
        });
    }
    if matched {
        cfg.planner.match_axes = "XYZ".chars().map(|c| cfg.axis_index(c).unwrap()).collect();
    }
    cfg
}

#[test]
fn matching_x_and_y_cuts_the_contour_error_of_a_circle_tenfold() {
    eprintln!(
        "| feed | contour error unmatched | matched | ratio | path lag unmatched (X, Y) | \
         matched (X, Y) |"
    );
    for feed in [3000, 6000] {
        let off = run_circle(&slow_x(true, false), feed);
        let on = run_circle(&slow_x(true, true), feed);
        let ratio = off.contour_um / on.contour_um;
        eprintln!(
            "| F{feed} | {:.2} µm (trace {:.2}) | {:.3} µm (trace {:.3}) | {ratio:.0}× | \
             {:.0} µm ({:.0}, {:.0}) | {:.0} µm ({:.0}, {:.0}) |",
            off.contour_um,
            off.trace_um,
            on.contour_um,
            on.trace_um,
            off.lag_um,
            off.axis_lag_um[0],
            off.axis_lag_um[1],
            on.lag_um,
            on.axis_lag_um[0],
            on.axis_lag_um[1]
        );
        assert!(
            off.contour_um > 20.0,
            "F{feed}: the mismatch shows: {}",
            off.contour_um
        );
        assert!(
            ratio >= 10.0,
            "F{feed}: {} -> {} µm",
            off.contour_um,
            on.contour_um
        );
        // The trace measures about the same (its positions are printed to 0.1 µm; a stale
        // sample of a slow axis may pass its test).
        for f in [&off, &on] {
            assert!(
                (f.trace_um - f.contour_um).abs() <= 0.2 + 0.05 * f.contour_um,
                "F{feed}: report {} trace {}",
                f.contour_um,
                f.trace_um
            );
        }
        // Matching moves the error into a lag along the path: the fast axis Y now lags as
        // much as the slow X (it lagged about half as much).
        let [x_off, y_off] = off.axis_lag_um;
        let [x_on, y_on] = on.axis_lag_um;
        assert!(
            y_off < 0.6 * x_off,
            "F{feed}: unmatched lags X {x_off} Y {y_off}"
        );
        assert!(
            (y_on - x_on).abs() < 0.02 * x_on,
            "F{feed}: matched lags X {x_on} Y {y_on}"
        );
        // Position is not lost: the run ends at the programmed end, to a count.
        let x = on.report.axes.iter().find(|a| a.name == 'X').unwrap();
        let y = on.report.axes.iter().find(|a| a.name == 'Y').unwrap();
        assert!(
            (x.final_position - (CX + 10.0)).abs() <= 1e-4,
            "{}",
            x.final_position
        );
        assert!(y.final_position.abs() <= 1e-4, "{}", y.final_position);
    }
}

#[test]
fn equal_dynamics_are_not_shaped_and_a_set_without_models_of_the_difference_changes_nothing() {
    // Equal models (the shipped machine with the set on): the setpoints are the unshaped
    // ones, so the run is identical to one without the set.
    let mut on = MachineConfig::default_machine();
    on.planner.match_axes = vec![0, 1, 2];
    let a = run_circle(&on, 6000);
    let b = run_circle(&MachineConfig::default_machine(), 6000);
    assert_eq!(a.contour_um, b.contour_um);
    assert_eq!(a.lag_um, b.lag_um);
    assert!(
        a.contour_um < 1.0,
        "equal dynamics contour {} µm",
        a.contour_um
    );
    // The slow drive unmodelled: the master believes the axes equal, nothing is shaped.
    let c = run_circle(&slow_x(false, true), 6000);
    let d = run_circle(&slow_x(false, false), 6000);
    assert_eq!(c.contour_um, d.contour_um);
}

/// A rigid tap whose tool axis Z contours matched (X slow makes the contouring target 2 cycles
/// / 40 Hz) and a spindle at 150 Hz / 1 cycle: the tap's matching shapes the spindle to what Z
/// lags like through the contouring set, and the thread stays coupled at the actual positions.
#[test]
fn a_tap_stays_coupled_when_its_tool_axis_contours_matched() {
    let text = "%\nG21 G90 G17 G94 G54\nG0 X20. Y20. Z10.\nM29 S2000\n\
                G98 G84 X20. Y20. Z-16. R3. F3000.\nX60.\nG80\nG0 Z50.\nM30\n%\n";
    for matched in [false, true] {
        let cfg = slow_x(true, matched);
        let src = SourceFile::new("tap.nc", text);
        let ast = cnc402_lang::parse(&src).unwrap();
        let r = run_program(&cfg, src, ast, RunOptions::default(), &mut |_| {})
            .unwrap_or_else(|e| panic!("{e:?}"));
        assert!(r.ok, "{:?}", r.error);
        assert_eq!(r.tapping.len(), 2);
        let act = r
            .tapping
            .iter()
            .map(|t| t.max_coupling_error_um_act)
            .fold(0.0, f64::max);
        eprintln!("tap at 2000 rpm, XYZ matched {matched}: actual coupling {act:.3} µm");
        assert!(act <= 5.0, "matched {matched}: {act} µm");
        let z = r.axes.iter().find(|a| a.name == 'Z').unwrap();
        assert!(
            (z.final_position - 50.0).abs() <= 1e-4,
            "{}",
            z.final_position
        );
    }
}

/// Runs `text` on the controller over the simulated bus, calling `hook` with every status
/// record (it may raise the operator's stop); returns the outcome and the records.
fn drive(
    cfg: &MachineConfig,
    text: &str,
    mut hook: impl FnMut(&Status, &AtomicBool),
) -> (Outcome, Vec<Status>) {
    let mut link = SimLink::simulated(cfg, None).unwrap();
    let start = common::started(&mut link);
    let mut feeder = common::feeder(cfg, "t.nc", text, &start);
    let (mut mp, mc) = move_ring(64);
    let (sp, mut sc) = status_ring(1024);
    let stop = Arc::new(AtomicBool::new(false));
    let mut ctrl = CycleController::new(cfg, start, link, mc, sp, stop.clone());
    let period = Duration::from_micros(cfg.bus.period_us as u64);
    let mut now = Instant::ZERO;
    let mut out = Vec::new();
    loop {
        feeder.fill(&mut mp).expect("program");
        now += period;
        let step = ctrl.step(now);
        while let Some(s) = sc.try_pop() {
            hook(&s, &stop);
            out.push(s);
        }
        if let Step::Done(o) = step {
            return (o, out);
        }
        assert!(out.len() < 200_000, "runaway");
    }
}

/// An operator's stop mid-circle, a dwell and the program's end with X, Y matched: the path
/// decelerates on the circle, and the shaped setpoints catch up with the point the path
/// rests at — exactly, in counts — before the quick stop, during the dwell, and at the end.
#[test]
fn at_a_stop_and_a_hold_the_shaped_setpoints_reach_the_held_point_exactly() {
    let cfg = slow_x(true, true);
    let (outcome, st) = drive(&cfg, &circle_program(6000), |s, stop| {
        if s.tick >= 400 {
            stop.store(true, Ordering::SeqCst);
        }
    });
    assert!(matches!(outcome, Outcome::Stopped { .. }), "{outcome:?}");
    // The last record before the quick stop took over: setpoints equal the held path's.
    let last = st
        .iter()
        .rev()
        .find(|s| s.phase == Phase::Stopping)
        .unwrap();
    assert!(last.cmd[1] > 1.0, "stopped on the circle: {:?}", last.cmd);
    for i in 0..2 {
        let want = (last.cmd[i] * cfg.axes[i].counts_per_unit).round() as i32;
        assert_eq!(last.cmd_counts[i], want, "axis {i}");
        assert!((last.act_counts[i] - want).abs() <= 1, "axis {i}: {last:?}");
    }
    // A dwell halfway round the circle, and the end of the program.
    let text = circle_program(6000).replace(
        "G3 X10.0 Y0. I0. J10.0",
        "G3 X20. Y10. I0. J10.\nG4 P200\nG3 X10. Y0. I-10. J0.",
    );
    let (outcome, st) = drive(&cfg, &text, |_, _| {});
    assert_eq!(outcome, Outcome::Finished);
    let counts = |s: &Status, i: usize| (s.cmd[i] * cfg.axes[i].counts_per_unit).round() as i32;
    let dwell_start = st.iter().find(|s| s.line == 5).unwrap();
    let dwell_end = st.iter().rev().find(|s| s.line == 5).unwrap();
    let end = st.last().unwrap();
    assert_ne!(
        dwell_start.cmd_counts[1],
        counts(dwell_start, 1),
        "Y still shaped"
    );
    for i in 0..2 {
        assert_eq!(dwell_end.cmd_counts[i], counts(dwell_end, i), "axis {i}");
        assert_eq!(end.cmd_counts[i], counts(end, i), "axis {i}");
        assert!(
            (end.act_counts[i] - end.cmd_counts[i]).abs() <= 1,
            "{end:?}"
        );
    }
    assert_eq!((end.cmd[0], end.cmd[1]), (20.0, 0.0));
}
