//! The rigid-tapping coupling checker: fed once per tick with Z and C (setpoints and actual
//! positions) and the program line, it finds each window in which both axes move and reports
//! the pitch observed and the worst deviation from it, in µm of Z, for setpoints and for
//! actual positions. Used by `cnc402 run` and by the `simdrive` process (which sees only what
//! arrives on the bus, so it reports every window of coupled Z+C motion, taps or not). A
//! caller that knows where the taps are (`cnc402 run`: the planned coupling of each move)
//! delimits the windows itself with [`CouplingChecker::feed_marked`].

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

/// One window of coupled Z and C motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TapWindow {
    /// Program line at the window's first tick.
    pub line: u32,
    /// Tick number (count of samples fed before it) of the window's first moving tick.
    pub first_tick: u64,
    /// Ticks in the window.
    pub ticks: u64,
    /// Z path length (sum of |ΔZ| of the setpoints), mm.
    pub z_travel_mm: f64,
    /// C path length (sum of |ΔC| of the setpoints), degrees.
    pub c_travel_deg: f64,
    /// The pitch deviations are measured from (mm/rev, always positive): the observed one,
    /// or for a window delimited with [`CouplingChecker::feed_marked`] the commanded one.
    pub pitch_mm: f64,
    /// Pitch observed: Z travel per C revolution of the setpoints (mm/rev), always positive.
    pub observed_pitch_mm: f64,
    /// Whether Z and C move in the same sense (Z+ with C+): the sign of the coupling.
    pub same_sense: bool,
    /// Worst |ΔZ − ΔC·pitch/360·sense| over the window, setpoints, µm of Z.
    pub max_error_um_cmd: f64,
    /// The same for actual positions (against the setpoints' pitch), µm of Z.
    pub max_error_um_act: f64,
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
    z_travel: f64,
    c_travel: f64,
    dot: f64,
    /// Caller-delimited window: its id and commanded ratio.
    mark: Option<(u64, f64)>,
}

/// Finds tapping windows in a stream of samples (see the module doc).
///
/// The pitch is only known when a window ends, so the window's samples are kept (in a
/// buffer reused from window to window: it allocates only when a window is longer than every
/// earlier one; [`with_capacity`](Self::with_capacity) avoids even that).
#[derive(Clone, Debug)]
pub struct CouplingChecker {
    z_eps: f64,
    c_eps: f64,
    prev: Option<CouplingSample>,
    ticks: u64,
    open: Option<Open>,
    samples: Vec<Rel>,
    windows: Vec<TapWindow>,
    last_deviation: Option<TickDeviation>,
}

impl CouplingChecker {
    /// A checker for Z with `z_counts_per_mm` and C with `c_counts_per_deg`: an axis "moves"
    /// in a tick when its setpoint changes by more than half a count.
    pub fn new(z_counts_per_mm: f64, c_counts_per_deg: f64) -> CouplingChecker {
        CouplingChecker::with_capacity(z_counts_per_mm, c_counts_per_deg, 0)
    }

    /// As [`new`](Self::new), with room for windows of `ticks` ticks without allocating.
    pub fn with_capacity(
        z_counts_per_mm: f64,
        c_counts_per_deg: f64,
        ticks: usize,
    ) -> CouplingChecker {
        let eps = |cpu: f64| {
            if cpu.is_finite() && cpu > 0.0 {
                0.5 / cpu
            } else {
                1e-9
            }
        };
        CouplingChecker {
            z_eps: eps(z_counts_per_mm),
            c_eps: eps(c_counts_per_deg),
            prev: None,
            ticks: 0,
            open: None,
            samples: Vec::with_capacity(ticks),
            windows: Vec::new(),
            last_deviation: None,
        }
    }

    /// Feeds one tick. Returns the window that this tick closed, if any.
    pub fn feed(&mut self, s: CouplingSample) -> Option<TapWindow> {
        let tick = self.ticks;
        self.ticks += 1;
        let prev = self.prev.replace(s)?;
        let dz = s.z_cmd - prev.z_cmd;
        let dc = s.c_cmd - prev.c_cmd;
        let both = dz.abs() > self.z_eps && dc.abs() > self.c_eps;
        if !both {
            return self.close();
        }
        let open = self.open.get_or_insert(Open {
            line: s.line,
            first_tick: tick,
            origin: prev,
            z_travel: 0.0,
            c_travel: 0.0,
            dot: 0.0,
            mark: None,
        });
        open.z_travel += dz.abs();
        open.c_travel += dc.abs();
        open.dot += dz * dc;
        let o = open.origin;
        self.samples.push(Rel {
            dz_cmd: s.z_cmd - o.z_cmd,
            dc_cmd: s.c_cmd - o.c_cmd,
            // Actuals are measured from the setpoints' origin: an actual that has not caught up
            // at the window's start is part of the coupling error, not a new zero.
            dz_act: s.z_act - o.z_cmd,
            dc_act: s.c_act - o.c_cmd,
            act_valid: !s.actual_stale,
            cmd_valid: true,
        });
        None
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
        let open = self.open.get_or_insert(Open {
            line: s.line,
            first_tick: tick,
            origin: before,
            z_travel: 0.0,
            c_travel: 0.0,
            dot: 0.0,
            mark: Some((m.id, m.ratio)),
        });
        if !m.setpoints_ignored {
            let (dz, dc) = (s.z_cmd - before.z_cmd, s.c_cmd - before.c_cmd);
            open.z_travel += dz.abs();
            open.c_travel += dc.abs();
            open.dot += dz * dc;
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
        self.samples.push(r);
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

    /// Closes the open window (end of the stream); returns it.
    pub fn finish(&mut self) -> Option<TapWindow> {
        self.close()
    }

    fn close(&mut self) -> Option<TapWindow> {
        let open = self.open.take()?;
        let observed_same_sense = open.dot >= 0.0;
        // Z per degree of C, signed.
        let observed = if open.c_travel > 0.0 {
            open.z_travel / open.c_travel * if observed_same_sense { 1.0 } else { -1.0 }
        } else {
            0.0
        };
        let (k, same_sense) = match open.mark {
            Some((_, ratio)) => (ratio, ratio >= 0.0),
            None => (observed, observed_same_sense),
        };
        let mut cmd: f64 = 0.0;
        let mut act: f64 = 0.0;
        for r in &self.samples {
            if r.cmd_valid {
                cmd = cmd.max((r.dz_cmd - k * r.dc_cmd).abs());
            }
            if r.act_valid {
                act = act.max((r.dz_act - k * r.dc_act).abs());
            }
        }
        let w = TapWindow {
            line: open.line,
            first_tick: open.first_tick,
            ticks: self.samples.len() as u64,
            z_travel_mm: open.z_travel,
            c_travel_deg: open.c_travel,
            pitch_mm: k.abs() * 360.0,
            observed_pitch_mm: observed.abs() * 360.0,
            same_sense,
            max_error_um_cmd: cmd * 1000.0,
            max_error_um_act: act * 1000.0,
        };
        self.samples.clear();
        self.windows.push(w);
        Some(w)
    }

    /// Every window closed so far.
    pub fn windows(&self) -> &[TapWindow] {
        &self.windows
    }

    /// Windows merged per program line (a peck tap is several windows on one line): the
    /// pitch from the line's total travel, the worst errors of its windows.
    pub fn by_line(&self) -> Vec<TapWindow> {
        let mut out: Vec<TapWindow> = Vec::new();
        for w in &self.windows {
            match out.iter_mut().find(|o| o.line == w.line) {
                Some(o) => {
                    // Unmarked windows report the observed pitch (bit-identical to it);
                    // marked ones keep the commanded pitch of the line's first window.
                    let unmarked =
                        o.pitch_mm == o.observed_pitch_mm && w.pitch_mm == w.observed_pitch_mm;
                    o.ticks += w.ticks;
                    o.z_travel_mm += w.z_travel_mm;
                    o.c_travel_deg += w.c_travel_deg;
                    o.observed_pitch_mm = if o.c_travel_deg > 0.0 {
                        o.z_travel_mm / o.c_travel_deg * 360.0
                    } else {
                        0.0
                    };
                    if unmarked {
                        o.pitch_mm = o.observed_pitch_mm;
                    }
                    o.max_error_um_cmd = o.max_error_um_cmd.max(w.max_error_um_cmd);
                    o.max_error_um_act = o.max_error_um_act.max(w.max_error_um_act);
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
        // Expected: the largest C lag in degrees, times pitch/360, in µm, over the moving ticks.
        let mut expected: f64 = 0.0;
        for s in &samples {
            expected = expected.max((s.c_cmd - s.c_act).abs() * 1.5 / 360.0 * 1000.0);
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
        assert!((worst - 5000.0).abs() < 1e-6, "{worst}");
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
    fn a_helix_with_the_spindle_running_is_no_tap_when_unmarked() {
        // Z feeds down while C turns at speed (a helical move, the spindle merely running):
        // both move every tick, so the unmarked checker reports a window; the caller that
        // knows no tap is running reports none.
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
}
