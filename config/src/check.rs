//! The checks every section applies to its values, and the form a failed check takes: the
//! span of the offending text, the dotted key and the message (`ConfigError` adds file, line
//! and column).

use std::fmt;
use std::marker::PhantomData;

use serde::de::value::MapAccessDeserializer;
use serde::de::{Deserialize, Deserializer, MapAccess, Visitor};
use toml::Spanned;

/// A failed check: span of the value, key path, message.
pub(crate) type Invalid = (std::ops::Range<usize>, String, String);

/// A default value: spans nothing (an error about it is reported at no position).
/// Largest |position| the drive's INT32 position objects (0x607A, 0x6064, 0x60F4) hold.
pub(crate) const MAX_COUNTS: f64 = i32::MAX as f64;

pub(crate) fn sp<T>(v: T) -> Spanned<T> {
    Spanned::new(0..0, v)
}

/// A finite number above 0.
pub(crate) fn positive(v: &Spanned<f64>, key: &str) -> Result<f64, Invalid> {
    let x = *v.get_ref();
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err((
            v.span(),
            key.to_string(),
            format!("must be a positive number, got {x}"),
        ))
    }
}

/// An angle within one turn: 0 ≤ x < 360.
pub(crate) fn angle_in_turn(v: &Spanned<f64>, key: &str) -> Result<f64, Invalid> {
    let x = *v.get_ref();
    if x.is_finite() && (0.0..360.0).contains(&x) {
        Ok(x)
    } else {
        Err((
            v.span(),
            key.to_string(),
            format!("must be an angle in degrees with 0 <= angle < 360, got {x}"),
        ))
    }
}

/// An integer in `lo..=hi`.
pub(crate) fn int_in(v: &Spanned<i64>, key: &str, lo: i64, hi: i64) -> Result<i64, Invalid> {
    let x = *v.get_ref();
    if (lo..=hi).contains(&x) {
        Ok(x)
    } else {
        Err((
            v.span(),
            key.to_string(),
            format!("must be in {lo}..={hi}, got {x}"),
        ))
    }
}

/// A positive number no larger than `hi` (the key's sane ceiling, see the crate's table).
pub(crate) fn positive_at_most(v: &Spanned<f64>, key: &str, hi: f64) -> Result<f64, Invalid> {
    let x = positive(v, key)?;
    if x <= hi {
        Ok(x)
    } else {
        Err((
            v.span(),
            key.to_string(),
            format!("must be at most {hi}, got {x}"),
        ))
    }
}

/// A finite number with |x| ≤ `bound`; `what` says where the bound comes from.
pub(crate) fn finite_within(
    v: &Spanned<f64>,
    key: &str,
    bound: f64,
    what: &str,
) -> Result<f64, Invalid> {
    let x = *v.get_ref();
    if !x.is_finite() {
        return Err((v.span(), key.to_string(), "must be finite".into()));
    }
    if x.abs() > bound {
        return Err((
            v.span(),
            key.to_string(),
            format!("must be within ±{bound} ({what}), got {x}"),
        ));
    }
    Ok(x)
}

/// A value that must be written as a TOML table (`{ … }` or a `[section]`). serde's derived
/// structs also take an array, filling their fields by position (`sim = []` meant "all
/// defaults", `sim = [5]` set `delay_cycles`); this wrapper refuses anything but a table.
pub(crate) struct Table<T>(pub T);

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Table<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct TableOnly<T>(PhantomData<T>);
        impl<'de, T: Deserialize<'de>> Visitor<'de> for TableOnly<T> {
            type Value = T;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a table")
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<T, A::Error> {
                T::deserialize(MapAccessDeserializer::new(map))
            }
        }
        d.deserialize_map(TableOnly(PhantomData)).map(Table)
    }
}

/// `#[serde(deserialize_with)]` form of [`Table`].
pub(crate) fn table<'de, D: Deserializer<'de>, T: Deserialize<'de>>(d: D) -> Result<T, D::Error> {
    Table::deserialize(d).map(|t| t.0)
}
