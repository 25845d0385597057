//! `[work_offsets]`: G54..G59, the machine position of each work zero per axis letter (axes
//! left out are 0).

use std::collections::BTreeMap;

use toml::Spanned;

use crate::axes::MAX_COUNTS;
use crate::check::{Invalid, finite_within};
use crate::{AxisConfig, MAX_AXES};

/// `[work_offsets]` as written: `G54 = { X = 0.0, … }`, with spans on names and values.
pub(crate) type RawWorkOffsets = BTreeMap<Spanned<String>, BTreeMap<Spanned<String>, Spanned<f64>>>;

/// The six work offsets, indexed G54..G59 then like `axes`.
pub(crate) fn validate(
    raw: &RawWorkOffsets,
    axes: &[AxisConfig],
) -> Result<[[f64; MAX_AXES]; 6], Invalid> {
    let mut work_offsets = [[0.0; MAX_AXES]; 6];
    // TOML keys are case-sensitive, these names are not: `G54` and `g54` (or `X` and `x`)
    // are one offset given twice, which the map kept both of and the later one won.
    let mut given: [Option<&Spanned<String>>; 6] = [None; 6];
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
        once(&mut given[idx], g, "work_offsets", "work offset")?;
        let mut axes_given: [Option<&Spanned<String>>; MAX_AXES] = [None; MAX_AXES];
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
            let key = format!("work_offsets.{}.{}", g.get_ref(), axis.get_ref());
            once(
                &mut axes_given[ai],
                axis,
                &format!("work_offsets.{}", g.get_ref()),
                "axis",
            )?;
            // Any machine position the offset leads to is sent as INT32 counts.
            let reach = MAX_COUNTS / axes[ai].counts_per_unit;
            work_offsets[idx][ai] = finite_within(
                v,
                &key,
                reach,
                "the drive's 32-bit position at this axis's scale",
            )?;
        }
    }
    Ok(work_offsets)
}

/// Records `name` as the spelling of its slot; a second spelling (`G54` and `g54`) is an
/// error at whichever of the two comes later in the file.
fn once<'a>(
    slot: &mut Option<&'a Spanned<String>>,
    name: &'a Spanned<String>,
    prefix: &str,
    what: &str,
) -> Result<(), Invalid> {
    let Some(first) = slot.replace(name) else {
        return Ok(());
    };
    let later = if first.span().start > name.span().start {
        first
    } else {
        name
    };
    Err((
        later.span(),
        format!("{prefix}.{}", later.get_ref()),
        format!(
            "{:?} and {:?} are the same {what} (names are not case-sensitive)",
            first.get_ref(),
            name.get_ref()
        ),
    ))
}
