//! PDOs: raw data bytes, their COB-IDs, and mapping entries (0xIIIISSLL) with bit-exact
//! packing of up to 64 mapped bits, little-endian as CiA 301 lays them out.
//!
//! Not canopen-rs 0.6.1's `pdo` module: it packs whole bytes only ("sub-byte PDO packing" is
//! on its roadmap) and its `Node` applies every RPDO on arrival and sends every synchronous
//! TPDO on every SYNC (node.rs ~457-499). Packing here is pure; when a PDO is applied or sent
//! is the device's business (`sim`).

use core::fmt;

use super::NodeId;

/// Receive (master → device) or transmit (device → master).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PdoDirection {
    /// RPDO, consumed by the device.
    Rpdo,
    /// TPDO, produced by the device.
    Tpdo,
}

/// The default COB-ID of PDO `n` (1..=4) of `node`; `None` for other `n`.
pub fn pdo_cob_id(direction: PdoDirection, n: u8, node: NodeId) -> Option<u16> {
    if !(1..=4).contains(&n) {
        return None;
    }
    let base = match direction {
        PdoDirection::Tpdo => 0x080,
        PdoDirection::Rpdo => 0x100,
    };
    Some(base + 0x100 * n as u16 + node.get() as u16)
}

/// One mapping entry: object index, sub-index, length in bits (encoded `0xIIIISSLL`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MappingEntry {
    /// Object index.
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
    /// Length in bits (1..=64).
    pub bits: u8,
}

impl MappingEntry {
    /// An entry.
    pub const fn new(index: u16, sub: u8, bits: u8) -> MappingEntry {
        MappingEntry { index, sub, bits }
    }
    /// Decodes `0xIIIISSLL`.
    pub const fn from_u32(v: u32) -> MappingEntry {
        MappingEntry {
            index: (v >> 16) as u16,
            sub: (v >> 8) as u8,
            bits: v as u8,
        }
    }
    /// Encodes `0xIIIISSLL`.
    pub const fn to_u32(self) -> u32 {
        (self.index as u32) << 16 | (self.sub as u32) << 8 | self.bits as u32
    }
}

/// Why a PDO could not be packed or unpacked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PdoError {
    /// More than 8 entries, or more than 64 bits mapped.
    TooLong,
    /// An entry with 0 bits.
    ZeroLength,
    /// The frame is shorter than the mapping (EMCY 0x8210).
    FrameTooShort {
        /// Bytes the mapping needs.
        expected: usize,
        /// Bytes received.
        got: usize,
    },
    /// The frame is longer than the mapping (EMCY 0x8220).
    FrameTooLong {
        /// Bytes the mapping needs.
        expected: usize,
        /// Bytes received.
        got: usize,
    },
}

impl fmt::Display for PdoError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PdoError::TooLong => write!(f, "mapping exceeds 8 entries / 64 bits"),
            PdoError::ZeroLength => write!(f, "mapping entry with 0 bits"),
            PdoError::FrameTooShort { expected, got } => {
                write!(f, "PDO has {got} bytes, mapping needs {expected}")
            }
            PdoError::FrameTooLong { expected, got } => {
                write!(f, "PDO has {got} bytes, mapping needs only {expected}")
            }
        }
    }
}

/// A PDO mapping: up to 8 entries, at most 64 bits, fixed capacity (no allocation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct PdoMap {
    entries: [Option<MappingEntry>; 8],
    len: u8,
}

impl PdoMap {
    /// An empty mapping.
    pub const fn new() -> PdoMap {
        PdoMap {
            entries: [None; 8],
            len: 0,
        }
    }
    /// A mapping of `entries`, checked.
    pub fn from_entries(entries: &[MappingEntry]) -> Result<PdoMap, PdoError> {
        let mut m = PdoMap::new();
        for e in entries {
            m.push(*e)?;
        }
        Ok(m)
    }
    /// Appends an entry; fails past 8 entries or 64 bits.
    pub fn push(&mut self, e: MappingEntry) -> Result<(), PdoError> {
        if e.bits == 0 {
            return Err(PdoError::ZeroLength);
        }
        if self.len >= 8 || self.total_bits() + e.bits as u32 > 64 {
            return Err(PdoError::TooLong);
        }
        self.entries[self.len as usize] = Some(e);
        self.len += 1;
        Ok(())
    }
    /// Number of entries.
    pub fn len(&self) -> usize {
        self.len as usize
    }
    /// No entries.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
    /// The entries in order.
    pub fn entries(&self) -> impl Iterator<Item = MappingEntry> + '_ {
        self.entries[..self.len as usize].iter().flatten().copied()
    }
    /// Mapped bits.
    pub fn total_bits(&self) -> u32 {
        self.entries().map(|e| e.bits as u32).sum()
    }
    /// Bytes of the PDO (bits rounded up).
    pub fn byte_len(&self) -> usize {
        self.total_bits().div_ceil(8) as usize
    }

    /// Packs values into `out`; `value(entry)` gives each entry's raw value (low `bits` bits
    /// used). Returns the PDO length in bytes.
    pub fn pack(&self, out: &mut [u8; 8], mut value: impl FnMut(MappingEntry) -> u64) -> usize {
        let mut acc: u64 = 0;
        let mut shift = 0u32;
        for e in self.entries() {
            let v = value(e) & mask(e.bits);
            acc |= v.checked_shl(shift).unwrap_or(0);
            shift += e.bits as u32;
        }
        *out = acc.to_le_bytes();
        self.byte_len()
    }

    /// Unpacks `data`, calling `sink(entry, raw)` per entry (raw = the entry's bits,
    /// zero-extended). The length must match the mapping exactly.
    pub fn unpack(
        &self,
        data: &[u8],
        mut sink: impl FnMut(MappingEntry, u64),
    ) -> Result<(), PdoError> {
        let expected = self.byte_len();
        if data.len() < expected {
            return Err(PdoError::FrameTooShort {
                expected,
                got: data.len(),
            });
        }
        if data.len() > expected {
            return Err(PdoError::FrameTooLong {
                expected,
                got: data.len(),
            });
        }
        let mut b = [0u8; 8];
        b[..data.len()].copy_from_slice(data);
        let acc = u64::from_le_bytes(b);
        let mut shift = 0u32;
        for e in self.entries() {
            sink(e, acc.checked_shr(shift).unwrap_or(0) & mask(e.bits));
            shift += e.bits as u32;
        }
        Ok(())
    }
}

fn mask(bits: u8) -> u64 {
    if bits >= 64 {
        u64::MAX
    } else {
        (1u64 << bits) - 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cob_ids() {
        let n = NodeId::new(3).unwrap();
        assert_eq!(pdo_cob_id(PdoDirection::Tpdo, 1, n), Some(0x183));
        assert_eq!(pdo_cob_id(PdoDirection::Tpdo, 4, n), Some(0x483));
        assert_eq!(pdo_cob_id(PdoDirection::Rpdo, 1, n), Some(0x203));
        assert_eq!(pdo_cob_id(PdoDirection::Rpdo, 4, n), Some(0x503));
        assert_eq!(pdo_cob_id(PdoDirection::Rpdo, 0, n), None);
        assert_eq!(pdo_cob_id(PdoDirection::Rpdo, 5, n), None);
    }

    #[test]
    fn csp_rpdo_packs_controlword_then_target() {
        let m = PdoMap::from_entries(&[
            MappingEntry::from_u32(0x6040_0010),
            MappingEntry::from_u32(0x607A_0020),
        ])
        .unwrap();
        assert_eq!(m.byte_len(), 6);
        let mut out = [0u8; 8];
        let target: i32 = -2;
        let n = m.pack(&mut out, |e| match e.index {
            0x6040 => 0x000F,
            0x607A => target as u32 as u64,
            _ => 0,
        });
        assert_eq!(&out[..n], &[0x0F, 0x00, 0xFE, 0xFF, 0xFF, 0xFF]);
        let mut got = Vec::new();
        m.unpack(&out[..n], |e, v| got.push((e.index, v))).unwrap();
        assert_eq!(got, vec![(0x6040, 0x0F), (0x607A, 0xFFFF_FFFE)]);
        assert_eq!(
            m.unpack(&out[..5], |_, _| ()),
            Err(PdoError::FrameTooShort {
                expected: 6,
                got: 5
            })
        );
        assert_eq!(
            m.unpack(&out[..7], |_, _| ()),
            Err(PdoError::FrameTooLong {
                expected: 6,
                got: 7
            })
        );
    }

    #[test]
    fn sub_byte_entries_and_limits() {
        let m = PdoMap::from_entries(&[
            MappingEntry::new(0x2000, 1, 1),
            MappingEntry::new(0x2000, 2, 3),
            MappingEntry::new(0x2000, 3, 12),
        ])
        .unwrap();
        let mut out = [0u8; 8];
        let n = m.pack(&mut out, |e| match e.sub {
            1 => 1,
            2 => 0b101,
            _ => 0xABC,
        });
        assert_eq!(n, 2);
        // bit0 = 1, bits1..4 = 101, bits 4..16 = 0xABC
        assert_eq!(
            u16::from_le_bytes([out[0], out[1]]),
            1 | 0b101 << 1 | 0xABC << 4
        );
        let mut got = Vec::new();
        m.unpack(&out[..n], |e, v| got.push((e.sub, v))).unwrap();
        assert_eq!(got, vec![(1, 1), (2, 5), (3, 0xABC)]);
        assert_eq!(MappingEntry::from_u32(0x6064_0020).to_u32(), 0x6064_0020);
        let mut full = PdoMap::from_entries(&[MappingEntry::new(1, 0, 64)]).unwrap();
        assert_eq!(
            full.push(MappingEntry::new(1, 0, 1)),
            Err(PdoError::TooLong)
        );
        let mut eight = PdoMap::new();
        for i in 0..8 {
            eight.push(MappingEntry::new(i, 0, 8)).unwrap();
        }
        assert_eq!(
            eight.push(MappingEntry::new(9, 0, 8)),
            Err(PdoError::TooLong)
        );
        assert_eq!(
            PdoMap::new().push(MappingEntry::new(1, 0, 0)),
            Err(PdoError::ZeroLength)
        );
        // A 64-bit entry round-trips.
        let mut out = [0u8; 8];
        full.pack(&mut out, |_| u64::MAX - 1);
        let mut v = 0;
        full.unpack(&out, |_, x| v = x).unwrap();
        assert_eq!(v, u64::MAX - 1);
    }
}
