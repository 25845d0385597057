//! The in-process simulated bus: the master's endpoint plus attached devices on one medium,
//! in time the caller passes in. Frames are serialised at the configured bit rate (55 + 10·n
//! bits each), arbitrated by identifier when several wait, and delivered to every node but
//! the sender when their last bit is on the wire — the same frames a real bus carries.

use std::collections::VecDeque;

use super::{BusCounters, BusError, CanBus, FrameSink};
use crate::time::Instant;
use crate::wire::CanFrame;

/// A node on the simulated bus: it receives every frame it did not send itself, and is polled
/// for its timers. The same interface serves a device on a real socket (`simdrive`).
pub trait CanDevice {
    /// A frame arrived at `now` (the time its last bit was on the wire).
    fn on_frame(&mut self, frame: &CanFrame, now: Instant, tx: &mut dyn FrameSink);
    /// Time moved on to `now`: run timers (heartbeat, boot delay, fault reactions).
    fn poll(&mut self, now: Instant, tx: &mut dyn FrameSink);
}

impl<D: CanDevice + ?Sized> CanDevice for Box<D> {
    fn on_frame(&mut self, frame: &CanFrame, now: Instant, tx: &mut dyn FrameSink) {
        (**self).on_frame(frame, now, tx)
    }
    fn poll(&mut self, now: Instant, tx: &mut dyn FrameSink) {
        (**self).poll(now, tx)
    }
}

/// Who put a frame on the simulated bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Origin {
    /// The master endpoint (the [`CanBus`] side of [`SimBus`]).
    Master,
    /// Attached device number `n` (the order of [`SimBus::attach`]).
    Device(usize),
}

/// One frame as it completed on the medium (recorded when tracing is on).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TraceEntry {
    /// When its last bit was on the wire.
    pub at: Instant,
    /// The frame.
    pub frame: CanFrame,
    /// Its sender.
    pub origin: Origin,
}

#[derive(Clone, Copy, Debug)]
struct Pending {
    ready: Instant,
    seq: u64,
    frame: CanFrame,
    origin: Origin,
}

struct Sink<'a> {
    pending: &'a mut VecDeque<Pending>,
    seq: &'a mut u64,
    origin: Origin,
}

impl FrameSink for Sink<'_> {
    fn transmit(&mut self, frame: &CanFrame, now: Instant) -> Result<(), BusError> {
        *self.seq += 1;
        self.pending.push_back(Pending {
            ready: now,
            seq: *self.seq,
            frame: *frame,
            origin: self.origin,
        });
        Ok(())
    }
}

/// The simulated bus. As a [`CanBus`] it is the master's endpoint; devices are attached with
/// [`attach`](Self::attach) and run inside [`advance`](Self::advance).
pub struct SimBus<D: CanDevice = Box<dyn CanDevice>> {
    bitrate: u32,
    now: Instant,
    bus_free_at: Instant,
    seq: u64,
    /// Transmit queues, FIFO each: index 0 the master's, `n + 1` device `n`'s.
    queues: Vec<VecDeque<Pending>>,
    master_rx: VecDeque<CanFrame>,
    master_rx_capacity: usize,
    devices: Vec<D>,
    counters: BusCounters,
    trace: Option<Vec<TraceEntry>>,
}

impl<D: CanDevice> SimBus<D> {
    /// Receive queue depth of the master endpoint (like a socket buffer); overflow drops.
    pub const DEFAULT_RX_CAPACITY: usize = 4096;

    /// A bus at `bitrate` bit/s (0 = frames take no time). Time starts at [`Instant::ZERO`].
    pub fn new(bitrate: u32) -> SimBus<D> {
        SimBus {
            bitrate,
            now: Instant::ZERO,
            bus_free_at: Instant::ZERO,
            seq: 0,
            queues: vec![VecDeque::with_capacity(1024)],
            master_rx: VecDeque::with_capacity(Self::DEFAULT_RX_CAPACITY),
            master_rx_capacity: Self::DEFAULT_RX_CAPACITY,
            devices: Vec::new(),
            counters: BusCounters::default(),
            trace: None,
        }
    }

    /// Attaches a device; returns its number (for [`Origin::Device`] and `device_mut`).
    pub fn attach(&mut self, device: D) -> usize {
        self.devices.push(device);
        self.queues.push(VecDeque::with_capacity(256));
        self.devices.len() - 1
    }

    /// The attached devices.
    pub fn devices(&self) -> &[D] {
        &self.devices
    }

    /// Device number `n`.
    pub fn device(&self, n: usize) -> Option<&D> {
        self.devices.get(n)
    }

    /// Device number `n`, mutable (fault injection, inspection).
    pub fn device_mut(&mut self, n: usize) -> Option<&mut D> {
        self.devices.get_mut(n)
    }

    /// The bus time (the last `advance`).
    pub fn now(&self) -> Instant {
        self.now
    }

    /// The bit rate.
    pub fn bitrate(&self) -> u32 {
        self.bitrate
    }

    /// Starts recording every completed frame (allocates; for tests and reports).
    pub fn start_trace(&mut self) {
        self.trace = Some(Vec::new());
    }

    /// Takes the recorded frames (tracing continues).
    pub fn take_trace(&mut self) -> Vec<TraceEntry> {
        self.trace.as_mut().map(std::mem::take).unwrap_or_default()
    }

    /// Frames waiting for the medium.
    pub fn pending(&self) -> usize {
        self.queues.iter().map(VecDeque::len).sum()
    }

    fn frame_time(&self, frame: &CanFrame) -> core::time::Duration {
        if self.bitrate == 0 {
            core::time::Duration::ZERO
        } else {
            core::time::Duration::from_nanos(
                frame.bits() as u64 * 1_000_000_000 / self.bitrate as u64,
            )
        }
    }

    /// Delivers every frame whose transmission ends at or before `now`.
    fn deliver_until(&mut self, now: Instant) {
        loop {
            // Each node's transmit queue is FIFO (as a SocketCAN socket's is): only the head
            // of each queue competes. Among the heads waiting when the bus goes idle,
            // arbitration lets the lowest identifier win.
            let Some(earliest) = self
                .queues
                .iter()
                .filter_map(|q| q.front())
                .map(|p| p.ready)
                .min()
            else {
                return;
            };
            let start = earliest.max(self.bus_free_at);
            let Some(qi) = (0..self.queues.len())
                .filter(|&q| self.queues[q].front().is_some_and(|p| p.ready <= start))
                .min_by_key(|&q| {
                    let p = &self.queues[q][0];
                    (p.frame.id(), p.seq)
                })
            else {
                return;
            };
            let end = start + self.frame_time(&self.queues[qi][0].frame);
            if end > now {
                return;
            }
            let Some(p) = self.queues[qi].pop_front() else {
                return;
            };
            self.bus_free_at = end;
            self.counters.bus_frames += 1;
            self.counters.bus_bits += p.frame.bits() as u64;
            if let Some(t) = self.trace.as_mut() {
                t.push(TraceEntry {
                    at: end,
                    frame: p.frame,
                    origin: p.origin,
                });
            }
            if p.origin != Origin::Master {
                if self.master_rx.len() < self.master_rx_capacity {
                    self.master_rx.push_back(p.frame);
                } else {
                    self.counters.dropped += 1;
                }
            }
            for (n, (d, q)) in self
                .devices
                .iter_mut()
                .zip(&mut self.queues[1..])
                .enumerate()
            {
                if p.origin == Origin::Device(n) {
                    continue;
                }
                let mut sink = Sink {
                    pending: q,
                    seq: &mut self.seq,
                    origin: Origin::Device(n),
                };
                d.on_frame(&p.frame, end, &mut sink);
            }
        }
    }

    /// Runs the bus and the devices up to `now`: completes frames in order, lets devices
    /// answer, polls device timers at `now`, and completes what that produced. Going back in
    /// time is ignored.
    pub fn advance(&mut self, now: Instant) {
        let now = now.max(self.now);
        self.deliver_until(now);
        for (n, (d, q)) in self
            .devices
            .iter_mut()
            .zip(&mut self.queues[1..])
            .enumerate()
        {
            let mut sink = Sink {
                pending: q,
                seq: &mut self.seq,
                origin: Origin::Device(n),
            };
            d.poll(now, &mut sink);
        }
        self.deliver_until(now);
        self.now = now;
    }
}

impl<D: CanDevice> CanBus for SimBus<D> {
    /// Queues the master's frame at the current bus time.
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        self.seq += 1;
        self.queues[0].push_back(Pending {
            ready: self.now,
            seq: self.seq,
            frame: *frame,
            origin: Origin::Master,
        });
        self.counters.tx_frames += 1;
        Ok(())
    }

    fn recv(&mut self) -> Result<Option<CanFrame>, BusError> {
        let f = self.master_rx.pop_front();
        if f.is_some() {
            self.counters.rx_frames += 1;
        }
        Ok(f)
    }

    fn counters(&self) -> BusCounters {
        self.counters
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Echoes every frame with id + 1 and sends a "tick" frame on every poll if armed.
    struct Echo {
        seen: Vec<(Instant, CanFrame)>,
        tick: Option<u16>,
    }

    impl CanDevice for Echo {
        fn on_frame(&mut self, frame: &CanFrame, now: Instant, tx: &mut dyn FrameSink) {
            self.seen.push((now, *frame));
            if frame.id() < 0x700 {
                let f = CanFrame::new(frame.id() + 1, frame.data()).unwrap();
                tx.transmit(&f, now).unwrap();
            }
        }
        fn poll(&mut self, now: Instant, tx: &mut dyn FrameSink) {
            if let Some(id) = self.tick.take() {
                tx.transmit(&CanFrame::new(id, &[]).unwrap(), now).unwrap();
            }
        }
    }

    fn f(id: u16, n: usize) -> CanFrame {
        CanFrame::new(id, &[0u8; 8][..n]).unwrap()
    }

    #[test]
    fn frames_take_their_bit_time_and_replies_come_back() {
        let mut bus: SimBus<Echo> = SimBus::new(1_000_000);
        bus.attach(Echo {
            seen: vec![],
            tick: None,
        });
        bus.send(&f(0x600, 8)).unwrap();
        bus.advance(Instant::from_nanos(134_000));
        assert_eq!(
            bus.recv().unwrap(),
            None,
            "135 bits at 1 Mbit/s take 135 µs"
        );
        bus.advance(Instant::from_nanos(135_000));
        assert_eq!(
            bus.device(0).unwrap().seen,
            vec![(Instant::from_micros(135), f(0x600, 8))]
        );
        assert_eq!(bus.recv().unwrap(), None);
        bus.advance(Instant::from_micros(270));
        assert_eq!(bus.recv().unwrap(), Some(f(0x601, 8)));
        let c = bus.counters();
        assert_eq!(
            (c.tx_frames, c.rx_frames, c.bus_frames, c.bus_bits),
            (1, 1, 2, 270)
        );
        assert!(
            (c.load_percent(1_000_000, core::time::Duration::from_micros(270)) - 100.0).abs()
                < 1e-9
        );
    }

    #[test]
    fn arbitration_lowest_id_first_and_sender_does_not_hear_itself() {
        let mut bus: SimBus<Echo> = SimBus::new(500_000);
        bus.attach(Echo {
            seen: vec![],
            tick: Some(0x700),
        });
        bus.attach(Echo {
            seen: vec![],
            tick: Some(0x701),
        });
        bus.start_trace();
        bus.send(&f(0x7FF, 0)).unwrap();
        bus.send(&f(0x750, 0)).unwrap();
        bus.advance(Instant::from_millis(10));
        // The ticks were queued at 10 ms and finish on the wire after it.
        assert_eq!(bus.pending(), 2);
        bus.advance(Instant::from_millis(11));
        let ids: Vec<_> = bus
            .take_trace()
            .iter()
            .map(|t| (t.frame.id(), t.origin))
            .collect();
        // One sender's queue is FIFO: 0x7FF was queued first and goes first.
        assert_eq!(ids[0], (0x7FF, Origin::Master));
        assert_eq!(ids[1], (0x750, Origin::Master));
        // Device 1's tick (0x701) competes with device 0's (0x700): arbitration by id.
        assert_eq!(
            &ids[2..],
            &[(0x700, Origin::Device(0)), (0x701, Origin::Device(1))]
        );
        // Different senders at the same time: the lower id wins.
        bus.device_mut(0).unwrap().tick = Some(0x020);
        bus.device_mut(1).unwrap().tick = Some(0x010);
        bus.advance(Instant::from_millis(12));
        bus.advance(Instant::from_millis(13));
        let ids: Vec<_> = bus.take_trace().iter().map(|t| t.frame.id()).collect();
        assert_eq!(&ids[..2], &[0x010, 0x020]);
        assert!(
            bus.device(0)
                .unwrap()
                .seen
                .iter()
                .all(|(_, fr)| fr.id() != 0x020)
        );
    }

    #[test]
    fn zero_bitrate_delivers_at_once_in_one_advance() {
        let mut bus: SimBus<Echo> = SimBus::new(0);
        bus.attach(Echo {
            seen: vec![],
            tick: None,
        });
        bus.send(&f(0x100, 1)).unwrap();
        bus.advance(Instant::ZERO);
        assert_eq!(bus.recv().unwrap(), Some(f(0x101, 1)));
    }

    #[test]
    fn overloaded_bus_queues_frames_in_time() {
        // 20 × 135 bits = 2.7 ms of frames sent at t=0 on a 1 Mbit/s bus.
        let mut bus: SimBus<Echo> = SimBus::new(1_000_000);
        for i in 0..20 {
            bus.send(&f(0x700 + i, 8)).unwrap();
        }
        bus.advance(Instant::from_millis(1));
        assert_eq!(bus.counters().bus_frames, 7);
        bus.advance(Instant::from_millis(3));
        assert_eq!(bus.counters().bus_frames, 20);
        assert_eq!(bus.pending(), 0);
    }
}
