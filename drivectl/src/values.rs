//! Object addresses (`INDEX[:SUB]`), CANopen data types as typed on the command line, and
//! the conversions between values and the little-endian bytes SDO carries.

use core::fmt;

use serde_json::{Value as Json, json};

use crate::error::{CliError, Result};

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

/// Parses an unsigned number in decimal or `0x` hex.
pub fn parse_uint(s: &str) -> Option<u64> {
    let s = s.trim().replace('_', "");
    match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => u64::from_str_radix(h, 16).ok(),
        None => s.parse().ok(),
    }
}

/// Parses a signed number in decimal or (`-`)`0x` hex.
pub fn parse_int(s: &str) -> Option<i128> {
    let s = s.trim();
    match s.strip_prefix('-') {
        Some(rest) => parse_uint(rest).map(|v| -(v as i128)),
        None => parse_uint(s.strip_prefix('+').unwrap_or(s)).map(|v| v as i128),
    }
}

/// Parses `INDEX[:SUB]`: the index is hex (with or without `0x`), the sub-index hex with
/// `0x` or decimal without it (`6041`, `0x6041:0`, `1018:4`, `1018:0x04`).
///
/// ```
/// use drivectl::values::{ObjectAddr, parse_object};
/// assert_eq!(parse_object("0x1018:4").unwrap(), ObjectAddr { index: 0x1018, sub: 4 });
/// assert_eq!(parse_object("6041").unwrap(), ObjectAddr { index: 0x6041, sub: 0 });
/// assert!(parse_object("6041:300").is_err());
/// ```
pub fn parse_object(s: &str) -> core::result::Result<ObjectAddr, String> {
    let (i, sub) = match s.split_once(':') {
        Some((i, sub)) => (i, Some(sub)),
        None => (s, None),
    };
    let i = i.trim();
    let hex = i
        .strip_prefix("0x")
        .or_else(|| i.strip_prefix("0X"))
        .unwrap_or(i);
    let index = u16::from_str_radix(hex, 16)
        .map_err(|_| format!("`{s}`: index `{i}` is not a 16-bit hex number (e.g. 6041)"))?;
    let sub = match sub {
        None => 0,
        Some(t) => {
            let v =
                parse_uint(t).ok_or_else(|| format!("`{s}`: sub-index `{t}` is not a number"))?;
            u8::try_from(v).map_err(|_| format!("`{s}`: sub-index {v} above 255"))?
        }
    };
    Ok(ObjectAddr { index, sub })
}

/// A CANopen data type as named on the command line or in an EDS.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DataType {
    /// BOOLEAN.
    Bool,
    /// UNSIGNED8..64.
    U8,
    /// UNSIGNED16.
    U16,
    /// UNSIGNED32.
    U32,
    /// UNSIGNED64.
    U64,
    /// INTEGER8..64.
    I8,
    /// INTEGER16.
    I16,
    /// INTEGER32.
    I32,
    /// INTEGER64.
    I64,
    /// REAL32.
    F32,
    /// REAL64.
    F64,
    /// VISIBLE_STRING.
    Str,
    /// OCTET_STRING / DOMAIN (hex bytes).
    Bytes,
}

/// The names `TYPE` accepts (for help texts).
pub const TYPE_NAMES: &str = "bool, u8, u16, u32, u64, i8, i16, i32, i64, f32, f64, string, bytes (CiA names too: unsigned16, integer32, real32, visible_string, octet_string, domain)";

impl DataType {
    /// Parses a type name: short (`u16`), CiA 301 (`unsigned16`, `visible_string`).
    pub fn parse(s: &str) -> Option<DataType> {
        use DataType::*;
        Some(match s.to_ascii_lowercase().as_str() {
            "bool" | "boolean" => Bool,
            "u8" | "uint8" | "unsigned8" => U8,
            "u16" | "uint16" | "unsigned16" => U16,
            "u32" | "uint32" | "unsigned32" => U32,
            "u64" | "uint64" | "unsigned64" => U64,
            "i8" | "int8" | "integer8" => I8,
            "i16" | "int16" | "integer16" => I16,
            "i32" | "int32" | "integer32" => I32,
            "i64" | "int64" | "integer64" => I64,
            "f32" | "real32" | "float" => F32,
            "f64" | "real64" | "double" => F64,
            "string" | "str" | "vs" | "visible_string" => Str,
            "bytes" | "hex" | "domain" | "octet_string" | "os" => Bytes,
            _ => return None,
        })
    }

    /// From a CiA 306 `DataType=` code (0x0001 BOOLEAN ... 0x001B UNSIGNED64).
    pub fn from_eds_code(code: u16) -> Option<DataType> {
        use DataType::*;
        Some(match code {
            0x0001 => Bool,
            0x0002 => I8,
            0x0003 => I16,
            0x0004 => I32,
            0x0005 => U8,
            0x0006 => U16,
            0x0007 => U32,
            0x0008 => F32,
            0x0009 => Str,
            0x000A | 0x000F => Bytes,
            0x0011 => F64,
            0x0015 => I64,
            0x001B => U64,
            _ => return None,
        })
    }

    /// From the drives crate's object dictionary type.
    pub fn from_od(t: cnc402_drives::od::DataType) -> DataType {
        use cnc402_drives::od::DataType as T;
        match t {
            T::Boolean => DataType::Bool,
            T::Integer8 => DataType::I8,
            T::Integer16 => DataType::I16,
            T::Integer32 => DataType::I32,
            T::Integer64 => DataType::I64,
            T::Unsigned8 => DataType::U8,
            T::Unsigned16 => DataType::U16,
            T::Unsigned32 => DataType::U32,
            T::Unsigned64 => DataType::U64,
            T::VisibleString => DataType::Str,
            T::OctetString | T::Domain => DataType::Bytes,
        }
    }

    /// Bytes of a fixed-size type.
    pub fn size(self) -> Option<usize> {
        use DataType::*;
        match self {
            Bool | U8 | I8 => Some(1),
            U16 | I16 => Some(2),
            U32 | I32 | F32 => Some(4),
            U64 | I64 | F64 => Some(8),
            Str | Bytes => None,
        }
    }

    /// The CiA 301 name.
    pub fn cia_name(self) -> &'static str {
        use DataType::*;
        match self {
            Bool => "BOOLEAN",
            U8 => "UNSIGNED8",
            U16 => "UNSIGNED16",
            U32 => "UNSIGNED32",
            U64 => "UNSIGNED64",
            I8 => "INTEGER8",
            I16 => "INTEGER16",
            I32 => "INTEGER32",
            I64 => "INTEGER64",
            F32 => "REAL32",
            F64 => "REAL64",
            Str => "VISIBLE_STRING",
            Bytes => "OCTET_STRING",
        }
    }

    /// Encodes a value typed by the user. Errors name the type and its range.
    pub fn encode(self, text: &str) -> Result<Vec<u8>> {
        use DataType::*;
        let bad = |why: &str| {
            CliError::usage(format!(
                "value `{text}` is not a valid {}: {why}",
                self.cia_name()
            ))
        };
        let int = |min: i128, max: i128| -> Result<i128> {
            let v = parse_int(text).ok_or_else(|| bad("not an integer"))?;
            if v < min || v > max {
                return Err(bad(&format!("outside {min}..={max}")));
            }
            Ok(v)
        };
        Ok(match self {
            Bool => match text.trim().to_ascii_lowercase().as_str() {
                "1" | "true" | "on" => vec![1],
                "0" | "false" | "off" => vec![0],
                _ => return Err(bad("expected true/false/1/0")),
            },
            U8 => vec![int(0, u8::MAX as i128)? as u8],
            U16 => (int(0, u16::MAX as i128)? as u16).to_le_bytes().to_vec(),
            U32 => (int(0, u32::MAX as i128)? as u32).to_le_bytes().to_vec(),
            U64 => (int(0, u64::MAX as i128)? as u64).to_le_bytes().to_vec(),
            I8 => (int(i8::MIN as i128, i8::MAX as i128)? as i8)
                .to_le_bytes()
                .to_vec(),
            I16 => (int(i16::MIN as i128, i16::MAX as i128)? as i16)
                .to_le_bytes()
                .to_vec(),
            I32 => (int(i32::MIN as i128, i32::MAX as i128)? as i32)
                .to_le_bytes()
                .to_vec(),
            I64 => (int(i64::MIN as i128, i64::MAX as i128)? as i64)
                .to_le_bytes()
                .to_vec(),
            F32 => text
                .trim()
                .parse::<f32>()
                .map_err(|_| bad("not a number"))?
                .to_le_bytes()
                .to_vec(),
            F64 => text
                .trim()
                .parse::<f64>()
                .map_err(|_| bad("not a number"))?
                .to_le_bytes()
                .to_vec(),
            Str => text.as_bytes().to_vec(),
            Bytes => {
                parse_hex_bytes(text).ok_or_else(|| bad("expected hex bytes, e.g. 0011aabb"))?
            }
        })
    }

    /// Decodes SDO data as this type: `(text, json)`. A size that does not fit the type is a
    /// protocol error naming both sizes.
    pub fn decode(self, data: &[u8]) -> Result<(String, Json)> {
        use DataType::*;
        if let Some(n) = self.size()
            && data.len() != n
        {
            return Err(CliError::protocol(format!(
                "wrong data type: the drive returned {} byte(s) ({}), {} needs {n}",
                data.len(),
                hex(data),
                self.cia_name()
            )));
        }
        let mut b = [0u8; 8];
        let k = data.len().min(8);
        b[..k].copy_from_slice(&data[..k]);
        let u = u64::from_le_bytes(b);
        Ok(match self {
            Bool => ((u != 0).to_string(), json!(u != 0)),
            U8 | U16 | U32 | U64 => {
                let w = 2 * data.len();
                (format!("{u} ({u:#0w$x})", w = w + 2), json!(u))
            }
            I8 => signed(data[0] as i8 as i64, data),
            I16 => signed(i16::from_le_bytes([b[0], b[1]]) as i64, data),
            I32 => signed(i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as i64, data),
            I64 => signed(i64::from_le_bytes(b), data),
            F32 => {
                let v = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                (v.to_string(), json!(v))
            }
            F64 => {
                let v = f64::from_le_bytes(b);
                (v.to_string(), json!(v))
            }
            Str => {
                let s = String::from_utf8_lossy(data)
                    .trim_end_matches('\0')
                    .to_string();
                (format!("\"{s}\""), json!(s))
            }
            Bytes => (hex(data), json!(hex(data))),
        })
    }
}

fn signed(v: i64, data: &[u8]) -> (String, Json) {
    (format!("{v} ({})", hex_le(data)), json!(v))
}

/// Hex digits of bytes in wire order (`0011aabb`).
pub fn hex(data: &[u8]) -> String {
    data.iter().map(|b| format!("{b:02x}")).collect()
}

/// `0x…` of a little-endian integer's bytes (most significant first).
fn hex_le(data: &[u8]) -> String {
    let mut s = String::from("0x");
    for b in data.iter().rev() {
        s.push_str(&format!("{b:02x}"));
    }
    s
}

/// Parses hex bytes (`0011AABB`, `00 11 aa bb`, `0x0011`).
pub fn parse_hex_bytes(s: &str) -> Option<Vec<u8>> {
    let s: String = s
        .trim()
        .trim_start_matches("0x")
        .chars()
        .filter(|c| !c.is_whitespace() && *c != ':' && *c != '-')
        .collect();
    if !s.len().is_multiple_of(2) {
        return None;
    }
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(s.get(i..i + 2)?, 16).ok())
        .collect()
}

/// A guess for data of unknown type: integers by length, else a string if printable, else hex.
pub fn decode_untyped(data: &[u8]) -> (String, Json) {
    match data.len() {
        1 | 2 | 4 | 8 => {
            let t = match data.len() {
                1 => DataType::U8,
                2 => DataType::U16,
                4 => DataType::U32,
                _ => DataType::U64,
            };
            t.decode(data)
                .unwrap_or_else(|_| (hex(data), json!(hex(data))))
        }
        _ if !data.is_empty() && data.iter().all(|&c| c == 0 || (0x20..0x7f).contains(&c)) => {
            DataType::Str
                .decode(data)
                .unwrap_or_else(|_| (hex(data), json!(hex(data))))
        }
        _ => (hex(data), json!(hex(data))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encode_checks_range_and_decode_checks_size() {
        assert_eq!(DataType::U16.encode("0x1234").unwrap(), vec![0x34, 0x12]);
        assert_eq!(
            DataType::I32.encode("-2").unwrap(),
            vec![0xfe, 0xff, 0xff, 0xff]
        );
        assert!(
            DataType::U8
                .encode("256")
                .unwrap_err()
                .message
                .contains("0..=255")
        );
        assert!(DataType::I8.encode("x").is_err());
        assert_eq!(
            DataType::Bytes.encode("00 11 aa").unwrap(),
            vec![0, 0x11, 0xaa]
        );
        let e = DataType::U32.decode(&[1, 2]).unwrap_err();
        assert!(e.message.contains("wrong data type"), "{e}");
        assert_eq!(DataType::I16.decode(&[0xff, 0xff]).unwrap().1, json!(-1));
        assert_eq!(DataType::Str.decode(b"ab\0").unwrap().1, json!("ab"));
    }

    #[test]
    fn object_addresses() {
        assert_eq!(
            parse_object("1A00:0x02").unwrap(),
            ObjectAddr {
                index: 0x1A00,
                sub: 2
            }
        );
        assert!(parse_object("zz").is_err());
        assert!(parse_object("12345").is_err());
    }
}
