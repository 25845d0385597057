//! The plain-block lane: a G0/G1 block of literal axis words (with F and an N number) in a
//! modal state where such a block does nothing but move, run straight from its bytes — no
//! parse tree, no word table, no pass through every check of the general block layer, which
//! a CAM program of millions of such lines would pay for on each. The lane is all or nothing:
//! whatever it is not sure of it leaves to the general path, which then runs the line from
//! its start, so it never makes an error of its own; a differential test holds the two equal.

use std::collections::VecDeque;

use cnc402_config::{MAX_AXES, MachineConfig};
use cnc402_lang::Dialect;
use cnc402_motion::segment::{AxisPos, SegmentKind, Source};

use super::exec::{all_finite as finite, linuxcnc_default_spindle, single_op};
use super::machine::Machine;
use super::state::Motion;
use crate::canon::{self, CanonKind, CanonOp};

/// Not an axis the lane moves (a letter of no configured axis, or a spindle's).
const NO_AXIS: u8 = u8::MAX;

/// What the lane knows of a machine, found once from its config: the axis each letter moves.
#[derive(Clone, Debug)]
pub(crate) struct PlainLane {
    /// By letter `A`..`Z`: the configured axis index, or [`NO_AXIS`].
    axis_of: [u8; 26],
    /// The axes that are rotary (their words are degrees whatever the units).
    rotary: [bool; MAX_AXES],
}

impl PlainLane {
    pub(crate) fn new(cfg: &MachineConfig) -> PlainLane {
        let mut axis_of = [NO_AXIS; 26];
        let mut rotary = [false; MAX_AXES];
        let spindles = cfg.spindle_axes();
        for (i, ax) in cfg.axes.iter().enumerate().take(MAX_AXES) {
            // A spindle axis's word may be a rigid tap (`G1 Z.. C..`): the general path's.
            if spindles.contains(&Some(i)) || !ax.name.is_ascii_uppercase() {
                continue;
            }
            axis_of[usize::from(ax.name as u8 - b'A')] = i as u8;
            rotary[i] = ax.kind.is_rotary();
        }
        PlainLane { axis_of, rotary }
    }

    /// The block of `body` when the lane can read it: words of `G0`/`G1` (one at most,
    /// written without a point or sign), `F`, and the letters of non-spindle axes, each once,
    /// at least one axis word; no comment.
    pub(crate) fn read(&self, body: &[u8]) -> Option<PlainBlock> {
        let mut r = Reading {
            lane: self,
            block: PlainBlock::EMPTY,
            ok: true,
            letters: 0,
        };
        let (n, _) = cnc402_lang::plain::words(body, &mut r)?;
        r.block.n = n;
        (r.ok && r.block.given != 0).then_some(r.block)
    }
}

/// A line being read by [`PlainLane::read`].
struct Reading<'a> {
    lane: &'a PlainLane,
    block: PlainBlock,
    /// No word the lane leaves to the general path so far.
    ok: bool,
    /// The letters seen (bit `letter - 'A'`).
    letters: u32,
}

impl cnc402_lang::plain::WordSink for Reading<'_> {
    fn word(&mut self, letter: u8, v: f64, point: bool) {
        let bit = 1u32 << (letter - b'A');
        self.ok &= self.letters & bit == 0;
        self.letters |= bit;
        let b = &mut self.block;
        match letter {
            // `-0` is a sign the general path reads its own way.
            b'G' if !point && v.is_sign_positive() && (v == 0.0 || v == 1.0) => {
                b.motion = Some(if v == 0.0 {
                    Motion::Rapid
                } else {
                    Motion::Linear
                });
            }
            b'F' => b.feed = Some(v),
            _ => match self.lane.axis_of[usize::from(letter - b'A')] {
                NO_AXIS => self.ok = false,
                i => {
                    b.values[usize::from(i)] = v;
                    b.given |= 1 << i;
                }
            },
        }
    }

    fn restart(&mut self) {
        (self.block, self.ok, self.letters) = (PlainBlock::EMPTY, true, 0);
    }
}

/// A block the lane reads (see [`PlainLane::read`]).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PlainBlock {
    /// Its `N` number.
    pub n: Option<u32>,
    /// `G0`/`G1` of the block.
    motion: Option<Motion>,
    /// `F` as written.
    feed: Option<f64>,
    /// Each axis word's value as written (program units), by axis index; `given` says which.
    values: [f64; MAX_AXES],
    given: u16,
}

impl PlainBlock {
    const EMPTY: PlainBlock = PlainBlock {
        n: None,
        motion: None,
        feed: None,
        values: [0.0; MAX_AXES],
        given: 0,
    };
}

/// The state a plain block changes, as it was before: put back when the block turns out to
/// be no plain one after all.
struct Before {
    motion: Motion,
    cycle_data: super::state::CycleData,
    rigid: bool,
    exact_stop_once: bool,
    feed: f64,
    pos: AxisPos,
    tlo_in_pos: f64,
    polar_step: Option<[f64; 2]>,
}

impl Machine {
    /// Runs `b` (from `source`) as the general block layer would run that block, its
    /// operation appended to `out`, when the lane is sure to: `true`. `false`, and nothing
    /// changed (the state is as it was, `out` too), when the block is the general path's: the
    /// modal state is no plain one (a canned cycle, cutter compensation, a held corner), the
    /// target is past a soft limit, the feed is zero or overflows, or the block would not
    /// move. `lane`: the machine's letters. `linuxcnc`: the block is read as LinuxCNC's.
    /// `lane_canon`: the last block was the lane's (`Machine::lane_canon` as it was then).
    pub(crate) fn run_plain(
        &mut self,
        lane: &PlainLane,
        (b, linuxcnc): (&PlainBlock, bool),
        (source, lane_canon): (Source, bool),
        out: &mut VecDeque<CanonOp>,
    ) -> bool {
        let st = &self.state;
        if st.cycle.is_some() || st.pending_corner.is_some() || st.comp.is_some() {
            return false;
        }
        let motion = b.motion.unwrap_or(st.motion);
        if !matches!(motion, Motion::Rapid | Motion::Linear) || !self.default_spindle_kept() {
            return false;
        }
        let unit = st.unit();
        if b.feed.is_some_and(|f| f < 0.0) {
            return false;
        }
        let feed = b.feed.map_or(st.feed, |f| f * unit);
        // The targets as `Exec::targets` makes them (G90/G91, work zero, tool length offset).
        let mut end = st.pos;
        let mut given = b.given;
        while given != 0 {
            let i = given.trailing_zeros() as usize;
            given &= given - 1;
            let v = if lane.rotary[i] {
                b.values[i]
            } else {
                b.values[i] * unit
            };
            end[i] = st.target(i, v);
        }
        if self.map.outside_limits(&end) || end == st.pos {
            return false;
        }
        let kind = match motion {
            Motion::Rapid => SegmentKind::Rapid { end },
            _ => {
                let rate = match st.feed_per_rev {
                    true if st.speed <= 0.0 && feed > 0.0 => return false,
                    true => feed * st.speed,
                    false => feed,
                };
                // A NaN is the general path's too.
                if rate.is_nan() || rate <= 0.0 {
                    return false;
                }
                SegmentKind::Linear { end, feed: rate }
            }
        };
        let tlo_moves =
            st.tool_axis.is_some_and(|z| b.given >> z & 1 != 0) && st.tlo_in_pos != st.tlo;
        if lane_canon
            && !st.exact_stop_once
            && !tlo_moves
            && let Some(state) = &self.canon
        {
            // The last block was the lane's and this one changes nothing of the canonical
            // state: the operation is made and checked first, the state changed after.
            debug_assert!(st.canon_state_is(state));
            let op = CanonOp {
                kind: CanonKind::Single(state.convert(kind, self.map.xyz, false)),
                source,
                state: state.clone(),
            };
            // The shift, S, the tool length and the state's offsets are as the last lane
            // block found them finite.
            if !finite_move(&op, feed) || !canon::makes_motion(std::iter::once(&op), &st.pos) {
                return false;
            }
            self.apply(b, linuxcnc, feed, end);
            out.push_back(op);
            self.lane_canon = true;
            return true;
        }
        let before = self.change_state(b, linuxcnc, feed, end);
        let from = before.pos;
        let op = single_op(self.map.xyz, &self.state, &mut self.canon, kind, source);
        // What `Exec::check_finite` and the runaway guard (`canon::makes_motion`) ask of the
        // block after it ran: the general path gives the error, or runs the block as a
        // block without motion.
        if !self.finite_after(&op) || !canon::makes_motion(std::iter::once(&op), &from) {
            self.put_back(before);
            return false;
        }
        out.push_back(op);
        self.lane_canon = true;
        true
    }

    /// LinuxCNC selects its default spindle in every block (`Exec::spindle_selection`): the
    /// lane runs only when that changes nothing.
    fn default_spindle_kept(&self) -> bool {
        if self.dialect != Dialect::LinuxCnc {
            return true;
        }
        self.state.spindle_sel == linuxcnc_default_spindle(&self.cfg, &self.opts)
    }

    /// The modal state after the block, as `Exec::run` leaves it (what it was, returned):
    /// the motion code (and the canned cycle data it clears), G9 gone, F, the position and
    /// the tool length offset vector restored on a programmed tool-axis move.
    fn change_state(&mut self, b: &PlainBlock, linuxcnc: bool, feed: f64, end: AxisPos) -> Before {
        let st = &self.state;
        let before = Before {
            motion: st.motion,
            cycle_data: st.cycle_data,
            rigid: st.rigid,
            exact_stop_once: st.exact_stop_once,
            feed: st.feed,
            pos: st.pos,
            tlo_in_pos: st.tlo_in_pos,
            polar_step: st.polar_step,
        };
        self.apply(b, linuxcnc, feed, end);
        before
    }

    /// [`change_state`](Self::change_state) without keeping what the state was.
    fn apply(&mut self, b: &PlainBlock, linuxcnc: bool, feed: f64, end: AxisPos) {
        let st = &mut self.state;
        if linuxcnc {
            st.polar_step = None;
        }
        st.exact_stop_once = false;
        if let Some(m) = b.motion {
            st.motion = m;
            st.cycle = None;
            st.cycle_data = Default::default();
            st.rigid = false;
        }
        st.feed = feed;
        let mut given = b.given;
        while given != 0 {
            st.restore_tlo(given.trailing_zeros() as usize);
            given &= given - 1;
        }
        st.pos = end;
    }

    fn put_back(&mut self, b: Before) {
        let st = &mut self.state;
        st.motion = b.motion;
        st.cycle_data = b.cycle_data;
        st.rigid = b.rigid;
        st.exact_stop_once = b.exact_stop_once;
        st.feed = b.feed;
        st.pos = b.pos;
        st.tlo_in_pos = b.tlo_in_pos;
        st.polar_step = b.polar_step;
    }

    /// Every number `Exec::check_finite` looks at is finite after the block made `op`.
    fn finite_after(&self, op: &CanonOp) -> bool {
        let st = &self.state;
        // The position is the move's end (checked with the operation).
        finite_move(op, st.feed)
            && finite(&st.shift)
            && finite(&[st.speed, st.tlo])
            && finite(&op.state.offset.0)
    }
}

/// The move `op` (its end and feed rate) and the modal feed `feed` are finite.
fn finite_move(op: &CanonOp, feed: f64) -> bool {
    let (end, rate) = match &op.kind {
        CanonKind::Single(SegmentKind::Rapid { end }) => (end, 0.0),
        CanonKind::Single(SegmentKind::Linear { end, feed }) => (end, *feed),
        _ => return false,
    };
    finite(&end.0) && finite(&[rate, feed])
}
