//! A small object dictionary: (index, sub-index) → typed value with access rights, a
//! PDO-mappable flag and an optional value range; errors map to SDO abort codes. Used by the
//! simulated drive's SDO server, and by drivectl for its data types and value codec.
//!
//! Not canopen-rs 0.6.1's `ObjectDictionary`: it has no PDO-mappable flag (needed for abort
//! 0x06040041), reports a missing sub-index like a missing object (no 0x06090011), and caps
//! strings at 32 bytes (datatypes.rs ~29).

use std::fmt;
use std::hash::{Hash, Hasher};

use crate::wire::AbortCode;

/// A CANopen basic data type (defined with the EDS/DCF reader in `cnc402_config::eds`, so the
/// config, the master, the simulator and drivectl share one).
pub use cnc402_config::eds::DataType;

/// 0x1010: store parameters (CiA 301); sub 1 saves all parameters.
pub const STORE_PARAMETERS: u16 = 0x1010;
/// 0x1011: restore default parameters; sub 1 restores all (effective after a reset).
pub const RESTORE_DEFAULTS: u16 = 0x1011;
/// The signature a store takes: "save" in ASCII, as a little-endian UNSIGNED32.
pub const SAVE_SIGNATURE: u32 = 0x6576_6173;
/// The signature a restore takes: "load".
pub const LOAD_SIGNATURE: u32 = 0x6461_6F6C;

/// A typed value. Equality and hashing compare type and bits (so a REAL NaN equals itself
/// and 0.0 differs from -0.0).
#[derive(Clone, Debug)]
pub enum Value {
    /// BOOLEAN.
    Boolean(bool),
    /// INTEGER8.
    I8(i8),
    /// INTEGER16.
    I16(i16),
    /// INTEGER32.
    I32(i32),
    /// INTEGER64.
    I64(i64),
    /// UNSIGNED8.
    U8(u8),
    /// UNSIGNED16.
    U16(u16),
    /// UNSIGNED32.
    U32(u32),
    /// UNSIGNED64.
    U64(u64),
    /// REAL32.
    Real32(f32),
    /// REAL64.
    Real64(f64),
    /// VISIBLE_STRING.
    VisibleString(String),
    /// OCTET_STRING.
    OctetString(Vec<u8>),
    /// DOMAIN.
    Domain(Vec<u8>),
}

impl Value {
    /// Its data type.
    pub fn data_type(&self) -> DataType {
        match self {
            Value::Boolean(_) => DataType::Boolean,
            Value::I8(_) => DataType::Integer8,
            Value::I16(_) => DataType::Integer16,
            Value::I32(_) => DataType::Integer32,
            Value::I64(_) => DataType::Integer64,
            Value::U8(_) => DataType::Unsigned8,
            Value::U16(_) => DataType::Unsigned16,
            Value::U32(_) => DataType::Unsigned32,
            Value::U64(_) => DataType::Unsigned64,
            Value::Real32(_) => DataType::Real32,
            Value::Real64(_) => DataType::Real64,
            Value::VisibleString(_) => DataType::VisibleString,
            Value::OctetString(_) => DataType::OctetString,
            Value::Domain(_) => DataType::Domain,
        }
    }

    /// The raw bits of a fixed-size value, zero-extended (for PDO packing); `None` for strings.
    pub fn to_raw(&self) -> Option<u64> {
        Some(match *self {
            Value::Boolean(b) => b as u64,
            Value::I8(v) => v as u8 as u64,
            Value::I16(v) => v as u16 as u64,
            Value::I32(v) => v as u32 as u64,
            Value::I64(v) => v as u64,
            Value::U8(v) => v as u64,
            Value::U16(v) => v as u64,
            Value::U32(v) => v as u64,
            Value::U64(v) => v,
            Value::Real32(v) => v.to_bits() as u64,
            Value::Real64(v) => v.to_bits(),
            _ => return None,
        })
    }

    /// A value of fixed-size type `t` from raw bits (low bits used; sign from the type).
    pub fn from_raw(t: DataType, raw: u64) -> Option<Value> {
        Some(match t {
            DataType::Boolean => Value::Boolean(raw & 1 != 0),
            DataType::Integer8 => Value::I8(raw as u8 as i8),
            DataType::Integer16 => Value::I16(raw as u16 as i16),
            DataType::Integer32 => Value::I32(raw as u32 as i32),
            DataType::Integer64 => Value::I64(raw as i64),
            DataType::Unsigned8 => Value::U8(raw as u8),
            DataType::Unsigned16 => Value::U16(raw as u16),
            DataType::Unsigned32 => Value::U32(raw as u32),
            DataType::Unsigned64 => Value::U64(raw),
            DataType::Real32 => Value::Real32(f32::from_bits(raw as u32)),
            DataType::Real64 => Value::Real64(f64::from_bits(raw)),
            _ => return None,
        })
    }

    /// As a signed number (integers and booleans), sign-extended; `None` for reals and strings.
    pub fn as_i64(&self) -> Option<i64> {
        let t = self.data_type();
        if matches!(t, DataType::Real32 | DataType::Real64) {
            return None;
        }
        let raw = self.to_raw()?;
        let bits = t.size()? * 8;
        Some(if t.is_signed() && bits < 64 {
            let shift = 64 - bits;
            ((raw << shift) as i64) >> shift
        } else {
            raw as i64
        })
    }

    /// As an unsigned number: the raw bits of a fixed-size value (a REAL's IEEE bits).
    pub fn as_u64(&self) -> Option<u64> {
        self.to_raw()
    }

    /// Little-endian bytes as SDO carries them.
    pub fn to_bytes(&self) -> Vec<u8> {
        match self {
            Value::VisibleString(s) => s.as_bytes().to_vec(),
            Value::OctetString(b) | Value::Domain(b) => b.clone(),
            v => {
                let n = v.data_type().size().unwrap_or(0);
                v.to_raw().unwrap_or(0).to_le_bytes()[..n].to_vec()
            }
        }
    }

    /// An integer value of type `t` from `v`, range-checked against the type
    /// ([`OdError::ValueTooHigh`]/[`OdError::ValueTooLow`]); [`OdError::InvalidValue`] if `t`
    /// is not an integer type.
    pub fn from_int(t: DataType, v: i128) -> Result<Value, OdError> {
        let (min, max) = t.int_range().ok_or(OdError::InvalidValue)?;
        if v > max {
            return Err(OdError::ValueTooHigh);
        }
        if v < min {
            return Err(OdError::ValueTooLow);
        }
        // In range, so the low 64 bits are the two's complement of the value.
        Value::from_raw(t, v as u64).ok_or(OdError::InvalidValue)
    }

    /// Decodes SDO bytes as type `t`; fixed-size types need exactly their size.
    pub fn from_bytes(t: DataType, bytes: &[u8]) -> Result<Value, OdError> {
        match t.size() {
            Some(n) => {
                if bytes.len() > n {
                    return Err(OdError::LengthTooHigh);
                }
                if bytes.len() < n {
                    return Err(OdError::LengthTooLow);
                }
                let mut b = [0u8; 8];
                b[..n].copy_from_slice(bytes);
                Value::from_raw(t, u64::from_le_bytes(b)).ok_or(OdError::LengthMismatch)
            }
            None => Ok(match t {
                DataType::VisibleString => Value::VisibleString(
                    String::from_utf8(bytes.to_vec()).map_err(|_| OdError::InvalidValue)?,
                ),
                DataType::OctetString => Value::OctetString(bytes.to_vec()),
                _ => Value::Domain(bytes.to_vec()),
            }),
        }
    }
}

impl PartialEq for Value {
    fn eq(&self, other: &Value) -> bool {
        match (self, other) {
            (Value::VisibleString(a), Value::VisibleString(b)) => a == b,
            (Value::OctetString(a), Value::OctetString(b))
            | (Value::Domain(a), Value::Domain(b)) => a == b,
            _ => {
                self.data_type() == other.data_type()
                    && self.to_raw().is_some()
                    && self.to_raw() == other.to_raw()
            }
        }
    }
}

impl Eq for Value {}

impl Hash for Value {
    fn hash<H: Hasher>(&self, h: &mut H) {
        self.data_type().hash(h);
        match self {
            Value::VisibleString(s) => s.hash(h),
            Value::OctetString(b) | Value::Domain(b) => b.hash(h),
            v => v.to_raw().hash(h),
        }
    }
}

/// Access rights of an entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Access {
    /// Read only (may change inside the device, e.g. the statusword).
    ReadOnly,
    /// Write only.
    WriteOnly,
    /// Read and write.
    ReadWrite,
    /// Constant.
    Const,
}

impl Access {
    /// Whether SDO upload is allowed.
    pub const fn readable(self) -> bool {
        !matches!(self, Access::WriteOnly)
    }
    /// Whether SDO download is allowed.
    pub const fn writable(self) -> bool {
        matches!(self, Access::WriteOnly | Access::ReadWrite)
    }
}

/// One object dictionary entry.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// Human-readable name (for messages).
    pub name: &'static str,
    /// Current value; its variant fixes the type.
    pub value: Value,
    /// Access rights.
    pub access: Access,
    /// May be mapped into a PDO.
    pub pdo_mappable: bool,
    /// Allowed range of integer values written over SDO (inclusive).
    pub range: Option<(i64, i64)>,
}

impl Entry {
    /// An entry, not PDO-mappable, no range.
    pub fn new(name: &'static str, access: Access, value: Value) -> Entry {
        Entry {
            name,
            value,
            access,
            pdo_mappable: false,
            range: None,
        }
    }
    /// Marks it PDO-mappable.
    pub fn mappable(mut self) -> Entry {
        self.pdo_mappable = true;
        self
    }
    /// Restricts SDO writes to `min..=max`.
    pub fn range(mut self, min: i64, max: i64) -> Entry {
        self.range = Some((min, max));
        self
    }
}

/// Why an access failed; [`OdError::abort_code`] gives the SDO abort code.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OdError {
    /// No such index.
    NoObject,
    /// Index exists, sub-index does not.
    NoSubIndex,
    /// Write to a read-only or constant entry.
    ReadOnly,
    /// Read of a write-only entry.
    WriteOnly,
    /// Value type does not match the entry.
    LengthMismatch,
    /// More bytes than the type has.
    LengthTooHigh,
    /// Fewer bytes than the type has.
    LengthTooLow,
    /// Above the entry's range.
    ValueTooHigh,
    /// Below the entry's range.
    ValueTooLow,
    /// A value the entry does not accept.
    InvalidValue,
}

impl OdError {
    /// The SDO abort code a server answers with.
    pub const fn abort_code(self) -> AbortCode {
        match self {
            OdError::NoObject => AbortCode::NoObject,
            OdError::NoSubIndex => AbortCode::NoSubIndex,
            OdError::ReadOnly => AbortCode::WriteReadOnly,
            OdError::WriteOnly => AbortCode::ReadWriteOnly,
            OdError::LengthMismatch => AbortCode::LengthMismatch,
            OdError::LengthTooHigh => AbortCode::LengthTooHigh,
            OdError::LengthTooLow => AbortCode::LengthTooLow,
            OdError::ValueTooHigh => AbortCode::ValueTooHigh,
            OdError::ValueTooLow => AbortCode::ValueTooLow,
            OdError::InvalidValue => AbortCode::InvalidValue,
        }
    }
}

impl fmt::Display for OdError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = self.abort_code();
        write!(f, "{}", c)
    }
}

impl std::error::Error for OdError {}

/// A remembered entry position, from [`ObjectDictionary::slot`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Slot {
    pos: u32,
    key: u32,
}

/// The object dictionary: entries sorted by (index, sub) in one vector, looked up by binary
/// search (the simulated drive reads a dozen entries per SYNC; this keeps that cheap and
/// allocation-free).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjectDictionary {
    entries: Vec<(u32, Entry)>,
}

const fn key(index: u16, sub: u8) -> u32 {
    (index as u32) << 8 | sub as u32
}

impl ObjectDictionary {
    /// An empty dictionary.
    pub fn new() -> ObjectDictionary {
        ObjectDictionary::default()
    }

    /// Inserts (or replaces) an entry.
    pub fn insert(&mut self, index: u16, sub: u8, entry: Entry) {
        let k = key(index, sub);
        match self.entries.binary_search_by_key(&k, |e| e.0) {
            Ok(i) => self.entries[i].1 = entry,
            Err(i) => self.entries.insert(i, (k, entry)),
        }
    }

    /// Inserts a variable at sub-index 0.
    pub fn insert_var(&mut self, index: u16, entry: Entry) {
        self.insert(index, 0, entry);
    }

    /// Whether the object (any sub-index) exists.
    pub fn has_object(&self, index: u16) -> bool {
        let i = self.entries.partition_point(|e| e.0 < key(index, 0));
        self.entries
            .get(i)
            .is_some_and(|e| e.0 >> 8 == index as u32)
    }

    fn position(&self, index: u16, sub: u8) -> Result<usize, OdError> {
        self.entries
            .binary_search_by_key(&key(index, sub), |e| e.0)
            .map_err(|_| {
                if self.has_object(index) {
                    OdError::NoSubIndex
                } else {
                    OdError::NoObject
                }
            })
    }

    /// The entry at (index, sub).
    pub fn entry(&self, index: u16, sub: u8) -> Result<&Entry, OdError> {
        let i = self.position(index, sub)?;
        Ok(&self.entries[i].1)
    }

    fn entry_mut(&mut self, index: u16, sub: u8) -> Result<&mut Entry, OdError> {
        let i = self.position(index, sub)?;
        Ok(&mut self.entries[i].1)
    }

    /// Reads as an SDO upload would: fails on write-only entries.
    pub fn read(&self, index: u16, sub: u8) -> Result<&Value, OdError> {
        let e = self.entry(index, sub)?;
        if !e.access.readable() {
            return Err(OdError::WriteOnly);
        }
        Ok(&e.value)
    }

    /// The value regardless of access rights (device-internal).
    pub fn get(&self, index: u16, sub: u8) -> Option<&Value> {
        self.entry(index, sub).ok().map(|e| &e.value)
    }

    /// Device-internal unsigned read (raw bits); `None` if missing or a string.
    pub fn get_u64(&self, index: u16, sub: u8) -> Option<u64> {
        self.get(index, sub)?.as_u64()
    }

    /// Device-internal signed read; `None` if missing or a string.
    pub fn get_i64(&self, index: u16, sub: u8) -> Option<i64> {
        self.get(index, sub)?.as_i64()
    }

    /// Checks an SDO download of `bytes` without storing it; returns the decoded value.
    pub fn check_write(&self, index: u16, sub: u8, bytes: &[u8]) -> Result<Value, OdError> {
        let e = self.entry(index, sub)?;
        if !e.access.writable() {
            return Err(OdError::ReadOnly);
        }
        let v = Value::from_bytes(e.value.data_type(), bytes)?;
        if let (Some((min, max)), Some(x)) = (e.range, v.as_i64()) {
            if x > max {
                return Err(OdError::ValueTooHigh);
            }
            if x < min {
                return Err(OdError::ValueTooLow);
            }
        }
        Ok(v)
    }

    /// An SDO download: checks access, length and range, then stores.
    pub fn write(&mut self, index: u16, sub: u8, bytes: &[u8]) -> Result<(), OdError> {
        let v = self.check_write(index, sub, bytes)?;
        self.entry_mut(index, sub)?.value = v;
        Ok(())
    }

    /// Device-internal store, ignoring access rights; the type must match.
    pub fn set(&mut self, index: u16, sub: u8, value: Value) -> Result<(), OdError> {
        let e = self.entry_mut(index, sub)?;
        if e.value.data_type() != value.data_type() {
            return Err(OdError::LengthMismatch);
        }
        e.value = value;
        Ok(())
    }

    /// Device-internal store of raw bits into a fixed-size entry (PDO unpacking; no
    /// allocation).
    pub fn set_raw(&mut self, index: u16, sub: u8, raw: u64) -> Result<(), OdError> {
        let e = self.entry_mut(index, sub)?;
        e.value = Value::from_raw(e.value.data_type(), raw).ok_or(OdError::LengthMismatch)?;
        Ok(())
    }

    /// A handle to the entry at (index, sub) for repeated access without a search (the
    /// device's per-SYNC objects). Stays valid across value changes and clones; after an
    /// insert it falls back to a search.
    pub fn slot(&self, index: u16, sub: u8) -> Option<Slot> {
        let pos = self.position(index, sub).ok()?;
        Some(Slot {
            pos: pos as u32,
            key: key(index, sub),
        })
    }

    fn resolve(&self, s: Slot) -> Option<usize> {
        match self.entries.get(s.pos as usize) {
            Some(e) if e.0 == s.key => Some(s.pos as usize),
            _ => self.entries.binary_search_by_key(&s.key, |e| e.0).ok(),
        }
    }

    /// The value at a slot.
    pub fn get_at(&self, s: Slot) -> Option<&Value> {
        self.resolve(s).map(|i| &self.entries[i].1.value)
    }

    /// Raw bits at a slot (see [`Value::to_raw`]).
    pub fn get_u64_at(&self, s: Slot) -> Option<u64> {
        self.get_at(s)?.as_u64()
    }

    /// Device-internal store of raw bits at a slot (no search, no allocation).
    pub fn set_raw_at(&mut self, s: Slot, raw: u64) -> Result<(), OdError> {
        let i = self.resolve(s).ok_or(OdError::NoObject)?;
        let e = &mut self.entries[i].1;
        e.value = Value::from_raw(e.value.data_type(), raw).ok_or(OdError::LengthMismatch)?;
        Ok(())
    }

    /// Sub-indices of an object, ascending.
    pub fn subs(&self, index: u16) -> impl Iterator<Item = u8> + '_ {
        let from = self.entries.partition_point(|e| e.0 < key(index, 0));
        self.entries[from..]
            .iter()
            .take_while(move |e| e.0 >> 8 == index as u32)
            .map(|e| e.0 as u8)
    }

    /// All object indices, ascending.
    pub fn indices(&self) -> impl Iterator<Item = u16> + '_ {
        let mut last = None;
        self.entries.iter().filter_map(move |e| {
            let index = (e.0 >> 8) as u16;
            if last == Some(index) {
                None
            } else {
                last = Some(index);
                Some(index)
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: [DataType; 14] = [
        DataType::Boolean,
        DataType::Integer8,
        DataType::Integer16,
        DataType::Integer32,
        DataType::Integer64,
        DataType::Unsigned8,
        DataType::Unsigned16,
        DataType::Unsigned32,
        DataType::Unsigned64,
        DataType::Real32,
        DataType::Real64,
        DataType::VisibleString,
        DataType::OctetString,
        DataType::Domain,
    ];

    #[test]
    fn type_codes_names_and_ranges() {
        for t in ALL {
            assert_eq!(DataType::from_code(t.code()), Some(t), "{t}");
        }
        assert_eq!(DataType::from_code(0x0007), Some(DataType::Unsigned32));
        assert_eq!(DataType::from_code(0x0008), Some(DataType::Real32));
        assert_eq!(DataType::from_code(0x0011), Some(DataType::Real64));
        assert_eq!(DataType::from_code(0x000C), None); // TIME_OF_DAY: not here
        assert_eq!(DataType::Real64.cia_name(), "REAL64");
        assert_eq!(DataType::Unsigned16.to_string(), "UNSIGNED16");
        assert_eq!(DataType::Integer8.int_range(), Some((-128, 127)));
        assert_eq!(
            DataType::Unsigned64.int_range(),
            Some((0, u64::MAX as i128))
        );
        assert_eq!(DataType::Real32.int_range(), None);
        assert!(DataType::Integer64.is_signed() && !DataType::Unsigned8.is_signed());
        assert!(!DataType::Real32.is_signed());
    }

    #[test]
    fn integers_from_i128_are_range_checked() {
        assert_eq!(Value::from_int(DataType::Integer32, -2), Ok(Value::I32(-2)));
        assert_eq!(
            Value::from_int(DataType::Integer32, -2).unwrap().to_bytes(),
            vec![0xfe, 0xff, 0xff, 0xff]
        );
        assert_eq!(
            Value::from_int(DataType::Unsigned64, u64::MAX as i128),
            Ok(Value::U64(u64::MAX))
        );
        assert_eq!(
            Value::from_int(DataType::Integer64, i64::MIN as i128),
            Ok(Value::I64(i64::MIN))
        );
        assert_eq!(
            Value::from_int(DataType::Unsigned8, 256),
            Err(OdError::ValueTooHigh)
        );
        assert_eq!(
            Value::from_int(DataType::Unsigned8, -1),
            Err(OdError::ValueTooLow)
        );
        assert_eq!(
            Value::from_int(DataType::Integer16, -32769),
            Err(OdError::ValueTooLow)
        );
        assert_eq!(
            Value::from_int(DataType::Real32, 1),
            Err(OdError::InvalidValue)
        );
    }

    fn od() -> ObjectDictionary {
        let mut od = ObjectDictionary::new();
        od.insert_var(
            0x1000,
            Entry::new("device type", Access::Const, Value::U32(0x0002_0192)),
        );
        od.insert_var(
            0x1008,
            Entry::new(
                "name",
                Access::Const,
                Value::VisibleString("cnc402 sim".into()),
            ),
        );
        od.insert_var(
            0x6040,
            Entry::new("controlword", Access::ReadWrite, Value::U16(0)).mappable(),
        );
        od.insert_var(
            0x6041,
            Entry::new("statusword", Access::ReadOnly, Value::U16(0x250)).mappable(),
        );
        od.insert_var(
            0x6060,
            Entry::new("mode", Access::ReadWrite, Value::I8(0)).range(-128, 10),
        );
        od.insert_var(
            0x607A,
            Entry::new("target", Access::ReadWrite, Value::I32(0)).mappable(),
        );
        od.insert_var(
            0x2000,
            Entry::new("secret", Access::WriteOnly, Value::U8(0)),
        );
        od.insert(0x1018, 0, Entry::new("n", Access::Const, Value::U8(4)));
        od.insert(
            0x1018,
            1,
            Entry::new("vendor", Access::Const, Value::U32(0x1234)),
        );
        od
    }

    #[test]
    fn reads_and_errors_with_abort_codes() {
        let od = od();
        assert_eq!(od.read(0x1000, 0), Ok(&Value::U32(0x0002_0192)));
        assert_eq!(
            od.read(0x1000, 0).unwrap().to_bytes(),
            vec![0x92, 0x01, 0x02, 0x00]
        );
        assert_eq!(
            od.read(0x1008, 0).unwrap().to_bytes(),
            b"cnc402 sim".to_vec()
        );
        assert_eq!(od.read(0x1001, 0), Err(OdError::NoObject));
        assert_eq!(od.read(0x1018, 5), Err(OdError::NoSubIndex));
        assert_eq!(od.read(0x2000, 0), Err(OdError::WriteOnly));
        assert_eq!(OdError::NoObject.abort_code().to_u32(), 0x0602_0000);
        assert_eq!(OdError::NoSubIndex.abort_code().to_u32(), 0x0609_0011);
        assert_eq!(OdError::ReadOnly.abort_code().to_u32(), 0x0601_0002);
        assert_eq!(OdError::WriteOnly.abort_code().to_u32(), 0x0601_0001);
        assert!(od.entry(0x607A, 0).unwrap().pdo_mappable);
        assert!(!od.entry(0x1000, 0).unwrap().pdo_mappable);
        assert_eq!(od.subs(0x1018).collect::<Vec<_>>(), vec![0, 1]);
        assert_eq!(od.subs(0x1019).count(), 0);
        assert_eq!(
            od.indices().collect::<Vec<_>>(),
            vec![
                0x1000, 0x1008, 0x1018, 0x2000, 0x6040, 0x6041, 0x6060, 0x607A
            ]
        );
        assert!(od.has_object(0x1018) && !od.has_object(0x1019) && !od.has_object(0x0FFF));
    }

    #[test]
    fn writes_check_access_length_and_range() {
        let mut od = od();
        assert_eq!(od.write(0x6041, 0, &[0, 0]), Err(OdError::ReadOnly));
        assert_eq!(od.write(0x1000, 0, &[0; 4]), Err(OdError::ReadOnly));
        assert_eq!(od.write(0x6040, 0, &[0x0F]), Err(OdError::LengthTooLow));
        assert_eq!(
            od.write(0x6040, 0, &[0x0F, 0, 0]),
            Err(OdError::LengthTooHigh)
        );
        assert_eq!(od.write(0x6040, 0, &[0x0F, 0]), Ok(()));
        assert_eq!(od.get_u64(0x6040, 0), Some(0x0F));
        assert_eq!(od.write(0x6060, 0, &[11]), Err(OdError::ValueTooHigh));
        assert_eq!(od.write(0x6060, 0, &[8]), Ok(()));
        assert_eq!(od.write(0x607A, 0, &(-5i32).to_le_bytes()), Ok(()));
        assert_eq!(od.get_i64(0x607A, 0), Some(-5));
        assert_eq!(od.write(0x2000, 0, &[1]), Ok(()));
        assert_eq!(od.set(0x6041, 0, Value::U16(0x237)), Ok(()));
        assert_eq!(
            od.set(0x6041, 0, Value::U32(1)),
            Err(OdError::LengthMismatch)
        );
        assert_eq!(od.set_raw(0x607A, 0, 0xFFFF_FFFF), Ok(()));
        assert_eq!(od.get_i64(0x607A, 0), Some(-1));
        assert_eq!(od.set_raw(0x1008, 0, 1), Err(OdError::LengthMismatch));
        // Slots: direct access, and still right after an insert moved the entries.
        let s = od.slot(0x607A, 0).unwrap();
        od.set_raw_at(s, 42).unwrap();
        assert_eq!(od.get_i64(0x607A, 0), Some(42));
        od.insert_var(0x0100, Entry::new("first", Access::ReadOnly, Value::U8(1)));
        assert_eq!(od.get_u64_at(s), Some(42));
        od.set_raw_at(s, 43).unwrap();
        assert_eq!(od.get_i64(0x607A, 0), Some(43));
        assert_eq!(od.slot(0x607A, 1), None);
    }

    #[test]
    fn values_round_trip_through_bytes_and_raw() {
        let vals = [
            Value::Boolean(true),
            Value::I8(-3),
            Value::I16(-300),
            Value::I32(i32::MIN),
            Value::I64(-1),
            Value::U8(200),
            Value::U16(0xBEEF),
            Value::U32(0xDEAD_BEEF),
            Value::U64(u64::MAX),
            Value::Real32(-3.5),
            Value::Real64(1e-300),
            Value::Real32(f32::NAN),
            Value::VisibleString("héllo".into()),
            Value::OctetString(vec![0, 1, 2]),
            Value::Domain(vec![]),
        ];
        for v in vals {
            let t = v.data_type();
            assert_eq!(Value::from_bytes(t, &v.to_bytes()), Ok(v.clone()));
            if let Some(raw) = v.to_raw() {
                assert_eq!(Value::from_raw(t, raw), Some(v.clone()));
                assert_eq!(
                    t.pdo_bits().map(|b| b as usize),
                    t.size()
                        .map(|n| if t == DataType::Boolean { 1 } else { n * 8 })
                );
            }
        }
        assert_eq!(Value::I16(-300).as_i64(), Some(-300));
        assert_eq!(Value::Real32(3.5).to_bytes(), 3.5f32.to_le_bytes().to_vec());
        assert_eq!(
            Value::from_bytes(DataType::Real64, &2.25f64.to_le_bytes()),
            Ok(Value::Real64(2.25))
        );
        assert_eq!(Value::Real32(3.0).as_i64(), None);
        assert_ne!(Value::Real32(0.0), Value::Real32(-0.0));
        assert_ne!(Value::Real32(1.0), Value::U32(1.0f32.to_bits()));
        assert_ne!(Value::U8(1), Value::I8(1));
        assert_eq!(Value::U32(0xFFFF_FFFF).as_i64(), Some(0xFFFF_FFFF));
        assert_eq!(
            Value::from_bytes(DataType::VisibleString, &[0xFF]),
            Err(OdError::InvalidValue)
        );
    }
}
