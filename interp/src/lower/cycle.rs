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

/// One step of an expanded cycle, in machine coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct CycleStep {
    pub kind: SegmentKind,
    /// For a move: the program letters to blame, in order, if its end is out of limits.
    pub hint: [char; 2],
}

/// The hole being drilled: machine levels along the drilling axis.
struct Hole {
    r_level: f64,
    bottom: f64,
    ret: f64,
}

/// Expands `cc` (recorded under `state`) into machine-coordinate steps.
pub fn expand(cc: &CannedCycle, state: &CanonState) -> Vec<CycleStep> {
    let mut ex = Expander::new(cc, state);
    ex.run();
    ex.out
}

struct Expander<'a> {
    cc: &'a CannedCycle,
    /// Letters of the plane's first, second and drilling axis.
    letters: (char, char, char),
    pos: AxisPos,
    /// Work → machine offset of every axis (holes and levels are work coordinates).
    offset: AxisPos,
    /// Machine levels of the block's holes.
    hole: Hole,
    /// Tap coupling: C at the block's start, degrees of C per mm into the hole.
    tap: Option<(usize, f64, f64)>,
    out: Vec<CycleStep>,
}

impl<'a> Expander<'a> {
    fn new(cc: &'a CannedCycle, state: &CanonState) -> Self {
        let [_, _, id] = cc.axes;
        let o = state.offset.0[id];
        let pos = state.to_machine(&cc.start);
        let tap = cc.tap.map(|t| {
            let hand = if t.dir == SpindleDir::Ccw { -1.0 } else { 1.0 };
            (t.spindle, pos.0[t.spindle], hand * 360.0 / t.pitch)
        });
        Expander {
            cc,
            letters: state.plane.letters(),
            pos,
            offset: state.offset,
            hole: Hole {
                r_level: cc.r_level + o,
                bottom: cc.bottom + o,
                ret: cc.return_level + o,
            },
            tap,
            out: Vec::new(),
        }
    }

    fn run(&mut self) {
        let [ia, ib, _] = self.cc.axes;
        let plan = self.cc.plan;
        if self.tap.is_some() && plan.spindle_turning {
            self.spindle_stop();
        }
        for &[a, b] in &self.cc.holes {
            let mut p = self.pos;
            p[ia] = a + self.offset.0[ia];
            p[ib] = b + self.offset.0[ib];
            let (la, lb, _) = self.letters;
            self.rapid_to(p, [la, lb]);
            if self.cc.code == 87 {
                self.back_boring();
            } else {
                let r = self.hole.r_level;
                self.rapid_d(r);
                self.hole_body();
            }
        }
        if self.tap.is_some() {
            self.restore();
        }
    }

    fn push(&mut self, kind: SegmentKind, hint: [char; 2]) {
        self.out.push(CycleStep { kind, hint });
    }

    fn spindle_stop(&mut self) {
        self.push(
            SegmentKind::Spindle {
                rpm: 0.0,
                dir: SpindleDir::Stop,
            },
            ['\0'; 2],
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
                },
                ['\0'; 2],
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

    /// A tap move to `level`, C coupled: C = c0 + |level − R| · k.
    fn tap_d(&mut self, level: f64) {
        let Some((ic, c0, k)) = self.tap else {
            return;
        };
        let id = self.cc.axes[2];
        let mut p = self.pos;
        p[id] = level;
        p[ic] = c0 + (level - self.hole.r_level).abs() * k;
        let hint = self.hint(level);
        let kind = super::tap_segment(p, self.cc.feed, id, ic, self.tap_pitch());
        self.push(kind, hint);
        self.pos = p;
    }

    /// Signed pitch of the tap's coupling: Δtool = pitch · ΔC / 360 on the way in and out.
    fn tap_pitch(&self) -> f64 {
        let Some((_, _, k)) = self.tap else {
            return 0.0;
        };
        // Into the hole C grows by k per mm while the tool moves towards the bottom.
        let into = (self.hole.bottom - self.hole.r_level).signum();
        into * 360.0 / k
    }

    fn dwell_data(&mut self) {
        if let Some(s) = self.cc.words.p
            && s > 0.0
        {
            self.push(SegmentKind::Dwell { seconds: s }, ['\0'; 2]);
        }
    }

    fn orient(&mut self) {
        self.spindle_stop();
        if let Some(angle) = self.cc.plan.orient_angle {
            self.push(
                SegmentKind::SpindleOrient {
                    angle,
                    program: None,
                },
                ['\0'; 2],
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
                let peck = self.cc.tap.and_then(|t| t.peck.map(|q| (q, t.peck_retract)));
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
                self.feed_d(r);
                self.rapid_d(ret);
            }
            86 => {
                self.feed_d(bottom);
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
                    ['\0'; 2],
                );
                self.rapid_d(ret);
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
        };
        self.orient();
        self.shift(q);
        self.rapid_d(self.hole.r_level);
        self.shift(-q);
        self.push(on.clone(), ['\0'; 2]);
        self.feed_d(self.hole.bottom);
        self.dwell_data();
        self.orient();
        self.shift(q);
        self.rapid_d(self.hole.ret);
        self.shift(-q);
        self.push(on, ['\0'; 2]);
    }
}
