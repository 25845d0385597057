//! A fault-injecting wrapper around any [`CanBus`] (smoltcp's `FaultInjector` idea): drop,
//! corrupt, truncate or delay frames that match a filter, in either direction, on every n-th
//! match, a bounded number of times; and a bus-off window in which the wrapped endpoint can
//! neither send nor receive. Deterministic: no randomness, so a failing test replays.

use core::time::Duration;

use super::{BusCounters, BusError, CanBus};
use crate::time::Instant;
use crate::wire::{CanFrame, Function};

/// Which frames a rule applies to: `(id & mask) == id_value`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameFilter {
    /// Identifier mask.
    pub mask: u16,
    /// Identifier value after masking.
    pub value: u16,
}

impl FrameFilter {
    /// Every frame.
    pub const fn any() -> FrameFilter {
        FrameFilter { mask: 0, value: 0 }
    }
    /// Exactly this identifier.
    pub const fn id(id: u16) -> FrameFilter {
        FrameFilter {
            mask: 0x7FF,
            value: id,
        }
    }
    /// The identifier of a service (e.g. `Function::Tpdo(1, node)`); a function without a
    /// COB-ID matches nothing.
    pub fn function(f: Function) -> FrameFilter {
        match f.cob_id() {
            Some(id) => FrameFilter::id(id),
            None => FrameFilter {
                mask: 0xFFFF,
                value: 0xF000,
            },
        }
    }
    /// A service class for all nodes: e.g. `FrameFilter::class(0x180)` = every TPDO1.
    pub const fn class(base: u16) -> FrameFilter {
        FrameFilter {
            mask: 0x780,
            value: base & 0x780,
        }
    }
    /// Whether `frame` matches.
    pub fn matches(&self, frame: &CanFrame) -> bool {
        frame.id() & self.mask == self.value
    }
}

/// Which way frames go through the wrapper.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Frames the wrapped endpoint sends.
    Tx,
    /// Frames it receives.
    Rx,
    /// Both.
    Both,
}

/// What happens to a matching frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// It is lost.
    Drop,
    /// Data byte `byte` is XORed with `xor` (no effect if the frame is shorter).
    Corrupt {
        /// Byte index.
        byte: u8,
        /// Bits flipped.
        xor: u8,
    },
    /// Its data is cut to `len` bytes.
    Truncate {
        /// New length.
        len: u8,
    },
    /// It is held back for this long (time from [`FaultInjector::set_now`]).
    Delay(Duration),
}

/// One fault rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FaultRule {
    /// Frames it looks at.
    pub filter: FrameFilter,
    /// In which direction.
    pub direction: Direction,
    /// What it does.
    pub action: Action,
    /// Let this many matches pass untouched first.
    pub skip: u32,
    /// Then act on every `every`-th match (1 = all; 0 is treated as 1).
    pub every: u32,
    /// Act at most this many times (`None` = unlimited).
    pub limit: Option<u32>,
}

impl FaultRule {
    /// A rule acting on every match in `direction`, unlimited.
    pub const fn new(filter: FrameFilter, direction: Direction, action: Action) -> FaultRule {
        FaultRule {
            filter,
            direction,
            action,
            skip: 0,
            every: 1,
            limit: None,
        }
    }
    /// Skips the first `n` matches.
    pub const fn skip(mut self, n: u32) -> FaultRule {
        self.skip = n;
        self
    }
    /// Acts on every `n`-th match.
    pub const fn every(mut self, n: u32) -> FaultRule {
        self.every = n;
        self
    }
    /// Acts at most `n` times.
    pub const fn limit(mut self, n: u32) -> FaultRule {
        self.limit = Some(n);
        self
    }
}

#[derive(Clone, Copy, Debug)]
struct RuleState {
    rule: FaultRule,
    matched: u32,
    applied: u32,
}

/// Wraps a [`CanBus`] and applies [`FaultRule`]s to the frames going through it.
pub struct FaultInjector<B: CanBus> {
    inner: B,
    rules: Vec<RuleState>,
    now: Instant,
    held_tx: Vec<(Instant, CanFrame)>,
    held_rx: Vec<(Instant, CanFrame)>,
    dropped: u64,
    /// From when until when the endpoint is bus-off (`[from, until)`).
    bus_off: Option<(Instant, Instant)>,
}

enum Verdict {
    Pass(CanFrame),
    Drop,
    Hold(Instant, CanFrame),
}

impl<B: CanBus> FaultInjector<B> {
    /// Wraps `inner` with no rules.
    pub fn new(inner: B) -> FaultInjector<B> {
        FaultInjector {
            inner,
            // Room for a few rules so that arming one in a cycle does not allocate.
            rules: Vec::with_capacity(8),
            now: Instant::ZERO,
            // Room for the frames a delay rule holds at a time (a few cycles' worth), so that
            // holding one inside a simulated cycle does not allocate.
            held_tx: Vec::with_capacity(64),
            held_rx: Vec::with_capacity(64),
            dropped: 0,
            bus_off: None,
        }
    }
    /// Makes the endpoint bus-off from `from` for `duration` (time from
    /// [`set_now`](Self::set_now)): every send and receive fails with [`BusError::BusOff`] and
    /// the frames that reach it meanwhile are lost; afterwards it works again (recovery, as a
    /// CAN controller's after 128 × 11 recessive bits).
    pub fn set_bus_off(&mut self, from: Instant, duration: Duration) {
        self.bus_off = Some((from, from + duration));
    }
    /// Whether the endpoint is bus-off now.
    pub fn is_bus_off(&self) -> bool {
        self.bus_off
            .is_some_and(|(from, until)| self.now >= from && self.now < until)
    }
    /// Adds a rule; returns its number (for [`applied`](Self::applied)).
    pub fn add_rule(&mut self, rule: FaultRule) -> usize {
        self.rules.push(RuleState {
            rule,
            matched: 0,
            applied: 0,
        });
        self.rules.len() - 1
    }
    /// Removes all rules (held frames are still released on time).
    pub fn clear_rules(&mut self) {
        self.rules.clear();
    }
    /// How many times rule `n` acted.
    pub fn applied(&self, n: usize) -> u32 {
        self.rules.get(n).map(|r| r.applied).unwrap_or(0)
    }
    /// The wrapped bus.
    pub fn inner(&self) -> &B {
        &self.inner
    }
    /// The wrapped bus, mutable (e.g. to `advance` a [`super::SimBus`]).
    pub fn inner_mut(&mut self) -> &mut B {
        &mut self.inner
    }
    /// Sets the time for delays and sends delayed transmit frames that are due.
    pub fn set_now(&mut self, now: Instant) -> Result<(), BusError> {
        self.now = now;
        if self.is_bus_off() {
            return Ok(());
        }
        let mut i = 0;
        while i < self.held_tx.len() {
            if self.held_tx[i].0 <= now {
                let (_, f) = self.held_tx.remove(i);
                self.inner.send(&f)?;
            } else {
                i += 1;
            }
        }
        Ok(())
    }

    fn judge(&mut self, frame: &CanFrame, dir: Direction) -> Verdict {
        let mut frame = *frame;
        for r in &mut self.rules {
            let rule = r.rule;
            let dir_ok = rule.direction == Direction::Both || rule.direction == dir;
            if !dir_ok || !rule.filter.matches(&frame) {
                continue;
            }
            r.matched = r.matched.saturating_add(1);
            if r.matched <= rule.skip {
                continue;
            }
            if (r.matched - rule.skip - 1) % rule.every.max(1) != 0 {
                continue;
            }
            if rule.limit.is_some_and(|l| r.applied >= l) {
                continue;
            }
            r.applied += 1;
            match rule.action {
                Action::Drop => return Verdict::Drop,
                Action::Corrupt { byte, xor } => {
                    if let Some(b) = frame.data_mut().get_mut(byte as usize) {
                        *b ^= xor;
                    }
                }
                Action::Truncate { len } => {
                    let n = (len as usize).min(frame.dlc());
                    let mut d = [0u8; 8];
                    d[..n].copy_from_slice(&frame.data()[..n]);
                    frame = CanFrame::new(frame.id(), &d[..n]).unwrap_or(frame);
                }
                Action::Delay(d) => return Verdict::Hold(self.now + d, frame),
            }
        }
        Verdict::Pass(frame)
    }
}

impl<B: CanBus> CanBus for FaultInjector<B> {
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        if self.is_bus_off() {
            return Err(BusError::BusOff);
        }
        match self.judge(frame, Direction::Tx) {
            Verdict::Pass(f) => self.inner.send(&f),
            Verdict::Drop => {
                self.dropped += 1;
                Ok(())
            }
            Verdict::Hold(t, f) => {
                self.held_tx.push((t, f));
                Ok(())
            }
        }
    }

    fn recv(&mut self) -> Result<Option<CanFrame>, BusError> {
        if self.is_bus_off() {
            // What the others send meanwhile never reaches a bus-off controller.
            while self.inner.recv()?.is_some() {
                self.dropped += 1;
            }
            return Err(BusError::BusOff);
        }
        if let Some(i) = self.held_rx.iter().position(|(t, _)| *t <= self.now) {
            return Ok(Some(self.held_rx.remove(i).1));
        }
        while let Some(f) = self.inner.recv()? {
            match self.judge(&f, Direction::Rx) {
                Verdict::Pass(f) => return Ok(Some(f)),
                Verdict::Drop => self.dropped += 1,
                Verdict::Hold(t, f) => self.held_rx.push((t, f)),
            }
        }
        Ok(None)
    }

    fn counters(&self) -> BusCounters {
        let mut c = self.inner.counters();
        c.dropped += self.dropped;
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::VecDeque;

    /// A loopback: what is sent is received.
    #[derive(Default)]
    struct Loop {
        q: VecDeque<CanFrame>,
        sent: u64,
    }
    impl CanBus for Loop {
        fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
            self.sent += 1;
            self.q.push_back(*frame);
            Ok(())
        }
        fn recv(&mut self) -> Result<Option<CanFrame>, BusError> {
            Ok(self.q.pop_front())
        }
        fn counters(&self) -> BusCounters {
            BusCounters {
                tx_frames: self.sent,
                ..Default::default()
            }
        }
    }

    fn f(id: u16, d: &[u8]) -> CanFrame {
        CanFrame::new(id, d).unwrap()
    }

    fn drain<B: CanBus>(b: &mut B) -> Vec<CanFrame> {
        let mut v = vec![];
        while let Some(x) = b.recv().unwrap() {
            v.push(x);
        }
        v
    }

    #[test]
    fn drop_every_second_tpdo_after_skip_with_limit() {
        let mut b = FaultInjector::new(Loop::default());
        let r = b.add_rule(
            FaultRule::new(FrameFilter::class(0x180), Direction::Rx, Action::Drop)
                .skip(1)
                .every(2)
                .limit(2),
        );
        for i in 0..8u8 {
            b.send(&f(0x181, &[i])).unwrap();
            b.send(&f(0x701, &[i])).unwrap();
        }
        let got: Vec<_> = drain(&mut b)
            .iter()
            .filter(|x| x.id() == 0x181)
            .map(|x| x.data()[0])
            .collect();
        // matches 1..8: skip #1, then #2 and #4 dropped (limit 2).
        assert_eq!(got, vec![0, 2, 4, 5, 6, 7]);
        assert_eq!(b.applied(r), 2);
        assert_eq!(b.counters().dropped, 2);
    }

    #[test]
    fn corrupt_truncate_and_direction() {
        let mut b = FaultInjector::new(Loop::default());
        b.add_rule(FaultRule::new(
            FrameFilter::id(0x201),
            Direction::Tx,
            Action::Corrupt { byte: 1, xor: 0xFF },
        ));
        b.add_rule(FaultRule::new(
            FrameFilter::id(0x202),
            Direction::Rx,
            Action::Truncate { len: 2 },
        ));
        b.add_rule(FaultRule::new(
            FrameFilter::id(0x203),
            Direction::Tx,
            Action::Corrupt { byte: 7, xor: 1 },
        ));
        b.send(&f(0x201, &[1, 2, 3])).unwrap();
        b.send(&f(0x202, &[1, 2, 3])).unwrap();
        b.send(&f(0x203, &[1])).unwrap();
        assert_eq!(
            drain(&mut b),
            vec![f(0x201, &[1, 0xFD, 3]), f(0x202, &[1, 2]), f(0x203, &[1])]
        );
    }

    #[test]
    fn bus_off_refuses_sends_and_loses_frames_then_recovers() {
        let mut b = FaultInjector::new(Loop::default());
        b.set_bus_off(Instant::from_millis(1), Duration::from_millis(2));
        b.send(&f(0x181, &[1])).unwrap();
        b.set_now(Instant::from_millis(1)).unwrap();
        assert!(b.is_bus_off());
        assert_eq!(b.send(&f(0x181, &[2])), Err(BusError::BusOff));
        assert_eq!(b.recv(), Err(BusError::BusOff));
        assert_eq!(b.counters().dropped, 1, "the frame in flight was lost");
        b.set_now(Instant::from_millis(3)).unwrap();
        assert!(!b.is_bus_off());
        b.send(&f(0x181, &[3])).unwrap();
        assert_eq!(drain(&mut b), vec![f(0x181, &[3])]);
    }

    #[test]
    fn delay_holds_frames_until_time() {
        let mut b = FaultInjector::new(Loop::default());
        b.add_rule(FaultRule::new(
            FrameFilter::id(0x80),
            Direction::Tx,
            Action::Delay(Duration::from_millis(2)),
        ));
        b.add_rule(FaultRule::new(
            FrameFilter::id(0x181),
            Direction::Rx,
            Action::Delay(Duration::from_millis(1)),
        ));
        b.send(&f(0x80, &[])).unwrap();
        b.send(&f(0x181, &[])).unwrap();
        assert_eq!(b.inner().sent, 1, "SYNC held");
        assert_eq!(drain(&mut b), vec![]);
        b.set_now(Instant::from_millis(1)).unwrap();
        assert_eq!(drain(&mut b), vec![f(0x181, &[])]);
        b.set_now(Instant::from_millis(2)).unwrap();
        assert_eq!(drain(&mut b), vec![f(0x80, &[])]);
    }
}
