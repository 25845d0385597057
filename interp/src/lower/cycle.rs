//! Canned-cycle expansion (G73 G74 G76 G81–G89): one [`CannedCycle`] into the machine
//! sequence of rapid, feed, tap, dwell, spindle and orientation segments, Fanuc's order.
//! A pure function of the operation: the interpreter runs it to check the moves against the
//! soft limits (each step names the words to blame), lowering runs it to make the segments.
//!
//! Conventions: G76/G87 stop the spindle and orient it to the physical angle
//! `interp.spindle_orient_angle`, then shift by Q along +first plane axis (G17 +X, G18 +Z,
//! G19 +Y). G87 always returns to the initial level.

use cnc402_motion::segment::{AxisPos, SegmentKind, SpindleDir, StopKind};

use crate::canon::{CannedCycle, CanonState};

/// Lengths closer than this are the same point.
const EPS: f64 = 1e-9;

/// Most pecks one hole may take (G73, G83, and G74/G84 with Q): 10,000 pecks drill a
/// 100 mm hole at 0.01 mm a peck, far finer than any real peck depth.
pub const MAX_PECKS: f64 = 10_000.0;
/// Most moves one canned-cycle block may expand to (holes × moves a hole takes): the
/// expansion is held in memory by lowering, and 100,000 moves are a few MB; 9,999 repeats
/// (the most K/L allows) of a G81 hole are 30,000.
pub const MAX_CYCLE_MOVES: f64 = 100_000.0;

/// How many pecks a hole `depth` deep takes at `q` a peck (as [`Expander`] makes them; an
/// `f64`, so that an absurd count is a number to report, never an overflow).
pub fn peck_count(q: f64, depth: f64) -> f64 {
    if depth - q < 1e-6 {
        1.0
    } else {
        ((depth - 1e-6) / q).ceil().max(1.0)
    }
}

/// At most how many moves one hole of `pecks` pecks takes (positioning, up to three moves a
/// peck, and the spindle, dwell, orientation and shift steps around them).
pub fn moves_per_hole(pecks: f64) -> f64 {
    3.0 * pecks + 12.0
}

/// One step of an expanded cycle, in machine coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct CycleStep {
    pub kind: SegmentKind,
    /// For a move: the program letters to blame, in order, if its end is out of limits
    /// (events carry [`NO_HINT`]; only moves are checked).
    pub hint: [char; 2],
}

/// The hint of a step that is no move.
pub const NO_HINT: [char; 2] = ['\0'; 2];

/// A rigid tap's coupling for the block: C = c0 + |d − R| · k, and the signed pitch the tap
/// segments carry (Δd = pitch · ΔC / 360; negative for G84 into a hole below R).
#[derive(Clone, Copy)]
struct TapCoupling {
    spindle: usize,
    c0: f64,
    k: f64,
    pitch: f64,
}

/// The hole being drilled: machine levels along the drilling axis.
struct Hole {
    r_level: f64,
    bottom: f64,
    ret: f64,
}

/// Expands `cc` (recorded under `state`) into machine-coordinate steps.
pub fn expand(cc: &CannedCycle, state: &CanonState) -> Vec<CycleStep> {
    let o = state.offset.0[cc.axes[2]];
    let levels = [cc.r_level + o, cc.bottom + o, cc.return_level + o];
    let mut ex = Expander::at_machine(cc, state, state.to_machine(&cc.start), levels);
    ex.begin();
    let [ia, ib, _] = cc.axes;
    for &[a, b] in &cc.holes {
        ex.hole(a + state.offset.0[ia], b + state.offset.0[ib]);
    }
    ex.finish();
    ex.out
}

/// A cycle being expanded hole by hole (the interpreter computes each hole's position from
/// where the previous one left the tool, as G91 repeats need).
pub(crate) struct Expander<'a> {
    cc: &'a CannedCycle,
    /// Letters of the plane's first, second and drilling axis.
    letters: (char, char, char),
    pos: AxisPos,
    /// Machine levels of the block's holes.
    hole: Hole,
    tap: Option<TapCoupling>,
    out: Vec<CycleStep>,
    /// Holes positioned so far in this block.
    holes: u32,
    /// LinuxCNC: the machine level it takes the tool to be at before the first hole.
    lc_level: f64,
}

impl<'a> Expander<'a> {
    /// Starts at machine position `start` with the machine drilling-axis `levels` (R,
    /// bottom, return); `cc.start`, `cc.holes` and the levels in `cc` are not read (the
    /// interpreter has the machine values exactly; [`expand`] derives them from `cc`).
    pub(crate) fn at_machine(
        cc: &'a CannedCycle,
        state: &CanonState,
        start: AxisPos,
        levels: [f64; 3],
    ) -> Self {
        let tap = cc.tap.map(|t| {
            let hand = if t.dir == SpindleDir::Ccw { -1.0 } else { 1.0 };
            TapCoupling {
                spindle: t.spindle,
                c0: start.0[t.spindle],
                k: hand * 360.0 / t.pitch,
                // Exact from the programmed pitch (Δd / ΔC = sign(bottom − R) / k).
                pitch: (levels[1] - levels[0]).signum() * hand * t.pitch,
            }
        });
        Expander {
            cc,
            letters: state.plane.letters(),
            pos: start,
            hole: Hole {
                r_level: levels[0],
                bottom: levels[1],
                ret: levels[2],
            },
            tap,
            out: Vec::new(),
            holes: 0,
            lc_level: cc
                .plan
                .linuxcnc
                .map_or(0.0, |l| l.level + state.offset.0[cc.axes[2]]),
        }
    }

    /// Before the first hole: a tap stops a turning spindle (it turns as a position axis).
    pub(crate) fn begin(&mut self) {
        if self.tap.is_some() && self.cc.plan.spindle_turning {
            self.spindle_stop();
        }
        // LinuxCNC's preliminary motion: below R, the tool first goes straight up to R.
        let r = self.hole.r_level;
        if self.cc.plan.linuxcnc.is_some_and(|l| l.first) && self.above(r, self.lc_level) {
            self.rapid_d(r);
            self.lc_level = r;
        }
    }

    /// One hole at machine position (`a`, `b`) of the plane's first and second axis:
    /// positioning at the current level, then the cycle's sequence.
    pub(crate) fn hole(&mut self, a: f64, b: f64) {
        let [ia, ib, _] = self.cc.axes;
        let mut p = self.pos;
        p[ia] = a;
        p[ib] = b;
        let (la, lb, _) = self.letters;
        // LinuxCNC positions each hole with one rapid to its XY at the higher of where it takes
        // the tool to be and the return level (after a G88 hole: from the bottom).
        if self.cc.plan.linuxcnc.is_some() && self.cc.code != 87 {
            let ret = self.hole.ret;
            let from = if self.holes == 0 { self.lc_level } else { ret };
            p[self.cc.axes[2]] = if self.above(from, ret) { from } else { ret };
        }
        self.holes += 1;
        self.rapid_to(p, [la, lb]);
        if self.cc.code == 87 {
            self.back_boring();
        } else {
            let r = self.hole.r_level;
            self.rapid_d(r);
            self.hole_body();
        }
    }

    /// After the last hole: a tap turns the spindle on again as the block found it.
    pub(crate) fn finish(&mut self) {
        if self.tap.is_some() {
            self.restore();
        }
    }

    /// Level `a` is farther out of the hole than level `b`.
    fn above(&self, a: f64, b: f64) -> bool {
        (a - b) * (self.hole.r_level - self.hole.bottom) > 0.0
    }

    /// Where the steps so far leave the tool (machine coordinates).
    pub(crate) fn position(&self) -> AxisPos {
        self.pos
    }

    /// The steps made since the last call.
    pub(crate) fn take_steps(&mut self) -> Vec<CycleStep> {
        std::mem::take(&mut self.out)
    }

    fn push(&mut self, kind: SegmentKind, hint: [char; 2]) {
        self.out.push(CycleStep { kind, hint });
    }

    fn spindle_stop(&mut self) {
        self.push(
            SegmentKind::Spindle {
                rpm: 0.0,
                dir: SpindleDir::Stop,
                spindle: self.cc.plan.spindle,
            },
            NO_HINT,
        );
    }

    /// Turns the spindle on again as the block found it.
    fn restore(&mut self) {
        let plan = self.cc.plan;
        if plan.spindle_turning {
            self.push(
                SegmentKind::Spindle {
                    rpm: plan.speed,
                    dir: plan.spindle_dir,
                    spindle: plan.spindle,
                },
                NO_HINT,
            );
        }
    }

    fn rapid_to(&mut self, p: AxisPos, hint: [char; 2]) {
        if p.0
            .iter()
            .zip(self.pos.0.iter())
            .any(|(a, b)| (a - b).abs() > EPS)
        {
            self.push(SegmentKind::Rapid { end: p }, hint);
            self.pos = p;
        }
    }

    /// Words to blame for a drilling-axis target out of limits: R for the R level.
    fn hint(&self, level: f64) -> [char; 2] {
        let d = self.letters.2;
        if level == self.hole.r_level {
            ['R', d]
        } else {
            [d, 'R']
        }
    }

    fn rapid_d(&mut self, level: f64) {
        let mut p = self.pos;
        p[self.cc.axes[2]] = level;
        let hint = self.hint(level);
        self.rapid_to(p, hint);
    }

    fn feed_d(&mut self, level: f64) {
        let mut p = self.pos;
        p[self.cc.axes[2]] = level;
        let hint = self.hint(level);
        self.push(
            SegmentKind::Linear {
                end: p,
                feed: self.cc.feed,
            },
            hint,
        );
        self.pos = p;
    }

    /// A tap move to `level`, C coupled: C = c0 + |level − R| · k. A move that turns no
    /// spindle or feeds no tool couples nothing ([`SegmentKind::tap_or_feed`]).
    fn tap_d(&mut self, level: f64) {
        let Some(t) = self.tap else {
            return;
        };
        let id = self.cc.axes[2];
        let mut p = self.pos;
        p[id] = level;
        p[t.spindle] = t.c0 + (level - self.hole.r_level).abs() * t.k;
        let hint = self.hint(level);
        let kind = SegmentKind::tap_or_feed(&self.pos, p, self.cc.feed, (id, t.spindle), t.pitch);
        self.push(kind, hint);
        self.pos = p;
    }

    fn dwell_data(&mut self) {
        if let Some(s) = self.cc.words.p
            && s > 0.0
        {
            self.push(SegmentKind::Dwell { seconds: s }, NO_HINT);
        }
    }

    fn orient(&mut self) {
        self.spindle_stop();
        if let Some(angle) = self.cc.plan.orient_angle {
            self.push(
                SegmentKind::SpindleOrient {
                    angle,
                    program: None,
                    spindle: self.cc.plan.spindle,
                },
                NO_HINT,
            );
        }
    }

    fn shift(&mut self, by: f64) {
        let mut p = self.pos;
        p[self.cc.axes[0]] += by;
        self.rapid_to(p, ['Q', self.letters.0]);
    }

    /// Level at distance `t` from R into the hole.
    fn level(&self, t: f64) -> f64 {
        self.hole.r_level + (self.hole.bottom - self.hole.r_level).signum() * t
    }

    /// Depths (from R) of successive pecks of `q` down to `depth`, and the last is `depth`.
    fn pecks(q: f64, depth: f64) -> impl Iterator<Item = (f64, bool)> {
        let mut t = 0.0;
        let mut done = false;
        std::iter::from_fn(move || {
            if done {
                return None;
            }
            let mut nt = (t + q).min(depth);
            if depth - nt < 1e-6 {
                nt = depth;
            }
            done = nt >= depth;
            t = nt;
            Some((nt, done))
        })
    }

    /// From the R level: the cycle's drilling, bottom action and return.
    fn hole_body(&mut self) {
        let (r, bottom, ret) = (self.hole.r_level, self.hole.bottom, self.hole.ret);
        let depth = (bottom - r).abs();
        let q = self.cc.words.q;
        match self.cc.code {
            81 => {
                self.feed_d(bottom);
                self.rapid_d(ret);
            }
            82 => {
                self.feed_d(bottom);
                self.dwell_data();
                self.rapid_d(ret);
            }
            73 | 83 => {
                let q = q.unwrap_or(depth);
                let d = if self.cc.code == 73 {
                    self.cc.plan.peck_retract
                } else {
                    self.cc.plan.peck_clearance
                };
                for (nt, last) in Self::pecks(q, depth) {
                    self.feed_d(self.level(nt));
                    if last {
                        break;
                    }
                    if self.cc.code == 83 {
                        self.rapid_d(r);
                    }
                    self.rapid_d(self.level((nt - d).max(0.0)));
                }
                self.rapid_d(ret);
            }
            84 | 74 => {
                let peck = self
                    .cc
                    .tap
                    .and_then(|t| t.peck.map(|q| (q, t.peck_retract)));
                match peck {
                    Some((q, d)) => {
                        for (nt, last) in Self::pecks(q, depth) {
                            self.tap_d(self.level(nt));
                            if last {
                                break;
                            }
                            self.tap_d(self.level((nt - d).max(0.0)));
                        }
                    }
                    None => self.tap_d(bottom),
                }
                self.dwell_data();
                self.tap_d(r);
                self.rapid_d(ret);
            }
            85 => {
                self.feed_d(bottom);
                self.feed_d(r);
                self.rapid_d(ret);
            }
            89 => {
                self.feed_d(bottom);
                self.dwell_data();
                // LinuxCNC feeds straight out to the return level.
                if self.cc.plan.linuxcnc.is_some() {
                    self.feed_d(ret);
                } else {
                    self.feed_d(r);
                    self.rapid_d(ret);
                }
            }
            86 => {
                self.feed_d(bottom);
                // LinuxCNC dwells P at the bottom of G86; Fanuc's G86 has no dwell.
                if self.cc.plan.linuxcnc.is_some() {
                    self.dwell_data();
                }
                self.spindle_stop();
                self.rapid_d(ret);
                self.restore();
            }
            88 => {
                self.feed_d(bottom);
                self.dwell_data();
                self.spindle_stop();
                self.push(
                    SegmentKind::Stop {
                        kind: StopKind::Program,
                    },
                    NO_HINT,
                );
                // LinuxCNC leaves the way out to the operator (the next hole's positioning
                // starts at the bottom); Fanuc rapids out on restart.
                if self.cc.plan.linuxcnc.is_none() {
                    self.rapid_d(ret);
                }
                self.restore();
            }
            76 => {
                let q = q.unwrap_or(0.0);
                self.feed_d(bottom);
                self.dwell_data();
                self.orient();
                self.shift(q);
                self.rapid_d(ret);
                self.shift(-q);
                self.restore();
            }
            _ => {}
        }
    }

    /// G87: orient, shift, rapid to the R level (the bottom of the bore), shift back, spindle
    /// on, feed up to Z, dwell, orient, shift, rapid to the initial level, shift back, spindle
    /// on.
    fn back_boring(&mut self) {
        let q = self.cc.words.q.unwrap_or(0.0);
        let plan = self.cc.plan;
        let on = SegmentKind::Spindle {
            rpm: plan.speed,
            dir: plan.spindle_dir,
            spindle: plan.spindle,
        };
        self.orient();
        self.shift(q);
        self.rapid_d(self.hole.r_level);
        self.shift(-q);
        self.push(on.clone(), NO_HINT);
        self.feed_d(self.hole.bottom);
        self.dwell_data();
        self.orient();
        self.shift(q);
        self.rapid_d(self.hole.ret);
        self.shift(-q);
        self.push(on, NO_HINT);
    }
}
