//! `[work_offsets]`: G54..G59, the machine position of each work zero per axis letter (axes
//! left out are 0).

use std::collections::BTreeMap;

use toml::Spanned;

use crate::check::Invalid;
use crate::{AxisConfig, MAX_AXES};

/// `[work_offsets]` as written: `G54 = { X = 0.0, … }`, with spans on names and values.
pub(crate) type RawWorkOffsets = BTreeMap<Spanned<String>, BTreeMap<Spanned<String>, Spanned<f64>>>;

/// The six work offsets, indexed G54..G59 then like `axes`.
pub(crate) fn validate(
    raw: &RawWorkOffsets,
    axes: &[AxisConfig],
) -> Result<[[f64; MAX_AXES]; 6], Invalid> {
    let mut work_offsets = [[0.0; MAX_AXES]; 6];
    for (g, offs) in raw {
        let idx = match g.get_ref().to_ascii_uppercase().as_str() {
            "G54" => 0,
            "G55" => 1,
            "G56" => 2,
            "G57" => 3,
            "G58" => 4,
            "G59" => 5,
            o => {
                return Err((
                    g.span(),
                    format!("work_offsets.{o}"),
                    "expected G54..G59".into(),
                ));
            }
        };
        for (axis, v) in offs {
            let letter = axis.get_ref().to_ascii_uppercase();
            let Some(ai) = axes
                .iter()
                .position(|a| letter.len() == 1 && a.name.to_string() == letter)
            else {
                return Err((
                    axis.span(),
                    format!("work_offsets.{}.{}", g.get_ref(), axis.get_ref()),
                    "no such axis".into(),
                ));
            };
            if !v.get_ref().is_finite() {
                return Err((
                    v.span(),
                    format!("work_offsets.{}.{}", g.get_ref(), axis.get_ref()),
                    "must be finite".into(),
                ));
            }
            work_offsets[idx][ai] = *v.get_ref();
        }
    }
    Ok(work_offsets)
}
