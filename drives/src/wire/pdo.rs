//! PDOs: raw data bytes, their COB-IDs, and mapping entries (0xIIIISSLL) with bit-exact
//! packing of up to 64 mapped bits, little-endian as CiA 301 lays them out. [`PdoMap`] is a
//! mapping parameter as a device stores it (any dictionary entry); [`PdoLayout`] is the
//! validated layout of a PDO of known CiA 402 objects with precomputed bit offsets, packing
//! and unpacking [`PdoValues`] (its `Repr`) without allocating — the master's RPDO1/TPDO1.
//!
//! Not canopen-rs 0.6.1's `pdo` module: it packs whole bytes only ("sub-byte PDO packing" is
//! on its roadmap) and its `Node` applies every RPDO on arrival and sends every synchronous
//! TPDO on every SYNC (node.rs ~457-499). Packing here is pure; when a PDO is applied or sent
//! is the device's business (`sim`).

use core::fmt;

use cia402::objects as obj;

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
    /// A [`PdoLayout`] entry that is not a known [`PdoObject`].
    UnknownObject {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
    },
    /// A [`PdoLayout`] entry whose bit length is not its object's.
    WrongObjectLength {
        /// The object.
        object: PdoObject,
        /// Bits the entry gives.
        bits: u8,
    },
    /// A [`PdoLayout`] entry for an object the other direction carries (a statusword in an
    /// RPDO, a controlword in a TPDO).
    WrongDirection(PdoObject),
    /// A [`PdoLayout`] that maps one object twice.
    DuplicateObject(PdoObject),
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
            PdoError::UnknownObject { index, sub } => {
                write!(
                    f,
                    "{index:#06x}:{sub} is not a process data object this layout knows"
                )
            }
            PdoError::WrongObjectLength { object, bits } => write!(
                f,
                "{object:?} mapped with {bits} bits, it has {}",
                object.entry().bits
            ),
            PdoError::WrongDirection(o) => write!(f, "{o:?} is not carried in this direction"),
            PdoError::DuplicateObject(o) => write!(f, "{o:?} mapped twice"),
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
        check_append(self.len as usize, self.total_bits(), e)?;
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
            acc |= place(value(e), e.bits, shift);
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
        let acc = read_exact(data, self.byte_len())?;
        let mut shift = 0u32;
        for e in self.entries() {
            sink(e, take(acc, e.bits, shift));
            shift += e.bits as u32;
        }
        Ok(())
    }
}

/// The rule every mapping obeys (CiA 301): an entry has bits, at most 8 entries, at most 64
/// bits. `len` entries of `bits` bits are mapped before `e`.
const fn check_append(len: usize, bits: u32, e: MappingEntry) -> Result<(), PdoError> {
    if e.bits == 0 {
        return Err(PdoError::ZeroLength);
    }
    if len >= 8 || bits + e.bits as u32 > 64 {
        return Err(PdoError::TooLong);
    }
    Ok(())
}

/// `value`'s low `bits` bits at bit `offset` of the little-endian PDO word.
const fn place(value: u64, bits: u8, offset: u32) -> u64 {
    match (value & mask(bits)).checked_shl(offset) {
        Some(v) => v,
        None => 0,
    }
}

/// The `bits` bits at bit `offset` of the little-endian PDO word, zero-extended.
const fn take(word: u64, bits: u8, offset: u32) -> u64 {
    match word.checked_shr(offset) {
        Some(v) => v & mask(bits),
        None => 0,
    }
}

/// The PDO word of `data`, which must be exactly `expected` bytes (a device answers other
/// lengths with EMCY 0x8210/0x8220).
fn read_exact(data: &[u8], expected: usize) -> Result<u64, PdoError> {
    let got = data.len();
    if got < expected {
        return Err(PdoError::FrameTooShort { expected, got });
    }
    if got > expected || got > 8 {
        return Err(PdoError::FrameTooLong { expected, got });
    }
    let mut b = [0u8; 8];
    b[..got].copy_from_slice(data);
    Ok(u64::from_le_bytes(b))
}

/// A CiA 402 process data object a [`PdoLayout`] may map: its dictionary entry (index,
/// sub-index, bit length) and the direction that carries it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PdoObject {
    /// 0x6040, UNSIGNED16, master → drive.
    Controlword,
    /// 0x6060, INTEGER8, master → drive.
    ModesOfOperation,
    /// 0x607A, INTEGER32 counts, master → drive.
    TargetPosition,
    /// 0x6041, UNSIGNED16, drive → master.
    Statusword,
    /// 0x6061, INTEGER8, drive → master.
    ModesOfOperationDisplay,
    /// 0x6064, INTEGER32 counts, drive → master.
    PositionActual,
    /// 0x606C, INTEGER32, drive → master.
    VelocityActual,
    /// 0x60F4, INTEGER32 counts, drive → master.
    FollowingErrorActual,
    /// 0x603F, UNSIGNED16, drive → master.
    ErrorCode,
    /// 0x60FD digital inputs, UNSIGNED32, drive → master (limit and home switches, E-stop).
    DigitalInputs,
    /// 0x60FE:1 digital outputs, UNSIGNED32, master → drive (coolant, spindle enable, clamp).
    DigitalOutputs,
}

impl PdoObject {
    /// Every known object, in the order of [`PdoValues`]' slots.
    pub const ALL: [PdoObject; 11] = [
        PdoObject::Controlword,
        PdoObject::ModesOfOperation,
        PdoObject::TargetPosition,
        PdoObject::Statusword,
        PdoObject::ModesOfOperationDisplay,
        PdoObject::PositionActual,
        PdoObject::VelocityActual,
        PdoObject::FollowingErrorActual,
        PdoObject::ErrorCode,
        PdoObject::DigitalInputs,
        PdoObject::DigitalOutputs,
    ];

    /// The mapping entry of the object (index, sub-index, bit length).
    pub const fn entry(self) -> MappingEntry {
        match self {
            PdoObject::Controlword => MappingEntry::new(obj::CONTROLWORD, 0, 16),
            PdoObject::ModesOfOperation => MappingEntry::new(obj::MODES_OF_OPERATION, 0, 8),
            PdoObject::TargetPosition => MappingEntry::new(obj::TARGET_POSITION, 0, 32),
            PdoObject::Statusword => MappingEntry::new(obj::STATUSWORD, 0, 16),
            PdoObject::ModesOfOperationDisplay => {
                MappingEntry::new(obj::MODES_OF_OPERATION_DISPLAY, 0, 8)
            }
            PdoObject::PositionActual => MappingEntry::new(obj::POSITION_ACTUAL, 0, 32),
            PdoObject::VelocityActual => MappingEntry::new(obj::VELOCITY_ACTUAL, 0, 32),
            PdoObject::FollowingErrorActual => {
                MappingEntry::new(obj::FOLLOWING_ERROR_ACTUAL, 0, 32)
            }
            PdoObject::ErrorCode => MappingEntry::new(obj::ERROR_CODE, 0, 16),
            PdoObject::DigitalInputs => MappingEntry::new(obj::DIGITAL_INPUTS, 0, 32),
            PdoObject::DigitalOutputs => MappingEntry::new(obj::DIGITAL_OUTPUTS, 1, 32),
        }
    }

    /// The direction whose PDOs carry the object: RPDO for what the master commands, TPDO
    /// for what the drive reports.
    pub const fn direction(self) -> PdoDirection {
        match self {
            PdoObject::Controlword
            | PdoObject::ModesOfOperation
            | PdoObject::TargetPosition
            | PdoObject::DigitalOutputs => PdoDirection::Rpdo,
            _ => PdoDirection::Tpdo,
        }
    }

    /// The object at `index:sub`, if it is a known one.
    pub const fn at(index: u16, sub: u8) -> Option<PdoObject> {
        let mut k = 0;
        while k < PdoObject::ALL.len() {
            let e = PdoObject::ALL[k].entry();
            if e.index == index && e.sub == sub {
                return Some(PdoObject::ALL[k]);
            }
            k += 1;
        }
        None
    }

    /// The object's slot in [`PdoValues`].
    const fn slot(self) -> usize {
        self as usize
    }
}

/// The values of a PDO's objects: the `Repr` a [`PdoLayout`] packs and unpacks. Values are
/// raw, the object's bits zero-extended (`as u16`, `as u32 as i32` give the typed value).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PdoValues {
    raw: [u64; PdoObject::ALL.len()],
    /// Bit `slot` set: the object has a value.
    present: u16,
}

impl PdoValues {
    /// No values.
    pub const fn new() -> PdoValues {
        PdoValues {
            raw: [0; PdoObject::ALL.len()],
            present: 0,
        }
    }
    /// These values with `object` set to `raw` (cut to the object's bits).
    pub const fn with(mut self, object: PdoObject, raw: u64) -> PdoValues {
        self.raw[object.slot()] = raw & mask(object.entry().bits);
        self.present |= 1 << object.slot();
        self
    }
    /// The raw value of `object`, if it has one.
    pub const fn get(&self, object: PdoObject) -> Option<u64> {
        if self.present & (1 << object.slot()) != 0 {
            Some(self.raw[object.slot()])
        } else {
            None
        }
    }
}

/// One mapped object of a [`PdoLayout`] and where its bits start in the PDO.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PdoField {
    /// The object (its entry gives index, sub-index and bit length).
    pub object: PdoObject,
    /// Bit offset of its lowest bit in the little-endian PDO data.
    pub offset: u8,
}

/// A validated PDO layout: up to 8 known objects of one direction, each once, at most 64
/// bits, with the bit offset of each precomputed. Built from the mapping entries a master
/// writes to 0x1600+n / 0x1A00+n (sub 1..=n in order); packing and unpacking allocate
/// nothing and never panic.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PdoLayout {
    direction: PdoDirection,
    fields: [PdoField; 8],
    len: u8,
    bits: u8,
}

impl PdoLayout {
    /// The layout of `entries` (mapping sub 1, 2, … in order) for a PDO of `direction`;
    /// refuses what does not fit 8 entries / 64 bits, an unknown object, an object of the
    /// other direction or with another bit length, and an object mapped twice.
    pub const fn new(
        direction: PdoDirection,
        entries: &[MappingEntry],
    ) -> Result<PdoLayout, PdoError> {
        let unused = PdoField {
            object: PdoObject::Controlword,
            offset: 0,
        };
        let mut layout = PdoLayout {
            direction,
            fields: [unused; 8],
            len: 0,
            bits: 0,
        };
        let mut k = 0;
        while k < entries.len() {
            let e = entries[k];
            if let Err(err) = check_append(k, layout.bits as u32, e) {
                return Err(err);
            }
            let Some(object) = PdoObject::at(e.index, e.sub) else {
                return Err(PdoError::UnknownObject {
                    index: e.index,
                    sub: e.sub,
                });
            };
            if object.entry().bits != e.bits {
                return Err(PdoError::WrongObjectLength {
                    object,
                    bits: e.bits,
                });
            }
            if !matches!(
                (object.direction(), direction),
                (PdoDirection::Rpdo, PdoDirection::Rpdo) | (PdoDirection::Tpdo, PdoDirection::Tpdo)
            ) {
                return Err(PdoError::WrongDirection(object));
            }
            if layout.maps(object) {
                return Err(PdoError::DuplicateObject(object));
            }
            layout.fields[k] = PdoField {
                object,
                offset: layout.bits,
            };
            layout.bits += e.bits;
            layout.len += 1;
            k += 1;
        }
        Ok(layout)
    }

    /// RPDO or TPDO.
    pub const fn direction(&self) -> PdoDirection {
        self.direction
    }
    /// The mapped objects in order, with their offsets.
    pub fn fields(&self) -> &[PdoField] {
        &self.fields[..self.len as usize]
    }
    /// The mapping entries in order: what a master writes to mapping sub 1..=n.
    pub fn entries(&self) -> impl ExactSizeIterator<Item = MappingEntry> + '_ {
        self.fields().iter().map(|f| f.object.entry())
    }
    /// The same mapping as a [`PdoMap`] (what a device stores).
    pub fn map(&self) -> PdoMap {
        let mut m = PdoMap::new();
        for e in self.entries() {
            // Validated by `new`: at most 8 entries, 64 bits.
            let _ = m.push(e);
        }
        m
    }
    /// Whether `object` is mapped.
    pub const fn maps(&self, object: PdoObject) -> bool {
        let mut k = 0;
        while k < self.len as usize {
            if self.fields[k].object as usize == object as usize {
                return true;
            }
            k += 1;
        }
        false
    }
    /// Bytes of the PDO (bits rounded up).
    pub const fn byte_len(&self) -> usize {
        (self.bits as usize).div_ceil(8)
    }

    /// The PDO data of `values` and its length; a mapped object without a value is sent
    /// as 0, values of objects not mapped are left out. Bytes past the length are 0.
    pub fn pack(&self, values: &PdoValues) -> ([u8; 8], usize) {
        let mut word = 0u64;
        for f in self.fields() {
            let raw = values.raw[f.object.slot()];
            word |= place(raw, f.object.entry().bits, f.offset as u32);
        }
        (word.to_le_bytes(), self.byte_len())
    }

    /// The values of PDO data `data`, which must be exactly [`byte_len`](Self::byte_len)
    /// bytes; every mapped object has a value.
    pub fn unpack(&self, data: &[u8]) -> Result<PdoValues, PdoError> {
        let word = read_exact(data, self.byte_len())?;
        let mut values = PdoValues::new();
        for f in self.fields() {
            values = values.with(f.object, take(word, f.object.entry().bits, f.offset as u32));
        }
        Ok(values)
    }
}

const fn mask(bits: u8) -> u64 {
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

    fn rpdo(entries: &[MappingEntry]) -> Result<PdoLayout, PdoError> {
        PdoLayout::new(PdoDirection::Rpdo, entries)
    }
    fn tpdo(entries: &[MappingEntry]) -> Result<PdoLayout, PdoError> {
        PdoLayout::new(PdoDirection::Tpdo, entries)
    }

    #[test]
    fn layout_offsets_and_csp_bytes() {
        let r = rpdo(&[
            MappingEntry::from_u32(0x6040_0010),
            MappingEntry::from_u32(0x607A_0020),
        ])
        .unwrap();
        assert_eq!(r.byte_len(), 6);
        assert_eq!(
            r.fields(),
            &[
                PdoField {
                    object: PdoObject::Controlword,
                    offset: 0
                },
                PdoField {
                    object: PdoObject::TargetPosition,
                    offset: 16
                }
            ]
        );
        let v = PdoValues::new()
            .with(PdoObject::Controlword, 0x000F)
            .with(PdoObject::TargetPosition, -2i32 as u32 as u64);
        let (d, n) = r.pack(&v);
        assert_eq!(&d[..n], &[0x0F, 0x00, 0xFE, 0xFF, 0xFF, 0xFF]);
        assert_eq!(&d[n..], &[0, 0], "bytes past the length are 0");
        // The entries boot writes, and the same mapping as a device stores it packs alike.
        let entries: Vec<u32> = r.entries().map(MappingEntry::to_u32).collect();
        assert_eq!(entries, [0x6040_0010, 0x607A_0020]);
        let mut via_map = [0u8; 8];
        r.map().pack(&mut via_map, |e| match e.index {
            0x6040 => 0x000F,
            _ => -2i32 as u32 as u64,
        });
        assert_eq!(via_map, d);
    }

    #[test]
    fn layout_round_trips() {
        let t = tpdo(&[
            PdoObject::Statusword.entry(),
            PdoObject::ModesOfOperationDisplay.entry(),
            PdoObject::PositionActual.entry(),
        ])
        .unwrap();
        assert_eq!(t.byte_len(), 7);
        let v = PdoValues::new()
            .with(PdoObject::Statusword, 0x1637)
            .with(PdoObject::ModesOfOperationDisplay, 8)
            .with(PdoObject::PositionActual, i32::MIN as u32 as u64);
        let (d, n) = t.pack(&v);
        assert_eq!(&d[..n], &[0x37, 0x16, 0x08, 0x00, 0x00, 0x00, 0x80][..]);
        let back = t.unpack(&d[..n]).unwrap();
        assert_eq!(back, v);
        assert_eq!(back.get(PdoObject::VelocityActual), None, "not mapped");
        assert_eq!(
            t.unpack(&d[..n - 1]),
            Err(PdoError::FrameTooShort {
                expected: 7,
                got: 6
            })
        );
        // Values of objects the layout does not map are left out; values are cut to their
        // object's bits.
        let r = rpdo(&[PdoObject::ModesOfOperation.entry()]).unwrap();
        let (d, n) = r.pack(
            &PdoValues::new()
                .with(PdoObject::ModesOfOperation, 0x1_08)
                .with(PdoObject::Controlword, 0xFFFF),
        );
        assert_eq!(&d[..n], &[0x08]);
        assert_eq!(
            r.unpack(&[8, 0]),
            Err(PdoError::FrameTooLong {
                expected: 1,
                got: 2
            })
        );
    }

    #[test]
    fn layout_refuses_what_does_not_fit_8_bytes() {
        // 16 + 32 + 32 = 80 bits.
        assert_eq!(
            tpdo(&[
                PdoObject::Statusword.entry(),
                PdoObject::PositionActual.entry(),
                PdoObject::VelocityActual.entry(),
            ]),
            Err(PdoError::TooLong)
        );
        // Exactly 64 bits fit.
        let t = tpdo(&[
            PdoObject::PositionActual.entry(),
            PdoObject::FollowingErrorActual.entry(),
        ])
        .unwrap();
        assert_eq!(t.byte_len(), 8);
        assert_eq!(
            tpdo(&[MappingEntry::new(0x6041, 0, 0)]),
            Err(PdoError::ZeroLength)
        );
    }

    #[test]
    fn layout_refuses_unknown_wrong_and_repeated_objects() {
        assert_eq!(
            rpdo(&[MappingEntry::new(0x2000, 1, 16)]),
            Err(PdoError::UnknownObject {
                index: 0x2000,
                sub: 1
            })
        );
        assert_eq!(
            rpdo(&[MappingEntry::new(0x6040, 1, 16)]),
            Err(PdoError::UnknownObject {
                index: 0x6040,
                sub: 1
            })
        );
        assert_eq!(
            rpdo(&[MappingEntry::new(0x607A, 0, 16)]),
            Err(PdoError::WrongObjectLength {
                object: PdoObject::TargetPosition,
                bits: 16
            })
        );
        assert_eq!(
            rpdo(&[PdoObject::Statusword.entry()]),
            Err(PdoError::WrongDirection(PdoObject::Statusword))
        );
        assert_eq!(
            tpdo(&[PdoObject::Controlword.entry()]),
            Err(PdoError::WrongDirection(PdoObject::Controlword))
        );
        assert_eq!(
            rpdo(&[
                PdoObject::Controlword.entry(),
                PdoObject::Controlword.entry()
            ]),
            Err(PdoError::DuplicateObject(PdoObject::Controlword))
        );
        for o in PdoObject::ALL {
            assert_eq!(PdoObject::at(o.entry().index, o.entry().sub), Some(o));
        }
        assert!(
            PdoError::UnknownObject {
                index: 0x2000,
                sub: 1
            }
            .to_string()
            .contains("0x2000:1")
        );
    }
}
