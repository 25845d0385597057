//! The reporting side of a run: consumes [`Status`] records (outside the loop) and keeps the
//! summary figures — path length, following errors, final positions, rigid-tap coupling
//! windows — plus an optional CSV trace and a decimated series for the plot.

use std::io::Write;

use cnc402_config::{MAX_AXES, MachineConfig};

use crate::status::{Status, TapCoupling};

/// One rigid-tap window: consecutive coupled moves with the same pitch.
#[derive(Clone, Debug, PartialEq)]
pub struct TapWindow {
    /// Program line of the first move of the window.
    pub line: u32,
    /// Thread pitch the setpoints follow (mm per spindle turn).
    pub pitch_mm: f64,
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
    /// Tool and spindle position at the window's start: setpoint level and actual.
    cmd0: (f64, f64),
    act0: (f64, f64),
    /// Recent actual samples of the tool and spindle axis by the tick they were sampled at
    /// (tick − age), so that they are compared at equal age.
    hist: [[(u64, f64); HIST]; 2],
}

const HIST: usize = 16;

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
}

/// See the module doc.
pub struct Recorder {
    names: Vec<char>,
    n: usize,
    linear: [bool; MAX_AXES],
    counts_per_unit: [f64; MAX_AXES],
    period: f64,
    has_drive: [bool; MAX_AXES],
    /// Records seen.
    pub ticks: u64,
    /// Commanded path length over the linear axes (mm).
    pub path_length: f64,
    /// Largest |following error| per axis as the drive link's monitor measures it (the
    /// command delayed by the drive's dead time, minus actual; mm / degrees).
    pub max_following_error: [f64; MAX_AXES],
    /// The last record.
    pub last: Option<Status>,
    /// Closed tap windows.
    pub taps: Vec<TapWindow>,
    open: Option<OpenWindow>,
    trace: Option<Box<dyn Write>>,
    trace_error: Option<std::io::Error>,
    plot: Vec<PlotPoint>,
    plot_axes: Option<(usize, usize)>,
    plot_every: u64,
    plot_coupling: f64,
    plot_coupling_act: f64,
    /// Actual-level coupling error of the last record (µm), for the plot.
    last_act_error: f64,
}

impl Recorder {
    /// A recorder for `cfg`'s axes; `expected_ticks` sizes the plot decimation.
    pub fn new(cfg: &MachineConfig, expected_ticks: u64) -> Recorder {
        let n = cfg.axes.len().min(MAX_AXES);
        let mut linear = [false; MAX_AXES];
        let mut counts_per_unit = [1.0; MAX_AXES];
        let mut has_drive = [false; MAX_AXES];
        for (i, a) in cfg.axes.iter().take(n).enumerate() {
            linear[i] = a.kind == cnc402_config::AxisKind::Linear;
            counts_per_unit[i] = a.counts_per_unit;
            has_drive[i] = a.node.is_some();
        }
        let z = cfg.axis_index('Z');
        let c = cfg.spindle_index();
        Recorder {
            names: cfg.axes.iter().take(n).map(|a| a.name).collect(),
            n,
            linear,
            counts_per_unit,
            period: cfg.bus.period_s(),
            has_drive,
            ticks: 0,
            path_length: 0.0,
            max_following_error: [0.0; MAX_AXES],
            last: None,
            taps: Vec::new(),
            open: None,
            trace: None,
            trace_error: None,
            plot: Vec::new(),
            plot_axes: z.zip(c),
            plot_every: (expected_ticks / 4000).max(1),
            plot_coupling: 0.0,
            plot_coupling_act: 0.0,
            last_act_error: 0.0,
        }
    }

    /// Writes a CSV trace (`t,line,<A>_cmd,<A>_act…,<A>_sw…`) to `out`, header first.
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
        h.push('\n');
        if let Err(e) = out.write_all(h.as_bytes()) {
            self.trace_error = Some(e);
        }
        self.trace = Some(out);
        self
    }

    /// Consumes one record.
    pub fn record(&mut self, s: &Status) {
        if let Some(prev) = &self.last {
            let mut d2 = 0.0;
            for i in 0..self.n {
                if self.linear[i] {
                    let d = s.cmd[i] - prev.cmd[i];
                    d2 += d * d;
                }
            }
            self.path_length += d2.sqrt();
        }
        for i in 0..self.n {
            let fe = s.following_error[i].abs();
            if fe.is_finite() {
                self.max_following_error[i] = self.max_following_error[i].max(fe);
            }
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
        if let Some((z, c)) = self.plot_axes
            && s.tick.is_multiple_of(self.plot_every)
        {
            // One point per interval; the coupling error keeps the interval's worst value.
            self.plot.push(PlotPoint {
                t: s.tick as f64 * self.period,
                z: s.cmd[z],
                c: s.cmd[c],
                coupling_um: self.plot_coupling,
                coupling_act_um: self.plot_coupling_act,
            });
            self.plot_coupling = 0.0;
            self.plot_coupling_act = 0.0;
        }
        self.ticks += 1;
        self.last = Some(*s);
    }

    fn pos(&self, axis: u8, counts_basis: &[i32; MAX_AXES]) -> f64 {
        counts_basis[axis as usize] as f64 / self.counts_per_unit[axis as usize]
    }

    /// Tracks tap windows; returns the setpoint coupling error of this record in µm.
    fn track_taps(&mut self, s: &Status) -> f64 {
        let prev = self.last;
        match (s.tap, self.open.is_some()) {
            (Some(c), false) => self.open_window(s, c, prev),
            (Some(c), true) => {
                let same = self.open.as_ref().is_some_and(|o| {
                    o.c.tool == c.tool && (o.c.ratio - c.ratio).abs() <= 1e-9 * c.ratio.abs()
                });
                if !same {
                    self.close_window();
                    self.open_window(s, c, prev);
                }
            }
            (None, true) => self.close_window(),
            (None, false) => {}
        }
        self.last_act_error = 0.0;
        let Some(o) = self.open.as_mut() else {
            return 0.0;
        };
        // Setpoint level: the counts that went on the wire, unwrapped against the start by
        // the f64 command (which never wraps).
        let tool = s.cmd_counts[o.c.tool as usize] as f64 / self.counts_per_unit[o.c.tool as usize];
        let spindle = s.cmd[o.c.spindle as usize];
        let sp_cpu = self.counts_per_unit[o.c.spindle as usize];
        let spindle_set = (spindle * sp_cpu).round() / sp_cpu;
        let e_cmd = (tool - o.cmd0.0) - o.c.ratio * (spindle_set - o.cmd0.1);
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
        if z.0 == both && c.0 == both {
            let e_act = (z.1 - o.act0.0) - o.c.ratio * (c.1 - o.act0.1);
            self.last_act_error = e_act * 1000.0;
            o.w.max_coupling_error_um_act = o.w.max_coupling_error_um_act.max(e_act.abs() * 1000.0);
        }
        o.w.ticks.1 = s.tick;
        if s.spindle_follow {
            // The spindle's setpoints no longer drive it; only the actual coupling counts.
            return 0.0;
        }
        o.w.max_coupling_error_um_cmd = o.w.max_coupling_error_um_cmd.max(e_cmd.abs() * 1000.0);
        e_cmd * 1000.0
    }

    fn open_window(&mut self, s: &Status, c: TapCoupling, prev: Option<Status>) {
        // The window is anchored at the position before its first tick (the move's start).
        let base = prev.unwrap_or(*s);
        let sp = c.spindle as usize;
        let sp_cpu = self.counts_per_unit[sp];
        self.open = Some(OpenWindow {
            w: TapWindow {
                line: s.line,
                pitch_mm: (c.ratio * 360.0).abs(),
                max_coupling_error_um_cmd: 0.0,
                max_coupling_error_um_act: 0.0,
                ticks: (s.tick, s.tick),
                move_index: s.moves_started,
                file: None,
            },
            c,
            cmd0: (
                self.pos(c.tool, &base.cmd_counts),
                (base.cmd[sp] * sp_cpu).round() / sp_cpu,
            ),
            // Actuals are measured from the setpoints' origin, as the bus-side checker does:
            // an axis that has not settled when the tap starts is part of the error.
            act0: (base.cmd[c.tool as usize], base.cmd[sp]),
            hist: [[(u64::MAX, 0.0); HIST]; 2],
        });
    }

    fn close_window(&mut self) {
        if let Some(o) = self.open.take() {
            self.taps.push(o.w);
        }
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

    /// The plot series (Z and C setpoints, coupling error).
    pub fn plot_points(&self) -> &[PlotPoint] {
        &self.plot
    }

    /// Axis names in config order.
    pub fn axis_names(&self) -> &[char] {
        &self.names
    }
}

/// A position with enough digits for 0.1 µm / one spindle count, trailing zeros cut.
fn fmt(v: f64) -> String {
    let s = format!("{v:.7}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}
