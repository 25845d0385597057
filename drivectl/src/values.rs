//! Object addresses (`INDEX[:SUB]`), CANopen data types as typed on the command line, and
//! the conversions between values and the little-endian bytes SDO carries.

use serde_json::{Value as Json, json};

use crate::error::{CliError, Result};

/// An object address: index and sub-index (the EDS reader's, shared with the master).
pub use cnc402_config::eds::ObjectAddr;

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

/// Parses `INDEX[:SUB]`: index and sub-index are both hex, with or without `0x`, as the help
/// and every printout write them (`6041`, `0x6041:0`, `1018:4`, `1018:0x04`, `1018:0a`).
///
/// ```
/// use drivectl::values::{ObjectAddr, parse_object};
/// assert_eq!(parse_object("0x1018:4").unwrap(), ObjectAddr { index: 0x1018, sub: 4 });
/// assert_eq!(parse_object("6041").unwrap(), ObjectAddr { index: 0x6041, sub: 0 });
/// assert_eq!(parse_object("0x1018:10").unwrap(), ObjectAddr { index: 0x1018, sub: 0x10 });
/// assert_eq!(parse_object("1A00:ff").unwrap(), ObjectAddr { index: 0x1A00, sub: 0xff });
/// assert!(parse_object("6041:100").is_err());
/// ```
pub fn parse_object(s: &str) -> core::result::Result<ObjectAddr, String> {
    let (i, sub) = match s.split_once(':') {
        Some((i, sub)) => (i, Some(sub)),
        None => (s, None),
    };
    // Hex digits only: from_str_radix alone also takes a sign (`1018:+1`).
    let hex = |t: &str| {
        let t = t.trim();
        let h = t
            .strip_prefix("0x")
            .or_else(|| t.strip_prefix("0X"))
            .unwrap_or(t);
        if h.chars().all(|c| c.is_ascii_hexdigit()) {
            h.to_string()
        } else {
            String::new()
        }
    };
    let index = u16::from_str_radix(&hex(i), 16).map_err(|_| {
        format!(
            "`{s}`: index `{}` is not a 16-bit hex number (e.g. 6041)",
            i.trim()
        )
    })?;
    let sub = match sub {
        None => 0,
        Some(t) => u8::from_str_radix(&hex(t), 16).map_err(|_| {
            format!("`{s}`: sub-index `{t}` is not a hex number 0..ff (e.g. 1018:0a)")
        })?,
    };
    Ok(ObjectAddr { index, sub })
}

/// The CANopen data type: the object dictionary's (`cnc402_drives::od`), one type for the
/// simulator, the EDS reader and the command line.
pub use cnc402_drives::od::DataType;
use cnc402_drives::od::{OdError, Value};

/// The names `TYPE` accepts (for help texts).
pub const TYPE_NAMES: &str = "bool, u8, u16, u32, u64, i8, i16, i32, i64, f32, f64, string, bytes (CiA names too: unsigned16, integer32, real32, visible_string, octet_string, domain)";

/// Parses a type name as typed on the command line: short (`u16`, `f32`, `bytes`) or CiA 301
/// (`unsigned16`, `real32`, `visible_string`), any case; `None` for an unknown name.
pub fn parse_type(s: &str) -> Option<DataType> {
    DataType::from_name(s)
}

/// Parses a value typed by the user as type `t`: integers in decimal or (`-`)`0x` hex,
/// range-checked; reals (`3.5`); booleans (`true`/`false`/`on`/`off`/`1`/`0`); strings as
/// given; octet strings and domains as hex bytes. Errors (usage) name the type and range.
pub fn parse_value(t: DataType, text: &str) -> Result<Value> {
    let bad = |why: &str| {
        CliError::usage(format!(
            "value `{text}` is not a valid {}: {why}",
            t.cia_name()
        ))
    };
    Ok(match t {
        DataType::Boolean => match text.trim().to_ascii_lowercase().as_str() {
            "1" | "true" | "on" => Value::Boolean(true),
            "0" | "false" | "off" => Value::Boolean(false),
            _ => return Err(bad("expected true/false/1/0")),
        },
        DataType::Real32 => Value::Real32(text.trim().parse().map_err(|_| bad("not a number"))?),
        DataType::Real64 => Value::Real64(text.trim().parse().map_err(|_| bad("not a number"))?),
        DataType::VisibleString => Value::VisibleString(text.to_string()),
        DataType::OctetString | DataType::Domain => {
            let b =
                parse_hex_bytes(text).ok_or_else(|| bad("expected hex bytes, e.g. 0011aabb"))?;
            if t == DataType::Domain {
                Value::Domain(b)
            } else {
                Value::OctetString(b)
            }
        }
        _ => {
            let v = parse_int(text).ok_or_else(|| bad("not an integer"))?;
            Value::from_int(t, v).map_err(|_| match t.int_range() {
                Some((min, max)) => bad(&format!("outside {min}..={max}")),
                None => bad("not an integer type"),
            })?
        }
    })
}

/// Encodes a value typed by the user as type `t` into the little-endian bytes SDO carries
/// ([`parse_value`], then the dictionary's codec).
///
/// ```
/// use drivectl::values::{DataType, encode};
/// assert_eq!(encode(DataType::Unsigned16, "0x1234").unwrap(), vec![0x34, 0x12]);
/// assert!(encode(DataType::Unsigned8, "256").is_err());
/// ```
pub fn encode(t: DataType, text: &str) -> Result<Vec<u8>> {
    Ok(parse_value(t, text)?.to_bytes())
}

/// Decodes SDO data as type `t` (the dictionary's codec) into `(text, json)`: unsigned as
/// `5000 (0x00001388)`, signed as `-2 (0xfffffffe)`, reals, strings without trailing NULs
/// (invalid UTF-8 shown with U+FFFD), bytes as hex. A size that does not fit the type is a
/// protocol error naming both sizes.
pub fn decode(t: DataType, data: &[u8]) -> Result<(String, Json)> {
    if let Some(n) = t.size()
        && data.len() != n
    {
        return Err(CliError::protocol(format!(
            "wrong data type: the drive returned {} byte(s) ({}), {} needs {n}",
            data.len(),
            hex(data),
            t.cia_name()
        )));
    }
    let value = match Value::from_bytes(t, data) {
        Ok(v) => v,
        // Not UTF-8: still shown (a diagnostic tool prints what it got).
        Err(OdError::InvalidValue) if t == DataType::VisibleString => {
            Value::VisibleString(String::from_utf8_lossy(data).into_owned())
        }
        Err(e) => {
            return Err(CliError::protocol(format!(
                "{} {} ({})",
                t.cia_name(),
                e,
                hex(data)
            )));
        }
    };
    Ok(match value {
        // Any non-zero byte is true (CiA 301 allows only 0 and 1; a drive may send more).
        Value::Boolean(_) => {
            let b = data.iter().any(|&c| c != 0);
            (b.to_string(), json!(b))
        }
        Value::U8(_) | Value::U16(_) | Value::U32(_) | Value::U64(_) => {
            let u = value.as_u64().unwrap_or(0);
            let w = 2 * data.len();
            (format!("{u} ({u:#0w$x})", w = w + 2), json!(u))
        }
        Value::I8(_) | Value::I16(_) | Value::I32(_) | Value::I64(_) => {
            let v = value.as_i64().unwrap_or(0);
            (format!("{v} ({})", hex_le(data)), json!(v))
        }
        Value::Real32(v) => (v.to_string(), json!(v)),
        Value::Real64(v) => (v.to_string(), json!(v)),
        Value::VisibleString(s) => {
            let s = s.trim_end_matches('\0').to_string();
            (format!("\"{s}\""), json!(s))
        }
        Value::OctetString(_) | Value::Domain(_) => (hex(data), json!(hex(data))),
    })
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
                1 => DataType::Unsigned8,
                2 => DataType::Unsigned16,
                4 => DataType::Unsigned32,
                _ => DataType::Unsigned64,
            };
            decode(t, data).unwrap_or_else(|_| (hex(data), json!(hex(data))))
        }
        _ if !data.is_empty() && data.iter().all(|&c| c == 0 || (0x20..0x7f).contains(&c)) => {
            decode(DataType::VisibleString, data).unwrap_or_else(|_| (hex(data), json!(hex(data))))
        }
        _ => (hex(data), json!(hex(data))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encode_checks_range_and_decode_checks_size() {
        use DataType::*;
        assert_eq!(encode(Unsigned16, "0x1234").unwrap(), vec![0x34, 0x12]);
        assert_eq!(
            encode(Integer32, "-2").unwrap(),
            vec![0xfe, 0xff, 0xff, 0xff]
        );
        assert!(
            encode(Unsigned8, "256")
                .unwrap_err()
                .message
                .contains("0..=255")
        );
        assert!(encode(Integer8, "x").is_err());
        assert_eq!(
            encode(OctetString, "00 11 aa").unwrap(),
            vec![0, 0x11, 0xaa]
        );
        let e = decode(Unsigned32, &[1, 2]).unwrap_err();
        assert!(e.message.contains("wrong data type"), "{e}");
        assert_eq!(decode(Integer16, &[0xff, 0xff]).unwrap().1, json!(-1));
        assert_eq!(decode(VisibleString, b"ab\0").unwrap().1, json!("ab"));
    }

    #[test]
    fn text_forms_of_every_kind() {
        use DataType::*;
        assert_eq!(parse_type("U32"), Some(Unsigned32));
        assert_eq!(parse_type("real64"), Some(Real64));
        assert_eq!(parse_type("bytes"), Some(OctetString));
        assert_eq!(parse_type("domain"), Some(Domain));
        assert_eq!(parse_type("u128"), None);
        assert_eq!(
            encode(Real32, "3.5").unwrap(),
            3.5f32.to_le_bytes().to_vec()
        );
        assert_eq!(
            decode(Real32, &3.5f32.to_le_bytes()).unwrap(),
            ("3.5".into(), json!(3.5))
        );
        assert_eq!(
            decode(Real64, &(-0.25f64).to_le_bytes()).unwrap().1,
            json!(-0.25)
        );
        assert!(
            encode(Real64, "abc")
                .unwrap_err()
                .message
                .contains("REAL64")
        );
        assert_eq!(encode(Boolean, "on").unwrap(), vec![1]);
        assert_eq!(decode(Boolean, &[2]).unwrap().1, json!(true));
        assert_eq!(
            decode(Unsigned32, &[0x88, 0x13, 0, 0]).unwrap().0,
            "5000 (0x00001388)"
        );
        assert_eq!(
            decode(Integer32, &[0xfe, 0xff, 0xff, 0xff]).unwrap().0,
            "-2 (0xfffffffe)"
        );
        assert_eq!(
            encode(Unsigned64, "18446744073709551615").unwrap(),
            vec![0xff; 8]
        );
        assert_eq!(
            encode(Integer64, "-0x10").unwrap(),
            (-16i64).to_le_bytes().to_vec()
        );
        assert!(
            encode(Integer16, "-32769")
                .unwrap_err()
                .message
                .contains("-32768..=32767")
        );
        assert_eq!(
            decode(VisibleString, &[b'a', 0xff]).unwrap().1,
            json!("a\u{fffd}")
        );
        assert_eq!(encode(Domain, "0xbeef").unwrap(), vec![0xbe, 0xef]);
        assert_eq!(decode(Domain, &[0xbe, 0xef]).unwrap().0, "beef");
        assert_eq!(decode_untyped(&[1, 0]).0, "1 (0x0001)");
        assert_eq!(decode_untyped(b"abc").1, json!("abc"));
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
        assert!(parse_object("1018:").is_err());
        assert!(parse_object("1018:+1").is_err());
        assert!(parse_object("12345").is_err());
    }
}
