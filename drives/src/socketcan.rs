//! The SocketCAN transport: [`SocketCanBus`] is a [`CanBus`] and a [`TimedBus`] over a kernel
//! CAN_RAW socket (`can0`, `vcan0`) opened with the `socketcan` crate. Every received frame is
//! handed back in arrival order (PDO, EMCY, heartbeat and SDO alike: telling them apart is the
//! caller's job, as with [`crate::bus::SimBus`]); sends are bounded in time; error frames are
//! counted and bus-off is reported as [`BusError::BusOff`].

use core::fmt;
use std::io;
use std::time::{Duration, Instant as StdInstant};

use ::socketcan::{
    CanDataFrame, CanError, CanFrame as SkFrame, CanRemoteFrame, CanSocket, EmbeddedFrame,
    ErrorCause, Frame, Socket, SocketOptions, StandardId,
};

use crate::bus::{BusCounters, BusError, CanBus};
use crate::master::TimedBus;
use crate::time::Instant;
use crate::wire::CanFrame;

/// What one frame read from the socket is.
#[derive(Debug)]
enum Received {
    /// A CANopen (11-bit) data or remote frame.
    Frame(CanFrame),
    /// A 29-bit frame: not CANopen CC, counted and skipped.
    Extended,
    /// An error frame, decoded; bus-off is reported to the caller.
    Error { error: CanError, bus_off: bool },
}

/// Sorts a socket frame into what [`SocketCanBus`] does with it.
fn classify(f: SkFrame) -> Received {
    match f {
        SkFrame::Error(e) => {
            let error = e.into_error();
            let bus_off = error.causes().any(|c| matches!(c, ErrorCause::BusOff));
            Received::Error { error, bus_off }
        }
        f if f.is_extended() => Received::Extended,
        SkFrame::Remote(r) => match CanFrame::new_remote(r.raw_id() as u16, r.dlc() as u8) {
            Ok(frame) => Received::Frame(frame),
            Err(_) => Received::Extended,
        },
        SkFrame::Data(d) => match CanFrame::new(d.raw_id() as u16, d.data()) {
            Ok(frame) => Received::Frame(frame),
            Err(_) => Received::Extended,
        },
    }
}

/// errno values this module interprets, and socket option numbers (Linux).
mod errno {
    pub const SOL_SOCKET: i32 = 1;
    pub const SO_RCVBUFFORCE: i32 = 33;
    pub const ENODEV: i32 = 19;
    pub const EAFNOSUPPORT: i32 = 97;
    pub const ENETDOWN: i32 = 100;
    pub const ENOBUFS: i32 = 105;
    pub const EAGAIN: i32 = 11;
    pub const EINTR: i32 = 4;
}

/// Why a CAN interface could not be opened.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum OpenError {
    /// The running kernel has no AF_CAN sockets (errno 97, `CONFIG_CAN` not set).
    NoCanSupport {
        /// The interface asked for.
        iface: String,
    },
    /// No network interface of that name.
    NoSuchInterface {
        /// The interface asked for.
        iface: String,
    },
    /// Any other OS error while opening or configuring the socket.
    Io {
        /// The interface asked for.
        iface: String,
        /// errno (0 if unknown).
        errno: i32,
        /// The OS message.
        message: String,
    },
}

impl fmt::Display for OpenError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OpenError::NoCanSupport { iface } => write!(
                f,
                "cannot open CAN interface {iface}: this kernel has no CAN support (AF_CAN, \
                 errno 97): see vcan-setup.sh / hil-tests/run.sh"
            ),
            OpenError::NoSuchInterface { iface } => write!(
                f,
                "cannot open CAN interface {iface}: no such interface (create it: \
                 ./vcan-setup.sh {iface}, or `ip link set up {iface} type can bitrate ...`)"
            ),
            OpenError::Io {
                iface,
                errno,
                message,
            } => write!(
                f,
                "cannot open CAN interface {iface}: {message} (errno {errno})"
            ),
        }
    }
}

impl std::error::Error for OpenError {}

/// Transmit settings of a [`SocketCanBus`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SocketCanOptions {
    /// How long one `send` may wait for room in the transmit queue (ENOBUFS / EAGAIN are
    /// retried until then, then reported as [`BusError::TxQueueFull`]). The 1 ms cyclic loop
    /// should use `Duration::ZERO` (one attempt, never sleeps); tools keep the default.
    pub send_budget: Duration,
    /// Pass CAN error frames to this socket (counted; bus-off becomes an error).
    pub error_frames: bool,
    /// Receive buffer to ask for: the kernel drops frames a full socket buffer cannot take
    /// (one CAN frame costs ~1 KiB of buffer), so a reader that falls behind for a moment
    /// needs room. Set with SO_RCVBUFFORCE where allowed (root / CAP_NET_ADMIN), else
    /// SO_RCVBUF, which the kernel caps at net.core.rmem_max.
    pub recv_buffer_bytes: usize,
}

impl Default for SocketCanOptions {
    fn default() -> Self {
        SocketCanOptions {
            send_budget: Duration::from_millis(2),
            error_frames: true,
            recv_buffer_bytes: 1 << 20,
        }
    }
}

/// A SocketCAN endpoint (see the module doc).
pub struct SocketCanBus {
    socket: CanSocket,
    iface: String,
    epoch: StdInstant,
    options: SocketCanOptions,
    counters: BusCounters,
    error_frames: u64,
    last_error: Option<CanError>,
    extended_frames: u64,
    tx_retries: u64,
}

impl fmt::Debug for SocketCanBus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SocketCanBus")
            .field("iface", &self.iface)
            .field("counters", &self.counters)
            .field("error_frames", &self.error_frames)
            .finish()
    }
}

fn os_errno(e: &io::Error) -> i32 {
    e.raw_os_error().unwrap_or(0)
}

fn bus_error(e: &io::Error) -> BusError {
    match os_errno(e) {
        errno::ENETDOWN | errno::ENODEV => BusError::Down,
        errno::ENOBUFS | errno::EAGAIN => BusError::TxQueueFull,
        n => BusError::Io(n),
    }
}

/// A zero send budget makes the socket non-blocking, so a cyclic send is one attempt that
/// never sleeps (SO_SNDTIMEO cannot express that: the kernel rounds even 1 µs up to a whole
/// tick, 1–10 ms). A positive budget blocks on a full socket buffer for at most the budget
/// (SO_SNDTIMEO), and `send` retries ENOBUFS within it. Reads never block either way: they
/// follow a poll.
fn apply_send_budget(socket: &CanSocket, budget: Duration) -> io::Result<()> {
    if budget.is_zero() {
        return socket.set_nonblocking(true);
    }
    socket.set_nonblocking(false)?;
    socket.set_write_timeout(budget)
}

/// The socket could take no frame now (queue or buffer full, or interrupted); reads: no
/// frame (also a poll that timed out).
fn is_would_block(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted
    ) || matches!(os_errno(e), errno::EAGAIN | errno::EINTR)
}

impl SocketCanBus {
    /// Opens interface `iface` with default options.
    ///
    /// ```no_run
    /// use cnc402_drives::bus::CanBus;
    /// use cnc402_drives::socketcan::SocketCanBus;
    /// let mut bus = SocketCanBus::open("vcan0")?;
    /// while let Some(frame) = bus.recv_timeout(std::time::Duration::from_millis(100))? {
    ///     println!("{frame}");
    /// }
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn open(iface: &str) -> Result<SocketCanBus, OpenError> {
        SocketCanBus::open_with(iface, SocketCanOptions::default())
    }

    /// Opens interface `iface`. A missing interface and a kernel without CAN are told apart
    /// (the first is the interface-name lookup failing, the second the socket call).
    pub fn open_with(iface: &str, options: SocketCanOptions) -> Result<SocketCanBus, OpenError> {
        let io_err = |e: &io::Error| OpenError::Io {
            iface: iface.to_string(),
            errno: os_errno(e),
            message: e.to_string(),
        };
        let socket = match CanSocket::open(iface) {
            Ok(s) => s,
            Err(e) => {
                let n = os_errno(&e);
                if n == errno::EAFNOSUPPORT {
                    return Err(OpenError::NoCanSupport {
                        iface: iface.to_string(),
                    });
                }
                if n == errno::ENODEV || e.kind() == io::ErrorKind::NotFound {
                    // The name lookup runs before the socket call: tell a kernel without CAN
                    // (which cannot have the interface either) from a missing interface.
                    if let Err(probe) = CanSocket::open_iface(0)
                        && os_errno(&probe) == errno::EAFNOSUPPORT
                    {
                        return Err(OpenError::NoCanSupport {
                            iface: iface.to_string(),
                        });
                    }
                    return Err(OpenError::NoSuchInterface {
                        iface: iface.to_string(),
                    });
                }
                return Err(io_err(&e));
            }
        };
        apply_send_budget(&socket, options.send_budget).map_err(|e| io_err(&e))?;
        if options.recv_buffer_bytes > 0 {
            // SO_RCVBUFFORCE passes net.core.rmem_max (~208 KiB, ~200 frames) where the
            // process may (CAP_NET_ADMIN); otherwise SO_RCVBUF, capped by the kernel.
            let bytes = i32::try_from(options.recv_buffer_bytes).unwrap_or(i32::MAX);
            if socket
                .set_socket_option_int(errno::SOL_SOCKET, errno::SO_RCVBUFFORCE, bytes)
                .is_err()
            {
                socket
                    .as_raw_socket()
                    .set_recv_buffer_size(options.recv_buffer_bytes)
                    .map_err(|e| io_err(&e))?;
            }
        }
        if options.error_frames {
            socket
                .set_error_filter_accept_all()
                .map_err(|e| io_err(&e))?;
        }
        Ok(SocketCanBus {
            socket,
            iface: iface.to_string(),
            epoch: StdInstant::now(),
            options,
            counters: BusCounters::default(),
            error_frames: 0,
            last_error: None,
            extended_frames: 0,
            tx_retries: 0,
        })
    }

    /// The interface name.
    pub fn iface(&self) -> &str {
        &self.iface
    }

    /// Error frames received so far (bus-off included).
    pub fn error_frames(&self) -> u64 {
        self.error_frames
    }

    /// The last error frame, decoded (controller problems, protocol violations, bus-off).
    pub fn last_error(&self) -> Option<&CanError> {
        self.last_error.as_ref()
    }

    /// Frames with a 29-bit identifier seen and skipped (CANopen CC uses 11-bit ids only).
    pub fn extended_frames(&self) -> u64 {
        self.extended_frames
    }

    /// The current send budget (see [`SocketCanOptions::send_budget`]).
    pub fn send_budget(&self) -> Duration {
        self.options.send_budget
    }

    /// Changes the send budget (see [`SocketCanOptions::send_budget`]): a generous one while
    /// booting, `Duration::ZERO` for the 1 ms cyclic loop. The budget applies at once; an
    /// error means the socket's write timeout could not be changed (the budget is set anyway).
    pub fn set_send_budget(&mut self, budget: Duration) -> Result<(), BusError> {
        self.options.send_budget = budget;
        apply_send_budget(&self.socket, budget).map_err(|e| bus_error(&e))
    }

    /// Sends that found the transmit queue full at least once and were retried.
    pub fn tx_retries(&self) -> u64 {
        self.tx_retries
    }

    fn to_socket_frame(frame: &CanFrame) -> Option<SkFrame> {
        let id = StandardId::new(frame.id())?;
        if frame.is_remote() {
            CanRemoteFrame::new_remote(id, frame.dlc()).map(SkFrame::Remote)
        } else {
            CanDataFrame::new(id, frame.data()).map(SkFrame::Data)
        }
    }

    /// Takes in one frame from the socket: `Ok(Some)` for a CANopen frame, `Ok(None)` for one
    /// that was counted and skipped (error frame, 29-bit id), `Err` for bus-off.
    fn take(&mut self, f: SkFrame) -> Result<Option<CanFrame>, BusError> {
        match classify(f) {
            Received::Frame(frame) => Ok(Some(self.count_rx(frame))),
            Received::Extended => {
                self.extended_frames += 1;
                self.counters.bus_frames += 1;
                Ok(None)
            }
            Received::Error { error, bus_off } => {
                self.error_frames += 1;
                self.last_error = Some(error);
                if bus_off {
                    Err(BusError::BusOff)
                } else {
                    Ok(None)
                }
            }
        }
    }

    fn count_rx(&mut self, frame: CanFrame) -> CanFrame {
        self.counters.rx_frames += 1;
        self.counters.bus_frames += 1;
        self.counters.bus_bits += frame.bits() as u64;
        frame
    }
}

impl CanBus for SocketCanBus {
    /// Writes the frame; on a full transmit queue (ENOBUFS, or the socket buffer full) it
    /// retries until [`SocketCanOptions::send_budget`] has passed, then reports
    /// [`BusError::TxQueueFull`]. A 29-bit or malformed frame cannot occur (`CanFrame` is
    /// 11-bit).
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        let Some(sk) = Self::to_socket_frame(frame) else {
            return Err(BusError::Io(0));
        };
        // The clock is read only once the queue is found full, and never with a zero budget
        // (the cyclic loop: one attempt on a non-blocking socket).
        let mut start: Option<StdInstant> = None;
        let mut retried = false;
        loop {
            match self.socket.write_frame(&sk) {
                Ok(()) => {
                    self.counters.tx_frames += 1;
                    self.counters.bus_frames += 1;
                    self.counters.bus_bits += frame.bits() as u64;
                    if retried {
                        self.tx_retries += 1;
                    }
                    return Ok(());
                }
                Err(e) => {
                    if !(is_would_block(&e) || os_errno(&e) == errno::ENOBUFS) {
                        return Err(bus_error(&e));
                    }
                    let budget = self.options.send_budget;
                    if budget.is_zero()
                        || start.get_or_insert_with(StdInstant::now).elapsed() >= budget
                    {
                        self.counters.dropped += 1;
                        return Err(BusError::TxQueueFull);
                    }
                    retried = true;
                    // ENOBUFS returns at once (the qdisc is full, the socket does not wait):
                    // give the controller time to drain a frame (~135 µs at 1 Mbit/s).
                    std::thread::sleep(Duration::from_micros(100));
                }
            }
        }
    }

    /// The next frame if one is queued in the socket; never waits.
    fn recv(&mut self) -> Result<Option<CanFrame>, BusError> {
        loop {
            match self.socket.read_frame_timeout(Duration::ZERO) {
                Ok(f) => match self.take(f)? {
                    Some(frame) => return Ok(Some(frame)),
                    None => continue,
                },
                Err(e) if is_would_block(&e) => return Ok(None),
                Err(e) => return Err(bus_error(&e)),
            }
        }
    }

    /// The next frame, waiting at most `timeout`. Whole milliseconds wait in poll(2)
    /// (never past the deadline); the sub-millisecond rest in short sleeps with a poll
    /// between them, so the wait ends within ~0.1 ms of the deadline. (SO_RCVTIMEO is not
    /// used: the kernel rounds it up to whole jiffies, 4 ms at HZ=250.)
    fn recv_timeout(&mut self, timeout: Duration) -> Result<Option<CanFrame>, BusError> {
        let deadline = StdInstant::now() + timeout;
        loop {
            if let Some(f) = self.recv()? {
                return Ok(Some(f));
            }
            let left = deadline.saturating_duration_since(StdInstant::now());
            if left.is_zero() {
                return Ok(None);
            }
            if left >= Duration::from_millis(1) {
                let whole = Duration::from_millis(left.as_millis() as u64);
                match self.socket.read_frame_timeout(whole) {
                    Ok(f) => {
                        if let Some(frame) = self.take(f)? {
                            return Ok(Some(frame));
                        }
                    }
                    Err(e) if is_would_block(&e) => {}
                    Err(e) => return Err(bus_error(&e)),
                }
            } else {
                std::thread::sleep(left.min(Duration::from_micros(50)));
            }
        }
    }

    fn counters(&self) -> BusCounters {
        self.counters
    }
}

impl TimedBus for SocketCanBus {
    /// Time since the socket was opened, on the monotonic clock.
    fn now(&self) -> Instant {
        Instant::from_nanos(u64::try_from(self.epoch.elapsed().as_nanos()).unwrap_or(u64::MAX))
    }

    fn recv_until(&mut self, deadline: Instant) -> Result<Option<CanFrame>, BusError> {
        let now = TimedBus::now(self);
        if now >= deadline {
            return self.recv();
        }
        match self.recv_timeout(deadline - now)? {
            Some(f) => Ok(Some(f)),
            None => {
                // Clocks read at slightly different moments: the contract is now() >= deadline.
                while TimedBus::now(self) < deadline {
                    std::hint::spin_loop();
                }
                Ok(None)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn open_errors_are_told_apart_and_named() {
        // Either outcome is right on some machine; what matters is the message. On a kernel
        // without CAN every name gives NoCanSupport; with CAN a made-up name gives
        // NoSuchInterface.
        match SocketCanBus::open("nosuchcan7") {
            Err(e @ OpenError::NoCanSupport { .. }) => {
                let s = e.to_string();
                assert!(s.contains("no CAN support"), "{s}");
                assert!(s.contains("errno 97"), "{s}");
                assert!(s.contains("hil-tests/run.sh"), "{s}");
            }
            Err(e @ OpenError::NoSuchInterface { .. }) => {
                assert!(e.to_string().contains("nosuchcan7: no such interface"));
            }
            other => panic!("unexpected: {other:?}"),
        }
    }

    #[test]
    fn frames_convert_both_ways() {
        let f = CanFrame::new(0x601, &[0x40, 0x41, 0x60, 0, 0, 0, 0, 0]).unwrap();
        let sk = SocketCanBus::to_socket_frame(&f).unwrap();
        assert_eq!(sk.raw_id(), 0x601);
        assert_eq!(sk.data(), f.data());
        let r = CanFrame::new_remote(0x701, 1).unwrap();
        let sk = SocketCanBus::to_socket_frame(&r).unwrap();
        assert!(matches!(sk, SkFrame::Remote(_)));
        assert_eq!(sk.dlc(), 1);
    }

    #[test]
    fn received_frames_are_sorted_and_bus_off_is_an_error() {
        use ::socketcan::{CanErrorFrame, ExtendedId};
        // CAN_ERR_BUSOFF (0x40 in the id) → bus-off.
        let bus_off = SkFrame::Error(CanErrorFrame::new_error(0x40, &[]).unwrap());
        assert!(matches!(
            classify(bus_off),
            Received::Error { bus_off: true, .. }
        ));
        // CAN_ERR_CRTL with "error passive" in data[1]: counted, not fatal.
        let passive = SkFrame::Error(CanErrorFrame::new_error(0x04, &[0, 0x20]).unwrap());
        assert!(matches!(
            classify(passive),
            Received::Error { bus_off: false, .. }
        ));
        let ext =
            SkFrame::Data(CanDataFrame::new(ExtendedId::new(0x1ABC_0001).unwrap(), &[1]).unwrap());
        assert!(matches!(classify(ext), Received::Extended));
        let data = SkFrame::Data(
            CanDataFrame::new(StandardId::new(0x181).unwrap(), &[0x37, 0x02]).unwrap(),
        );
        match classify(data) {
            Received::Frame(f) => assert_eq!(f.to_string(), "181#3702"),
            other => panic!("{other:?}"),
        }
        let rtr = SkFrame::Remote(
            CanRemoteFrame::new_remote(StandardId::new(0x703).unwrap(), 1).unwrap(),
        );
        match classify(rtr) {
            Received::Frame(f) => assert!(f.is_remote() && f.id() == 0x703 && f.dlc() == 1),
            other => panic!("{other:?}"),
        }
    }
}
