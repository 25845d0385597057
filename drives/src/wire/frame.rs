//! The classic CAN frame (11-bit identifier, 0..=8 data bytes), node ids, and the CANopen
//! pre-defined connection set: which COB-ID carries which service.

use core::fmt;

use super::WireError;

/// A CANopen node id, 1..=127.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct NodeId(u8);

impl NodeId {
    /// Validates `id` (1..=127).
    pub const fn new(id: u8) -> Result<NodeId, WireError> {
        if id >= 1 && id <= 127 {
            Ok(NodeId(id))
        } else {
            Err(WireError::BadNodeId(id))
        }
    }
    /// The raw id.
    pub const fn get(self) -> u8 {
        self.0
    }
}

impl fmt::Display for NodeId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// One classic CAN data (or remote) frame with an 11-bit identifier.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct CanFrame {
    id: u16,
    len: u8,
    rtr: bool,
    data: [u8; 8],
}

impl CanFrame {
    /// Largest 11-bit identifier.
    pub const MAX_ID: u16 = 0x7FF;

    /// A data frame; fails if `id > 0x7FF` or `data` is longer than 8 bytes.
    ///
    /// ```
    /// use cnc402_drives::wire::CanFrame;
    /// let f = CanFrame::new(0x183, &[0x37, 0x02]).unwrap();
    /// assert_eq!((f.id(), f.data(), f.bits()), (0x183, &[0x37u8, 0x02][..], 75));
    /// assert!(CanFrame::new(0x800, &[]).is_err());
    /// ```
    pub fn new(id: u16, data: &[u8]) -> Result<CanFrame, WireError> {
        if id > Self::MAX_ID {
            return Err(WireError::BadId(id));
        }
        if data.len() > 8 {
            return Err(WireError::BadLength);
        }
        let mut d = [0u8; 8];
        d[..data.len()].copy_from_slice(data);
        Ok(CanFrame {
            id,
            len: data.len() as u8,
            rtr: false,
            data: d,
        })
    }

    /// A remote (RTR) frame requesting `dlc` bytes.
    pub fn new_remote(id: u16, dlc: u8) -> Result<CanFrame, WireError> {
        if id > Self::MAX_ID {
            return Err(WireError::BadId(id));
        }
        if dlc > 8 {
            return Err(WireError::BadLength);
        }
        Ok(CanFrame {
            id,
            len: dlc,
            rtr: true,
            data: [0; 8],
        })
    }

    /// A data frame from parts already known to be valid (`id <= 0x7FF` is masked, `len` is
    /// clamped to 8). For codecs in this crate.
    pub(crate) const fn from_parts(id: u16, data: [u8; 8], len: usize) -> CanFrame {
        CanFrame {
            id: id & Self::MAX_ID,
            len: if len > 8 { 8 } else { len as u8 },
            rtr: false,
            data,
        }
    }

    /// The 11-bit identifier (COB-ID).
    pub const fn id(&self) -> u16 {
        self.id
    }
    /// Data length code, 0..=8.
    pub const fn dlc(&self) -> usize {
        self.len as usize
    }
    /// Whether this is a remote (RTR) frame.
    pub const fn is_remote(&self) -> bool {
        self.rtr
    }
    /// The data bytes (empty for a remote frame).
    pub fn data(&self) -> &[u8] {
        if self.rtr {
            &[]
        } else {
            &self.data[..self.len as usize]
        }
    }
    /// Mutable data bytes, for fault injection.
    pub fn data_mut(&mut self) -> &mut [u8] {
        let n = if self.rtr { 0 } else { self.len as usize };
        &mut self.data[..n]
    }
    /// The frame's service per the pre-defined connection set.
    pub fn function(&self) -> Function {
        Function::classify(self.id)
    }
    /// Bits on the wire, worst-case stuffing, including the 3-bit intermission:
    /// 55 + 10·n for an 11-bit data frame (a remote frame carries no data bits).
    pub const fn bits(&self) -> u32 {
        frame_bits(if self.rtr { 0 } else { self.len as usize })
    }
}

/// Bits a classic 11-bit frame with `n` data bytes occupies (worst-case stuffing,
/// intermission): the bus-load plan's arithmetic, kept in one place in `cnc402_config`.
pub use cnc402_config::busload::frame_bits;

impl fmt::Debug for CanFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{self}")
    }
}

impl fmt::Display for CanFrame {
    /// candump style: `183#3706A0860100` or `703#R`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:03X}#", self.id)?;
        if self.rtr {
            return write!(f, "R");
        }
        for b in self.data() {
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

/// The service of a COB-ID in the CANopen pre-defined connection set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Function {
    /// 0x000 NMT node control.
    Nmt,
    /// 0x080 SYNC.
    Sync,
    /// 0x080 + node EMCY.
    Emcy(NodeId),
    /// 0x100 TIME.
    Time,
    /// TPDO 1..=4 of a node (0x180/0x280/0x380/0x480 + node).
    Tpdo(u8, NodeId),
    /// RPDO 1..=4 of a node (0x200/0x300/0x400/0x500 + node).
    Rpdo(u8, NodeId),
    /// 0x580 + node: SDO server → client (response).
    SdoTx(NodeId),
    /// 0x600 + node: SDO client → server (request).
    SdoRx(NodeId),
    /// 0x700 + node: heartbeat / boot-up / node guarding.
    Heartbeat(NodeId),
    /// Anything else (LSS 0x7E4/0x7E5, node id 0 slots, ids remapped by the user).
    Other(u16),
}

impl Function {
    /// Classifies an 11-bit identifier by the pre-defined connection set.
    ///
    /// ```
    /// use cnc402_drives::wire::{Function, NodeId};
    /// let n3 = NodeId::new(3).unwrap();
    /// assert_eq!(Function::classify(0x183), Function::Tpdo(1, n3));
    /// assert_eq!(Function::classify(0x080), Function::Sync);
    /// assert_eq!(Function::classify(0x083), Function::Emcy(n3));
    /// ```
    pub fn classify(id: u16) -> Function {
        if id == 0x000 {
            return Function::Nmt;
        }
        if id == 0x080 {
            return Function::Sync;
        }
        if id == 0x100 {
            return Function::Time;
        }
        let base = id & 0x780;
        let Ok(node) = NodeId::new((id & 0x7F) as u8) else {
            return Function::Other(id);
        };
        match base {
            0x080 => Function::Emcy(node),
            0x180 => Function::Tpdo(1, node),
            0x280 => Function::Tpdo(2, node),
            0x380 => Function::Tpdo(3, node),
            0x480 => Function::Tpdo(4, node),
            0x200 => Function::Rpdo(1, node),
            0x300 => Function::Rpdo(2, node),
            0x400 => Function::Rpdo(3, node),
            0x500 => Function::Rpdo(4, node),
            0x580 => Function::SdoTx(node),
            0x600 => Function::SdoRx(node),
            0x700 => Function::Heartbeat(node),
            _ => Function::Other(id),
        }
    }

    /// The COB-ID of this function (inverse of [`classify`](Self::classify)); `None` for a
    /// PDO number outside 1..=4.
    pub fn cob_id(self) -> Option<u16> {
        let n = |node: NodeId| node.get() as u16;
        Some(match self {
            Function::Nmt => 0x000,
            Function::Sync => 0x080,
            Function::Time => 0x100,
            Function::Emcy(node) => 0x080 + n(node),
            Function::Tpdo(p @ 1..=4, node) => 0x080 + 0x100 * p as u16 + n(node),
            Function::Rpdo(p @ 1..=4, node) => 0x100 + 0x100 * p as u16 + n(node),
            Function::Tpdo(..) | Function::Rpdo(..) => return None,
            Function::SdoTx(node) => 0x580 + n(node),
            Function::SdoRx(node) => 0x600 + n(node),
            Function::Heartbeat(node) => 0x700 + n(node),
            Function::Other(id) => id & CanFrame::MAX_ID,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_limits_and_bits() {
        assert!(CanFrame::new(0x800, &[]).is_err());
        assert!(CanFrame::new(0x7FF, &[0; 9]).is_err());
        let f = CanFrame::new(0x183, &[1, 2, 3, 4, 5, 6]).unwrap();
        assert_eq!(
            (f.id(), f.dlc(), f.data()),
            (0x183, 6, &[1u8, 2, 3, 4, 5, 6][..])
        );
        assert_eq!(f.bits(), 115);
        assert_eq!(CanFrame::new(0x80, &[]).unwrap().bits(), 55);
        assert_eq!(CanFrame::new(0x80, &[0; 8]).unwrap().bits(), 135);
        assert_eq!(f.to_string(), "183#010203040506");
        let r = CanFrame::new_remote(0x701, 1).unwrap();
        assert!(r.is_remote() && r.data().is_empty() && r.to_string() == "701#R");
        assert!(CanFrame::new_remote(0x701, 9).is_err());
    }

    #[test]
    fn classify_and_cob_id_are_inverse_over_all_ids() {
        for id in 0..=0x7FFu16 {
            let f = Function::classify(id);
            assert_eq!(f.cob_id(), Some(id), "{id:#05x} {f:?}");
        }
        let n = NodeId::new(5).unwrap();
        assert_eq!(Function::classify(0x085), Function::Emcy(n));
        assert_eq!(Function::classify(0x185), Function::Tpdo(1, n));
        assert_eq!(Function::classify(0x505), Function::Rpdo(4, n));
        assert_eq!(Function::classify(0x585), Function::SdoTx(n));
        assert_eq!(Function::classify(0x605), Function::SdoRx(n));
        assert_eq!(Function::classify(0x705), Function::Heartbeat(n));
        assert_eq!(Function::classify(0x7E5), Function::Other(0x7E5));
        assert_eq!(Function::classify(0x180), Function::Other(0x180));
        assert_eq!(Function::Tpdo(5, n).cob_id(), None);
        assert!(NodeId::new(0).is_err() && NodeId::new(128).is_err());
    }
}
