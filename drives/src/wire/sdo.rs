//! SDO frames (client → server on 0x600 + node, server → client on 0x580 + node; always 8
//! bytes): initiate / segment download and upload, expedited with and without size, abort.
//!
//! Why not canopen-rs 0.6.1's SDO codec: it rejects an expedited upload without the size bit
//! (command 0x42, sdo/mod.rs ~202) that CiA 301 allows and real drives send; its abort code
//! enum lacks 0x06040041/42/43, 0x06070010, 0x06090030, 0x08000020..22 and cannot carry an
//! unknown code; its segmented buffers are capped at 32 bytes (datatypes.rs ~29); and it has
//! free functions per frame kind rather than one validated representation per direction, so
//! a peer cannot parse "whatever arrived" without guessing. This file replaces it.
//! Block transfer (ccs 6 / scs 5, 6) is not implemented: parsing it yields
//! `WireError::UnknownCommand` and a server should answer abort 0x05040001.

use core::fmt;

use super::{CanFrame, NodeId, WireError};

/// An SDO abort code (CiA 301 §7.2.4.3.17); unknown codes are kept as [`AbortCode::Other`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AbortCode {
    /// 0x05030000 toggle bit not alternated.
    ToggleNotAlternated,
    /// 0x05040000 SDO protocol timed out.
    Timeout,
    /// 0x05040001 client/server command specifier not valid or unknown.
    BadCommand,
    /// 0x05040002 invalid block size.
    InvalidBlockSize,
    /// 0x05040003 invalid sequence number.
    InvalidSequence,
    /// 0x05040004 CRC error.
    CrcError,
    /// 0x05040005 out of memory.
    OutOfMemory,
    /// 0x06010000 unsupported access to an object.
    UnsupportedAccess,
    /// 0x06010001 attempt to read a write-only object.
    ReadWriteOnly,
    /// 0x06010002 attempt to write a read-only object.
    WriteReadOnly,
    /// 0x06020000 object does not exist.
    NoObject,
    /// 0x06040041 object cannot be mapped to the PDO.
    CannotMap,
    /// 0x06040042 number and length of mapped objects would exceed the PDO length.
    MappingTooLong,
    /// 0x06040043 general parameter incompatibility.
    ParameterIncompatible,
    /// 0x06040047 general internal incompatibility in the device.
    DeviceIncompatible,
    /// 0x06060000 access failed due to a hardware error.
    HardwareError,
    /// 0x06070010 data type does not match, length of service parameter does not match.
    LengthMismatch,
    /// 0x06070012 length of service parameter too high.
    LengthTooHigh,
    /// 0x06070013 length of service parameter too low.
    LengthTooLow,
    /// 0x06090011 sub-index does not exist.
    NoSubIndex,
    /// 0x06090030 invalid value for parameter (download only).
    InvalidValue,
    /// 0x06090031 value written too high.
    ValueTooHigh,
    /// 0x06090032 value written too low.
    ValueTooLow,
    /// 0x06090036 maximum value is less than minimum value.
    MaxBelowMin,
    /// 0x060A0023 resource not available: SDO connection.
    ResourceNotAvailable,
    /// 0x08000000 general error.
    General,
    /// 0x08000020 data cannot be transferred or stored to the application.
    CannotStore,
    /// 0x08000021 … because of local control.
    LocalControl,
    /// 0x08000022 … because of the present device state.
    DeviceState,
    /// 0x08000023 object dictionary not present / dynamic generation failed.
    NoDictionary,
    /// 0x08000024 no data available.
    NoData,
    /// Any other code.
    Other(u32),
}

const ABORT_TABLE: [(AbortCode, u32, &str); 31] = [
    (
        AbortCode::ToggleNotAlternated,
        0x0503_0000,
        "toggle bit not alternated",
    ),
    (AbortCode::Timeout, 0x0504_0000, "SDO protocol timed out"),
    (
        AbortCode::BadCommand,
        0x0504_0001,
        "command specifier not valid or unknown",
    ),
    (
        AbortCode::InvalidBlockSize,
        0x0504_0002,
        "invalid block size",
    ),
    (
        AbortCode::InvalidSequence,
        0x0504_0003,
        "invalid sequence number",
    ),
    (AbortCode::CrcError, 0x0504_0004, "CRC error"),
    (AbortCode::OutOfMemory, 0x0504_0005, "out of memory"),
    (
        AbortCode::UnsupportedAccess,
        0x0601_0000,
        "unsupported access to an object",
    ),
    (
        AbortCode::ReadWriteOnly,
        0x0601_0001,
        "attempt to read a write-only object",
    ),
    (
        AbortCode::WriteReadOnly,
        0x0601_0002,
        "attempt to write a read-only object",
    ),
    (
        AbortCode::NoObject,
        0x0602_0000,
        "object does not exist in the object dictionary",
    ),
    (
        AbortCode::CannotMap,
        0x0604_0041,
        "object cannot be mapped to the PDO",
    ),
    (
        AbortCode::MappingTooLong,
        0x0604_0042,
        "mapped objects would exceed the PDO length",
    ),
    (
        AbortCode::ParameterIncompatible,
        0x0604_0043,
        "general parameter incompatibility",
    ),
    (
        AbortCode::DeviceIncompatible,
        0x0604_0047,
        "general internal incompatibility in the device",
    ),
    (
        AbortCode::HardwareError,
        0x0606_0000,
        "access failed due to a hardware error",
    ),
    (
        AbortCode::LengthMismatch,
        0x0607_0010,
        "data type or length does not match",
    ),
    (
        AbortCode::LengthTooHigh,
        0x0607_0012,
        "length of service parameter too high",
    ),
    (
        AbortCode::LengthTooLow,
        0x0607_0013,
        "length of service parameter too low",
    ),
    (
        AbortCode::NoSubIndex,
        0x0609_0011,
        "sub-index does not exist",
    ),
    (
        AbortCode::InvalidValue,
        0x0609_0030,
        "invalid value for parameter",
    ),
    (
        AbortCode::ValueTooHigh,
        0x0609_0031,
        "value written too high",
    ),
    (AbortCode::ValueTooLow, 0x0609_0032, "value written too low"),
    (
        AbortCode::MaxBelowMin,
        0x0609_0036,
        "maximum value is less than minimum value",
    ),
    (
        AbortCode::ResourceNotAvailable,
        0x060A_0023,
        "resource not available: SDO connection",
    ),
    (AbortCode::General, 0x0800_0000, "general error"),
    (
        AbortCode::CannotStore,
        0x0800_0020,
        "data cannot be transferred or stored",
    ),
    (
        AbortCode::LocalControl,
        0x0800_0021,
        "data cannot be stored because of local control",
    ),
    (
        AbortCode::DeviceState,
        0x0800_0022,
        "data cannot be stored in the present device state",
    ),
    (
        AbortCode::NoDictionary,
        0x0800_0023,
        "object dictionary not present",
    ),
    (AbortCode::NoData, 0x0800_0024, "no data available"),
];

impl AbortCode {
    /// Every named code (for tests and tables).
    pub fn named() -> impl Iterator<Item = AbortCode> {
        ABORT_TABLE.iter().map(|e| e.0)
    }

    /// From the 32-bit value on the wire.
    pub fn from_u32(v: u32) -> AbortCode {
        ABORT_TABLE
            .iter()
            .find(|e| e.1 == v)
            .map(|e| e.0)
            .unwrap_or(AbortCode::Other(v))
    }

    /// The 32-bit value on the wire.
    pub fn to_u32(self) -> u32 {
        match self {
            AbortCode::Other(v) => v,
            named => ABORT_TABLE
                .iter()
                .find(|e| e.0 == named)
                .map(|e| e.1)
                .unwrap_or(0),
        }
    }

    /// CiA 301's description.
    pub fn description(self) -> &'static str {
        match self {
            AbortCode::Other(_) => "unknown abort code",
            named => ABORT_TABLE
                .iter()
                .find(|e| e.0 == named)
                .map(|e| e.2)
                .unwrap_or(""),
        }
    }
}

impl fmt::Display for AbortCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:#010x} ({})", self.to_u32(), self.description())
    }
}

// Command specifiers, top three bits of byte 0.
const CCS_DOWNLOAD_SEGMENT: u8 = 0;
const CCS_INITIATE_DOWNLOAD: u8 = 1;
const CCS_INITIATE_UPLOAD: u8 = 2;
const CCS_UPLOAD_SEGMENT: u8 = 3;
const CS_ABORT: u8 = 4;
const SCS_UPLOAD_SEGMENT: u8 = 0;
const SCS_DOWNLOAD_SEGMENT: u8 = 1;
const SCS_INITIATE_UPLOAD: u8 = 2;
const SCS_INITIATE_DOWNLOAD: u8 = 3;

/// Zero-copy view of an SDO frame's 8 data bytes.
#[derive(Clone, Copy, Debug)]
pub struct SdoPacket<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> SdoPacket<T> {
    /// Checks the length (SDO frames are always 8 bytes).
    pub fn new_checked(buffer: T) -> Result<Self, WireError> {
        if buffer.as_ref().len() != 8 {
            return Err(WireError::BadLength);
        }
        Ok(SdoPacket { buffer })
    }
    fn b(&self) -> &[u8] {
        self.buffer.as_ref()
    }
    /// Byte 0.
    pub fn command_byte(&self) -> u8 {
        self.b()[0]
    }
    /// Command specifier (bits 7..5).
    pub fn specifier(&self) -> u8 {
        self.b()[0] >> 5
    }
    /// Toggle bit (bit 4) of segment frames.
    pub fn toggle(&self) -> bool {
        self.b()[0] & 0x10 != 0
    }
    /// Initiate frames: n (bits 3..2), unused bytes of expedited data.
    pub fn expedited_unused(&self) -> u8 {
        (self.b()[0] >> 2) & 0x03
    }
    /// Initiate frames: e (bit 1).
    pub fn expedited(&self) -> bool {
        self.b()[0] & 0x02 != 0
    }
    /// Initiate frames: s (bit 0).
    pub fn size_indicated(&self) -> bool {
        self.b()[0] & 0x01 != 0
    }
    /// Segment frames: n (bits 3..1), unused bytes of the 7.
    pub fn segment_unused(&self) -> u8 {
        (self.b()[0] >> 1) & 0x07
    }
    /// Segment frames: c (bit 0), last segment.
    pub fn last_segment(&self) -> bool {
        self.b()[0] & 0x01 != 0
    }
    /// Multiplexer: index (bytes 1..3).
    pub fn index(&self) -> u16 {
        u16::from_le_bytes([self.b()[1], self.b()[2]])
    }
    /// Multiplexer: sub-index (byte 3).
    pub fn sub(&self) -> u8 {
        self.b()[3]
    }
    /// Bytes 4..8 of an initiate / abort frame.
    pub fn data4(&self) -> [u8; 4] {
        let b = self.b();
        [b[4], b[5], b[6], b[7]]
    }
    /// Bytes 4..8 as a little-endian u32 (size or abort code).
    pub fn u32_field(&self) -> u32 {
        u32::from_le_bytes(self.data4())
    }
    /// Bytes 1..8 of a segment frame.
    pub fn segment_bytes(&self) -> &[u8] {
        &self.b()[1..8]
    }
}

/// Up to four bytes of an expedited transfer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ExpeditedData {
    bytes: [u8; 4],
    /// 1..=4 when the size is indicated; `None` when it is not (all four bytes carried, the
    /// receiver knows the type's length).
    size: Option<u8>,
}

impl ExpeditedData {
    /// Expedited data of 1..=4 bytes with the size indicated.
    pub fn new(data: &[u8]) -> Result<ExpeditedData, WireError> {
        if data.is_empty() || data.len() > 4 {
            return Err(WireError::Invalid("expedited data must be 1..=4 bytes"));
        }
        let mut bytes = [0u8; 4];
        bytes[..data.len()].copy_from_slice(data);
        Ok(ExpeditedData {
            bytes,
            size: Some(data.len() as u8),
        })
    }
    /// Four bytes without size indication (command 0x22 / 0x42).
    pub fn without_size(bytes: [u8; 4]) -> ExpeditedData {
        ExpeditedData { bytes, size: None }
    }
    /// The data: `size` bytes, or all four when the size is not indicated.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes[..self.size.unwrap_or(4) as usize]
    }
    /// The indicated size.
    pub fn size(&self) -> Option<u8> {
        self.size
    }
}

/// How an initiate download / upload response carries its data.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum InitiateKind {
    /// Data inline.
    Expedited(ExpeditedData),
    /// Segments follow; total size if indicated.
    Segmented {
        /// Total bytes, when the s bit is set.
        size: Option<u32>,
    },
}

/// A download segment (client) or upload segment (server): toggle, last flag, 0..=7 bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SdoSegment {
    /// Toggle bit; the first segment has 0.
    pub toggle: bool,
    /// No more segments follow.
    pub last: bool,
    data: [u8; 7],
    len: u8,
}

impl SdoSegment {
    /// A segment with up to 7 data bytes.
    pub fn new(toggle: bool, last: bool, data: &[u8]) -> Result<SdoSegment, WireError> {
        if data.len() > 7 {
            return Err(WireError::Invalid("segment data above 7 bytes"));
        }
        let mut d = [0u8; 7];
        d[..data.len()].copy_from_slice(data);
        Ok(SdoSegment {
            toggle,
            last,
            data: d,
            len: data.len() as u8,
        })
    }
    /// The data bytes.
    pub fn data(&self) -> &[u8] {
        &self.data[..self.len as usize]
    }
    fn parse(p: &SdoPacket<&[u8]>) -> SdoSegment {
        let len = 7 - p.segment_unused() as usize;
        let mut data = [0u8; 7];
        data[..len].copy_from_slice(&p.segment_bytes()[..len]);
        SdoSegment {
            toggle: p.toggle(),
            last: p.last_segment(),
            data,
            len: len as u8,
        }
    }
    fn emit(&self, cs: u8) -> [u8; 8] {
        let mut b = [0u8; 8];
        b[0] =
            (cs << 5) | (u8::from(self.toggle) << 4) | ((7 - self.len) << 1) | u8::from(self.last);
        b[1..8].copy_from_slice(&self.data);
        // Unused bytes go out as zero whatever the caller left in them.
        for x in &mut b[1 + self.len as usize..] {
            *x = 0;
        }
        b
    }
}

fn mux(b: &mut [u8; 8], index: u16, sub: u8) {
    b[1..3].copy_from_slice(&index.to_le_bytes());
    b[3] = sub;
}

fn parse_initiate(p: &SdoPacket<&[u8]>) -> InitiateKind {
    match (p.expedited(), p.size_indicated()) {
        (true, true) => {
            let size = 4 - p.expedited_unused();
            let mut bytes = [0u8; 4];
            bytes[..size as usize].copy_from_slice(&p.data4()[..size as usize]);
            InitiateKind::Expedited(ExpeditedData {
                bytes,
                size: Some(size),
            })
        }
        (true, false) => InitiateKind::Expedited(ExpeditedData::without_size(p.data4())),
        (false, true) => InitiateKind::Segmented {
            size: Some(p.u32_field()),
        },
        (false, false) => InitiateKind::Segmented { size: None },
    }
}

fn emit_initiate(cs: u8, index: u16, sub: u8, kind: &InitiateKind) -> [u8; 8] {
    let mut b = [0u8; 8];
    mux(&mut b, index, sub);
    match kind {
        InitiateKind::Expedited(e) => {
            b[0] = (cs << 5) | 0x02;
            if let Some(n) = e.size {
                b[0] |= ((4 - n) << 2) | 0x01;
            }
            b[4..4 + e.bytes().len()].copy_from_slice(e.bytes());
        }
        InitiateKind::Segmented { size } => {
            b[0] = cs << 5;
            if let Some(s) = size {
                b[0] |= 0x01;
                b[4..8].copy_from_slice(&s.to_le_bytes());
            }
        }
    }
    b
}

fn emit_abort(index: u16, sub: u8, code: AbortCode) -> [u8; 8] {
    let mut b = [0u8; 8];
    b[0] = CS_ABORT << 5;
    mux(&mut b, index, sub);
    b[4..8].copy_from_slice(&code.to_u32().to_le_bytes());
    b
}

fn sdo_packet(frame: &CanFrame, base: u16) -> Result<(NodeId, SdoPacket<&[u8]>), WireError> {
    let id = frame.id();
    if id & 0x780 != base || frame.is_remote() {
        return Err(WireError::WrongCobId(id));
    }
    let node = NodeId::new((id & 0x7F) as u8).map_err(|_| WireError::WrongCobId(id))?;
    Ok((node, SdoPacket::new_checked(frame.data())?))
}

/// A validated client → server SDO request.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SdoRequest {
    /// Initiate download (write).
    InitiateDownload {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// Expedited data or segmented size.
        kind: InitiateKind,
    },
    /// A download segment.
    DownloadSegment(SdoSegment),
    /// Initiate upload (read).
    InitiateUpload {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
    },
    /// Request the next upload segment.
    UploadSegment {
        /// Toggle bit.
        toggle: bool,
    },
    /// Abort the transfer.
    Abort {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// Why.
        code: AbortCode,
    },
}

impl SdoRequest {
    /// Parses the 8 data bytes of a request.
    pub fn parse_bytes(data: &[u8]) -> Result<SdoRequest, WireError> {
        let p = SdoPacket::new_checked(data)?;
        Ok(match p.specifier() {
            CCS_DOWNLOAD_SEGMENT => SdoRequest::DownloadSegment(SdoSegment::parse(&p)),
            CCS_INITIATE_DOWNLOAD => SdoRequest::InitiateDownload {
                index: p.index(),
                sub: p.sub(),
                kind: parse_initiate(&p),
            },
            CCS_INITIATE_UPLOAD => SdoRequest::InitiateUpload {
                index: p.index(),
                sub: p.sub(),
            },
            CCS_UPLOAD_SEGMENT => SdoRequest::UploadSegment { toggle: p.toggle() },
            CS_ABORT => SdoRequest::Abort {
                index: p.index(),
                sub: p.sub(),
                code: AbortCode::from_u32(p.u32_field()),
            },
            _ => return Err(WireError::UnknownCommand(p.command_byte())),
        })
    }

    /// Parses a request frame (0x600 + node); returns the addressed server's node id.
    ///
    /// ```
    /// use cnc402_drives::wire::{CanFrame, SdoRequest};
    /// let f = CanFrame::new(0x603, &[0x40, 0x64, 0x60, 0x00, 0, 0, 0, 0]).unwrap();
    /// let (node, req) = SdoRequest::parse(&f).unwrap();
    /// assert_eq!(node.get(), 3);
    /// assert_eq!(req, SdoRequest::InitiateUpload { index: 0x6064, sub: 0 });
    /// ```
    pub fn parse(frame: &CanFrame) -> Result<(NodeId, SdoRequest), WireError> {
        let (node, p) = sdo_packet(frame, 0x600)?;
        Ok((node, Self::parse_bytes(p.buffer)?))
    }

    /// The 8 data bytes.
    pub fn emit_bytes(&self) -> [u8; 8] {
        match self {
            SdoRequest::InitiateDownload { index, sub, kind } => {
                emit_initiate(CCS_INITIATE_DOWNLOAD, *index, *sub, kind)
            }
            SdoRequest::DownloadSegment(s) => s.emit(CCS_DOWNLOAD_SEGMENT),
            SdoRequest::InitiateUpload { index, sub } => {
                let mut b = [0u8; 8];
                b[0] = CCS_INITIATE_UPLOAD << 5;
                mux(&mut b, *index, *sub);
                b
            }
            SdoRequest::UploadSegment { toggle } => {
                let mut b = [0u8; 8];
                b[0] = (CCS_UPLOAD_SEGMENT << 5) | (u8::from(*toggle) << 4);
                b
            }
            SdoRequest::Abort { index, sub, code } => emit_abort(*index, *sub, *code),
        }
    }

    /// The request frame to server `node` (COB-ID 0x600 + node).
    pub fn emit(&self, node: NodeId) -> CanFrame {
        CanFrame::from_parts(0x600 + node.get() as u16, self.emit_bytes(), 8)
    }
}

/// A validated server → client SDO response.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SdoResponse {
    /// Initiate download confirmed.
    InitiateDownload {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
    },
    /// Download segment confirmed.
    DownloadSegment {
        /// Toggle bit echoed.
        toggle: bool,
    },
    /// Initiate upload response with expedited data or the segmented size.
    InitiateUpload {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// Expedited data or segmented size.
        kind: InitiateKind,
    },
    /// An upload segment.
    UploadSegment(SdoSegment),
    /// Abort.
    Abort {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// Why.
        code: AbortCode,
    },
}

impl SdoResponse {
    /// Parses the 8 data bytes of a response.
    pub fn parse_bytes(data: &[u8]) -> Result<SdoResponse, WireError> {
        let p = SdoPacket::new_checked(data)?;
        Ok(match p.specifier() {
            SCS_UPLOAD_SEGMENT => SdoResponse::UploadSegment(SdoSegment::parse(&p)),
            SCS_DOWNLOAD_SEGMENT => SdoResponse::DownloadSegment { toggle: p.toggle() },
            SCS_INITIATE_UPLOAD => SdoResponse::InitiateUpload {
                index: p.index(),
                sub: p.sub(),
                kind: parse_initiate(&p),
            },
            SCS_INITIATE_DOWNLOAD => SdoResponse::InitiateDownload {
                index: p.index(),
                sub: p.sub(),
            },
            CS_ABORT => SdoResponse::Abort {
                index: p.index(),
                sub: p.sub(),
                code: AbortCode::from_u32(p.u32_field()),
            },
            _ => return Err(WireError::UnknownCommand(p.command_byte())),
        })
    }

    /// Parses a response frame (0x580 + node); returns the responding server's node id.
    ///
    /// ```
    /// use cnc402_drives::wire::{AbortCode, CanFrame, SdoResponse};
    /// let f = CanFrame::new(0x583, &[0x80, 0x00, 0x16, 0x01, 0x22, 0x00, 0x00, 0x08]).unwrap();
    /// let (_, r) = SdoResponse::parse(&f).unwrap();
    /// assert_eq!(r, SdoResponse::Abort { index: 0x1600, sub: 1, code: AbortCode::DeviceState });
    /// ```
    pub fn parse(frame: &CanFrame) -> Result<(NodeId, SdoResponse), WireError> {
        let (node, p) = sdo_packet(frame, 0x580)?;
        Ok((node, Self::parse_bytes(p.buffer)?))
    }

    /// The 8 data bytes.
    pub fn emit_bytes(&self) -> [u8; 8] {
        match self {
            SdoResponse::InitiateDownload { index, sub } => {
                let mut b = [0u8; 8];
                b[0] = SCS_INITIATE_DOWNLOAD << 5;
                mux(&mut b, *index, *sub);
                b
            }
            SdoResponse::DownloadSegment { toggle } => {
                let mut b = [0u8; 8];
                b[0] = (SCS_DOWNLOAD_SEGMENT << 5) | (u8::from(*toggle) << 4);
                b
            }
            SdoResponse::InitiateUpload { index, sub, kind } => {
                emit_initiate(SCS_INITIATE_UPLOAD, *index, *sub, kind)
            }
            SdoResponse::UploadSegment(s) => s.emit(SCS_UPLOAD_SEGMENT),
            SdoResponse::Abort { index, sub, code } => emit_abort(*index, *sub, *code),
        }
    }

    /// The response frame from server `node` (COB-ID 0x580 + node).
    pub fn emit(&self, node: NodeId) -> CanFrame {
        CanFrame::from_parts(0x580 + node.get() as u16, self.emit_bytes(), 8)
    }

    /// The (index, sub) this response names, if it carries a multiplexer.
    pub fn multiplexer(&self) -> Option<(u16, u8)> {
        match *self {
            SdoResponse::InitiateDownload { index, sub }
            | SdoResponse::InitiateUpload { index, sub, .. }
            | SdoResponse::Abort { index, sub, .. } => Some((index, sub)),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn n(id: u8) -> NodeId {
        NodeId::new(id).unwrap()
    }

    #[test]
    fn known_bytes() {
        // Write 0x6060 = 8 (INT8), expedited, size 1: 2F 60 60 00 08 00 00 00.
        let r = SdoRequest::InitiateDownload {
            index: 0x6060,
            sub: 0,
            kind: InitiateKind::Expedited(ExpeditedData::new(&[8]).unwrap()),
        };
        assert_eq!(r.emit(n(3)).to_string(), "603#2F60600008000000");
        // Write 0x1017 = 50 (UINT16): 2B.
        let r = SdoRequest::InitiateDownload {
            index: 0x1017,
            sub: 0,
            kind: InitiateKind::Expedited(ExpeditedData::new(&[50, 0]).unwrap()),
        };
        assert_eq!(r.emit_bytes()[0], 0x2B);
        // UINT32 → 0x23, read request 0x40, confirm 0x60, upload response 0x43 for 4 bytes.
        let r = SdoRequest::InitiateDownload {
            index: 0x1600,
            sub: 1,
            kind: InitiateKind::Expedited(
                ExpeditedData::new(&0x6040_0010u32.to_le_bytes()).unwrap(),
            ),
        };
        assert_eq!(r.emit(n(1)).to_string(), "601#2300160110004060");
        assert_eq!(
            SdoRequest::InitiateUpload {
                index: 0x1000,
                sub: 0
            }
            .emit(n(1))
            .to_string(),
            "601#4000100000000000"
        );
        assert_eq!(
            SdoResponse::InitiateDownload {
                index: 0x1600,
                sub: 1
            }
            .emit(n(1))
            .to_string(),
            "581#6000160100000000"
        );
        let up = SdoResponse::InitiateUpload {
            index: 0x1000,
            sub: 0,
            kind: InitiateKind::Expedited(
                ExpeditedData::new(&0x0002_0192u32.to_le_bytes()).unwrap(),
            ),
        };
        assert_eq!(up.emit(n(1)).to_string(), "581#4300100092010200");
        let abort = SdoResponse::Abort {
            index: 0x1600,
            sub: 0,
            code: AbortCode::DeviceState,
        };
        assert_eq!(abort.emit(n(1)).to_string(), "581#8000160022000008");
        // Segmented download initiate with size 10: 0x21.
        let r = SdoRequest::InitiateDownload {
            index: 0x1008,
            sub: 0,
            kind: InitiateKind::Segmented { size: Some(10) },
        };
        assert_eq!(r.emit_bytes(), [0x21, 0x08, 0x10, 0, 10, 0, 0, 0]);
        // Last download segment with 3 bytes, toggle 1: 0x10 | (4 << 1) | 1 = 0x19.
        let s = SdoRequest::DownloadSegment(SdoSegment::new(true, true, b"abc").unwrap());
        assert_eq!(s.emit_bytes(), [0x19, b'a', b'b', b'c', 0, 0, 0, 0]);
        assert_eq!(
            SdoRequest::UploadSegment { toggle: true }.emit_bytes()[0],
            0x70
        );
        assert_eq!(
            SdoResponse::DownloadSegment { toggle: true }.emit_bytes()[0],
            0x30
        );
    }

    #[test]
    fn expedited_upload_without_size_is_accepted() {
        // 0x42: e = 1, s = 0 — canopen-rs 0.6.1 rejects this; CiA 301 allows it.
        let (node, r) =
            SdoResponse::parse(&CanFrame::new(0x583, &[0x42, 0x64, 0x60, 0, 1, 2, 3, 4]).unwrap())
                .unwrap();
        assert_eq!(node, n(3));
        match r {
            SdoResponse::InitiateUpload {
                index: 0x6064,
                sub: 0,
                kind: InitiateKind::Expedited(e),
            } => {
                assert_eq!(e.size(), None);
                assert_eq!(e.bytes(), &[1, 2, 3, 4]);
            }
            other => panic!("{other:?}"),
        }
    }

    fn all_requests() -> Vec<SdoRequest> {
        let mut v = vec![
            SdoRequest::InitiateUpload {
                index: 0x6064,
                sub: 0,
            },
            SdoRequest::UploadSegment { toggle: false },
            SdoRequest::UploadSegment { toggle: true },
            SdoRequest::InitiateDownload {
                index: 0x1008,
                sub: 0,
                kind: InitiateKind::Segmented { size: None },
            },
            SdoRequest::InitiateDownload {
                index: 0x1008,
                sub: 0,
                kind: InitiateKind::Segmented {
                    size: Some(u32::MAX),
                },
            },
            SdoRequest::InitiateDownload {
                index: 0x607A,
                sub: 0,
                kind: InitiateKind::Expedited(ExpeditedData::without_size([1, 2, 3, 4])),
            },
        ];
        for len in 1..=4 {
            v.push(SdoRequest::InitiateDownload {
                index: 0xFFFF,
                sub: 0xFF,
                kind: InitiateKind::Expedited(ExpeditedData::new(&[0xA5; 4][..len]).unwrap()),
            });
        }
        for len in 0..=7 {
            for (t, l) in [(false, false), (true, true), (false, true), (true, false)] {
                v.push(SdoRequest::DownloadSegment(
                    SdoSegment::new(t, l, &[0x5A; 7][..len]).unwrap(),
                ));
            }
        }
        for code in AbortCode::named().chain([AbortCode::Other(0x1234_5678)]) {
            v.push(SdoRequest::Abort {
                index: 0x2000,
                sub: 3,
                code,
            });
        }
        v
    }

    fn all_responses() -> Vec<SdoResponse> {
        let mut v = vec![
            SdoResponse::InitiateDownload {
                index: 0x6040,
                sub: 0,
            },
            SdoResponse::DownloadSegment { toggle: false },
            SdoResponse::DownloadSegment { toggle: true },
            SdoResponse::InitiateUpload {
                index: 0x1008,
                sub: 0,
                kind: InitiateKind::Segmented { size: Some(17) },
            },
            SdoResponse::InitiateUpload {
                index: 0x1008,
                sub: 0,
                kind: InitiateKind::Segmented { size: None },
            },
            SdoResponse::InitiateUpload {
                index: 0x6064,
                sub: 0,
                kind: InitiateKind::Expedited(ExpeditedData::without_size([9, 8, 7, 6])),
            },
        ];
        for len in 1..=4 {
            v.push(SdoResponse::InitiateUpload {
                index: 0x1018,
                sub: 1,
                kind: InitiateKind::Expedited(
                    ExpeditedData::new(&[0x11, 0x22, 0x33, 0x44][..len]).unwrap(),
                ),
            });
        }
        for len in 0..=7 {
            for (t, l) in [(false, false), (true, true)] {
                v.push(SdoResponse::UploadSegment(
                    SdoSegment::new(t, l, &[7; 7][..len]).unwrap(),
                ));
            }
        }
        for code in AbortCode::named() {
            v.push(SdoResponse::Abort {
                index: 0x6065,
                sub: 0,
                code,
            });
        }
        v
    }

    #[test]
    fn round_trips() {
        for r in all_requests() {
            let f = r.emit(n(42));
            assert_eq!(SdoRequest::parse(&f), Ok((n(42), r)), "{f}");
        }
        for r in all_responses() {
            let f = r.emit(n(42));
            assert_eq!(SdoResponse::parse(&f), Ok((n(42), r)), "{f}");
        }
    }

    #[test]
    fn abort_codes_round_trip_and_name_the_notes_values() {
        for c in AbortCode::named() {
            assert_eq!(AbortCode::from_u32(c.to_u32()), c);
            assert!(!c.description().is_empty());
        }
        for (v, c) in [
            (0x0504_0000, AbortCode::Timeout),
            (0x0504_0001, AbortCode::BadCommand),
            (0x0601_0000, AbortCode::UnsupportedAccess),
            (0x0601_0001, AbortCode::ReadWriteOnly),
            (0x0601_0002, AbortCode::WriteReadOnly),
            (0x0602_0000, AbortCode::NoObject),
            (0x0604_0041, AbortCode::CannotMap),
            (0x0604_0042, AbortCode::MappingTooLong),
            (0x0604_0043, AbortCode::ParameterIncompatible),
            (0x0607_0010, AbortCode::LengthMismatch),
            (0x0609_0011, AbortCode::NoSubIndex),
            (0x0609_0030, AbortCode::InvalidValue),
            (0x0800_0000, AbortCode::General),
            (0x0800_0020, AbortCode::CannotStore),
            (0x0800_0021, AbortCode::LocalControl),
            (0x0800_0022, AbortCode::DeviceState),
        ] {
            assert_eq!(AbortCode::from_u32(v), c);
        }
        assert_eq!(AbortCode::from_u32(7), AbortCode::Other(7));
        assert_eq!(
            AbortCode::NoObject.to_string(),
            "0x06020000 (object does not exist in the object dictionary)"
        );
    }

    #[test]
    fn malformed_frames_are_errors_and_nothing_panics() {
        // Every command byte with every length, on both directions.
        for cmd in 0..=255u8 {
            for len in 0..=8 {
                let mut d = [0xFFu8; 8];
                d[0] = cmd;
                let req = SdoRequest::parse(&CanFrame::new(0x601, &d[..len]).unwrap());
                let rsp = SdoResponse::parse(&CanFrame::new(0x581, &d[..len]).unwrap());
                if len != 8 {
                    assert_eq!(req, Err(WireError::BadLength));
                    assert_eq!(rsp, Err(WireError::BadLength));
                } else {
                    let cs = cmd >> 5;
                    assert_eq!(req.is_err(), cs > 4, "{cmd:#x}");
                    assert_eq!(rsp.is_err(), cs > 4, "{cmd:#x}");
                    // Anything that parses re-emits to a frame that parses to the same value.
                    if let Ok((node, r)) = req {
                        assert_eq!(SdoRequest::parse(&r.emit(node)), Ok((node, r)));
                    }
                    if let Ok((node, r)) = rsp {
                        assert_eq!(SdoResponse::parse(&r.emit(node)), Ok((node, r)));
                    }
                }
            }
        }
        assert_eq!(
            SdoRequest::parse(&CanFrame::new(0x581, &[0x40; 8]).unwrap()),
            Err(WireError::WrongCobId(0x581))
        );
        assert_eq!(
            SdoRequest::parse(&CanFrame::new(0x600, &[0x40; 8]).unwrap()),
            Err(WireError::WrongCobId(0x600))
        );
        assert_eq!(
            SdoResponse::parse(&CanFrame::new(0x601, &[0x40; 8]).unwrap()),
            Err(WireError::WrongCobId(0x601))
        );
        // Block transfer commands are not supported.
        assert_eq!(
            SdoRequest::parse_bytes(&[0xC0, 0, 0, 0, 0, 0, 0, 0]),
            Err(WireError::UnknownCommand(0xC0))
        );
        assert_eq!(
            SdoResponse::parse_bytes(&[0xA4, 0, 0, 0, 0, 0, 0, 0]),
            Err(WireError::UnknownCommand(0xA4))
        );
        assert!(ExpeditedData::new(&[]).is_err() && ExpeditedData::new(&[0; 5]).is_err());
        assert!(SdoSegment::new(false, false, &[0; 8]).is_err());
    }
}
