//! LinuxCNC's "naive CAM" merging (`G64 P… Q…`): a run of short feed lines whose corner
//! points all lie within the collinearity tolerance Q of one straight line is planned as that
//! one line, so CAM output that approximates a straight edge with many tiny, noisy steps runs
//! as a straight move. Semantics as LinuxCNC's canon layer (`emccanon.cc`: `see_segment`,
//! `linkable`, `flush_segments`): at most [`MAX_CHAIN`] lines, only linear axes moving, the
//! merged line carries the last block's source.

use crate::segment::{AxisPos, MAX_AXES, Segment, SegmentEnd, SegmentKind};

/// Most lines merged into one (LinuxCNC's limit: its chains hold 100 points).
pub const MAX_CHAIN: usize = 100;

/// A run of merged feed lines, waiting for the line that breaks it.
#[derive(Clone, Debug)]
pub struct CollinearChain {
    /// Which axes are linear (rotary axes must not move in a merged line).
    linear: [bool; MAX_AXES],
    /// Where the run starts.
    start: AxisPos,
    /// The end points of the lines merged so far, in order; the last is the run's end.
    points: Vec<AxisPos>,
    /// The last line taken: its feed, source and end stand for the merged line.
    last: Option<Segment>,
    /// The largest distance of a merged corner point from its merged line, mm.
    max_deviation: f64,
}

impl CollinearChain {
    /// An empty chain for a machine whose linear axes are `linear`.
    pub fn new(linear: [bool; MAX_AXES]) -> CollinearChain {
        CollinearChain {
            linear,
            start: AxisPos::default(),
            points: Vec::with_capacity(MAX_CHAIN),
            last: None,
            max_deviation: 0.0,
        }
    }

    /// Lines held.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when no line is held.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Where the chain ends (the next line starts), if it holds any line.
    pub fn end(&self) -> Option<AxisPos> {
        self.points.last().copied()
    }

    /// The largest distance (mm) of a programmed corner from the line that replaced it, over
    /// every merge so far: how far merging moved the path (at most each run's Q).
    pub fn max_deviation(&self) -> f64 {
        self.max_deviation
    }

    /// Q of `seg` when it may take part in a merge: a feed line ending `Continuous` with a
    /// collinearity tolerance > 0 that moves no rotary axis (from `start`).
    pub fn mergeable(&self, seg: &Segment, start: &AxisPos) -> Option<f64> {
        let SegmentKind::Linear { end, .. } = &seg.kind else {
            return None;
        };
        let SegmentEnd::Continuous { collinear, .. } = seg.ends else {
            return None;
        };
        let rotary_moves = (0..MAX_AXES).any(|k| !self.linear[k] && end[k] != start[k]);
        (collinear > 0.0 && !rotary_moves && *end != *start).then_some(collinear)
    }

    /// Takes `seg` into the chain if it continues it: the same feed and tolerances, and every
    /// corner point so far within Q of the straight line from the chain's start to `seg`'s
    /// end. `seg` must be [`mergeable`](Self::mergeable). False (and nothing changes) if it
    /// does not continue the chain: [`take`](Self::take) the chain, then [`begin`](Self::begin)
    /// a new one with it.
    pub fn extend(&mut self, seg: &Segment, q: f64) -> bool {
        let (Some(last), SegmentKind::Linear { end, feed }) = (&self.last, &seg.kind) else {
            return false;
        };
        let SegmentKind::Linear {
            feed: last_feed, ..
        } = last.kind
        else {
            return false;
        };
        if self.points.len() >= MAX_CHAIN || *feed != last_feed || seg.ends != last.ends {
            return false;
        }
        let mut worst = 0.0f64;
        for p in &self.points {
            let d = self.distance_to_chord(p, end);
            if d > q {
                return false;
            }
            worst = worst.max(d);
        }
        self.points.push(*end);
        self.max_deviation = self.max_deviation.max(worst);
        self.last = Some(seg.clone());
        true
    }

    /// Starts a chain at `start` with `seg` (a [`mergeable`](Self::mergeable) line).
    pub fn begin(&mut self, seg: &Segment, start: AxisPos) {
        self.start = start;
        self.points.clear();
        if let SegmentKind::Linear { end, .. } = seg.kind {
            self.points.push(end);
        }
        self.last = Some(seg.clone());
    }

    /// The merged line (the last block's segment, which already ends where the run ends), and
    /// an empty chain.
    pub fn take(&mut self) -> Option<Segment> {
        self.points.clear();
        self.last.take()
    }

    /// Distance of `p` from the segment start → `end`, over the linear axes (LinuxCNC clamps
    /// the foot of the perpendicular to the segment, so a point beyond an end counts its
    /// distance to that end).
    fn distance_to_chord(&self, p: &AxisPos, end: &AxisPos) -> f64 {
        let (mut mm, mut mp) = (0.0, 0.0);
        for k in (0..MAX_AXES).filter(|&k| self.linear[k]) {
            let m = end[k] - self.start[k];
            mm += m * m;
            mp += m * (p[k] - self.start[k]);
        }
        let t = if mm > 0.0 {
            (mp / mm).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let mut d2 = 0.0;
        for k in (0..MAX_AXES).filter(|&k| self.linear[k]) {
            let foot = self.start[k] + t * (end[k] - self.start[k]);
            d2 += (p[k] - foot) * (p[k] - foot);
        }
        d2.sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::segment::Source;

    fn line(x: f64, y: f64, feed: f64, q: f64) -> Segment {
        let mut end = AxisPos::default();
        end[0] = x;
        end[1] = y;
        Segment {
            kind: SegmentKind::Linear { end, feed },
            source: Source {
                file: "t.nc".into(),
                line: x as u32,
                n: None,
            },
            ends: SegmentEnd::Continuous {
                tolerance: 0.01,
                collinear: q,
            },
        }
    }

    fn chain() -> CollinearChain {
        let mut linear = [false; MAX_AXES];
        linear[..3].fill(true);
        CollinearChain::new(linear)
    }

    /// Feeds `segs` through a chain from the origin as the lookahead does; returns the lines
    /// that come out.
    fn merge(segs: &[Segment]) -> Vec<Segment> {
        let mut c = chain();
        let mut out = Vec::new();
        let mut at = AxisPos::default();
        for s in segs {
            let q = c.mergeable(s, &at).expect("mergeable");
            if c.is_empty() {
                c.begin(s, at);
            } else if !c.extend(s, q) {
                out.extend(c.take());
                c.begin(s, at);
            }
            if let SegmentKind::Linear { end, .. } = s.kind {
                at = end;
            }
        }
        out.extend(c.take());
        out
    }

    #[test]
    fn noisy_straight_steps_become_one_line_ending_where_the_last_block_ends() {
        let segs: Vec<_> = (1..=50)
            .map(|i| {
                line(
                    i as f64,
                    if i % 2 == 0 { 0.004 } else { -0.004 },
                    600.0,
                    0.01,
                )
            })
            .collect();
        let out = merge(&segs);
        assert_eq!(out.len(), 1);
        assert_eq!(
            out[0], segs[49],
            "the last block's segment stands for the run"
        );
    }

    #[test]
    fn a_corner_point_beyond_q_breaks_the_run() {
        let segs = [
            line(1.0, 0.0, 600.0, 0.01),
            line(2.0, 0.0, 600.0, 0.01),
            line(3.0, 0.5, 600.0, 0.01),
            line(4.0, 1.0, 600.0, 0.01),
        ];
        let out = merge(&segs);
        assert_eq!(out.len(), 2);
        assert_eq!(out[0], segs[1]);
        assert_eq!(out[1], segs[3]);
    }

    #[test]
    fn runs_stop_at_max_chain_lines_and_at_a_feed_change() {
        let segs: Vec<_> = (1..=250)
            .map(|i| line(i as f64, 0.0, 600.0, 0.01))
            .collect();
        assert_eq!(merge(&segs).len(), 3, "100 + 100 + 50");
        let mut segs: Vec<_> = (1..=10).map(|i| line(i as f64, 0.0, 600.0, 0.01)).collect();
        segs[5] = line(6.0, 0.0, 300.0, 0.01);
        assert_eq!(merge(&segs).len(), 3);
    }

    #[test]
    fn zero_q_exact_stop_rapids_and_rotary_motion_do_not_merge() {
        let c = chain();
        let at = AxisPos::default();
        assert_eq!(c.mergeable(&line(1.0, 0.0, 600.0, 0.0), &at), None);
        let mut s = line(1.0, 0.0, 600.0, 0.01);
        s.ends = SegmentEnd::ExactStop;
        assert_eq!(c.mergeable(&s, &at), None);
        let mut end = AxisPos::default();
        end[3] = 90.0;
        let mut s = line(0.0, 0.0, 600.0, 0.01);
        s.kind = SegmentKind::Linear { end, feed: 600.0 };
        assert_eq!(c.mergeable(&s, &at), None);
        s.kind = SegmentKind::Rapid { end };
        assert_eq!(c.mergeable(&s, &at), None);
    }

    #[test]
    fn the_deviation_merging_made_is_kept() {
        let segs = [line(1.0, 0.006, 600.0, 0.01), line(2.0, 0.0, 600.0, 0.01)];
        let mut c = chain();
        c.begin(&segs[0], AxisPos::default());
        assert!(c.extend(&segs[1], 0.01));
        assert!((c.max_deviation() - 0.006).abs() < 1e-12);
    }
}
