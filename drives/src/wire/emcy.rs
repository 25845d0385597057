//! EMCY (COB-ID 0x080 + node, 8 bytes): error code, error register, 5 manufacturer bytes.
//! The byte layout is canopen-rs's `EmergencyMessage` codec.

use canopen_rs::emcy::{EmergencyMessage, ErrorRegister};

use super::{CanFrame, NodeId, WireError};

/// EMCY error codes this project produces or reacts to (CiA 301 / CiA 402).
pub mod emcy_code {
    /// Error reset / no error.
    pub const NO_ERROR: u16 = 0x0000;
    /// Generic error.
    pub const GENERIC: u16 = 0x1000;
    /// CAN overrun (objects lost).
    pub const CAN_OVERRUN: u16 = 0x8110;
    /// CAN in error passive mode.
    pub const CAN_ERROR_PASSIVE: u16 = 0x8120;
    /// Life guard or heartbeat error.
    pub const HEARTBEAT: u16 = 0x8130;
    /// Recovered from bus-off.
    pub const BUS_OFF_RECOVERED: u16 = 0x8140;
    /// PDO not processed due to length error.
    pub const PDO_LENGTH: u16 = 0x8210;
    /// PDO length exceeded.
    pub const PDO_LENGTH_EXCEEDED: u16 = 0x8220;
    /// RPDO timeout.
    pub const RPDO_TIMEOUT: u16 = 0x8250;
    /// Following error (CiA 402).
    pub const FOLLOWING_ERROR: u16 = 0x8611;
}

/// Zero-copy view of an EMCY frame's data bytes.
#[derive(Clone, Copy, Debug)]
pub struct EmcyPacket<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> EmcyPacket<T> {
    /// Checks the length (exactly 8).
    pub fn new_checked(buffer: T) -> Result<Self, WireError> {
        if buffer.as_ref().len() != 8 {
            return Err(WireError::BadLength);
        }
        Ok(EmcyPacket { buffer })
    }
    /// Bytes 0..2.
    pub fn error_code(&self) -> u16 {
        let b = self.buffer.as_ref();
        u16::from_le_bytes([b[0], b[1]])
    }
    /// Byte 2 (copy of 0x1001).
    pub fn error_register(&self) -> u8 {
        self.buffer.as_ref()[2]
    }
    /// Bytes 3..8.
    pub fn manufacturer(&self) -> &[u8] {
        &self.buffer.as_ref()[3..8]
    }
}

/// A validated EMCY message.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct EmcyRepr {
    /// The producer.
    pub node: NodeId,
    /// Error code ([`emcy_code`]); 0 = error reset.
    pub code: u16,
    /// Error register 0x1001 at the time.
    pub register: u8,
    /// Manufacturer-specific bytes.
    pub manufacturer: [u8; 5],
}

impl EmcyRepr {
    /// Parses a frame on 0x081..=0x0FF with exactly 8 data bytes.
    ///
    /// ```
    /// use cnc402_drives::wire::{CanFrame, EmcyRepr};
    /// let f = CanFrame::new(0x084, &[0x11, 0x86, 0x21, 0, 0, 0, 0, 0]).unwrap();
    /// let e = EmcyRepr::parse(&f).unwrap();
    /// assert_eq!((e.node.get(), e.code, e.register), (4, 0x8611, 0x21));
    /// assert!(EmcyRepr::parse(&CanFrame::new(0x084, &[0x11, 0x86]).unwrap()).is_err());
    /// ```
    pub fn parse(frame: &CanFrame) -> Result<EmcyRepr, WireError> {
        let id = frame.id();
        if id & 0x780 != 0x080 {
            return Err(WireError::WrongCobId(id));
        }
        let node = NodeId::new((id & 0x7F) as u8).map_err(|_| WireError::WrongCobId(id))?;
        let m = EmergencyMessage::decode(frame.data()).map_err(|_| WireError::BadLength)?;
        Ok(EmcyRepr {
            node,
            code: m.error_code,
            register: m.error_register.0,
            manufacturer: m.vendor_specific,
        })
    }

    /// The frame.
    pub fn emit(&self) -> CanFrame {
        let p = EmergencyMessage::new(self.code, ErrorRegister(self.register), self.manufacturer)
            .encode();
        CanFrame::from_parts(0x080 + self.node.get() as u16, p, 8)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn emcy_round_trip_view_and_malformed() {
        let r = EmcyRepr {
            node: NodeId::new(4).unwrap(),
            code: emcy_code::FOLLOWING_ERROR,
            register: 0x21,
            manufacturer: [1, 2, 3, 4, 5],
        };
        let f = r.emit();
        assert_eq!(f.to_string(), "084#1186210102030405");
        assert_eq!(EmcyRepr::parse(&f), Ok(r));
        let v = EmcyPacket::new_checked(f.data()).unwrap();
        assert_eq!(
            (v.error_code(), v.error_register(), v.manufacturer()),
            (0x8611, 0x21, &[1u8, 2, 3, 4, 5][..])
        );
        let p = |id, d: &[u8]| EmcyRepr::parse(&CanFrame::new(id, d).unwrap());
        assert_eq!(p(0x080, &[0; 8]), Err(WireError::WrongCobId(0x80)));
        assert_eq!(p(0x084, &[0; 7]), Err(WireError::BadLength));
        assert_eq!(p(0x184, &[0; 8]), Err(WireError::WrongCobId(0x184)));
        assert!(EmcyPacket::new_checked(&[0u8; 3][..]).is_err());
    }
}
