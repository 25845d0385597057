//! CAN frames and the CANopen messages they carry. Per message type: a zero-copy view over
//! the data bytes (`*Packet`, field accessors, length checked once) and a validated `*Repr`
//! with `parse` and `emit`. Parsers never panic on bad input; they return [`WireError`].
//!
//! canopen-rs 0.6.1 is used for the NMT, heartbeat, SYNC and EMCY codecs (they are correct);
//! SDO and PDO codecs are this crate's own — see the notes in `sdo.rs` and `pdo.rs` (which also
//! holds [`PdoLayout`], the validated RPDO/TPDO layout the master packs and unpacks by).

mod emcy;
mod frame;
mod nmt;
mod pdo;
mod sdo;
mod sync;

use core::fmt;

pub use emcy::{EmcyPacket, EmcyRepr, emcy_code};
pub use frame::{CanFrame, Function, NodeId, frame_bits};
pub use nmt::{
    HeartbeatPacket, HeartbeatRepr, NmtCommand, NmtPacket, NmtRepr, NmtState, NmtTarget,
};
pub use pdo::{
    MappingEntry, PdoDirection, PdoError, PdoField, PdoLayout, PdoMap, PdoObject, PdoValues,
    pdo_cob_id,
};
pub use sdo::{
    AbortCode, ExpeditedData, InitiateKind, SdoPacket, SdoRequest, SdoResponse, SdoSegment,
};
pub use sync::SyncRepr;

/// Why a frame could not be parsed or built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WireError {
    /// Identifier above 0x7FF.
    BadId(u16),
    /// Node id outside 1..=127.
    BadNodeId(u8),
    /// Data length wrong for this message type.
    BadLength,
    /// The frame's COB-ID is not the one this message type uses.
    WrongCobId(u16),
    /// Unknown command specifier / NMT command / NMT state byte.
    UnknownCommand(u8),
    /// A field value the protocol does not allow.
    Invalid(&'static str),
}

impl fmt::Display for WireError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            WireError::BadId(id) => write!(f, "CAN id {id:#x} above 0x7FF"),
            WireError::BadNodeId(n) => write!(f, "node id {n} outside 1..=127"),
            WireError::BadLength => write!(f, "data length wrong for this message"),
            WireError::WrongCobId(id) => write!(f, "COB-ID {id:#05x} is not this message's"),
            WireError::UnknownCommand(c) => write!(f, "unknown command byte {c:#04x}"),
            WireError::Invalid(what) => write!(f, "invalid field: {what}"),
        }
    }
}

impl std::error::Error for WireError {}
