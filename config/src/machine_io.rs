//! `[machine]` I/O beyond the E-stop bit: the outputs the program switches (coolant, spindle
//! enable, tool clamp) on the drives' 0x60FE bits, the E-stop's stop category, and what M6
//! does (`tool_change`). Validated against the axes: an output lives on an axis with a drive.

use serde::Deserialize;
use toml::Spanned;

use crate::axes::AxisConfig;
use crate::check::{self, Invalid};

/// An output on a drive's 0x60FE:1 bit (axis index in the config, bit 16..=31: the
/// manufacturer-specific outputs of CiA 402; bits 0..15 are reserved or the brake).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutputBit {
    pub axis: usize,
    pub bit: u8,
}

/// The named machine outputs (`[machine] outputs`), each on at most one drive bit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MachineOutputs {
    /// On with M8, off with M9 (and M2/M30).
    pub coolant_flood: Option<OutputBit>,
    /// On with M7, off with M9.
    pub coolant_mist: Option<OutputBit>,
    /// On with M3/M4 (a speed ≠ 0), off with M5 and at the end of the run.
    pub spindle_enable: Option<OutputBit>,
    /// On (clamped) except while a tool change releases it.
    pub tool_clamp: Option<OutputBit>,
}

/// The names `[machine] outputs` accepts, in [`MachineOutputs::all`]'s order.
pub const OUTPUT_NAMES: [&str; 4] = [
    "coolant_flood",
    "coolant_mist",
    "spindle_enable",
    "tool_clamp",
];

impl MachineOutputs {
    /// Every output with its name (unconfigured ones `None`).
    pub fn all(&self) -> [(&'static str, Option<OutputBit>); 4] {
        [
            (OUTPUT_NAMES[0], self.coolant_flood),
            (OUTPUT_NAMES[1], self.coolant_mist),
            (OUTPUT_NAMES[2], self.spindle_enable),
            (OUTPUT_NAMES[3], self.tool_clamp),
        ]
    }
}

/// The E-stop's stop category (IEC 60204-1), `estop_input = { …, category = 0|1|2 }`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StopCategory {
    /// 0: power removed at once (controlword "disable voltage"); the axes coast or brake.
    Zero,
    /// 1: quick stop, then the power stage off (the default).
    #[default]
    One,
    /// 2: quick stop; the drives stay enabled, holding position.
    Two,
}

/// What M6 does (`[machine] tool_change`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ToolChange {
    /// Logged only: the tool is assumed in the spindle (the default).
    #[default]
    Log,
    /// Hold as M0 does with "insert tool T…", tool clamp released around the hold.
    Manual,
}

/// `[machine] outputs = { name = { axis = "Z", bit = 16 }, … }` as written.
#[derive(Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawOutputs {
    coolant_flood: Option<Spanned<RawOutputBit>>,
    coolant_mist: Option<Spanned<RawOutputBit>>,
    spindle_enable: Option<Spanned<RawOutputBit>>,
    tool_clamp: Option<Spanned<RawOutputBit>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawOutputBit {
    axis: Spanned<String>,
    bit: Spanned<i64>,
}

/// The axis named `name` if it has a drive.
pub(crate) fn drive_axis(
    axes: &[AxisConfig],
    name: &Spanned<String>,
    key: &str,
) -> Result<usize, Invalid> {
    let upper = name.get_ref().to_ascii_uppercase();
    axes.iter()
        .position(|a| a.name.to_string() == upper && a.node.is_some())
        .ok_or_else(|| {
            (
                name.span(),
                key.to_string(),
                format!("{upper:?} is not an axis with a drive"),
            )
        })
}

impl RawOutputs {
    /// Each output on an axis with a drive, bit 16..=31, no two on the same bit.
    pub(crate) fn validate(&self, axes: &[AxisConfig]) -> Result<MachineOutputs, Invalid> {
        let raw = [
            &self.coolant_flood,
            &self.coolant_mist,
            &self.spindle_enable,
            &self.tool_clamp,
        ];
        let mut out = [None; 4];
        for (i, r) in raw.iter().enumerate() {
            let Some(r) = r else { continue };
            let key = |f: &str| format!("machine.outputs.{}.{f}", OUTPUT_NAMES[i]);
            let axis = drive_axis(axes, &r.get_ref().axis, &key("axis"))?;
            let bit = check::int_in(&r.get_ref().bit, &key("bit"), 16, 31)? as u8;
            let this = OutputBit { axis, bit };
            if let Some(j) = out[..i].iter().position(|o| *o == Some(this)) {
                return Err((
                    r.span(),
                    format!("machine.outputs.{}", OUTPUT_NAMES[i]),
                    format!("the same drive bit as `{}`", OUTPUT_NAMES[j]),
                ));
            }
            out[i] = Some(this);
        }
        Ok(MachineOutputs {
            coolant_flood: out[0],
            coolant_mist: out[1],
            spindle_enable: out[2],
            tool_clamp: out[3],
        })
    }
}

/// `category` of `estop_input`: 0, 1 or 2 (1 when absent).
pub(crate) fn stop_category(v: Option<&Spanned<i64>>) -> Result<StopCategory, Invalid> {
    let Some(v) = v else {
        return Ok(StopCategory::One);
    };
    Ok(
        match check::int_in(v, "machine.estop_input.category", 0, 2)? {
            0 => StopCategory::Zero,
            1 => StopCategory::One,
            _ => StopCategory::Two,
        },
    )
}

/// `tool_change = "manual"` or `"none"`.
pub(crate) fn tool_change(v: Option<&Spanned<String>>) -> Result<ToolChange, Invalid> {
    let Some(n) = v else {
        return Ok(ToolChange::Log);
    };
    match n.get_ref().as_str() {
        "manual" => Ok(ToolChange::Manual),
        "none" => Ok(ToolChange::Log),
        other => Err((
            n.span(),
            "machine.tool_change".into(),
            format!("{other:?}: expected \"manual\" or \"none\""),
        )),
    }
}
