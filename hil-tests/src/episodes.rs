//! Z+C coupling from quantized bus positions (drive counts), for `simdrive`. An *episode* opens
//! when C moves and lasts while Z and C move each in one direction; it ends when both have
//! rested for [`REST_TICKS`] SYNCs, either reverses, or Z has moved [`Z_ALONE_TICKS`] SYNCs
//! without C (a rapid after the tap; those SYNCs are left out). Per episode: the pitch of the
//! least-squares line ΔZ = k·ΔC and the half-width of the band of deviations from it (the best
//! offset chosen), for the setpoints and the actual positions, in µm of Z.
//!
//! Not `cnc402_drives::coupling::CouplingChecker`: that one opens a window only while BOTH axes
//! change by more than half a count per tick, which holds for the interpolator's unrounded
//! setpoints but not for counts off the bus: at the slow ends of a tap Z moves less than a
//! count per SYNC (1 C count is 0.11 Z counts at 1.5 mm pitch), so one tap fell apart into
//! ~20 windows with meaningless pitches. Here a tick where only one axis moves continues the
//! episode, and the fit tolerates the quantized start and end points (±½ count each).

/// SYNCs without motion that end an episode (near standstill a setpoint changes by a count
/// only every few SYNCs: a single quiet SYNC must not split a tap).
pub const REST_TICKS: u32 = 100;

/// An episode with C turning alone for this many consecutive SYNCs is a move with the spindle
/// running (drilling), not a tap: in a rigid tap C turns alone only while Z's step is below one
/// count (a few SYNCs at the ends of a ramp).
pub const SPINDLE_RUNNING_TICKS: u32 = 100;

/// An episode whose first or last C step is at least this fraction of its largest is a move
/// with the spindle turning at speed (a drill feeding in or retracting): a tap starts from and
/// ends at standstill or a reversal, where C's step is near zero.
pub const SPINDLE_AT_SPEED: f64 = 0.5;

/// Positions at one SYNC, in drive counts (unwrapped).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CountSample {
    pub z_cmd: i64,
    pub c_cmd: i64,
    pub z_act: i64,
    pub c_act: i64,
}

/// One episode of Z and C motion (both moved).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Episode {
    /// Sample number of the episode's first moving SYNC.
    pub first_tick: u64,
    /// SYNCs in the episode.
    pub ticks: u64,
    pub z_travel_mm: f64,
    pub c_travel_deg: f64,
    /// Z travel per C revolution, from the least-squares slope.
    pub pitch_mm: f64,
    /// Z+ with C+.
    pub same_sense: bool,
    /// Half-width of the band of ΔZ − k·ΔC over the episode, setpoints, µm of Z: the worst
    /// deviation from the fitted line with the best offset.
    pub max_error_um_cmd: f64,
    /// The same for the actual positions (with the setpoints' slope), µm.
    pub max_error_um_act: f64,
    /// Longest run of SYNCs with C turning and Z not.
    pub c_alone_ticks: u32,
    /// `c_alone_ticks >= SPINDLE_RUNNING_TICKS`, or C at speed (≥ [`SPINDLE_AT_SPEED`] of its
    /// largest step) at the first or last SYNC it moved: not a tap.
    pub spindle_running: bool,
}

#[derive(Clone, Copy, Debug)]
struct Open {
    first_tick: u64,
    origin: CountSample,
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

/// Finds episodes in a stream of [`CountSample`]s (see the module doc).
#[derive(Clone, Debug)]
pub struct EpisodeChecker {
    z_cpu: f64,
    c_cpu: f64,
    tick: u64,
    prev: Option<CountSample>,
    open: Option<Open>,
    /// (Δz_cmd, Δc_cmd, Δz_act, Δc_act) from the origin, counts.
    samples: Vec<[i64; 4]>,
    episodes: Vec<Episode>,
}

/// Samples kept per episode; a longer episode (a spindle turning for hours) keeps its figures
/// from the first ones.
const MAX_SAMPLES: usize = 1 << 21;

/// Z moving this many SYNCs while C stands still ends an episode (a rapid or feed after the
/// tap, in the same direction).
pub const Z_ALONE_TICKS: u32 = 20;

impl EpisodeChecker {
    /// A checker for Z with `z_counts_per_mm` and C with `c_counts_per_deg` (non-positive or
    /// non-finite values count as 1).
    pub fn new(z_counts_per_mm: f64, c_counts_per_deg: f64) -> EpisodeChecker {
        let ok = |v: f64| if v.is_finite() && v > 0.0 { v } else { 1.0 };
        EpisodeChecker {
            z_cpu: ok(z_counts_per_mm),
            c_cpu: ok(c_counts_per_deg),
            tick: 0,
            prev: None,
            open: None,
            samples: Vec::with_capacity(1 << 14),
            episodes: Vec::new(),
        }
    }

    /// Feeds one SYNC's positions; returns the episode this sample closed, if any.
    pub fn feed(&mut self, s: CountSample) -> Option<Episode> {
        let tick = self.tick;
        self.tick += 1;
        let p = self.prev.replace(s)?;
        let dz = s.z_cmd - p.z_cmd;
        let dc = s.c_cmd - p.c_cmd;
        let mut closed = None;
        if let Some(o) = &self.open {
            let rev = |d: i64, dir: i64| d != 0 && dir != 0 && d.signum() != dir;
            if rev(dz, o.z_dir) || rev(dc, o.c_dir) {
                closed = self.close();
            }
        }
        if self.open.is_none() && dc == 0 {
            // Episodes open when C moves; Z alone (a rapid) is not one.
            return closed;
        }
        let o = self.open.get_or_insert(Open {
            first_tick: tick,
            origin: p,
            z_dir: 0,
            c_dir: 0,
            c_alone: 0,
            c_alone_max: 0,
            rest: 0,
            since_c: 0,
            z_moves_since_c: 0,
            first_dc: dc.abs(),
            last_dc: 0,
            max_dc: 0,
        });
        if o.z_dir == 0 {
            o.z_dir = dz.signum();
        }
        if o.c_dir == 0 {
            o.c_dir = dc.signum();
        }
        if dz == 0 && dc == 0 {
            o.rest += 1;
        } else {
            o.rest = 0;
        }
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
            self.samples.push([
                s.z_cmd - g.z_cmd,
                s.c_cmd - g.c_cmd,
                s.z_act - g.z_cmd,
                s.c_act - g.c_cmd,
            ]);
        }
        if rest >= REST_TICKS || z_alone >= Z_ALONE_TICKS {
            // Leave out what came after C's last move (rest, or Z going on alone).
            let keep = self.samples.len().saturating_sub(since_c);
            self.samples.truncate(keep);
            return self.close().or(closed);
        }
        closed
    }

    /// Closes the open episode and forgets the last sample (the positions may jump, e.g. after
    /// an NMT reset): the next sample starts afresh.
    pub fn restart(&mut self) -> Option<Episode> {
        self.prev = None;
        self.close()
    }

    /// Closes the open episode (end of the stream); returns it.
    pub fn finish(&mut self) -> Option<Episode> {
        self.close()
    }

    fn close(&mut self) -> Option<Episode> {
        let o = self.open.take()?;
        let n = self.samples.len();
        let (zc, cc) = (self.z_cpu, self.c_cpu);
        let z_travel = self.samples.iter().map(|r| r[0].abs()).max().unwrap_or(0);
        let c_travel = self.samples.iter().map(|r| r[1].abs()).max().unwrap_or(0);
        if z_travel == 0 || c_travel == 0 || n < 2 {
            self.samples.clear();
            return None;
        }
        // Least-squares slope of ΔZ (mm) over ΔC (degrees) through the setpoint samples.
        let nf = n as f64;
        let (mut sz, mut sc) = (0.0, 0.0);
        for r in &self.samples {
            sz += r[0] as f64 / zc;
            sc += r[1] as f64 / cc;
        }
        let (mz, mc) = (sz / nf, sc / nf);
        let (mut scz, mut scc) = (0.0, 0.0);
        for r in &self.samples {
            let (z, c) = (r[0] as f64 / zc - mz, r[1] as f64 / cc - mc);
            scz += c * z;
            scc += c * c;
        }
        let k = if scc > 0.0 { scz / scc } else { 0.0 };
        let band = |zi: usize, ci: usize| {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for r in &self.samples {
                let d = r[zi] as f64 / zc - k * (r[ci] as f64 / cc);
                lo = lo.min(d);
                hi = hi.max(d);
            }
            (hi - lo) / 2.0
        };
        let (cmd, act) = (band(0, 1), band(2, 3));
        self.samples.clear();
        let spindle_running = o.c_alone_max >= SPINDLE_RUNNING_TICKS
            || o.first_dc as f64 >= SPINDLE_AT_SPEED * o.max_dc as f64
            || o.last_dc as f64 >= SPINDLE_AT_SPEED * o.max_dc as f64;
        let e = Episode {
            first_tick: o.first_tick,
            ticks: n as u64,
            z_travel_mm: z_travel as f64 / zc,
            c_travel_deg: c_travel as f64 / cc,
            pitch_mm: k.abs() * 360.0,
            same_sense: k >= 0.0,
            max_error_um_cmd: cmd * 1000.0,
            max_error_um_act: act * 1000.0,
            c_alone_ticks: o.c_alone_max,
            spindle_running,
        };
        self.episodes.push(e);
        Some(e)
    }

    /// Episodes closed so far.
    pub fn episodes(&self) -> &[Episode] {
        &self.episodes
    }

    /// The setpoint limit for an episode: one Z count, or the Z equivalent of one C count,
    /// whichever is larger (µm).
    pub fn limit_um(&self, e: &Episode) -> f64 {
        (1.0 / self.z_cpu).max(e.pitch_mm / 360.0 / self.c_cpu) * 1000.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const Z_CPU: f64 = 10000.0;
    const C_CPU: f64 = 131072.0 / 360.0;

    /// A tap down and out at `pitch`, smooth ramps, rounded to counts like a master does.
    fn tap(pitch: f64, revs: f64, ticks: u64, glitch_at: Option<u64>) -> EpisodeChecker {
        let mut ch = EpisodeChecker::new(Z_CPU, C_CPU);
        let smooth =
            |u: f64| u - (2.0 * std::f64::consts::PI * u).sin() / (2.0 * std::f64::consts::PI);
        for _ in 0..5 {
            ch.feed(CountSample::default());
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
            ch.feed(CountSample {
                z_cmd: zc,
                c_cmd: cc,
                z_act: zc,
                c_act: cc,
            });
        }
        for _ in 0..5 {
            ch.feed(CountSample::default());
        }
        ch.finish();
        ch
    }

    #[test]
    fn a_long_rest_ends_an_episode_a_short_one_does_not() {
        let mut ch = EpisodeChecker::new(Z_CPU, C_CPU);
        let mut t = 0i64;
        let mut feed = |ch: &mut EpisodeChecker, moving: bool| {
            if moving {
                t += 1;
            }
            ch.feed(CountSample {
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
        assert_eq!(ch.episodes().len(), 1);
    }

    #[test]
    fn a_rounded_tap_is_two_episodes_within_one_count() {
        let ch = tap(1.5, 4.0, 1500, None);
        let e = ch.episodes();
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
        let ch = tap(1.5, 4.0, 1500, Some(700));
        let e = ch.episodes()[0];
        assert!(e.max_error_um_cmd > ch.limit_um(&e), "{e:?}");
    }

    #[test]
    fn z_feeding_while_the_spindle_turns_is_flagged() {
        let mut ch = EpisodeChecker::new(Z_CPU, C_CPU);
        for t in 0..600i64 {
            let z = -(t.clamp(200, 400) - 200) * 30;
            ch.feed(CountSample {
                z_cmd: z,
                c_cmd: t * 3641,
                z_act: z,
                c_act: t * 3641,
            });
        }
        ch.finish();
        let e = ch.episodes();
        assert_eq!(e.len(), 1);
        assert!(e[0].spindle_running && e[0].c_alone_ticks >= 199, "{e:?}");
    }

    #[test]
    fn drilling_pecks_with_the_spindle_at_speed_are_all_flagged() {
        // C at a constant 3641 counts/SYNC; Z feeds down 300 SYNCs and rapids up 100, 3 times,
        // with no pause: every episode starts or ends with C at full speed.
        let mut ch = EpisodeChecker::new(Z_CPU, C_CPU);
        let mut z = 0i64;
        let mut t = 0i64;
        for _ in 0..3 {
            for step in std::iter::repeat_n(-10, 300).chain(std::iter::repeat_n(30, 100)) {
                z += step;
                t += 1;
                ch.feed(CountSample {
                    z_cmd: z,
                    c_cmd: t * 3641,
                    z_act: z,
                    c_act: t * 3641,
                });
            }
        }
        ch.finish();
        let e = ch.episodes();
        assert!(e.len() >= 5, "{e:#?}");
        assert!(
            e.iter().all(|x| x.spindle_running && x.c_alone_ticks == 0),
            "{e:#?}"
        );
    }

    #[test]
    fn restart_forgets_the_last_sample() {
        let mut ch = EpisodeChecker::new(Z_CPU, C_CPU);
        ch.feed(CountSample::default());
        assert_eq!(ch.restart(), None);
        // A jump after the restart is not motion.
        ch.feed(CountSample {
            z_cmd: 500_000,
            c_cmd: 9_000_000,
            z_act: 0,
            c_act: 0,
        });
        ch.feed(CountSample {
            z_cmd: 500_000,
            c_cmd: 9_000_000,
            z_act: 0,
            c_act: 0,
        });
        assert_eq!(ch.finish(), None);
        assert!(ch.episodes().is_empty());
    }

    #[test]
    fn spindle_alone_or_z_alone_makes_no_episode() {
        let mut ch = EpisodeChecker::new(Z_CPU, C_CPU);
        for t in 0..300i64 {
            ch.feed(CountSample {
                c_cmd: t * 100,
                ..CountSample::default()
            });
        }
        for _ in 0..REST_TICKS {
            ch.feed(CountSample {
                c_cmd: 29900,
                ..CountSample::default()
            });
        }
        for t in 0..300i64 {
            ch.feed(CountSample {
                z_cmd: t * 100,
                c_cmd: 29900,
                ..CountSample::default()
            });
        }
        assert_eq!(ch.finish(), None);
        assert!(ch.episodes().is_empty());
    }
}
