//! `[tool_offsets]`: the tool offset table (Fanuc memory C), numbers 1..=[`TOOL_OFFSETS`],
//! length and radius with their wear; numbers and keys left out are 0. An entry may also
//! carry the tool's cutting data (diameter, teeth, Vc, fz: [`CuttingData`]) for the post's
//! n = 1000·Vc/(π·D) and F = fz·z·n; left out, it is unknown.

use std::collections::BTreeMap;

use serde::Deserialize;
use toml::Spanned;

use crate::check::{Invalid, Table};

/// How many tool offset numbers there are (H1..H400, D1..D400), as Fanuc's 400-offset option.
pub const TOOL_OFFSETS: usize = 400;

/// Largest |value| of a tool offset (mm): 10 m, longer than any tool or tool holder. A larger
/// one was taken and sent the axis off its soft limits at the program's G43.
const MAX_TOOL_OFFSET: f64 = 10_000.0;

/// Ranges of the cutting data: a diameter up to 1 m, 1 to 1000 teeth, a cutting speed up
/// to 10,000 m/min, a feed per tooth up to 10 mm.
const MAX_DIAMETER: f64 = 1000.0;
const MAX_TEETH: i64 = 1000;
const MAX_VC: f64 = 10_000.0;
const MAX_FZ: f64 = 10.0;

/// One tool offset number (Fanuc memory C): tool length (H) and radius (D), geometry and wear,
/// in mm. The length used by G43/G44 is `length + length_wear`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ToolOffset {
    pub length: f64,
    pub length_wear: f64,
    pub radius: f64,
    pub radius_wear: f64,
    /// The tool's cutting data (the post's tool table when `--tools` is not given).
    pub cutting: CuttingData,
}

/// A tool's cutting data, each `None` when the entry leaves it out: diameter (mm), number
/// of teeth, cutting speed Vc (m/min), feed per tooth fz (mm).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct CuttingData {
    pub diameter: Option<f64>,
    pub teeth: Option<u32>,
    pub vc: Option<f64>,
    pub fz: Option<f64>,
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
    diameter: Option<Spanned<f64>>,
    teeth: Option<Spanned<i64>>,
    vc: Option<Spanned<f64>>,
    fz: Option<Spanned<f64>>,
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
            cutting: cutting_data(n, t)?,
        };
    }
    Ok(tool_offsets)
}

/// The cutting data of entry `n`: each key present must be within its range (> 0).
fn cutting_data(n: &str, t: &RawToolOffset) -> Result<CuttingData, Invalid> {
    let within = |v: &Option<Spanned<f64>>, field: &str, max: f64, unit: &str| match v {
        None => Ok(None),
        Some(v) if *v.get_ref() > 0.0 && *v.get_ref() <= max => Ok(Some(*v.get_ref())),
        Some(v) => Err((
            v.span(),
            format!("tool_offsets.{n}.{field}"),
            format!("must be > 0 and at most {max} {unit}, got {}", v.get_ref()),
        )),
    };
    let teeth = match &t.teeth {
        None => None,
        Some(z) if (1..=MAX_TEETH).contains(z.get_ref()) => Some(*z.get_ref() as u32),
        Some(z) => {
            return Err((
                z.span(),
                format!("tool_offsets.{n}.teeth"),
                format!("must be 1 to {MAX_TEETH}, got {}", z.get_ref()),
            ));
        }
    };
    Ok(CuttingData {
        diameter: within(&t.diameter, "diameter", MAX_DIAMETER, "mm")?,
        teeth,
        vc: within(&t.vc, "vc", MAX_VC, "m/min")?,
        fz: within(&t.fz, "fz", MAX_FZ, "mm per tooth")?,
    })
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use crate::MachineConfig;

    const SHIPPED: &str = include_str!("../machine.toml");
    const ENTRY: &str = "1 = { length = -180.0, radius = 5.0 }";

    fn with(entry: &str) -> Result<MachineConfig, crate::ConfigError> {
        assert!(SHIPPED.contains(ENTRY));
        MachineConfig::parse(&SHIPPED.replace(ENTRY, entry), Path::new("m.toml"))
    }

    #[test]
    fn an_entry_carries_the_tools_cutting_data() {
        let c = with(
            "1 = { length = -180.0, radius = 5.0, diameter = 10.0, teeth = 4, vc = 150.0, \
             fz = 0.05 }",
        )
        .unwrap();
        let d = c.tool_offsets[0].cutting;
        assert_eq!(
            (d.diameter, d.teeth, d.vc, d.fz),
            (Some(10.0), Some(4), Some(150.0), Some(0.05))
        );
        assert_eq!(c.tool_offsets[1].cutting, crate::CuttingData::default());
    }

    #[test]
    fn cutting_data_out_of_range_is_refused_with_key_and_line() {
        let line = SHIPPED.lines().position(|l| l == ENTRY).unwrap() + 1;
        for (extra, key, why) in [
            (
                "diameter = 0.0",
                "tool_offsets.1.diameter",
                "must be > 0 and at most 1000 mm",
            ),
            (
                "diameter = 1e9",
                "tool_offsets.1.diameter",
                "at most 1000 mm",
            ),
            ("teeth = 0", "tool_offsets.1.teeth", "must be 1 to 1000"),
            ("vc = -150.0", "tool_offsets.1.vc", "at most 10000 m/min"),
            ("fz = nan", "tool_offsets.1.fz", "at most 10 mm per tooth"),
        ] {
            let e = with(&format!("1 = {{ length = -180.0, radius = 5.0, {extra} }}")).unwrap_err();
            assert_eq!(e.key, key, "{e}");
            assert!(e.message.contains(why), "{e}");
            assert_eq!(e.line, line, "{e}");
        }
    }
}
