//! The SDO client: an explicit, non-blocking state machine ([`SdoClient`]: feed it received
//! frames and the time, send what it returns) for expedited and segmented upload/download of
//! any length, plus a blocking convenience ([`BlockingSdo`]) over any [`TimedBus`] for use
//! outside the cyclic loop.
//!
//! Not canopen-host 0.6.1's SDO helpers: they do not check the response's index/sub-index,
//! have no timeout, never send an abort frame, cap segmented data at 32 bytes, and throw away
//! every non-SDO frame that arrives while they wait (PDOs, EMCY, heartbeats are lost). Here
//! every response is checked against the request's multiplexer, a timeout sends abort
//! 0x05040000 to the server, and frames that are not this transfer's are handed back.

use core::fmt;
use core::time::Duration;

use super::timed::TimedBus;
use crate::bus::BusError;
use crate::time::Instant;
use crate::wire::{
    AbortCode, CanFrame, ExpeditedData, Function, InitiateKind, NodeId, SdoRequest, SdoResponse,
    SdoSegment,
};

/// Why an SDO transfer failed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SdoErrorKind {
    /// The server aborted the transfer with this code.
    Aborted(AbortCode),
    /// No response within the timeout; abort 0x05040000 was sent to the server.
    Timeout {
        /// The timeout that expired.
        after: Duration,
    },
    /// The server broke the protocol; the client sent abort `sent` to it.
    Protocol {
        /// The abort code the client sent.
        sent: AbortCode,
        /// What was wrong.
        what: ProtocolViolation,
    },
    /// The value read has a size the caller's type does not match.
    WrongSize {
        /// Bytes expected.
        expected: usize,
        /// Bytes received.
        got: usize,
    },
    /// A transfer is already running on this client.
    Busy,
    /// In cyclic operation the bus has no room for SDO next to the PDOs.
    NoBusCapacity {
        /// Share of the bus the cyclic frames and heartbeats use.
        cyclic_load_percent: f64,
    },
    /// The axis addressed has no drive (virtual axis or index out of range).
    NoDrive {
        /// The axis index.
        axis: usize,
    },
    /// The transport failed.
    Bus(BusError),
}

/// How a server broke the SDO protocol.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProtocolViolation {
    /// A response for another object (index, sub-index) than the one requested.
    WrongObject {
        /// The multiplexer in the response.
        index: u16,
        /// Its sub-index.
        sub: u8,
    },
    /// A segment with the toggle bit not alternated.
    Toggle,
    /// A response of a kind that does not fit the transfer's state.
    UnexpectedResponse,
    /// A frame on the SDO response COB-ID that is no valid SDO response.
    Malformed,
    /// More (or less) data than the indicated size.
    SizeMismatch {
        /// The size the server indicated.
        indicated: u32,
        /// Bytes received.
        received: usize,
    },
}

impl fmt::Display for ProtocolViolation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ProtocolViolation::WrongObject { index, sub } => {
                write!(f, "response names object {index:#06x}:{sub:02x}")
            }
            ProtocolViolation::Toggle => write!(f, "toggle bit not alternated"),
            ProtocolViolation::UnexpectedResponse => write!(f, "unexpected response"),
            ProtocolViolation::Malformed => write!(f, "malformed SDO response"),
            ProtocolViolation::SizeMismatch {
                indicated,
                received,
            } => write!(f, "indicated {indicated} bytes, received {received}"),
        }
    }
}

/// A failed SDO transfer, naming the node and the object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SdoError {
    /// The server's node id.
    pub node: u8,
    /// Object index.
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
    /// Download (write) or upload (read).
    pub write: bool,
    /// What went wrong.
    pub kind: SdoErrorKind,
}

impl SdoError {
    /// The abort code the server sent, if it aborted.
    pub fn abort_code(&self) -> Option<AbortCode> {
        match self.kind {
            SdoErrorKind::Aborted(c) => Some(c),
            _ => None,
        }
    }
}

impl fmt::Display for SdoError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let op = if self.write { "write" } else { "read" };
        write!(
            f,
            "node {}: SDO {op} of {:#06x}:{:02x}: ",
            self.node, self.index, self.sub
        )?;
        match self.kind {
            SdoErrorKind::Aborted(code) => write!(f, "aborted by the drive with {code}"),
            SdoErrorKind::Timeout { after } => write!(
                f,
                "no response within {} ms (abort {} sent)",
                after.as_millis(),
                AbortCode::Timeout
            ),
            SdoErrorKind::Protocol { sent, what } => {
                write!(f, "protocol error: {what} (abort {sent} sent)")
            }
            SdoErrorKind::WrongSize { expected, got } => {
                write!(f, "value has {got} bytes, expected {expected}")
            }
            SdoErrorKind::Busy => write!(f, "another SDO transfer is running"),
            SdoErrorKind::NoBusCapacity {
                cyclic_load_percent,
            } => write!(
                f,
                "no bus capacity during cyclic operation (cyclic frames use \
                 {cyclic_load_percent:.1} %); use a longer period or SDO at standstill"
            ),
            SdoErrorKind::NoDrive { axis } => write!(f, "axis {axis} has no drive"),
            SdoErrorKind::Bus(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for SdoError {}

/// What [`SdoClient::on_frame`] / [`SdoClient::poll`] asks the caller to do.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SdoEvent {
    /// The frame is not an SDO response of this client's server: handle it elsewhere.
    NotMine,
    /// Nothing to do (no transfer running, or nothing due).
    Idle,
    /// Send this request; the transfer continues.
    Send(CanFrame),
    /// The transfer completed (upload data in [`SdoClient::data`]).
    Done,
    /// The transfer failed; send `abort` to the server if present.
    Failed(SdoError, Option<CanFrame>),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Idle,
    /// Waiting for the initiate upload response.
    UploadInitiate,
    /// Waiting for an upload segment with this toggle.
    UploadSegment {
        toggle: bool,
    },
    /// Waiting for the initiate download confirmation.
    DownloadInitiate,
    /// Waiting for the confirmation of the download segment with this toggle.
    DownloadSegment {
        toggle: bool,
    },
}

/// A non-blocking SDO client for one server node. Start a transfer, send the frame it returns,
/// then feed it every received frame ([`on_frame`](Self::on_frame)) and the time
/// ([`poll`](Self::poll)); it answers with the next frame to send, completion or failure.
/// The data buffer is reused between transfers (no allocation once it is large enough).
#[derive(Clone, Debug)]
pub struct SdoClient {
    node: NodeId,
    timeout: Duration,
    phase: Phase,
    index: u16,
    sub: u8,
    deadline: Instant,
    buf: Vec<u8>,
    /// Download: bytes sent so far. Upload: unused.
    pos: usize,
    /// Upload: size indicated by the server.
    indicated: Option<u32>,
    /// Upload: an expedited response without size indication (4 bytes, type decides).
    unsized_expedited: bool,
}

impl SdoClient {
    /// Initial buffer capacity: uploads and downloads up to this size never allocate.
    pub const BUFFER_CAPACITY: usize = 256;

    /// A client for server `node` with response timeout `timeout`.
    pub fn new(node: NodeId, timeout: Duration) -> SdoClient {
        SdoClient {
            node,
            timeout,
            phase: Phase::Idle,
            index: 0,
            sub: 0,
            deadline: Instant::ZERO,
            buf: Vec::with_capacity(Self::BUFFER_CAPACITY),
            pos: 0,
            indicated: None,
            unsized_expedited: false,
        }
    }

    /// The server.
    pub fn node(&self) -> NodeId {
        self.node
    }

    /// Whether a transfer is running.
    pub fn is_busy(&self) -> bool {
        self.phase != Phase::Idle
    }

    /// The object of the current (or last) transfer.
    pub fn object(&self) -> (u16, u8) {
        (self.index, self.sub)
    }

    /// The data of the last completed upload.
    pub fn data(&self) -> &[u8] {
        &self.buf
    }

    /// Whether the last upload was expedited without size indication (all 4 bytes carried;
    /// the reader's type decides how many are meaningful).
    pub fn size_unknown(&self) -> bool {
        self.unsized_expedited
    }

    fn error(&self, kind: SdoErrorKind) -> SdoError {
        SdoError {
            node: self.node.get(),
            index: self.index,
            sub: self.sub,
            write: matches!(
                self.phase,
                Phase::DownloadInitiate | Phase::DownloadSegment { .. }
            ),
            kind,
        }
    }

    fn busy(&self, index: u16, sub: u8, write: bool) -> SdoError {
        SdoError {
            node: self.node.get(),
            index,
            sub,
            write,
            kind: SdoErrorKind::Busy,
        }
    }

    /// Starts reading `index:sub`; returns the request frame to send.
    pub fn start_upload(
        &mut self,
        index: u16,
        sub: u8,
        now: Instant,
    ) -> Result<CanFrame, SdoError> {
        if self.is_busy() {
            return Err(self.busy(index, sub, false));
        }
        self.index = index;
        self.sub = sub;
        self.buf.clear();
        self.indicated = None;
        self.unsized_expedited = false;
        self.phase = Phase::UploadInitiate;
        self.deadline = now + self.timeout;
        Ok(SdoRequest::InitiateUpload { index, sub }.emit(self.node))
    }

    /// Starts writing `data` (any length; 1..=4 bytes go expedited) to `index:sub`; returns
    /// the request frame to send. An empty `data` is sent as a segmented download of size 0.
    pub fn start_download(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        now: Instant,
    ) -> Result<CanFrame, SdoError> {
        if self.is_busy() {
            return Err(self.busy(index, sub, true));
        }
        self.index = index;
        self.sub = sub;
        self.buf.clear();
        self.buf.extend_from_slice(data);
        self.pos = 0;
        self.phase = Phase::DownloadInitiate;
        self.deadline = now + self.timeout;
        let kind = match ExpeditedData::new(data) {
            Ok(e) => InitiateKind::Expedited(e),
            Err(_) => InitiateKind::Segmented {
                size: Some(data.len().min(u32::MAX as usize) as u32),
            },
        };
        Ok(SdoRequest::InitiateDownload { index, sub, kind }.emit(self.node))
    }

    /// Abandons a running transfer; returns the abort frame (general error 0x08000000 unless
    /// `code` is given) to send to the server, or `None` when idle.
    pub fn cancel(&mut self, code: Option<AbortCode>) -> Option<CanFrame> {
        if !self.is_busy() {
            return None;
        }
        self.phase = Phase::Idle;
        Some(self.abort_frame(code.unwrap_or(AbortCode::General)))
    }

    fn abort_frame(&self, code: AbortCode) -> CanFrame {
        SdoRequest::Abort {
            index: self.index,
            sub: self.sub,
            code,
        }
        .emit(self.node)
    }

    fn fail_protocol(&mut self, what: ProtocolViolation) -> SdoEvent {
        let sent = match what {
            ProtocolViolation::Toggle => AbortCode::ToggleNotAlternated,
            ProtocolViolation::UnexpectedResponse | ProtocolViolation::Malformed => {
                AbortCode::BadCommand
            }
            ProtocolViolation::SizeMismatch { .. } => AbortCode::LengthMismatch,
            ProtocolViolation::WrongObject { .. } => AbortCode::General,
        };
        let err = self.error(SdoErrorKind::Protocol { sent, what });
        let abort = self.abort_frame(sent);
        self.phase = Phase::Idle;
        SdoEvent::Failed(err, Some(abort))
    }

    /// Checks the time: after the timeout, the transfer fails and abort 0x05040000 is to be
    /// sent to the server.
    pub fn poll(&mut self, now: Instant) -> SdoEvent {
        if self.phase == Phase::Idle || now < self.deadline {
            return SdoEvent::Idle;
        }
        let err = self.error(SdoErrorKind::Timeout {
            after: self.timeout,
        });
        let abort = self.abort_frame(AbortCode::Timeout);
        self.phase = Phase::Idle;
        SdoEvent::Failed(err, Some(abort))
    }

    /// Feeds a received frame. Frames that are not SDO responses from this client's server
    /// give [`SdoEvent::NotMine`]; the caller must handle them (nothing is dropped here).
    pub fn on_frame(&mut self, frame: &CanFrame, now: Instant) -> SdoEvent {
        if frame.function() != Function::SdoTx(self.node) {
            return SdoEvent::NotMine;
        }
        if self.phase == Phase::Idle {
            // A late answer to a transfer that already ended (e.g. after a timeout).
            return SdoEvent::Idle;
        }
        let resp = match SdoResponse::parse(frame) {
            Ok((_, r)) => r,
            Err(_) => return self.fail_protocol(ProtocolViolation::Malformed),
        };
        if let SdoResponse::Abort { index, sub, code } = resp {
            // An abort for another object is still the end of this transfer (one SDO channel
            // per server); report the code the server gave.
            let _ = (index, sub);
            let err = self.error(SdoErrorKind::Aborted(code));
            self.phase = Phase::Idle;
            return SdoEvent::Failed(err, None);
        }
        if let Some((index, sub)) = resp.multiplexer()
            && (index, sub) != (self.index, self.sub)
        {
            return self.fail_protocol(ProtocolViolation::WrongObject { index, sub });
        }
        self.deadline = now + self.timeout;
        match (self.phase, resp) {
            (Phase::UploadInitiate, SdoResponse::InitiateUpload { kind, .. }) => match kind {
                InitiateKind::Expedited(e) => {
                    self.buf.extend_from_slice(e.bytes());
                    self.unsized_expedited = e.size().is_none();
                    self.phase = Phase::Idle;
                    SdoEvent::Done
                }
                InitiateKind::Segmented { size } => {
                    self.indicated = size;
                    self.phase = Phase::UploadSegment { toggle: false };
                    SdoEvent::Send(SdoRequest::UploadSegment { toggle: false }.emit(self.node))
                }
            },
            (Phase::UploadSegment { toggle }, SdoResponse::UploadSegment(seg)) => {
                if seg.toggle != toggle {
                    return self.fail_protocol(ProtocolViolation::Toggle);
                }
                self.buf.extend_from_slice(seg.data());
                if let Some(ind) = self.indicated
                    && (self.buf.len() > ind as usize
                        || (seg.last && self.buf.len() != ind as usize))
                {
                    return self.fail_protocol(ProtocolViolation::SizeMismatch {
                        indicated: ind,
                        received: self.buf.len(),
                    });
                }
                if seg.last {
                    self.phase = Phase::Idle;
                    SdoEvent::Done
                } else {
                    self.phase = Phase::UploadSegment { toggle: !toggle };
                    SdoEvent::Send(SdoRequest::UploadSegment { toggle: !toggle }.emit(self.node))
                }
            }
            (Phase::DownloadInitiate, SdoResponse::InitiateDownload { .. }) => {
                if self.buf.len() <= 4 && !self.buf.is_empty() {
                    self.phase = Phase::Idle;
                    return SdoEvent::Done;
                }
                self.next_download_segment(false)
            }
            (Phase::DownloadSegment { toggle }, SdoResponse::DownloadSegment { toggle: t }) => {
                if t != toggle {
                    return self.fail_protocol(ProtocolViolation::Toggle);
                }
                if self.pos >= self.buf.len() {
                    self.phase = Phase::Idle;
                    return SdoEvent::Done;
                }
                self.next_download_segment(!toggle)
            }
            _ => self.fail_protocol(ProtocolViolation::UnexpectedResponse),
        }
    }

    fn next_download_segment(&mut self, toggle: bool) -> SdoEvent {
        let end = (self.pos + 7).min(self.buf.len());
        let last = end == self.buf.len();
        let seg = match SdoSegment::new(toggle, last, &self.buf[self.pos..end]) {
            Ok(s) => s,
            // Unreachable by construction (≤ 7 bytes); fail rather than panic.
            Err(_) => return self.fail_protocol(ProtocolViolation::UnexpectedResponse),
        };
        self.pos = end;
        self.phase = Phase::DownloadSegment { toggle };
        SdoEvent::Send(SdoRequest::DownloadSegment(seg).emit(self.node))
    }
}

/// Decodes a little-endian value of `N` bytes from an upload's data. Exactly `N` bytes are
/// required, except after an expedited upload without size indication, which carries 4 bytes
/// of which the type's first `N` count.
pub fn decode_le<const N: usize>(data: &[u8], size_unknown: bool) -> Option<[u8; N]> {
    if data.len() == N || (size_unknown && data.len() >= N) {
        let mut b = [0u8; N];
        b.copy_from_slice(&data[..N]);
        Some(b)
    } else {
        None
    }
}

/// Blocking SDO transfers over a [`TimedBus`], for use outside the cyclic loop (boot,
/// configuration, `drivectl`). Frames that arrive while waiting and are not this transfer's
/// response go to `other` — nothing is dropped.
pub struct BlockingSdo<'a, B: TimedBus + ?Sized> {
    bus: &'a mut B,
    timeout: Duration,
    other: &'a mut dyn FnMut(&CanFrame),
}

impl<'a, B: TimedBus + ?Sized> BlockingSdo<'a, B> {
    /// Transfers on `bus` with response timeout `timeout`; other frames go to `other`.
    pub fn new(
        bus: &'a mut B,
        timeout: Duration,
        other: &'a mut dyn FnMut(&CanFrame),
    ) -> BlockingSdo<'a, B> {
        BlockingSdo {
            bus,
            timeout,
            other,
        }
    }

    /// The bus's time.
    pub fn now(&self) -> Instant {
        self.bus.now()
    }

    /// The bus (to send NMT or other frames between transfers).
    pub fn bus(&mut self) -> &mut B {
        self.bus
    }

    /// Lets `d` pass on the bus, handing every frame that arrives to `other`.
    pub fn wait(&mut self, d: Duration) -> Result<(), BusError> {
        let deadline = self.bus.now() + d;
        while let Some(f) = self.bus.recv_until(deadline)? {
            (self.other)(&f);
        }
        Ok(())
    }

    fn run(&mut self, client: &mut SdoClient, first: CanFrame) -> Result<(), SdoError> {
        let bus_err = |c: &SdoClient, e: BusError, write: bool| SdoError {
            node: c.node.get(),
            index: c.index,
            sub: c.sub,
            write,
            kind: SdoErrorKind::Bus(e),
        };
        let write = matches!(client.phase, Phase::DownloadInitiate);
        self.bus
            .send(&first)
            .map_err(|e| bus_err(client, e, write))?;
        loop {
            let deadline = client.deadline;
            let frame = self
                .bus
                .recv_until(deadline)
                .map_err(|e| bus_err(client, e, write))?;
            let now = self.bus.now();
            let ev = match frame {
                Some(f) => match client.on_frame(&f, now) {
                    SdoEvent::NotMine => {
                        (self.other)(&f);
                        continue;
                    }
                    ev => ev,
                },
                None => client.poll(now),
            };
            match ev {
                SdoEvent::NotMine | SdoEvent::Idle => {}
                SdoEvent::Send(f) => self.bus.send(&f).map_err(|e| bus_err(client, e, write))?,
                SdoEvent::Done => return Ok(()),
                SdoEvent::Failed(err, abort) => {
                    if let Some(a) = abort {
                        // The transfer has failed already; a send error adds nothing.
                        let _ = self.bus.send(&a);
                    }
                    return Err(err);
                }
            }
        }
    }

    /// Reads `index:sub` of `node`; returns the raw bytes (any length).
    pub fn upload(&mut self, node: NodeId, index: u16, sub: u8) -> Result<Vec<u8>, SdoError> {
        let mut c = SdoClient::new(node, self.timeout);
        let first = c.start_upload(index, sub, self.bus.now())?;
        self.run(&mut c, first)?;
        Ok(c.buf)
    }

    /// Writes `data` (any length) to `index:sub` of `node`.
    pub fn download(
        &mut self,
        node: NodeId,
        index: u16,
        sub: u8,
        data: &[u8],
    ) -> Result<(), SdoError> {
        let mut c = SdoClient::new(node, self.timeout);
        let first = c.start_download(index, sub, data, self.bus.now())?;
        self.run(&mut c, first)
    }

    fn read_n<const N: usize>(
        &mut self,
        node: NodeId,
        index: u16,
        sub: u8,
    ) -> Result<[u8; N], SdoError> {
        let mut c = SdoClient::new(node, self.timeout);
        let first = c.start_upload(index, sub, self.bus.now())?;
        self.run(&mut c, first)?;
        decode_le::<N>(c.data(), c.size_unknown()).ok_or(SdoError {
            node: node.get(),
            index,
            sub,
            write: false,
            kind: SdoErrorKind::WrongSize {
                expected: N,
                got: c.data().len(),
            },
        })
    }

    /// Reads an UNSIGNED8.
    pub fn read_u8(&mut self, node: NodeId, index: u16, sub: u8) -> Result<u8, SdoError> {
        self.read_n::<1>(node, index, sub).map(u8::from_le_bytes)
    }
    /// Reads an INTEGER8.
    pub fn read_i8(&mut self, node: NodeId, index: u16, sub: u8) -> Result<i8, SdoError> {
        self.read_n::<1>(node, index, sub).map(i8::from_le_bytes)
    }
    /// Reads an UNSIGNED16.
    pub fn read_u16(&mut self, node: NodeId, index: u16, sub: u8) -> Result<u16, SdoError> {
        self.read_n::<2>(node, index, sub).map(u16::from_le_bytes)
    }
    /// Reads an UNSIGNED32.
    pub fn read_u32(&mut self, node: NodeId, index: u16, sub: u8) -> Result<u32, SdoError> {
        self.read_n::<4>(node, index, sub).map(u32::from_le_bytes)
    }
    /// Reads an INTEGER32.
    pub fn read_i32(&mut self, node: NodeId, index: u16, sub: u8) -> Result<i32, SdoError> {
        self.read_n::<4>(node, index, sub).map(i32::from_le_bytes)
    }
    /// Reads a VISIBLE_STRING (invalid UTF-8 is replaced, trailing NULs dropped).
    pub fn read_string(&mut self, node: NodeId, index: u16, sub: u8) -> Result<String, SdoError> {
        let raw = self.upload(node, index, sub)?;
        let s = String::from_utf8_lossy(&raw);
        Ok(s.trim_end_matches('\0').to_string())
    }
    /// Writes an UNSIGNED8.
    pub fn write_u8(&mut self, node: NodeId, index: u16, sub: u8, v: u8) -> Result<(), SdoError> {
        self.download(node, index, sub, &v.to_le_bytes())
    }
    /// Writes an INTEGER8.
    pub fn write_i8(&mut self, node: NodeId, index: u16, sub: u8, v: i8) -> Result<(), SdoError> {
        self.download(node, index, sub, &v.to_le_bytes())
    }
    /// Writes an UNSIGNED16.
    pub fn write_u16(&mut self, node: NodeId, index: u16, sub: u8, v: u16) -> Result<(), SdoError> {
        self.download(node, index, sub, &v.to_le_bytes())
    }
    /// Writes an INTEGER16.
    pub fn write_i16(&mut self, node: NodeId, index: u16, sub: u8, v: i16) -> Result<(), SdoError> {
        self.download(node, index, sub, &v.to_le_bytes())
    }
    /// Writes an UNSIGNED32.
    pub fn write_u32(&mut self, node: NodeId, index: u16, sub: u8, v: u32) -> Result<(), SdoError> {
        self.download(node, index, sub, &v.to_le_bytes())
    }
    /// Writes an INTEGER32.
    pub fn write_i32(&mut self, node: NodeId, index: u16, sub: u8, v: i32) -> Result<(), SdoError> {
        self.download(node, index, sub, &v.to_le_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn n(id: u8) -> NodeId {
        NodeId::new(id).unwrap()
    }
    fn resp(node: u8, r: SdoResponse) -> CanFrame {
        r.emit(n(node))
    }
    const T: Duration = Duration::from_millis(100);

    #[test]
    fn expedited_upload_checks_the_object() {
        let mut c = SdoClient::new(n(3), T);
        let f = c.start_upload(0x6064, 0, Instant::ZERO).unwrap();
        assert_eq!(f.to_string(), "603#4064600000000000");
        // A reply for 0x6041 is a protocol error, not accepted as 0x6064.
        let wrong = resp(
            3,
            SdoResponse::InitiateUpload {
                index: 0x6041,
                sub: 0,
                kind: InitiateKind::Expedited(ExpeditedData::new(&[0x37, 0x02]).unwrap()),
            },
        );
        match c.on_frame(&wrong, Instant::ZERO) {
            SdoEvent::Failed(e, Some(abort)) => {
                assert_eq!(
                    e.kind,
                    SdoErrorKind::Protocol {
                        sent: AbortCode::General,
                        what: ProtocolViolation::WrongObject {
                            index: 0x6041,
                            sub: 0
                        }
                    }
                );
                assert_eq!(abort.to_string(), "603#8064600000000008");
            }
            other => panic!("{other:?}"),
        }
        // Unsized expedited (0x42) is accepted.
        c.start_upload(0x6064, 0, Instant::ZERO).unwrap();
        let ok = resp(
            3,
            SdoResponse::InitiateUpload {
                index: 0x6064,
                sub: 0,
                kind: InitiateKind::Expedited(ExpeditedData::without_size([1, 2, 3, 4])),
            },
        );
        assert_eq!(ok.data()[0], 0x42);
        assert_eq!(c.on_frame(&ok, Instant::ZERO), SdoEvent::Done);
        assert!(c.size_unknown());
        assert_eq!(decode_le::<2>(c.data(), true), Some([1, 2]));
        assert_eq!(decode_le::<2>(&[1, 2, 3, 4], false), None);
    }

    #[test]
    fn other_frames_are_not_mine() {
        let mut c = SdoClient::new(n(3), T);
        c.start_upload(0x1000, 0, Instant::ZERO).unwrap();
        for id in [0x183u16, 0x083, 0x703, 0x584, 0x603] {
            let f = CanFrame::new(id, &[0; 8]).unwrap();
            assert_eq!(c.on_frame(&f, Instant::ZERO), SdoEvent::NotMine, "{id:#x}");
        }
        assert!(c.is_busy());
    }

    #[test]
    fn segmented_download_and_toggle_error() {
        let data: Vec<u8> = (0..20).collect();
        let mut c = SdoClient::new(n(1), T);
        let f = c.start_download(0x2000, 1, &data, Instant::ZERO).unwrap();
        assert_eq!(f.to_string(), "601#2100200114000000");
        let ack = resp(
            1,
            SdoResponse::InitiateDownload {
                index: 0x2000,
                sub: 1,
            },
        );
        let SdoEvent::Send(s1) = c.on_frame(&ack, Instant::ZERO) else {
            panic!()
        };
        assert_eq!(s1.to_string(), "601#0000010203040506");
        let SdoEvent::Send(s2) = c.on_frame(
            &resp(1, SdoResponse::DownloadSegment { toggle: false }),
            Instant::ZERO,
        ) else {
            panic!()
        };
        assert_eq!(s2.data()[0], 0x10);
        // The server echoes the wrong toggle: abort 0x05030000.
        match c.on_frame(
            &resp(1, SdoResponse::DownloadSegment { toggle: false }),
            Instant::ZERO,
        ) {
            SdoEvent::Failed(e, Some(a)) => {
                assert!(matches!(
                    e.kind,
                    SdoErrorKind::Protocol {
                        sent: AbortCode::ToggleNotAlternated,
                        ..
                    }
                ));
                assert_eq!(&a.data()[4..], &0x0503_0000u32.to_le_bytes());
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn timeout_sends_abort_05040000_and_abort_is_named() {
        let mut c = SdoClient::new(n(2), T);
        c.start_upload(0x1008, 0, Instant::ZERO).unwrap();
        assert_eq!(c.poll(Instant::from_millis(99)), SdoEvent::Idle);
        match c.poll(Instant::from_millis(100)) {
            SdoEvent::Failed(e, Some(a)) => {
                assert_eq!(a.to_string(), "602#8008100000000405");
                assert!(e.to_string().contains("no response within 100 ms"), "{e}");
            }
            other => panic!("{other:?}"),
        }
        c.start_upload(0x2345, 0, Instant::ZERO).unwrap();
        let ab = resp(
            2,
            SdoResponse::Abort {
                index: 0x2345,
                sub: 0,
                code: AbortCode::NoObject,
            },
        );
        match c.on_frame(&ab, Instant::ZERO) {
            SdoEvent::Failed(e, None) => {
                assert_eq!(e.abort_code(), Some(AbortCode::NoObject));
                assert!(e.to_string().contains("object does not exist"), "{e}");
                assert!(e.to_string().contains("node 2"), "{e}");
                assert!(e.to_string().contains("0x2345:00"), "{e}");
            }
            other => panic!("{other:?}"),
        }
    }
}
