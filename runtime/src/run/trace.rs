//! The `--trace` CSV of a run of several channels: one row per tick with the machine's axes
//! in config order (each from the channel that owns it), the line of every channel
//! (`line` is channel 0's, `line_ch1`… the others'), the statuswords, and channel 0's panel
//! column. A one-channel run writes its trace through the recorder as before.

use std::collections::VecDeque;
use std::io::Write;

use cnc402_config::{MAX_AXES, MachineConfig};

use crate::recorder::{fmt, push_panel};
use crate::status::Status;

/// See the module doc.
pub(super) struct MachineTrace {
    out: Box<dyn Write>,
    error: Option<std::io::Error>,
    period_s: f64,
    /// Per machine axis: (channel, the channel's axis index), and whether it has a drive.
    axes: Vec<(usize, usize, bool)>,
    channels: usize,
}

impl MachineTrace {
    /// A trace of `cfg`'s channels to `out`, header first.
    pub(super) fn new(cfg: &MachineConfig, mut out: Box<dyn Write>) -> MachineTrace {
        let channels = cfg.channel_count();
        let mut axes = vec![(0, 0, false); cfg.axes.len().min(MAX_AXES)];
        for v in (0..channels).filter_map(|k| cfg.channel(k)) {
            for (i, &a) in v.axes.iter().enumerate() {
                if let Some(slot) = axes.get_mut(a) {
                    *slot = (v.index, i, cfg.axes[a].node.is_some());
                }
            }
        }
        let mut h = String::from("t,line");
        for k in 1..channels {
            h.push_str(&format!(",line_ch{k}"));
        }
        for a in cfg.axes.iter().take(axes.len()) {
            h.push_str(&format!(",{}_cmd,{}_act", a.name, a.name));
        }
        for (a, _) in cfg.axes.iter().zip(&axes).filter(|(_, x)| x.2) {
            h.push_str(&format!(",{}_sw", a.name));
        }
        h.push_str(",panel\n");
        let error = out.write_all(h.as_bytes()).err();
        MachineTrace {
            out,
            error,
            period_s: cfg.bus.period_s(),
            axes,
            channels,
        }
    }

    /// One row at `tick` from each channel's last record (a channel that ended keeps its
    /// last one).
    pub(super) fn row(&mut self, tick: u64, last: &[Option<Status>]) {
        if self.error.is_some() || last.len() < self.channels {
            return;
        }
        let line_of = |k: usize| last[k].map_or(0, |s| s.line);
        let mut row = format!("{:.6},{}", tick as f64 * self.period_s, line_of(0));
        for k in 1..self.channels {
            row.push_str(&format!(",{}", line_of(k)));
        }
        let at = |&(k, i, _): &(usize, usize, bool)| last[k].map(|s| (s, i));
        for x in &self.axes {
            let (c, a) = at(x).map_or((0.0, 0.0), |(s, i)| (s.cmd[i], s.act[i]));
            row.push_str(&format!(",{},{}", fmt(c), fmt(a)));
        }
        for x in self.axes.iter().filter(|x| x.2) {
            let sw = at(x).map_or(0, |(s, i)| s.statusword[i]);
            row.push_str(&format!(",0x{sw:04x}"));
        }
        row.push(',');
        if let Some(s) = &last[0] {
            push_panel(&mut row, s);
        }
        row.push('\n');
        self.error = self.out.write_all(row.as_bytes()).err();
    }

    /// Flushes; the first write error, if any.
    pub(super) fn finish(mut self) -> Result<(), std::io::Error> {
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        self.out.flush()
    }
}

/// The trace's rows from the channels' records as they are drained (several ticks at a time
/// in real time): a row for tick `t` is written once every channel has sent its record for
/// `t` or has ended (then its last record stands).
pub(super) struct TraceRows {
    pub(super) trace: MachineTrace,
    pending: Vec<VecDeque<Status>>,
    last: [Option<Status>; cnc402_config::MAX_CHANNELS],
    next: u64,
}

impl TraceRows {
    pub(super) fn new(trace: MachineTrace) -> TraceRows {
        TraceRows {
            pending: (0..trace.channels).map(|_| VecDeque::new()).collect(),
            trace,
            last: [None; cnc402_config::MAX_CHANNELS],
            next: 0,
        }
    }

    /// Channel `k`'s next record.
    pub(super) fn push(&mut self, k: usize, s: &Status) {
        if let Some(p) = self.pending.get_mut(k) {
            p.push_back(*s);
        }
    }

    /// Writes every row that is complete; `ended(k)`: channel `k` sends no more records.
    pub(super) fn flush(&mut self, ended: impl Fn(usize) -> bool) {
        // Each turn writes one row and takes at least one record: bounded by the records.
        loop {
            let mut any = false;
            for (k, p) in self.pending.iter_mut().enumerate() {
                while p.front().is_some_and(|s| s.tick < self.next) {
                    self.last[k] = p.pop_front();
                }
                match p.front() {
                    Some(s) if s.tick == self.next => any = true,
                    Some(_) => {}
                    None if ended(k) => {}
                    None => return,
                }
            }
            if !any {
                return;
            }
            for (k, p) in self.pending.iter_mut().enumerate() {
                if p.front().is_some_and(|s| s.tick == self.next) {
                    self.last[k] = p.pop_front();
                }
            }
            self.trace.row(self.next, &self.last);
            self.next += 1;
        }
    }
}
