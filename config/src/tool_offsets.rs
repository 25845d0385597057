//! `[tool_offsets]`: the tool offset table (Fanuc memory C), numbers 1..=[`TOOL_OFFSETS`],
//! length and radius with their wear; numbers and keys left out are 0.

use std::collections::BTreeMap;

use serde::Deserialize;
use toml::Spanned;

use crate::check::{Invalid, Table};

/// How many tool offset numbers there are (H1..H400, D1..D400), as Fanuc's 400-offset option.
pub const TOOL_OFFSETS: usize = 400;

/// Largest |value| of a tool offset (mm): 10 m, longer than any tool or tool holder. A larger
/// one was taken and sent the axis off its soft limits at the program's G43.
const MAX_TOOL_OFFSET: f64 = 10_000.0;

/// One tool offset number (Fanuc memory C): tool length (H) and radius (D), geometry and wear,
/// in mm. The length used by G43/G44 is `length + length_wear`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ToolOffset {
    pub length: f64,
    pub length_wear: f64,
    pub radius: f64,
    pub radius_wear: f64,
}

/// `[tool_offsets]` as written. Plain keys, so that an error inside an entry names it
/// (`tool_offsets.1.length`); a bad number is reported at the entry's value.
pub(crate) type RawToolOffsets = BTreeMap<String, Spanned<Table<RawToolOffset>>>;

/// `[tool_offsets]` entry: `1 = { length = 120.0, radius = 5.0 }`; keys left out are 0.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawToolOffset {
    length: Option<Spanned<f64>>,
    length_wear: Option<Spanned<f64>>,
    radius: Option<Spanned<f64>>,
    radius_wear: Option<Spanned<f64>>,
}

/// The whole table, `[n - 1]` holding number n.
pub(crate) fn validate(raw: &RawToolOffsets) -> Result<Vec<ToolOffset>, Invalid> {
    let mut tool_offsets = vec![ToolOffset::default(); TOOL_OFFSETS];
    for (n, t) in raw {
        let slot = n
            .parse::<usize>()
            .ok()
            .filter(|k| (1..=TOOL_OFFSETS).contains(k) && !n.starts_with('0'))
            .ok_or_else(|| {
                (
                    t.span(),
                    format!("tool_offsets.{n}"),
                    format!("expected an offset number 1..{TOOL_OFFSETS}"),
                )
            })?;
        let value = |v: &Option<Spanned<f64>>, field: &str| -> Result<f64, Invalid> {
            match v {
                None => Ok(0.0),
                Some(v) if v.get_ref().abs() <= MAX_TOOL_OFFSET => Ok(*v.get_ref()),
                Some(v) if v.get_ref().is_finite() => Err((
                    v.span(),
                    format!("tool_offsets.{n}.{field}"),
                    format!("must be within ±{MAX_TOOL_OFFSET} mm, got {}", v.get_ref()),
                )),
                Some(v) => Err((
                    v.span(),
                    format!("tool_offsets.{n}.{field}"),
                    "must be a finite number".into(),
                )),
            }
        };
        let t = &t.get_ref().0;
        tool_offsets[slot - 1] = ToolOffset {
            length: value(&t.length, "length")?,
            length_wear: value(&t.length_wear, "length_wear")?,
            radius: value(&t.radius, "radius")?,
            radius_wear: value(&t.radius_wear, "radius_wear")?,
        };
    }
    Ok(tool_offsets)
}
