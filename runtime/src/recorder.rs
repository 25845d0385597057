//! The reporting side of a run: consumes [`Status`] records (outside the loop) and keeps the
//! summary figures — path length, following errors, final positions, rigid-tap coupling
//! windows (measured by the drives crate's [`CouplingChecker`], the one `simdrive` uses, with
//! the windows delimited by the planned coupling) — plus an optional CSV trace and a
//! decimated series for the plot.

use std::io::Write;

use cnc402_config::{MAX_AXES, MachineConfig};
use cnc402_drives::coupling::{CouplingChecker, CouplingSample, TapMark};

use cnc402_motion::{AxisPos, PathAxes};

use crate::status::{Status, TapCoupling};

/// One rigid-tap window: consecutive coupled moves with the same pitch.
#[derive(Clone, Debug, PartialEq)]
pub struct TapWindow {
    /// Program line of the first move of the window.
    pub line: u32,
    /// Thread pitch the program commands (mm per spindle turn); deviations are measured
    /// from it.
    pub pitch_mm: f64,
    /// Pitch the setpoints showed: tool-axis travel per spindle turn over the window.
    pub pitch_observed_mm: f64,
    /// Worst deviation of the tool axis from spindle·pitch/360, setpoints (counts sent),
    /// in µm of the tool axis.
    pub max_coupling_error_um_cmd: f64,
    /// The same from actual positions (0x6064), Z and C compared at equal sample age (on a
    /// bus loaded near 100 % a drive's TPDO can arrive a cycle late).
    pub max_coupling_error_um_act: f64,
    /// First and last tick.
    pub ticks: (u64, u64),
    /// Number of the window's first move (see [`Status::moves_started`]); names its file.
    pub move_index: u64,
    /// The file of `line` (filled in when the run is reported).
    pub file: Option<String>,
}

struct OpenWindow {
    w: TapWindow,
    c: TapCoupling,
    /// The checker's id of this window.
    id: u64,
    /// Recent actual samples of the tool and spindle axis by the tick they were sampled at
    /// (tick − age), so that they are compared at equal age.
    hist: [[(u64, f64); HIST]; 2],
}

const HIST: usize = 16;

/// The plot series never holds more points than this (see `Recorder::thin_plot`).
pub const PLOT_MAX_POINTS: usize = 8000;

/// One sample of the plot series.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlotPoint {
    pub t: f64,
    pub z: f64,
    pub c: f64,
    /// Coupling error of the setpoints in µm (0 outside tap windows).
    pub coupling_um: f64,
    /// Coupling error of the actual positions in µm (equal sample age; 0 outside taps).
    pub coupling_act_um: f64,
    /// Commanded position of every axis (config order; Z and C above are two of them).
    pub cmd: [f64; MAX_AXES],
    /// Commanded velocity of every axis at this tick: the last period's step over the period.
    pub vel: [f64; MAX_AXES],
    /// Following error of every axis, the interval's largest in magnitude (signed).
    pub fe: [f64; MAX_AXES],
    /// Path speed over the linear axes at this tick (mm/s).
    pub speed: f64,
}

/// See the module doc.
pub struct Recorder {
    names: Vec<char>,
    n: usize,
    path_axes: PathAxes,
    counts_per_unit: [f64; MAX_AXES],
    period: f64,
    has_drive: [bool; MAX_AXES],
    /// Records seen.
    pub ticks: u64,
    /// Commanded path length over the linear axes (mm): the setpoints' straight steps from
    /// tick to tick ([`PathAxes::linear_distance`]; the spindle turning is no path).
    pub path_length: f64,
    /// The last record.
    pub last: Option<Status>,
    /// Closed tap windows.
    pub taps: Vec<TapWindow>,
    open: Option<OpenWindow>,
    checker: CouplingChecker,
    next_window: u64,
    trace: Option<Box<dyn Write>>,
    trace_error: Option<std::io::Error>,
    plot: Vec<PlotPoint>,
    /// Z and C, for the tapping panels (0 when the machine has no such axis).
    plot_axes: (Option<usize>, Option<usize>),
    plot_every: u64,
    /// The interval's worst following error per axis.
    plot_fe: [f64; MAX_AXES],
    plot_coupling: f64,
    plot_coupling_act: f64,
    /// Actual-level coupling error of the last record (µm), for the plot.
    last_act_error: f64,
}

impl Recorder {
    /// A recorder for `cfg`'s axes; `expected_ticks` sizes the plot decimation.
    pub fn new(cfg: &MachineConfig, expected_ticks: u64) -> Recorder {
        let n = cfg.axes.len().min(MAX_AXES);
        let mut counts_per_unit = [1.0; MAX_AXES];
        let mut has_drive = [false; MAX_AXES];
        for (i, a) in cfg.axes.iter().take(n).enumerate() {
            counts_per_unit[i] = a.counts_per_unit;
            has_drive[i] = a.node.is_some();
        }
        let z = cfg.axis_index('Z');
        let c = cfg.spindle_index();
        Recorder {
            names: cfg.axes.iter().take(n).map(|a| a.name).collect(),
            n,
            path_axes: PathAxes::new(cfg),
            counts_per_unit,
            period: cfg.bus.period_s(),
            has_drive,
            ticks: 0,
            path_length: 0.0,
            last: None,
            taps: Vec::new(),
            open: None,
            checker: CouplingChecker::new(
                z.map_or(1.0, |i| counts_per_unit[i]),
                c.map_or(1.0, |i| counts_per_unit[i]),
            ),
            next_window: 0,
            trace: None,
            trace_error: None,
            plot: Vec::new(),
            plot_axes: (z, c),
            plot_fe: [0.0; MAX_AXES],
            plot_every: (expected_ticks / 4000).max(1),
            plot_coupling: 0.0,
            plot_coupling_act: 0.0,
            last_act_error: 0.0,
        }
    }

    /// Writes a CSV trace (`t,line,<A>_cmd,<A>_act…,<A>_sw…,panel`) to `out`, header first;
    /// `panel` names the operator's feed hold, resume or override applied on that tick
    /// (`hold`, `resume`, `feed 50`, `spindle 110`; empty on the others).
    pub fn with_trace(mut self, mut out: Box<dyn Write>) -> Recorder {
        let mut h = String::from("t,line");
        for a in &self.names {
            h.push_str(&format!(",{a}_cmd,{a}_act"));
        }
        for (i, a) in self.names.iter().enumerate() {
            if self.has_drive[i] {
                h.push_str(&format!(",{a}_sw"));
            }
        }
        h.push_str(",panel\n");
        if let Err(e) = out.write_all(h.as_bytes()) {
            self.trace_error = Some(e);
        }
        self.trace = Some(out);
        self
    }

    /// Consumes one record.
    pub fn record(&mut self, s: &Status) {
        if let Some(prev) = &self.last {
            self.path_length += self
                .path_axes
                .linear_distance(&AxisPos(prev.cmd), &AxisPos(s.cmd));
        }
        let coupling = self.track_taps(s);
        if self.trace.is_some() && self.trace_error.is_none() {
            self.write_trace(s);
        }
        if coupling.abs() > self.plot_coupling.abs() {
            self.plot_coupling = coupling;
        }
        if self.last_act_error.abs() > self.plot_coupling_act.abs() {
            self.plot_coupling_act = self.last_act_error;
        }
        for (w, fe) in self.plot_fe.iter_mut().zip(s.following_error) {
            if fe.is_finite() && fe.abs() > w.abs() {
                *w = fe;
            }
        }
        if s.tick.is_multiple_of(self.plot_every) {
            self.push_plot_point(s);
        }
        self.ticks += 1;
        self.last = Some(*s);
    }

    /// One point of the plot series (one per interval; the coupling and following errors
    /// keep the interval's worst value).
    fn push_plot_point(&mut self, s: &Status) {
        let at = |i: Option<usize>| i.map_or(0.0, |i| s.cmd[i]);
        let prev = self.last.map_or(s.cmd, |p| p.cmd);
        let mut vel = [0.0; MAX_AXES];
        for (i, v) in vel.iter_mut().enumerate().take(self.n) {
            *v = (s.cmd[i] - prev[i]) / self.period;
        }
        let speed = self
            .path_axes
            .linear_distance(&AxisPos(prev), &AxisPos(s.cmd))
            / self.period;
        self.plot.push(PlotPoint {
            t: s.tick as f64 * self.period,
            z: at(self.plot_axes.0),
            c: at(self.plot_axes.1),
            coupling_um: self.plot_coupling,
            coupling_act_um: self.plot_coupling_act,
            cmd: s.cmd,
            vel,
            fe: std::mem::take(&mut self.plot_fe),
            speed,
        });
        self.plot_coupling = 0.0;
        self.plot_coupling_act = 0.0;
        if self.plot.len() >= PLOT_MAX_POINTS {
            self.thin_plot();
        }
    }

    /// The checker's sample of record `s` for tool axis `tool` and spindle `sp`: setpoints at
    /// the path's counts (what went on the wire unless a tap's dynamics were matched; the
    /// spindle's unwrapped by its f64 command, which never wraps), and the actual pair given.
    fn sample(
        &self,
        s: &Status,
        tool: usize,
        sp: usize,
        act: Option<(f64, f64)>,
    ) -> CouplingSample {
        let sp_cpu = self.counts_per_unit[sp];
        let (z_act, c_act) = act.unwrap_or((s.act[tool], s.act[sp]));
        CouplingSample {
            // The path's setpoints: with dynamic matching the drives get them shaped on
            // purpose (cmd_counts), which the actual-position figure judges.
            z_cmd: cnc402_motion::to_counts_wrapping(s.cmd[tool], self.counts_per_unit[tool])
                as f64
                / self.counts_per_unit[tool],
            z_act,
            c_cmd: (s.cmd[sp] * sp_cpu).round() / sp_cpu,
            c_act,
            line: s.line,
            actual_stale: act.is_none(),
        }
    }

    /// Tracks tap windows; returns the setpoint coupling error of this record in µm.
    fn track_taps(&mut self, s: &Status) -> f64 {
        let prev = self.last;
        let continues = match (s.tap, self.open.as_ref()) {
            (Some(c), Some(o)) => {
                o.c.tool == c.tool && (o.c.ratio - c.ratio).abs() <= 1e-9 * c.ratio.abs()
            }
            _ => false,
        };
        if !continues {
            self.close_window();
            if let Some(c) = s.tap {
                self.open_window(s, c, prev);
            }
        }
        self.last_act_error = 0.0;
        let Some(o) = self.open.as_mut() else {
            return 0.0;
        };
        // Actual level: Z and C sampled at the same SYNC (a late TPDO is an older sample).
        let (ti, si) = (o.c.tool as usize, o.c.spindle as usize);
        let (at, asp) = (s.age[ti] as u64, s.age[si] as u64);
        for (k, (i, age)) in [(ti, at), (si, asp)].into_iter().enumerate() {
            let sampled = s.tick.saturating_sub(age);
            o.hist[k][(sampled as usize) % HIST] = (sampled, s.act[i]);
        }
        let both = s.tick.saturating_sub(at.max(asp));
        let (z, c) = (
            o.hist[0][(both as usize) % HIST],
            o.hist[1][(both as usize) % HIST],
        );
        let pair = (z.0 == both && c.0 == both).then_some((z.1, c.1));
        o.w.ticks.1 = s.tick;
        let mark = TapMark {
            id: o.id,
            ratio: o.c.ratio,
            // The spindle's setpoints no longer drive it; only the actual coupling counts.
            setpoints_ignored: s.spindle_follow,
        };
        let sample = self.sample(s, ti, si, pair);
        self.checker.feed_marked(sample, Some(mark));
        let d = self.checker.last_deviation().unwrap_or_default();
        self.last_act_error = d.act_um.unwrap_or(0.0);
        d.cmd_um.unwrap_or(0.0)
    }

    fn open_window(&mut self, s: &Status, c: TapCoupling, prev: Option<Status>) {
        // The window is anchored at the position before its first tick (the move's start);
        // actuals are measured from the setpoints' origin, as on the bus side: an axis that
        // has not settled when the tap starts is part of the error.
        let base = prev.unwrap_or(*s);
        let origin = self.sample(&base, c.tool as usize, c.spindle as usize, None);
        self.checker.rebase(origin);
        self.next_window += 1;
        self.open = Some(OpenWindow {
            w: TapWindow {
                line: s.line,
                pitch_mm: (c.ratio * 360.0).abs(),
                pitch_observed_mm: 0.0,
                max_coupling_error_um_cmd: 0.0,
                max_coupling_error_um_act: 0.0,
                ticks: (s.tick, s.tick),
                move_index: s.moves_started,
                file: None,
            },
            c,
            id: self.next_window,
            hist: [[(u64::MAX, 0.0); HIST]; 2],
        });
    }

    fn close_window(&mut self) {
        let Some(mut o) = self.open.take() else {
            return;
        };
        if let Some(w) = self.checker.finish() {
            o.w.pitch_mm = w.pitch_mm;
            o.w.pitch_observed_mm = w.observed_pitch_mm;
            o.w.max_coupling_error_um_cmd = w.max_error_um_cmd;
            o.w.max_coupling_error_um_act = w.max_error_um_act;
        }
        self.taps.push(o.w);
    }

    fn write_trace(&mut self, s: &Status) {
        let mut line = format!("{:.6},{}", s.tick as f64 * self.period, s.line);
        for i in 0..self.n {
            line.push_str(&format!(",{},{}", fmt(s.cmd[i]), fmt(s.act[i])));
        }
        for i in 0..self.n {
            if self.has_drive[i] {
                line.push_str(&format!(",0x{:04x}", s.statusword[i]));
            }
        }
        line.push(',');
        push_panel(&mut line, s);
        line.push('\n');
        if let Some(t) = self.trace.as_mut()
            && let Err(e) = t.write_all(line.as_bytes())
        {
            self.trace_error = Some(e);
        }
    }

    /// Closes the open window and flushes the trace; returns the first trace write error.
    pub fn finish(&mut self) -> Result<(), std::io::Error> {
        self.close_window();
        if let Some(mut t) = self.trace.take()
            && let Err(e) = t.flush()
        {
            self.trace_error.get_or_insert(e);
        }
        match self.trace_error.take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// Halves the plot series and its rate, so that a run longer than the dry run said (a
    /// main program repeated by M99, a long hold) keeps a bounded series: each pair becomes
    /// its first point with the pair's worst coupling errors.
    fn thin_plot(&mut self) {
        let worst = |a: f64, b: f64| if b.abs() > a.abs() { b } else { a };
        let mut w = 0;
        for r in (0..self.plot.len()).step_by(2) {
            let mut p = self.plot[r];
            if let Some(q) = self.plot.get(r + 1) {
                p.coupling_um = worst(p.coupling_um, q.coupling_um);
                p.coupling_act_um = worst(p.coupling_act_um, q.coupling_act_um);
                for (a, b) in p.fe.iter_mut().zip(q.fe) {
                    *a = worst(*a, b);
                }
            }
            self.plot[w] = p;
            w += 1;
        }
        self.plot.truncate(w);
        self.plot_every = self.plot_every.saturating_mul(2);
    }

    /// The plot series (every axis's setpoint, velocity and following error, path speed,
    /// rigid-tap coupling error).
    pub fn plot_points(&self) -> &[PlotPoint] {
        &self.plot
    }

    /// Axis names in config order.
    pub fn axis_names(&self) -> &[char] {
        &self.names
    }
}

/// A position with enough digits for 0.1 µm / one spindle count, trailing zeros cut.
/// The trace's `panel` cell of record `s`: the panel change applied on its tick, if any.
pub(crate) fn push_panel(line: &mut String, s: &Status) {
    if let Some(a) = s.panel {
        line.push_str(a.name());
        if let Some(p) = a.percent() {
            line.push_str(&format!(" {p}"));
        }
    }
}

/// A trace number: up to 7 decimals, no trailing zeros, no `-0`.
pub(crate) fn fmt(v: f64) -> String {
    let s = format!("{v:.7}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn status(tick: u64) -> Status {
        Status {
            tick,
            line: 1,
            moves_started: 1,
            ..Status::default()
        }
    }

    /// Regression: a run far longer than its dry run (a main program repeated by M99) grew
    /// the plot series by about 4000 points per pass, without bound.
    #[test]
    fn the_plot_series_stays_bounded_and_spans_the_whole_run() {
        let cfg = MachineConfig::default_machine();
        // The dry run said 8000 ticks; the run lasts 100 times longer.
        let mut r = Recorder::new(&cfg, 8000);
        let n = 800_000;
        for t in 0..n {
            r.record(&status(t));
        }
        let p = r.plot_points();
        assert!(p.len() <= PLOT_MAX_POINTS, "{} points", p.len());
        assert!(p.len() >= PLOT_MAX_POINTS / 4, "{} points", p.len());
        let last = p.last().unwrap().t;
        assert!(
            last > (n as f64 * 1e-3) * 0.9,
            "the series reaches {last} s"
        );
        assert!(p.windows(2).all(|w| w[1].t > w[0].t));
    }

    /// The plot's path series: every axis's position and velocity, the path speed over the
    /// linear axes, and each interval's worst following error (signed), halved with the rest.
    #[test]
    fn plot_points_carry_velocity_speed_and_the_worst_following_error() {
        let cfg = MachineConfig::default_machine();
        let (x, y) = (cfg.axis_index('X').unwrap(), cfg.axis_index('Y').unwrap());
        // 40,000 expected ticks: one point every 10 ticks.
        let mut r = Recorder::new(&cfg, 40_000);
        for t in 0..21 {
            let mut s = status(t);
            s.cmd[x] = 0.003 * t as f64;
            s.cmd[y] = 0.004 * t as f64;
            s.following_error[y] = if t == 13 { -0.02 } else { 0.01 };
            r.record(&s);
        }
        let p = r.plot_points();
        assert_eq!(p.len(), 3, "ticks 0, 10, 20");
        assert!((p[1].vel[x] - 3.0).abs() < 1e-9 && (p[1].vel[y] - 4.0).abs() < 1e-9);
        assert!((p[1].speed - 5.0).abs() < 1e-9, "{}", p[1].speed);
        assert!((p[1].cmd[x] - 0.03).abs() < 1e-12);
        assert_eq!(p[2].fe[y], -0.02, "the interval 11..=20 holds the worst");
        assert_eq!(p[1].fe[y], 0.01);
        r.thin_plot();
        assert_eq!(r.plot_points()[0].fe[y], 0.01);
        assert_eq!(r.plot_points()[1].fe[y], -0.02);
    }
}
