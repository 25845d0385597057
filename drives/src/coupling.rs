//! The rigid-tapping coupling checker, one for `cnc402 run` and `simdrive`: fed once per tick
//! (or SYNC) with Z and C — f64 positions ([`CouplingSample`]) or drive counts off the bus
//! ([`CountSample`]) — it finds each window in which both move and reports the least-squares
//! pitch observed and the worst deviation from it in µm of Z, setpoints and actual positions.
//! Callers that know the taps (the planner's coupling) delimit windows with [`TapMark`]s
//! (deviations then from the commanded pitch); see [`CouplingChecker`] for the windowing.

/// Ticks without motion that end an unmarked window (near standstill a rounded setpoint
/// changes by a count only every few ticks: a single quiet tick must not split a tap).
pub const REST_TICKS: u32 = 100;

/// A window with C turning alone for this many consecutive ticks is a move with the spindle
/// running (drilling), not a tap: in a rigid tap C turns alone only while Z's step is below one
/// count (a few ticks at the ends of a ramp).
pub const SPINDLE_RUNNING_TICKS: u32 = 100;

/// A window whose first or last C step is at least this fraction of its largest is a move
/// with the spindle turning at speed (a drill feeding in or retracting): a tap starts from and
/// ends at standstill or a reversal, where C's step is near zero.
pub const SPINDLE_AT_SPEED: f64 = 0.5;

/// Z moving this many ticks while C stands still ends an unmarked window (a rapid or feed
/// after the tap, in the same direction).
pub const Z_ALONE_TICKS: u32 = 20;

/// Samples kept per window; a longer window (a spindle turning for hours) keeps its figures
/// from the first ones.
const MAX_SAMPLES: usize = 1 << 21;

/// One tick's positions: Z in mm, C in degrees (unwrapped), and the program line.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CouplingSample {
    /// Z setpoint (mm).
    pub z_cmd: f64,
    /// Z actual position (mm).
    pub z_act: f64,
    /// C setpoint (degrees).
    pub c_cmd: f64,
    /// C actual position (degrees).
    pub c_act: f64,
    /// The program line being executed.
    pub line: u32,
    /// The actual positions are not a pair sampled at the same instant (e.g. one drive's
    /// TPDO came a cycle late): this tick counts for the setpoints only.
    pub actual_stale: bool,
}

/// One SYNC's positions in drive counts (unwrapped), as seen on the bus: the targets of the
/// RPDOs and the actual positions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CountSample {
    /// Z target (counts).
    pub z_cmd: i64,
    /// C target (counts).
    pub c_cmd: i64,
    /// Z actual position (counts).
    pub z_act: i64,
    /// C actual position (counts).
    pub c_act: i64,
}

/// One window of coupled Z and C motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TapWindow {
    /// Program line at the window's first tick (0 for [`CountSample`] input).
    pub line: u32,
    /// Tick number (count of samples fed before it) of the window's first moving tick.
    pub first_tick: u64,
    /// Ticks in the window.
    pub ticks: u64,
    /// Z travel of the setpoints, mm: path length (marked windows) or the largest excursion
    /// from the window's origin (unmarked windows, which move in one direction).
    pub z_travel_mm: f64,
    /// The same for C, degrees.
    pub c_travel_deg: f64,
    /// The pitch deviations are measured from (mm/rev, always positive): the observed one,
    /// or for a window delimited with [`CouplingChecker::feed_marked`] the commanded one.
    pub pitch_mm: f64,
    /// Pitch observed, mm per C revolution, always positive: unmarked windows, the slope of
    /// the least-squares line ΔZ = k·ΔC through the setpoints; marked windows, Z path length
    /// per C revolution of the setpoints (their deviations are from the commanded pitch).
    pub observed_pitch_mm: f64,
    /// Whether Z and C move in the same sense (Z+ with C+): the sign of the coupling.
    pub same_sense: bool,
    /// Worst deviation of the setpoints from the pitch line, µm of Z: unmarked, the half-width
    /// of the band of ΔZ − k·ΔC (best offset); marked, max |ΔZ − ratio·ΔC| from the origin.
    pub max_error_um_cmd: f64,
    /// The same for actual positions (against the same line), µm of Z.
    pub max_error_um_act: f64,
    /// Delimited by the caller ([`CouplingChecker::feed_marked`]).
    pub marked: bool,
    /// Longest run of ticks with C turning and Z not (unmarked windows).
    pub c_alone_ticks: u32,
    /// Unmarked: `c_alone_ticks >= SPINDLE_RUNNING_TICKS`, or C at speed (≥
    /// [`SPINDLE_AT_SPEED`] of its largest step) at the first or last tick it moved: Z moved
    /// while the spindle was already turning, not a tap (report it, do not judge it).
    pub spindle_running: bool,
}

/// A tick that belongs to a window the caller delimits (see
/// [`CouplingChecker::feed_marked`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TapMark {
    /// The window: consecutive marked ticks with the same id form one window.
    pub id: u64,
    /// The commanded coupling, ΔZ/ΔC in mm per degree (signed): deviations are measured
    /// from it.
    pub ratio: f64,
    /// This tick's setpoints do not drive the spindle (its drive stopped following): they are
    /// not scored and not counted in the observed pitch; the actual positions still are.
    pub setpoints_ignored: bool,
}

/// One tick's deviations in a window with a commanded coupling, µm of Z, signed.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TickDeviation {
    /// Setpoints (`None`: not scored on this tick).
    pub cmd_um: Option<f64>,
    /// Actual positions (`None`: stale pair).
    pub act_um: Option<f64>,
}

#[derive(Clone, Copy, Debug)]
struct Rel {
    dz_cmd: f64,
    dc_cmd: f64,
    dz_act: f64,
    dc_act: f64,
    act_valid: bool,
    cmd_valid: bool,
}

#[derive(Clone, Copy, Debug)]
struct Open {
    line: u32,
    first_tick: u64,
    origin: CouplingSample,
    /// Path lengths (marked windows).
    z_travel: f64,
    c_travel: f64,
    /// Caller-delimited window: its id and commanded ratio.
    mark: Option<(u64, f64)>,
    // Unmarked windowing, on counts.
    z_dir: i64,
    c_dir: i64,
    c_alone: u32,
    c_alone_max: u32,
    rest: u32,
    /// Samples since C last moved, and Z's moves among them.
    since_c: usize,
    z_moves_since_c: u32,
    first_dc: i64,
    last_dc: i64,
    max_dc: i64,
}

impl Open {
    fn new(line: u32, first_tick: u64, origin: CouplingSample, mark: Option<(u64, f64)>) -> Open {
        Open {
            line,
            first_tick,
            origin,
            z_travel: 0.0,
            c_travel: 0.0,
            mark,
            z_dir: 0,
            c_dir: 0,
            c_alone: 0,
            c_alone_max: 0,
            rest: 0,
            since_c: 0,
            z_moves_since_c: 0,
            first_dc: 0,
            last_dc: 0,
            max_dc: 0,
        }
    }
}

/// Finds tapping windows in a stream of samples.
///
/// Unmarked windowing (`feed`, `feed_counts`) works on the positions rounded to counts, so it
/// is robust to sub-count motion: at the slow ends of a tap Z moves less than a count per tick
/// and a tick where only one axis moves continues the window. A window opens when C moves and
/// lasts while Z and C each keep one direction; it ends when both have rested for
/// [`REST_TICKS`] ticks, either reverses, or Z has moved [`Z_ALONE_TICKS`] ticks without C (a
/// rapid after the tap; those ticks are left out). Its figures are the half-width of the band
/// of ΔZ − k·ΔC around the least-squares line (the best offset chosen: the quantized start and
/// end points are ±½ count). A window that starts or ends with C at speed, or has C turning
/// alone for [`SPINDLE_RUNNING_TICKS`] ticks, is marked `spindle_running` (drilling, not a tap).
///
/// The pitch is only known when a window ends, so the window's samples are kept (in a
/// buffer reused from window to window: it allocates only when a window is longer than every
/// earlier one; [`with_capacity`](Self::with_capacity) avoids even that).
#[derive(Clone, Debug)]
pub struct CouplingChecker {
    z_cpu: f64,
    c_cpu: f64,
    prev: Option<CouplingSample>,
    ticks: u64,
    open: Option<Open>,
    samples: Vec<Rel>,
    windows: Vec<TapWindow>,
    last_deviation: Option<TickDeviation>,
}

impl CouplingChecker {
    /// A checker for Z with `z_counts_per_mm` and C with `c_counts_per_deg` (non-positive or
    /// non-finite values count as 1): unmarked windowing rounds positions to these counts.
    pub fn new(z_counts_per_mm: f64, c_counts_per_deg: f64) -> CouplingChecker {
        CouplingChecker::with_capacity(z_counts_per_mm, c_counts_per_deg, 0)
    }

    /// As [`new`](Self::new), with room for windows of `ticks` ticks without allocating.
    pub fn with_capacity(
        z_counts_per_mm: f64,
        c_counts_per_deg: f64,
        ticks: usize,
    ) -> CouplingChecker {
        let ok = |v: f64| if v.is_finite() && v > 0.0 { v } else { 1.0 };
        CouplingChecker {
            z_cpu: ok(z_counts_per_mm),
            c_cpu: ok(c_counts_per_deg),
            prev: None,
            ticks: 0,
            open: None,
            samples: Vec::with_capacity(ticks),
            windows: Vec::new(),
            last_deviation: None,
        }
    }

    /// Setpoints rounded to counts (saturating far out of range).
    fn counts(&self, s: &CouplingSample) -> (i64, i64) {
        (
            (s.z_cmd * self.z_cpu).round() as i64,
            (s.c_cmd * self.c_cpu).round() as i64,
        )
    }

    /// Feeds one SYNC's drive counts (the bus side: `simdrive`); the window's line is 0.
    /// Returns the window this sample closed, if any.
    pub fn feed_counts(&mut self, s: CountSample) -> Option<TapWindow> {
        let (zc, cc) = (self.z_cpu, self.c_cpu);
        self.feed(CouplingSample {
            z_cmd: s.z_cmd as f64 / zc,
            z_act: s.z_act as f64 / zc,
            c_cmd: s.c_cmd as f64 / cc,
            c_act: s.c_act as f64 / cc,
            line: 0,
            actual_stale: false,
        })
    }

    /// Feeds one tick of positions, windows found by the checker (see the module doc).
    /// Returns the window this tick closed, if any.
    pub fn feed(&mut self, s: CouplingSample) -> Option<TapWindow> {
        let tick = self.ticks;
        self.ticks += 1;
        self.last_deviation = None;
        let p = self.prev.replace(s)?;
        let ((pz, pc), (sz, sc)) = (self.counts(&p), self.counts(&s));
        let (dz, dc) = (sz.saturating_sub(pz), sc.saturating_sub(pc));
        let mut closed = None;
        if let Some(o) = &self.open {
            let rev = |d: i64, dir: i64| d != 0 && dir != 0 && d.signum() != dir;
            if rev(dz, o.z_dir) || rev(dc, o.c_dir) {
                closed = self.close();
            }
        }
        if self.open.is_none() && dc == 0 {
            // Windows open when C moves; Z alone (a rapid) is not one.
            return closed;
        }
        let o = self.open.get_or_insert_with(|| {
            let mut o = Open::new(s.line, tick, p, None);
            o.first_dc = dc.abs();
            o
        });
        if o.z_dir == 0 {
            o.z_dir = dz.signum();
        }
        if o.c_dir == 0 {
            o.c_dir = dc.signum();
        }
        o.rest = if dz == 0 && dc == 0 { o.rest + 1 } else { 0 };
        if dc != 0 && dz == 0 {
            o.c_alone += 1;
            o.c_alone_max = o.c_alone_max.max(o.c_alone);
        } else {
            o.c_alone = 0;
        }
        if dc != 0 {
            o.since_c = 0;
            o.z_moves_since_c = 0;
            o.last_dc = dc.abs();
            o.max_dc = o.max_dc.max(dc.abs());
        } else {
            o.since_c += 1;
            if dz != 0 {
                o.z_moves_since_c += 1;
            }
        }
        let g = o.origin;
        let (rest, z_alone, since_c) = (o.rest, o.z_moves_since_c, o.since_c);
        if self.samples.len() < MAX_SAMPLES {
            self.samples.push(Rel {
                dz_cmd: s.z_cmd - g.z_cmd,
                dc_cmd: s.c_cmd - g.c_cmd,
                // Actuals are measured from the setpoints' origin: an actual that has not
                // caught up at the window's start is part of the coupling error.
                dz_act: s.z_act - g.z_cmd,
                dc_act: s.c_act - g.c_cmd,
                act_valid: !s.actual_stale,
                cmd_valid: true,
            });
        }
        if rest >= REST_TICKS || z_alone >= Z_ALONE_TICKS {
            // Leave out what came after C's last move (rest, or Z going on alone).
            let keep = self.samples.len().saturating_sub(since_c);
            self.samples.truncate(keep);
            return self.close().or(closed);
        }
        closed
    }

    /// Feeds one tick whose window the caller knows: `Some(mark)` while a tap runs (a new
    /// `mark.id` closes the window and opens the next), `None` outside taps. The window is
    /// measured from the sample before its first tick, every marked tick counts (also those
    /// where one axis stands still, as at a reversal), and deviations are taken from the
    /// commanded `mark.ratio` (the observed pitch is reported too). Do not mix with
    /// [`feed`](Self::feed) in one checker. Returns the window this tick closed, if any.
    pub fn feed_marked(&mut self, s: CouplingSample, mark: Option<TapMark>) -> Option<TapWindow> {
        let tick = self.ticks;
        self.ticks += 1;
        let prev = self.prev.replace(s);
        self.last_deviation = None;
        let Some(m) = mark else {
            return self.close();
        };
        let closed = match self.open {
            Some(o) if o.mark.map(|(id, _)| id) != Some(m.id) => self.close(),
            _ => None,
        };
        let before = prev.unwrap_or(s);
        let open = self
            .open
            .get_or_insert_with(|| Open::new(s.line, tick, before, Some((m.id, m.ratio))));
        if !m.setpoints_ignored {
            open.z_travel += (s.z_cmd - before.z_cmd).abs();
            open.c_travel += (s.c_cmd - before.c_cmd).abs();
        }
        let o = open.origin;
        let r = Rel {
            dz_cmd: s.z_cmd - o.z_cmd,
            dc_cmd: s.c_cmd - o.c_cmd,
            dz_act: s.z_act - o.z_cmd,
            dc_act: s.c_act - o.c_cmd,
            act_valid: !s.actual_stale,
            cmd_valid: !m.setpoints_ignored,
        };
        if self.samples.len() < MAX_SAMPLES {
            self.samples.push(r);
        }
        self.last_deviation = Some(TickDeviation {
            cmd_um: r
                .cmd_valid
                .then_some((r.dz_cmd - m.ratio * r.dc_cmd) * 1000.0),
            act_um: r
                .act_valid
                .then_some((r.dz_act - m.ratio * r.dc_act) * 1000.0),
        });
        closed
    }

    /// The last tick's deviations, if it was fed with [`feed_marked`](Self::feed_marked)
    /// inside a window (for a live plot).
    pub fn last_deviation(&self) -> Option<TickDeviation> {
        self.last_deviation
    }

    /// The window open now: its line and the tick it started at.
    pub fn open_window(&self) -> Option<(u32, u64)> {
        self.open.map(|o| (o.line, o.first_tick))
    }

    /// Replaces the previous sample (the next window's origin) without counting a tick: for a
    /// caller that switches the pair of axes it feeds between windows.
    pub fn rebase(&mut self, prev: CouplingSample) {
        if self.open.is_none() {
            self.prev = Some(prev);
        }
    }

    /// Closes the open window and forgets the last sample (the positions may jump, e.g. across
    /// an NMT reset): the next sample starts afresh. Returns the window closed, if any.
    pub fn restart(&mut self) -> Option<TapWindow> {
        self.prev = None;
        self.close()
    }

    /// Closes the open window (end of the stream); returns it.
    pub fn finish(&mut self) -> Option<TapWindow> {
        self.close()
    }

    /// Least-squares slope of ΔZ over ΔC (mm per degree) through the scored setpoints.
    fn fit(&self) -> f64 {
        let (mut n, mut sz, mut sc) = (0.0, 0.0, 0.0);
        for r in self.samples.iter().filter(|r| r.cmd_valid) {
            n += 1.0;
            sz += r.dz_cmd;
            sc += r.dc_cmd;
        }
        if n < 1.0 {
            return 0.0;
        }
        let (mz, mc) = (sz / n, sc / n);
        let (mut scz, mut scc) = (0.0, 0.0);
        for r in self.samples.iter().filter(|r| r.cmd_valid) {
            let (z, c) = (r.dz_cmd - mz, r.dc_cmd - mc);
            scz += c * z;
            scc += c * c;
        }
        if scc > 0.0 { scz / scc } else { 0.0 }
    }

    fn close(&mut self) -> Option<TapWindow> {
        let o = self.open.take()?;
        let n = self.samples.len();
        let w = match o.mark {
            Some((_, ratio)) => {
                let (mut cmd, mut act): (f64, f64) = (0.0, 0.0);
                for r in &self.samples {
                    if r.cmd_valid {
                        cmd = cmd.max((r.dz_cmd - ratio * r.dc_cmd).abs());
                    }
                    if r.act_valid {
                        act = act.max((r.dz_act - ratio * r.dc_act).abs());
                    }
                }
                TapWindow {
                    line: o.line,
                    first_tick: o.first_tick,
                    ticks: n as u64,
                    z_travel_mm: o.z_travel,
                    c_travel_deg: o.c_travel,
                    pitch_mm: ratio.abs() * 360.0,
                    // Travel ratio: in and out of a tap both count, and a bump of Z within
                    // one direction leaves it exact (the commanded line is judged anyway).
                    observed_pitch_mm: if o.c_travel > 0.0 {
                        o.z_travel / o.c_travel * 360.0
                    } else {
                        0.0
                    },
                    same_sense: ratio >= 0.0,
                    max_error_um_cmd: cmd * 1000.0,
                    max_error_um_act: act * 1000.0,
                    marked: true,
                    c_alone_ticks: 0,
                    spindle_running: false,
                }
            }
            None => {
                let k_obs = self.fit();
                let exc = |f: fn(&Rel) -> f64| {
                    self.samples
                        .iter()
                        .map(|r| f(r).abs())
                        .fold(0.0_f64, f64::max)
                };
                let (z_travel, c_travel) = (exc(|r| r.dz_cmd), exc(|r| r.dc_cmd));
                if z_travel * self.z_cpu < 0.5 || c_travel * self.c_cpu < 0.5 || n < 2 {
                    self.samples.clear();
                    return None;
                }
                let band = |act: bool| {
                    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                    for r in &self.samples {
                        let d = if act {
                            if !r.act_valid {
                                continue;
                            }
                            r.dz_act - k_obs * r.dc_act
                        } else {
                            r.dz_cmd - k_obs * r.dc_cmd
                        };
                        lo = lo.min(d);
                        hi = hi.max(d);
                    }
                    if hi >= lo { (hi - lo) / 2.0 } else { 0.0 }
                };
                let spindle_running = o.c_alone_max >= SPINDLE_RUNNING_TICKS
                    || o.first_dc as f64 >= SPINDLE_AT_SPEED * o.max_dc as f64
                    || o.last_dc as f64 >= SPINDLE_AT_SPEED * o.max_dc as f64;
                TapWindow {
                    line: o.line,
                    first_tick: o.first_tick,
                    ticks: n as u64,
                    z_travel_mm: z_travel,
                    c_travel_deg: c_travel,
                    pitch_mm: k_obs.abs() * 360.0,
                    observed_pitch_mm: k_obs.abs() * 360.0,
                    same_sense: k_obs >= 0.0,
                    max_error_um_cmd: band(false) * 1000.0,
                    max_error_um_act: band(true) * 1000.0,
                    marked: false,
                    c_alone_ticks: o.c_alone_max,
                    spindle_running,
                }
            }
        };
        self.samples.clear();
        self.windows.push(w);
        Some(w)
    }

    /// Every window closed so far.
    pub fn windows(&self) -> &[TapWindow] {
        &self.windows
    }

    /// The setpoint limit for a window: one Z count, or the Z equivalent of one C count at the
    /// window's pitch, whichever is larger (µm).
    pub fn limit_um(&self, w: &TapWindow) -> f64 {
        (1.0 / self.z_cpu).max(w.pitch_mm / 360.0 / self.c_cpu) * 1000.0
    }

    /// Windows merged per program line (a peck tap is several windows on one line): the
    /// pitch from the line's total travel, the worst errors of its windows.
    pub fn by_line(&self) -> Vec<TapWindow> {
        let mut out: Vec<TapWindow> = Vec::new();
        for w in &self.windows {
            match out.iter_mut().find(|o| o.line == w.line) {
                Some(o) => {
                    o.ticks += w.ticks;
                    o.z_travel_mm += w.z_travel_mm;
                    o.c_travel_deg += w.c_travel_deg;
                    o.observed_pitch_mm = if o.c_travel_deg > 0.0 {
                        o.z_travel_mm / o.c_travel_deg * 360.0
                    } else {
                        0.0
                    };
                    // Unmarked windows report the observed pitch; marked ones keep the
                    // commanded pitch of the line's first window.
                    if !(o.marked && w.marked) {
                        o.pitch_mm = o.observed_pitch_mm;
                        o.marked = false;
                    }
                    o.max_error_um_cmd = o.max_error_um_cmd.max(w.max_error_um_cmd);
                    o.max_error_um_act = o.max_error_um_act.max(w.max_error_um_act);
                    o.c_alone_ticks = o.c_alone_ticks.max(w.c_alone_ticks);
                    o.spindle_running |= w.spindle_running;
                }
                None => out.push(*w),
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sample in which both drives follow their commands exactly.
    fn followed(z: i64, c: i64) -> CountSample {
        CountSample {
            z_cmd: z,
            c_cmd: c,
            z_act: z,
            c_act: c,
        }
    }

    const Z_CPU: f64 = 10000.0;
    const C_CPU: f64 = 131072.0 / 360.0;

    /// A tap at `pitch` mm/rev, right hand (Z down with C forward), with an S-ish velocity
    /// profile, in and out, with a still tick at the bottom; C actual lags by `lag` ticks.
    fn tap(pitch: f64, depth: f64, lag: usize, line: u32) -> Vec<CouplingSample> {
        let n = 400;
        let mut z = vec![10.0];
        for i in 1..=n {
            let u = i as f64 / n as f64;
            z.push(10.0 - depth * (3.0 * u * u - 2.0 * u * u * u));
        }
        z.push(10.0 - depth); // still at the bottom
        for i in 1..=n {
            let u = i as f64 / n as f64;
            z.push(10.0 - depth + depth * (3.0 * u * u - 2.0 * u * u * u));
        }
        let c: Vec<f64> = z
            .iter()
            .map(|zz| 720.0 + (10.0 - zz) / pitch * 360.0)
            .collect();
        let mut out = vec![];
        for (i, zz) in z.iter().enumerate() {
            out.push(CouplingSample {
                z_cmd: *zz,
                z_act: *zz,
                c_cmd: c[i],
                c_act: c[i.saturating_sub(lag)],
                line,
                actual_stale: false,
            });
        }
        // Rest before and after.
        let first = out[0];
        let last = *out.last().unwrap();
        let mut all = vec![first; 5];
        all.extend(out);
        all.extend(vec![
            CouplingSample {
                c_act: last.c_cmd,
                ..last
            };
            5
        ]);
        all
    }

    #[test]
    fn perfect_tap_deviates_less_than_a_count() {
        let mut ch = CouplingChecker::new(Z_CPU, C_CPU);
        for s in tap(1.5, 20.0, 0, 42) {
            ch.feed(s);
        }
        ch.finish();
        let w = ch.windows();
        assert_eq!(w.len(), 2, "in and out: {w:?}");
        for w in w {
            assert_eq!(w.line, 42);
            assert!((w.pitch_mm - 1.5).abs() < 1e-9, "{}", w.pitch_mm);
            assert!(!w.same_sense);
            assert!(!w.spindle_running && !w.marked, "{w:?}");
            assert!(
                w.max_error_um_cmd < 0.1,
                "< 1 count of Z: {}",
                w.max_error_um_cmd
            );
            assert!(w.max_error_um_act < 0.1);
            assert!((w.z_travel_mm - 20.0).abs() < 1e-9);
        }
        let merged = ch.by_line();
        assert_eq!(merged.len(), 1);
        assert!((merged[0].pitch_mm - 1.5).abs() < 1e-9);
    }

    #[test]
    fn c_lag_is_reported_in_um_of_z() {
        let lag = 3;
        let samples = tap(1.5, 20.0, lag, 7);
        let mut ch = CouplingChecker::new(Z_CPU, C_CPU);
        for s in &samples {
            ch.feed(*s);
        }
        ch.finish();
        // Expected: the half-width of the band of deviations (the best offset chosen), here
        // half the largest C lag in degrees times pitch/360, in µm: the lag is 0 at both ends.
        let mut expected: f64 = 0.0;
        for s in &samples {
            expected = expected.max((s.c_cmd - s.c_act).abs() * 1.5 / 360.0 * 1000.0 / 2.0);
        }
        let worst = ch
            .windows()
            .iter()
            .map(|w| w.max_error_um_act)
            .fold(0.0, f64::max);
        assert!(expected > 50.0, "{expected}");
        assert!((worst - expected).abs() < 1e-6, "{worst} vs {expected}");
        // Setpoints are still perfect.
        assert!(ch.windows().iter().all(|w| w.max_error_um_cmd < 0.1));
    }

    #[test]
    fn stale_actuals_count_for_setpoints_only() {
        let mut samples = tap(1.5, 20.0, 0, 3);
        // A tick whose actual pair is not from one instant: garbage actuals, marked stale.
        samples[100].z_act += 5.0;
        samples[100].actual_stale = true;
        let mut ch = CouplingChecker::new(Z_CPU, C_CPU);
        for s in &samples {
            ch.feed(*s);
        }
        ch.finish();
        assert!(ch.windows().iter().all(|w| w.max_error_um_act < 0.1));
        // Unmarked, the same garbage is reported.
        samples[100].actual_stale = false;
        let mut ch = CouplingChecker::new(Z_CPU, C_CPU);
        for s in &samples {
            ch.feed(*s);
        }
        ch.finish();
        let worst = ch
            .windows()
            .iter()
            .map(|w| w.max_error_um_act)
            .fold(0.0, f64::max);
        // A 5 mm spike on one tick: a band 5000 µm wide, half-width 2500 µm.
        assert!((worst - 2500.0).abs() < 1e-6, "{worst}");
    }

    #[test]
    fn z_alone_or_c_alone_is_no_window() {
        let mut ch = CouplingChecker::new(Z_CPU, C_CPU);
        for i in 0..100 {
            ch.feed(CouplingSample {
                z_cmd: i as f64 * 0.01,
                z_act: i as f64 * 0.01,
                c_cmd: 0.0,
                c_act: 0.0,
                line: 1,
                actual_stale: false,
            });
        }
        for i in 0..100 {
            ch.feed(CouplingSample {
                z_cmd: 1.0,
                z_act: 1.0,
                c_cmd: i as f64 * 36.0,
                c_act: i as f64 * 36.0,
                line: 2,
                actual_stale: false,
            });
        }
        assert_eq!(ch.finish(), None);
        assert!(ch.windows().is_empty());
    }

    fn marked(id: u64, pitch: f64) -> Option<TapMark> {
        Some(TapMark {
            id,
            ratio: -pitch / 360.0,
            setpoints_ignored: false,
        })
    }

    #[test]
    fn marked_tap_is_one_window_through_the_reversal_from_the_commanded_pitch() {
        let samples = tap(1.5, 20.0, 0, 42);
        let mut ch = CouplingChecker::new(Z_CPU, C_CPU);
        for (i, s) in samples.iter().enumerate() {
            // The caller knows the tap: every tick but the rest before and after.
            let inside = (5..samples.len() - 5).contains(&i);
            let closed = ch.feed_marked(*s, if inside { marked(1, 1.5) } else { None });
            assert_eq!(closed.is_some(), i == samples.len() - 5, "tick {i}");
            if inside {
                let d = ch.last_deviation().expect("inside a window");
                assert!(d.cmd_um.unwrap().abs() < 1e-6 && d.act_um.unwrap().abs() < 1e-6);
            } else {
                assert_eq!(ch.last_deviation(), None);
            }
        }
        ch.finish();
        let w = ch.windows();
        // In, the still tick at the bottom, out: one window (unmarked it is two).
        assert_eq!(w.len(), 1, "{w:?}");
        assert_eq!((w[0].line, w[0].first_tick), (42, 5));
        assert_eq!(w[0].pitch_mm, 1.5);
        assert!((w[0].observed_pitch_mm - 1.5).abs() < 1e-9);
        assert!(w[0].max_error_um_cmd < 1e-6 && w[0].max_error_um_act < 1e-6);
    }

    #[test]
    fn marked_windows_measure_from_the_commanded_pitch_and_a_new_id_splits() {
        // Setpoints follow 1.5 mm but the program commanded 1.4: the deviation grows with
        // the depth (20 mm · (1 − 1.4/1.5) = 1333 µm at the bottom) and the observed pitch
        // says what happened.
        let samples = tap(1.5, 20.0, 0, 9);
        let mut ch = CouplingChecker::new(Z_CPU, C_CPU);
        let half = samples.len() / 2;
        let mut closed = vec![];
        for (i, s) in samples.iter().enumerate() {
            let id = if i < half { 1 } else { 2 };
            closed.extend(ch.feed_marked(*s, marked(id, 1.4)));
        }
        closed.extend(ch.finish());
        assert_eq!(closed.len(), 2, "{closed:?}");
        assert_eq!(ch.windows().len(), 2);
        let w = &closed[0];
        assert!((w.pitch_mm - 1.4).abs() < 1e-12);
        assert!((w.observed_pitch_mm - 1.5).abs() < 1e-9);
        let want = 20.0 * (1.0 - 1.4 / 1.5) * 1000.0;
        assert!((w.max_error_um_cmd - want).abs() < 1.0, "{w:?}");
        // The second window is measured from its own origin.
        assert!(closed[1].max_error_um_cmd < closed[0].max_error_um_cmd + 1.0);
        // by_line keeps the commanded pitch for marked windows.
        let merged = ch.by_line();
        assert_eq!(merged.len(), 1);
        assert!((merged[0].pitch_mm - 1.4).abs() < 1e-12);
    }

    #[test]
    fn a_helix_with_the_spindle_running_is_flagged_unmarked_and_no_window_marked() {
        // Z feeds down while C turns at speed (a helical move, the spindle merely running):
        // both move every tick, so the unmarked checker reports a window flagged as spindle
        // running (C at speed at its ends); the caller that knows no tap is running reports none.
        let samples: Vec<CouplingSample> = (0..200)
            .map(|i| CouplingSample {
                z_cmd: -0.001 * i as f64,
                z_act: -0.001 * i as f64,
                c_cmd: 36.0 * i as f64,
                c_act: 36.0 * i as f64,
                line: 3,
                actual_stale: false,
            })
            .collect();
        let mut plain = CouplingChecker::new(Z_CPU, C_CPU);
        let mut marked_ch = CouplingChecker::new(Z_CPU, C_CPU);
        for s in &samples {
            plain.feed(*s);
            marked_ch.feed_marked(*s, None);
        }
        plain.finish();
        marked_ch.finish();
        assert_eq!(plain.windows().len(), 1);
        assert!(plain.windows()[0].spindle_running, "{:?}", plain.windows());
        assert!(marked_ch.windows().is_empty());
    }

    #[test]
    fn ignored_setpoints_are_not_scored_but_actuals_are() {
        let mut samples = tap(1.5, 20.0, 0, 4);
        // The spindle drive stopped following: its setpoints run away, Z follows C's actual.
        for s in samples[300..320].iter_mut() {
            s.c_cmd += 90.0;
        }
        samples[310].z_act += 0.01;
        let run = |ignore: bool| {
            let mut ch = CouplingChecker::new(Z_CPU, C_CPU);
            for (i, s) in samples.iter().enumerate() {
                let m = TapMark {
                    id: 1,
                    ratio: -1.5 / 360.0,
                    setpoints_ignored: ignore && (300..320).contains(&i),
                };
                ch.feed_marked(*s, Some(m));
            }
            ch.finish().expect("one window")
        };
        let w = run(true);
        assert!(w.max_error_um_cmd < 1e-6, "{w:?}");
        assert!((w.max_error_um_act - 10.0).abs() < 1e-6, "{w:?}");
        let w = run(false);
        assert!(
            (w.max_error_um_cmd - 90.0 * 1.5 / 360.0 * 1000.0).abs() < 1e-6,
            "{w:?}"
        );
    }

    // Bus side: drive counts (formerly simdrive's own episode checker).

    /// A tap down and out at `pitch`, smooth ramps, rounded to counts like a master does.
    fn rounded_tap(pitch: f64, revs: f64, ticks: u64, glitch_at: Option<u64>) -> CouplingChecker {
        let mut ch = CouplingChecker::new(Z_CPU, C_CPU);
        let smooth =
            |u: f64| u - (2.0 * std::f64::consts::PI * u).sin() / (2.0 * std::f64::consts::PI);
        for _ in 0..5 {
            ch.feed_counts(CountSample::default());
        }
        for t in 0..=2 * ticks {
            let s = if t <= ticks {
                smooth(t as f64 / ticks as f64)
            } else {
                1.0 - smooth((t - ticks) as f64 / ticks as f64)
            };
            let c = 360.0 * revs * s;
            let mut z = -c / 360.0 * pitch;
            if glitch_at == Some(t) {
                z += 0.0003;
            }
            let (zc, cc) = ((z * Z_CPU).round() as i64, (c * C_CPU).round() as i64);
            ch.feed_counts(followed(zc, cc));
        }
        for _ in 0..5 {
            ch.feed_counts(CountSample::default());
        }
        ch.finish();
        ch
    }

    #[test]
    fn a_long_rest_ends_an_episode_a_short_one_does_not() {
        let mut ch = CouplingChecker::new(Z_CPU, C_CPU);
        let mut t = 0i64;
        let mut feed = |ch: &mut CouplingChecker, moving: bool| {
            if moving {
                t += 1;
            }
            ch.feed_counts(CountSample {
                z_cmd: -t * 15,
                c_cmd: t * 1311,
                z_act: 0,
                c_act: 0,
            })
        };
        feed(&mut ch, false);
        for _ in 0..50 {
            feed(&mut ch, true);
        }
        for _ in 0..(REST_TICKS - 1) {
            assert_eq!(feed(&mut ch, false), None);
        }
        for _ in 0..50 {
            feed(&mut ch, true);
        }
        for _ in 0..(REST_TICKS - 1) {
            assert_eq!(feed(&mut ch, false), None);
        }
        let e = feed(&mut ch, false).expect("closed after REST_TICKS quiet SYNCs");
        assert_eq!(e.z_travel_mm, 100.0 * 15.0 / Z_CPU);
        assert_eq!(ch.windows().len(), 1);
    }

    #[test]
    fn a_rounded_tap_is_two_episodes_within_one_count() {
        let ch = rounded_tap(1.5, 4.0, 1500, None);
        let e = ch.windows();
        assert_eq!(e.len(), 2, "{e:#?}");
        for x in e {
            assert!((x.pitch_mm - 1.5).abs() < 1e-5, "{x:?}");
            assert!((x.c_travel_deg - 1440.0).abs() < 1e-9, "{x:?}");
            assert!(!x.same_sense);
            assert!(x.max_error_um_cmd <= ch.limit_um(x), "{x:?}");
            assert!(!x.spindle_running);
            assert!(x.c_alone_ticks > 0, "C moves alone at the slow ends");
        }
    }

    #[test]
    fn a_three_count_glitch_fails_the_limit() {
        let ch = rounded_tap(1.5, 4.0, 1500, Some(700));
        let e = ch.windows()[0];
        assert!(e.max_error_um_cmd > ch.limit_um(&e), "{e:?}");
    }

    #[test]
    fn z_feeding_while_the_spindle_turns_is_flagged() {
        let mut ch = CouplingChecker::new(Z_CPU, C_CPU);
        for t in 0..600i64 {
            let z = -(t.clamp(200, 400) - 200) * 30;
            ch.feed_counts(followed(z, t * 3641));
        }
        ch.finish();
        let e = ch.windows();
        assert_eq!(e.len(), 1);
        assert!(e[0].spindle_running && e[0].c_alone_ticks >= 199, "{e:?}");
    }

    #[test]
    fn drilling_pecks_with_the_spindle_at_speed_are_all_flagged() {
        // C at a constant 3641 counts/SYNC; Z feeds down 300 SYNCs and rapids up 100, 3 times,
        // with no pause: every episode starts or ends with C at full speed.
        let mut ch = CouplingChecker::new(Z_CPU, C_CPU);
        let mut z = 0i64;
        let mut t = 0i64;
        for _ in 0..3 {
            for step in std::iter::repeat_n(-10, 300).chain(std::iter::repeat_n(30, 100)) {
                z += step;
                t += 1;
                ch.feed_counts(followed(z, t * 3641));
            }
        }
        ch.finish();
        let e = ch.windows();
        assert!(e.len() >= 5, "{e:#?}");
        assert!(
            e.iter().all(|x| x.spindle_running && x.c_alone_ticks == 0),
            "{e:#?}"
        );
    }

    #[test]
    fn restart_forgets_the_last_sample() {
        let mut ch = CouplingChecker::new(Z_CPU, C_CPU);
        ch.feed_counts(CountSample::default());
        assert_eq!(ch.restart(), None);
        // A jump after the restart is not motion.
        ch.feed_counts(CountSample {
            z_cmd: 500_000,
            c_cmd: 9_000_000,
            z_act: 0,
            c_act: 0,
        });
        ch.feed_counts(CountSample {
            z_cmd: 500_000,
            c_cmd: 9_000_000,
            z_act: 0,
            c_act: 0,
        });
        assert_eq!(ch.finish(), None);
        assert!(ch.windows().is_empty());
    }

    #[test]
    fn spindle_alone_or_z_alone_makes_no_episode() {
        let mut ch = CouplingChecker::new(Z_CPU, C_CPU);
        for t in 0..300i64 {
            ch.feed_counts(CountSample {
                c_cmd: t * 100,
                ..CountSample::default()
            });
        }
        for _ in 0..REST_TICKS {
            ch.feed_counts(CountSample {
                c_cmd: 29900,
                ..CountSample::default()
            });
        }
        for t in 0..300i64 {
            ch.feed_counts(CountSample {
                z_cmd: t * 100,
                c_cmd: 29900,
                ..CountSample::default()
            });
        }
        assert_eq!(ch.finish(), None);
        assert!(ch.windows().is_empty());
    }

    #[test]
    fn f64_and_count_input_find_the_same_windows_of_a_slow_tap() {
        // A slow tap (3 s each way): at its ends Z moves far less than a count per tick, yet
        // the f64 input (unrounded setpoints) gives the same two windows as the counts.
        let counts = rounded_tap(1.5, 4.0, 3000, None);
        let mut f = CouplingChecker::new(Z_CPU, C_CPU);
        let smooth =
            |u: f64| u - (2.0 * std::f64::consts::PI * u).sin() / (2.0 * std::f64::consts::PI);
        let rest = CouplingSample::default();
        for _ in 0..5 {
            f.feed(rest);
        }
        for t in 0..=6000u64 {
            let u = if t <= 3000 {
                smooth(t as f64 / 3000.0)
            } else {
                1.0 - smooth((t - 3000) as f64 / 3000.0)
            };
            let c = 1440.0 * u;
            let z = -c / 360.0 * 1.5;
            f.feed(CouplingSample {
                z_cmd: z,
                z_act: z,
                c_cmd: c,
                c_act: c,
                line: 5,
                actual_stale: false,
            });
        }
        for _ in 0..5 {
            f.feed(rest);
        }
        f.finish();
        let (a, b) = (counts.windows(), f.windows());
        assert_eq!((a.len(), b.len()), (2, 2), "{a:#?} {b:#?}");
        for (x, y) in a.iter().zip(b) {
            assert_eq!((x.first_tick, x.ticks), (y.first_tick, y.ticks));
            assert!((x.pitch_mm - y.pitch_mm).abs() < 1e-5, "{x:?} {y:?}");
            assert!(y.max_error_um_cmd < 1e-6 && x.max_error_um_cmd <= counts.limit_um(x));
            assert_eq!(y.line, 5);
        }
    }
}
