//! CiA 306 EDS and DCF files, for the master (a drive's commissioning values, written at boot)
//! and for drivectl (names and types for printouts, objects by name): an INI reader with
//! `$NODEID` arithmetic, `CompactSubObj` arrays, `ParameterValue` (DCF) over `DefaultValue`,
//! data and access types, and name lookup (python-canopen's `"Parent.Sub"` names too).
//! canopen-rs 0.6.1's EDS parser resolves neither `$NODEID` nor `CompactSubObj`.

use std::collections::BTreeMap;
use std::fmt;

/// Most sub-objects one `CompactSubObj` may declare (sub-indices 1..=254).
pub const MAX_COMPACT_SUBS: u64 = 254;

/// A CANopen basic data type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DataType {
    /// BOOLEAN (1 byte on SDO, 1 bit in a PDO).
    Boolean,
    /// INTEGER8.
    Integer8,
    /// INTEGER16.
    Integer16,
    /// INTEGER32.
    Integer32,
    /// INTEGER64.
    Integer64,
    /// UNSIGNED8.
    Unsigned8,
    /// UNSIGNED16.
    Unsigned16,
    /// UNSIGNED32.
    Unsigned32,
    /// UNSIGNED64.
    Unsigned64,
    /// REAL32 (IEEE 754 single).
    Real32,
    /// REAL64 (IEEE 754 double).
    Real64,
    /// VISIBLE_STRING.
    VisibleString,
    /// OCTET_STRING.
    OctetString,
    /// DOMAIN.
    Domain,
}

impl DataType {
    /// Bytes of a fixed-size type; `None` for strings and domains.
    pub const fn size(self) -> Option<usize> {
        match self {
            DataType::Boolean | DataType::Integer8 | DataType::Unsigned8 => Some(1),
            DataType::Integer16 | DataType::Unsigned16 => Some(2),
            DataType::Integer32 | DataType::Unsigned32 | DataType::Real32 => Some(4),
            DataType::Integer64 | DataType::Unsigned64 | DataType::Real64 => Some(8),
            DataType::VisibleString | DataType::OctetString | DataType::Domain => None,
        }
    }
    /// Bits when mapped into a PDO; `None` for types that cannot be mapped.
    pub const fn pdo_bits(self) -> Option<u8> {
        match self {
            DataType::Boolean => Some(1),
            t => match t.size() {
                Some(n) => Some((n * 8) as u8),
                None => None,
            },
        }
    }
    /// Whether it is a signed integer type (INTEGER8..64).
    pub const fn is_signed(self) -> bool {
        matches!(
            self,
            DataType::Integer8 | DataType::Integer16 | DataType::Integer32 | DataType::Integer64
        )
    }

    /// The inclusive value range of an integer type; `None` for the others.
    pub const fn int_range(self) -> Option<(i128, i128)> {
        Some(match self {
            DataType::Integer8 => (i8::MIN as i128, i8::MAX as i128),
            DataType::Integer16 => (i16::MIN as i128, i16::MAX as i128),
            DataType::Integer32 => (i32::MIN as i128, i32::MAX as i128),
            DataType::Integer64 => (i64::MIN as i128, i64::MAX as i128),
            DataType::Unsigned8 => (0, u8::MAX as i128),
            DataType::Unsigned16 => (0, u16::MAX as i128),
            DataType::Unsigned32 => (0, u32::MAX as i128),
            DataType::Unsigned64 => (0, u64::MAX as i128),
            _ => return None,
        })
    }

    /// From a CiA 301 data type index, as in an EDS `DataType=` (0x0001 BOOLEAN ..
    /// 0x001B UNSIGNED64); `None` for the types this dictionary does not have.
    pub const fn from_code(code: u16) -> Option<DataType> {
        Some(match code {
            0x0001 => DataType::Boolean,
            0x0002 => DataType::Integer8,
            0x0003 => DataType::Integer16,
            0x0004 => DataType::Integer32,
            0x0005 => DataType::Unsigned8,
            0x0006 => DataType::Unsigned16,
            0x0007 => DataType::Unsigned32,
            0x0008 => DataType::Real32,
            0x0009 => DataType::VisibleString,
            0x000A => DataType::OctetString,
            0x000F => DataType::Domain,
            0x0011 => DataType::Real64,
            0x0015 => DataType::Integer64,
            0x001B => DataType::Unsigned64,
            _ => return None,
        })
    }

    /// The CiA 301 data type index (inverse of [`DataType::from_code`]).
    pub const fn code(self) -> u16 {
        match self {
            DataType::Boolean => 0x0001,
            DataType::Integer8 => 0x0002,
            DataType::Integer16 => 0x0003,
            DataType::Integer32 => 0x0004,
            DataType::Unsigned8 => 0x0005,
            DataType::Unsigned16 => 0x0006,
            DataType::Unsigned32 => 0x0007,
            DataType::Real32 => 0x0008,
            DataType::VisibleString => 0x0009,
            DataType::OctetString => 0x000A,
            DataType::Domain => 0x000F,
            DataType::Real64 => 0x0011,
            DataType::Integer64 => 0x0015,
            DataType::Unsigned64 => 0x001B,
        }
    }

    /// The CiA 301 name (`UNSIGNED16`, `VISIBLE_STRING`).
    pub const fn cia_name(self) -> &'static str {
        match self {
            DataType::Boolean => "BOOLEAN",
            DataType::Integer8 => "INTEGER8",
            DataType::Integer16 => "INTEGER16",
            DataType::Integer32 => "INTEGER32",
            DataType::Integer64 => "INTEGER64",
            DataType::Unsigned8 => "UNSIGNED8",
            DataType::Unsigned16 => "UNSIGNED16",
            DataType::Unsigned32 => "UNSIGNED32",
            DataType::Unsigned64 => "UNSIGNED64",
            DataType::Real32 => "REAL32",
            DataType::Real64 => "REAL64",
            DataType::VisibleString => "VISIBLE_STRING",
            DataType::OctetString => "OCTET_STRING",
            DataType::Domain => "DOMAIN",
        }
    }
}

impl fmt::Display for DataType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.cia_name())
    }
}

impl DataType {
    /// A type by name: short (`u16`, `i32`, `f32`, `string`, `bytes`) or CiA 301
    /// (`UNSIGNED16`, `INTEGER32`, `REAL32`, `VISIBLE_STRING`), any case.
    ///
    /// ```
    /// use cnc402_config::eds::DataType;
    /// assert_eq!(DataType::from_name("U32"), Some(DataType::Unsigned32));
    /// assert_eq!(DataType::from_name("visible_string"), Some(DataType::VisibleString));
    /// assert_eq!(DataType::from_name("u33"), None);
    /// ```
    pub fn from_name(s: &str) -> Option<DataType> {
        use DataType::*;
        Some(match s.to_ascii_lowercase().as_str() {
            "bool" | "boolean" => Boolean,
            "u8" | "uint8" | "unsigned8" => Unsigned8,
            "u16" | "uint16" | "unsigned16" => Unsigned16,
            "u32" | "uint32" | "unsigned32" => Unsigned32,
            "u64" | "uint64" | "unsigned64" => Unsigned64,
            "i8" | "int8" | "integer8" => Integer8,
            "i16" | "int16" | "integer16" => Integer16,
            "i32" | "int32" | "integer32" => Integer32,
            "i64" | "int64" | "integer64" => Integer64,
            "f32" | "real32" | "float" => Real32,
            "f64" | "real64" | "double" => Real64,
            "string" | "str" | "vs" | "visible_string" => VisibleString,
            "bytes" | "hex" | "octet_string" | "os" => OctetString,
            "domain" => Domain,
            _ => return None,
        })
    }

    /// The little-endian bytes of integer `v` as this type, range-checked; an error says the
    /// range (or that the type is no integer type).
    pub fn encode_int(self, v: i128) -> Result<Vec<u8>, String> {
        if self == DataType::Boolean {
            return match v {
                0 | 1 => Ok(vec![v as u8]),
                _ => Err(format!("{v} is not a BOOLEAN (0 or 1)")),
            };
        }
        let Some((min, max)) = self.int_range() else {
            return Err(format!("an integer cannot be a {}", self.cia_name()));
        };
        if !(min..=max).contains(&v) {
            return Err(format!(
                "{v} is outside {}'s {min}..={max}",
                self.cia_name()
            ));
        }
        let n = self.size().unwrap_or(0);
        Ok((v as i64 as u64).to_le_bytes()[..n].to_vec())
    }

    /// The bytes of a real `v` as REAL32/REAL64 (integers take [`encode_int`](Self::encode_int)).
    pub fn encode_real(self, v: f64) -> Result<Vec<u8>, String> {
        match self {
            DataType::Real32 if v.is_finite() && v.abs() <= f32::MAX as f64 => {
                Ok((v as f32).to_le_bytes().to_vec())
            }
            DataType::Real64 => Ok(v.to_le_bytes().to_vec()),
            t if t.int_range().is_some() && v.fract() == 0.0 && v.abs() < 1.9e19 => {
                self.encode_int(v as i128)
            }
            t => Err(format!("{v} cannot be a {}", t.cia_name())),
        }
    }

    /// The bytes of a value written as text in an EDS/DCF or a config: integers in decimal
    /// or `0x` hex, with `$NODEID` terms (`$NODEID+0x180`) when `node` is known; booleans;
    /// reals; strings as they are; octet strings and domains as hex bytes.
    ///
    /// ```
    /// use cnc402_config::eds::DataType;
    /// let t = DataType::Unsigned32;
    /// assert_eq!(t.encode_text("$NODEID+0x180", Some(3)).unwrap(), vec![0x83, 1, 0, 0]);
    /// assert!(t.encode_text("$NODEID+0x180", None).is_err());
    /// assert_eq!(DataType::Integer16.encode_text("-2", None).unwrap(), vec![0xfe, 0xff]);
    /// ```
    pub fn encode_text(self, text: &str, node: Option<u8>) -> Result<Vec<u8>, String> {
        let t = text.trim();
        match self {
            DataType::VisibleString => Ok(text.as_bytes().to_vec()),
            DataType::OctetString | DataType::Domain => {
                hex_bytes(t).ok_or_else(|| format!("`{t}` is not hex bytes (e.g. 0011aabb)"))
            }
            DataType::Real32 | DataType::Real64 => match t.parse::<f64>() {
                Ok(v) => self.encode_real(v),
                Err(_) => Err(format!("`{t}` is not a number")),
            },
            DataType::Boolean if t.eq_ignore_ascii_case("true") => Ok(vec![1]),
            DataType::Boolean if t.eq_ignore_ascii_case("false") => Ok(vec![0]),
            _ => self.encode_int(eval_int(t, node)?),
        }
    }
}

fn hex_bytes(s: &str) -> Option<Vec<u8>> {
    let h: String = s.chars().filter(|c| !c.is_whitespace()).collect();
    let h = h.strip_prefix("0x").unwrap_or(&h);
    if !h.len().is_multiple_of(2) || !h.chars().all(|c| c.is_ascii_hexdigit()) {
        return None;
    }
    (0..h.len() / 2)
        .map(|i| u8::from_str_radix(&h[2 * i..2 * i + 2], 16).ok())
        .collect()
}

/// An unsigned number in decimal, `0x` hex or (CiA 306) octal with a leading `0`.
pub fn parse_uint(s: &str) -> Option<u64> {
    let s = s.trim().replace('_', "");
    if let Some(h) = s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        return u64::from_str_radix(h, 16).ok();
    }
    if s.len() > 1 && s.starts_with('0') && s.chars().all(|c| c.is_ascii_digit()) {
        return u64::from_str_radix(&s[1..], 8).ok();
    }
    s.parse().ok()
}

/// An integer expression of an EDS/DCF value: terms joined by `+` (and a leading `-`), each
/// a number or `$NODEID` (any case). Without `node`, a `$NODEID` term is an error.
///
/// ```
/// use cnc402_config::eds::eval_int;
/// assert_eq!(eval_int("$NODEID+0x180", Some(5)), Ok(0x185));
/// assert_eq!(eval_int("0x200 + $nodeid", Some(1)), Ok(0x201));
/// assert_eq!(eval_int("-12", None), Ok(-12));
/// ```
pub fn eval_int(text: &str, node: Option<u8>) -> Result<i128, String> {
    let t = text.trim();
    let (neg, body) = match t.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, t),
    };
    let mut sum: i128 = 0;
    for term in body.split('+') {
        let term = term.trim();
        let v = if term.eq_ignore_ascii_case("$nodeid") {
            i128::from(
                node.ok_or_else(|| format!("`{t}` uses $NODEID and no node id is known here"))?,
            )
        } else {
            i128::from(parse_uint(term).ok_or_else(|| format!("`{t}` is not a number"))?)
        };
        sum += v;
    }
    Ok(if neg { -sum } else { sum })
}

/// An object address: index and sub-index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ObjectAddr {
    /// Index.
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
}

impl fmt::Display for ObjectAddr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:#06x}:{:02x}", self.index, self.sub)
    }
}

/// One object or sub-object of an EDS.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EdsEntry {
    /// `ParameterName`.
    pub name: String,
    /// `ObjectType` (7 VAR, 8 ARRAY, 9 RECORD).
    pub object_type: u8,
    /// `DataType` as a code (0x0007 = UNSIGNED32 ...).
    pub data_type_code: Option<u16>,
    /// `AccessType` (ro, wo, rw, rww, rwr, const), lower case.
    pub access: Option<String>,
    /// `DefaultValue` (may hold `$NODEID`).
    pub default: Option<String>,
    /// `ParameterValue` (DCF; may hold `$NODEID`).
    pub value: Option<String>,
    /// `PDOMapping=1`.
    pub pdo_mapping: bool,
    /// The line of the section header (or of the `CompactSubObj` key's object).
    pub line: usize,
}

impl EdsEntry {
    /// The data type, if the code is a basic one.
    pub fn data_type(&self) -> Option<DataType> {
        self.data_type_code.and_then(DataType::from_code)
    }
    /// Whether the access type allows an SDO write (rw, wo, rww, rwr).
    pub fn writable(&self) -> bool {
        matches!(
            self.access.as_deref(),
            Some("rw" | "wo" | "rww" | "rwr" | "readwrite" | "writeonly")
        )
    }
    /// The value a DCF sets: `ParameterValue`, else `DefaultValue`.
    pub fn effective_value(&self) -> Option<&str> {
        self.value.as_deref().or(self.default.as_deref())
    }
}

/// A parsed EDS/DCF.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Eds {
    /// `[FileInfo]` keys (lower-case) and values.
    pub file_info: BTreeMap<String, String>,
    /// `[DeviceInfo]` keys (lower-case) and values.
    pub device_info: BTreeMap<String, String>,
    /// `[DeviceComissioning]` (DCF) keys (lower-case) and values.
    pub commissioning: BTreeMap<String, String>,
    /// Objects by address; a VAR is at sub 0, the header of an ARRAY/RECORD at sub 0 too,
    /// unless its `[IIIIsub0]` section exists (that one wins for sub 0).
    pub objects: BTreeMap<ObjectAddr, EdsEntry>,
    /// Names of ARRAY/RECORD headers, by index.
    pub object_names: BTreeMap<u16, String>,
}

/// Sections by lower-case name: header line and key/values (keys lower case).
type Sections = Vec<(String, usize, BTreeMap<String, String>)>;

fn read_sections(text: &str) -> Result<Sections, (usize, String)> {
    let mut sections: Sections = Vec::new();
    for (n, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with(';') || line.starts_with('#') {
            continue;
        }
        if let Some(rest) = line.strip_prefix('[') {
            let Some(name) = rest.strip_suffix(']') else {
                return Err((n + 1, format!("section header `{line}` lacks `]`")));
            };
            sections.push((name.trim().to_ascii_lowercase(), n + 1, BTreeMap::new()));
            continue;
        }
        let Some((k, v)) = line.split_once('=') else {
            return Err((n + 1, format!("expected KEY=VALUE, found `{line}`")));
        };
        let Some(sec) = sections.last_mut() else {
            return Err((n + 1, "key before the first [section]".to_string()));
        };
        // Inline comments after values are common in hand-edited files.
        let v = v.split(';').next().unwrap_or("").trim();
        sec.2.insert(k.trim().to_ascii_lowercase(), v.to_string());
    }
    Ok(sections)
}

/// `[IIII]`, `[IIIIsubS]`, `[IIIIName]`, `[IIIIValue]`: the index and what follows it.
fn object_section(name: &str) -> Option<(u16, &str)> {
    let idx = name.get(..4)?;
    if !idx.chars().all(|c| c.is_ascii_hexdigit()) {
        return None;
    }
    Some((u16::from_str_radix(idx, 16).ok()?, &name[4..]))
}

impl Eds {
    /// Parses EDS/DCF text. Errors are `(line, message)`.
    ///
    /// ```
    /// use cnc402_config::eds::{DataType, Eds, ObjectAddr};
    /// let eds = Eds::parse(
    ///     "[6041]\nParameterName=Statusword\nObjectType=0x7\nDataType=0x0006\nAccessType=ro\n",
    /// ).unwrap();
    /// let e = &eds.objects[&ObjectAddr { index: 0x6041, sub: 0 }];
    /// assert_eq!(e.name, "Statusword");
    /// assert_eq!(e.data_type(), Some(DataType::Unsigned16));
    /// ```
    pub fn parse(text: &str) -> Result<Eds, (usize, String)> {
        let mut eds = Eds::default();
        let mut headers: Vec<(u16, usize, BTreeMap<String, String>)> = Vec::new();
        let mut extras: BTreeMap<(u16, &'static str), BTreeMap<String, String>> = BTreeMap::new();
        for (name, line, kv) in read_sections(text)? {
            match name.as_str() {
                "fileinfo" => eds.file_info = kv,
                "deviceinfo" => eds.device_info = kv,
                "devicecomissioning" | "devicecommissioning" => eds.commissioning = kv,
                _ => {
                    let Some((index, rest)) = object_section(&name) else {
                        continue; // MandatoryObjects, Comments, vendor sections ...
                    };
                    if rest.is_empty() {
                        headers.push((index, line, kv));
                    } else if let Some(s) = rest.strip_prefix("sub") {
                        let sub = u8::from_str_radix(s, 16).map_err(|_| {
                            (line, format!("bad sub-index in [{name}] (hex expected)"))
                        })?;
                        eds.objects
                            .insert(ObjectAddr { index, sub }, entry(&kv, line)?);
                    } else if rest == "name" {
                        extras.insert((index, "name"), kv);
                    } else if rest == "value" {
                        extras.insert((index, "value"), kv);
                    }
                }
            }
        }
        for (index, line, kv) in headers {
            let e = entry(&kv, line)?;
            eds.object_names.insert(index, e.name.clone());
            if let Some(n) = kv.get("compactsubobj").filter(|v| !v.is_empty()) {
                let names = extras.get(&(index, "name"));
                let values = extras.get(&(index, "value"));
                eds.expand_compact(index, &e, n, names, values)?;
                continue;
            }
            eds.objects.entry(ObjectAddr { index, sub: 0 }).or_insert(e);
        }
        Ok(eds)
    }

    /// A `CompactSubObj=n` object: sub 0 (UNSIGNED8, ro, n) and subs 1..=n with the header's
    /// type, access and default, named by `[IIIIName]` (else `name<sub>`) and valued by
    /// `[IIIIValue]` (a DCF's parameter values).
    fn expand_compact(
        &mut self,
        index: u16,
        header: &EdsEntry,
        count: &str,
        names: Option<&BTreeMap<String, String>>,
        values: Option<&BTreeMap<String, String>>,
    ) -> Result<(), (usize, String)> {
        let line = header.line;
        let n = parse_uint(count)
            .filter(|n| (1..=MAX_COMPACT_SUBS).contains(n))
            .ok_or((
                line,
                format!("CompactSubObj={count} is not in 1..={MAX_COMPACT_SUBS}"),
            ))?;
        let sub0 = EdsEntry {
            name: "Number of entries".into(),
            object_type: 7,
            data_type_code: Some(DataType::Unsigned8.code()),
            access: Some("ro".into()),
            default: Some(n.to_string()),
            value: None,
            pdo_mapping: false,
            line,
        };
        self.objects.insert(ObjectAddr { index, sub: 0 }, sub0);
        let by_sub = |m: Option<&BTreeMap<String, String>>, sub: u64| {
            m.and_then(|m| {
                m.iter()
                    .find(|(k, _)| parse_uint(k) == Some(sub))
                    .map(|(_, v)| v.clone())
            })
        };
        for sub in 1..=n {
            let e = EdsEntry {
                name: by_sub(names, sub).unwrap_or_else(|| format!("{}{sub}", header.name)),
                object_type: 7,
                value: by_sub(values, sub).or_else(|| header.value.clone()),
                ..header.clone()
            };
            self.objects.insert(
                ObjectAddr {
                    index,
                    sub: sub as u8,
                },
                e,
            );
        }
        Ok(())
    }

    /// The entry at `addr`.
    pub fn get(&self, addr: ObjectAddr) -> Option<&EdsEntry> {
        self.objects.get(&addr)
    }

    /// The node id a DCF was made for (`[DeviceComissioning] NodeID`).
    pub fn node_id(&self) -> Option<u8> {
        self.commissioning
            .get("nodeid")
            .and_then(|v| parse_uint(v))
            .and_then(|v| u8::try_from(v).ok())
    }

    /// A display name: the sub-object's name, prefixed with its array/record name.
    pub fn name(&self, addr: ObjectAddr) -> Option<String> {
        let sub = self.objects.get(&addr).map(|e| e.name.clone());
        let parent = self.object_names.get(&addr.index);
        match (parent, sub) {
            (Some(p), Some(s)) if addr.sub > 0 && *p != s => Some(format!("{p} / {s}")),
            (_, Some(s)) => Some(s),
            (Some(p), None) => Some(p.clone()),
            (None, None) => None,
        }
    }

    /// The names an object is found by: a VAR's own name; a sub-object's python-canopen name
    /// `Parent.Sub` (and its own name alone).
    pub fn lookup_names(&self) -> Vec<(ObjectAddr, String)> {
        let mut out = Vec::with_capacity(self.objects.len() * 2);
        for (a, e) in &self.objects {
            match self.object_names.get(&a.index) {
                Some(p) if *p != e.name || a.sub > 0 => {
                    out.push((*a, format!("{p}.{}", e.name)));
                    out.push((*a, e.name.clone()));
                }
                _ => out.push((*a, e.name.clone())),
            }
        }
        out
    }

    /// The bytes of `addr`'s effective value ([`EdsEntry::effective_value`]) for node `node`;
    /// `Ok(None)` when it has no value.
    pub fn encoded_value(
        &self,
        addr: ObjectAddr,
        node: Option<u8>,
    ) -> Result<Option<Vec<u8>>, String> {
        let Some(e) = self.get(addr) else {
            return Ok(None);
        };
        let Some(text) = e.effective_value() else {
            return Ok(None);
        };
        let t = e.data_type().ok_or_else(|| match e.data_type_code {
            Some(c) => format!("data type {c:#06x} is not a basic type"),
            None => "no DataType".to_string(),
        })?;
        t.encode_text(text, node).map(Some)
    }
}

/// Why [`find_object`] found no single object.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum NameError {
    /// No object has the name; the nearest names (at most 5).
    Unknown(Vec<(ObjectAddr, String)>),
    /// Several objects have it.
    Ambiguous(Vec<(ObjectAddr, String)>),
}

impl fmt::Display for NameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (what, list) = match self {
            NameError::Unknown(l) if l.is_empty() => return write!(f, "no object has this name"),
            NameError::Unknown(l) => ("no object has this name; nearest", l),
            NameError::Ambiguous(l) => ("several objects have this name", l),
        };
        write!(f, "{what}: ")?;
        for (k, (a, n)) in list.iter().enumerate() {
            let sep = if k > 0 { ", " } else { "" };
            write!(f, "{sep}\"{n}\" ({a})")?;
        }
        Ok(())
    }
}

impl std::error::Error for NameError {}

/// Names compare case-insensitively, with `_` and runs of spaces as one space.
fn fold(name: &str) -> String {
    let lower = name.to_lowercase().replace('_', " ");
    lower.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Levenshtein distance of two short strings, capped (names are compared by nearness only).
fn distance(a: &str, b: &str) -> usize {
    const CAP: usize = 128;
    let a: Vec<char> = a.chars().take(CAP).collect();
    let b: Vec<char> = b.chars().take(CAP).collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.iter().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            let cost = usize::from(ca != cb);
            cur[j + 1] = (prev[j] + cost).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

/// The object called `name` among `names` (address, name), compared as [`fold`] does; one
/// address named several ways counts once. Unknown: the 5 nearest names; several: all.
///
/// ```
/// use cnc402_config::eds::{ObjectAddr, find_object};
/// let names = vec![
///     (ObjectAddr { index: 0x6040, sub: 0 }, "Controlword".to_string()),
///     (ObjectAddr { index: 0x1010, sub: 1 }, "Store parameters.Save all parameters".to_string()),
/// ];
/// assert_eq!(find_object(&names, "controlword").unwrap().index, 0x6040);
/// assert_eq!(find_object(&names, "store parameters.save all parameters").unwrap().sub, 1);
/// assert!(find_object(&names, "controlwrd").unwrap_err().to_string().contains("Controlword"));
/// ```
pub fn find_object(names: &[(ObjectAddr, String)], name: &str) -> Result<ObjectAddr, NameError> {
    let want = fold(name);
    let mut hits: Vec<(ObjectAddr, String)> = Vec::new();
    for (a, n) in names {
        if fold(n) == want && !hits.iter().any(|(h, _)| h == a) {
            hits.push((*a, n.clone()));
        }
    }
    match hits.len() {
        1 => Ok(hits[0].0),
        0 => {
            let mut near: Vec<(usize, ObjectAddr, &String)> = names
                .iter()
                .map(|(a, n)| (distance(&fold(n), &want), *a, n))
                .collect();
            near.sort_by_key(|(d, a, _)| (*d, *a));
            let mut list: Vec<(ObjectAddr, String)> = Vec::new();
            for (_, a, n) in near {
                if list.len() == 5 {
                    break;
                }
                if !list.iter().any(|(h, _)| *h == a) {
                    list.push((a, n.clone()));
                }
            }
            Err(NameError::Unknown(list))
        }
        _ => Err(NameError::Ambiguous(hits)),
    }
}

fn entry(kv: &BTreeMap<String, String>, line: usize) -> Result<EdsEntry, (usize, String)> {
    // Keys are stored lower-case; errors use CiA 306's spelling.
    let num = |k: &str, shown: &str| -> Result<Option<u64>, (usize, String)> {
        match kv.get(k) {
            None => Ok(None),
            Some(v) if v.is_empty() => Ok(None),
            Some(v) => parse_uint(v)
                .map(Some)
                .ok_or((line, format!("{shown}={v} is not a number"))),
        }
    };
    Ok(EdsEntry {
        name: kv.get("parametername").cloned().unwrap_or_default(),
        object_type: num("objecttype", "ObjectType")?.unwrap_or(7) as u8,
        data_type_code: num("datatype", "DataType")?.map(|v| v as u16),
        access: kv.get("accesstype").map(|s| s.to_ascii_lowercase()),
        default: kv.get("defaultvalue").cloned().filter(|s| !s.is_empty()),
        value: kv.get("parametervalue").cloned().filter(|s| !s.is_empty()),
        pdo_mapping: num("pdomapping", "PDOMapping")?.unwrap_or(0) != 0,
        line,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const SAMPLE: &str = "\
[FileInfo]
FileName=drive.dcf
[DeviceInfo]
VendorName=ACME ; a comment
ProductName=Servo 9
[DeviceComissioning]
NodeID=3
[1010]
ParameterName=Store parameters
ObjectType=0x8
SubNumber=2
[1010sub0]
ParameterName=Highest sub-index
ObjectType=0x7
DataType=0x0005
AccessType=ro
DefaultValue=1
[1010sub1]
ParameterName=Save all parameters
ObjectType=0x7
DataType=0x0007
AccessType=rw
DefaultValue=1
[1800sub1]
ParameterName=COB-ID
DataType=0x0007
AccessType=rw
DefaultValue=$NODEID+0x180
ParameterValue=$NODEID+0x40000180
[1600]
ParameterName=RPDO1 mapping
ObjectType=0x8
DataType=0x0007
AccessType=rw
CompactSubObj=2
DefaultValue=0
[1600Value]
NrOfEntries=2
1=0x60400010
2=0x607A0020
[1600Name]
NrOfEntries=1
2=Target entry
[6060]
ParameterName=Modes of operation
DataType=0x0002
AccessType=rw
PDOMapping=1
";

    fn addr(index: u16, sub: u8) -> ObjectAddr {
        ObjectAddr { index, sub }
    }

    #[test]
    fn parses_objects_names_types_and_the_node_id() {
        let eds = Eds::parse(SAMPLE).unwrap();
        assert_eq!(eds.device_info["vendorname"], "ACME");
        assert_eq!(eds.node_id(), Some(3));
        let save = addr(0x1010, 1);
        assert_eq!(
            eds.name(save).unwrap(),
            "Store parameters / Save all parameters"
        );
        assert_eq!(
            eds.get(save).unwrap().data_type(),
            Some(DataType::Unsigned32)
        );
        assert!(eds.get(save).unwrap().writable());
        assert!(!eds.get(addr(0x1010, 0)).unwrap().writable());
        let m = eds.get(addr(0x6060, 0)).unwrap();
        assert_eq!(m.data_type(), Some(DataType::Integer8));
        assert!(m.pdo_mapping);
    }

    #[test]
    fn parameter_value_wins_and_nodeid_is_resolved() {
        let eds = Eds::parse(SAMPLE).unwrap();
        let cob = eds
            .encoded_value(addr(0x1800, 1), Some(3))
            .unwrap()
            .unwrap();
        assert_eq!(cob, 0x4000_0183u32.to_le_bytes().to_vec());
        let save = eds
            .encoded_value(addr(0x1010, 1), Some(3))
            .unwrap()
            .unwrap();
        assert_eq!(
            save,
            1u32.to_le_bytes().to_vec(),
            "DefaultValue without ParameterValue"
        );
        assert!(eds.encoded_value(addr(0x1800, 1), None).is_err());
        assert_eq!(eds.encoded_value(addr(0x6060, 0), Some(3)).unwrap(), None);
    }

    #[test]
    fn compact_sub_objects_are_expanded_with_names_and_values() {
        let eds = Eds::parse(SAMPLE).unwrap();
        let n = eds.get(addr(0x1600, 0)).unwrap();
        assert_eq!((n.default.as_deref(), n.writable()), (Some("2"), false));
        let s1 = eds.get(addr(0x1600, 1)).unwrap();
        assert_eq!(s1.name, "RPDO1 mapping1");
        assert_eq!(s1.value.as_deref(), Some("0x60400010"));
        let s2 = eds.get(addr(0x1600, 2)).unwrap();
        assert_eq!(s2.name, "Target entry");
        assert_eq!(
            eds.encoded_value(addr(0x1600, 2), None).unwrap().unwrap(),
            0x607A_0020u32.to_le_bytes().to_vec()
        );
        assert!(eds.get(addr(0x1600, 3)).is_none());
        let bad = SAMPLE.replace("CompactSubObj=2", "CompactSubObj=300");
        assert!(Eds::parse(&bad).unwrap_err().1.contains("CompactSubObj"));
    }

    #[test]
    fn names_are_found_case_insensitively_and_dotted() {
        let eds = Eds::parse(SAMPLE).unwrap();
        let names = eds.lookup_names();
        let find = |n: &str| find_object(&names, n);
        assert_eq!(find("modes OF operation"), Ok(addr(0x6060, 0)));
        assert_eq!(
            find("Store parameters.Save all parameters"),
            Ok(addr(0x1010, 1))
        );
        assert_eq!(find("save_all_parameters"), Ok(addr(0x1010, 1)));
        match find("Modes of operatoin") {
            Err(NameError::Unknown(near)) => assert_eq!(near[0].0, addr(0x6060, 0)),
            other => panic!("{other:?}"),
        }
        let twice = SAMPLE.replace("ParameterName=Highest sub-index", "ParameterName=COB-ID");
        let eds = Eds::parse(&twice).unwrap();
        assert!(matches!(
            find_object(&eds.lookup_names(), "cob-id"),
            Err(NameError::Ambiguous(l)) if l.len() == 2
        ));
    }

    #[test]
    fn errors_name_the_line() {
        let e = Eds::parse("[6041]\nParameterName=x\nDataType=zz\n").unwrap_err();
        assert_eq!(e.0, 1);
        assert!(e.1.contains("DataType=zz"));
        assert_eq!(Eds::parse("junk\n").unwrap_err().0, 1);
        assert_eq!(Eds::parse("[x]\nnot a pair\n").unwrap_err().0, 2);
    }

    #[test]
    fn values_are_range_checked_by_type() {
        assert!(DataType::Unsigned8.encode_text("256", None).is_err());
        assert_eq!(
            DataType::Unsigned8.encode_text("017", None).unwrap(),
            vec![15]
        );
        assert_eq!(
            DataType::Real32.encode_text("1.5", None).unwrap(),
            1.5f32.to_le_bytes()
        );
        assert_eq!(
            DataType::OctetString.encode_text("00ff", None).unwrap(),
            vec![0, 255]
        );
        assert!(DataType::VisibleString.encode_int(3).is_err());
    }
}
