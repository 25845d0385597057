//! `[planner]`: the motion planner's lookahead, which blends G64 (continuous) blocks at the
//! programmed feed: how many path segments it may hold ahead of the machine; and the axes
//! that contour together with matched dynamics (`match_axes`).

use serde::Deserialize;
use toml::Spanned;

use crate::axes::{AxisConfig, AxisKind};
use crate::check::{Invalid, int_in, sp};

/// Most segments the lookahead may hold (memory stays bounded: about 1 KB a segment).
pub const MAX_LOOKAHEAD: i64 = 100_000;

#[derive(Clone, Debug, PartialEq)]
pub struct PlannerConfig {
    /// Path segments the lookahead holds (2..=[`MAX_LOOKAHEAD`]). It plans so that the machine
    /// can always stop within them, so a window shorter than the braking distance at the
    /// feed lowers the speed of fine-segment programs.
    pub lookahead: usize,
    /// Indices (into `axes`) of the axes that contour together with matched dynamics: the
    /// 1 ms loop shapes their setpoints so that each lags like the slowest of their
    /// `dynamics` models. Empty: none is shaped (the default). Each has a drive and a model,
    /// none is the spindle, none twice, and there are two or more.
    pub match_axes: Vec<usize>,
}

impl Default for PlannerConfig {
    fn default() -> Self {
        PlannerConfig {
            lookahead: DEFAULT_LOOKAHEAD as usize,
            match_axes: Vec::new(),
        }
    }
}

const DEFAULT_LOOKAHEAD: i64 = 2000;

/// `[planner]` as written; every key has a default.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawPlanner {
    #[serde(default = "default_lookahead")]
    lookahead: Spanned<i64>,
    #[serde(default)]
    match_axes: Option<Spanned<Vec<Spanned<String>>>>,
}

impl Default for RawPlanner {
    fn default() -> Self {
        RawPlanner {
            lookahead: default_lookahead(),
            match_axes: None,
        }
    }
}

fn default_lookahead() -> Spanned<i64> {
    sp(DEFAULT_LOOKAHEAD)
}

impl RawPlanner {
    /// The planner's keys; `match_axes` is left empty until [`Self::match_axes`] has the
    /// axes to check it against.
    pub(crate) fn validate(&self) -> Result<PlannerConfig, Invalid> {
        Ok(PlannerConfig {
            lookahead: int_in(&self.lookahead, "planner.lookahead", 2, MAX_LOOKAHEAD)? as usize,
            match_axes: Vec::new(),
        })
    }

    /// `match_axes` resolved against the configured `axes`: each name an axis (any case)
    /// with a drive and a `dynamics` model, not the spindle (a tap matches it with the tool
    /// axis already), none twice; an empty list is off, a single axis has nothing to match.
    pub(crate) fn match_axes(&self, axes: &[AxisConfig]) -> Result<Vec<usize>, Invalid> {
        let Some(list) = &self.match_axes else {
            return Ok(Vec::new());
        };
        let mut out: Vec<usize> = Vec::new();
        for (k, name) in list.get_ref().iter().enumerate() {
            let key = format!("planner.match_axes[{k}]");
            let fail = |msg: String| Err((name.span(), key.clone(), msg));
            let text = name.get_ref();
            let Some(i) = axes
                .iter()
                .position(|a| text.eq_ignore_ascii_case(&a.name.to_string()))
            else {
                let known: String = axes.iter().map(|a| a.name).collect();
                return fail(format!(
                    "unknown axis \"{text}\" (the configured axes are {known})"
                ));
            };
            let a = &axes[i];
            if out.contains(&i) {
                return fail(format!("axis {} is named twice", a.name));
            }
            if a.kind == AxisKind::Spindle {
                return fail(format!(
                    "axis {} is the spindle: it does not contour (a rigid tap matches it with \
                     the tool axis already)",
                    a.name
                ));
            }
            if a.node.is_none() {
                return fail(format!(
                    "axis {} is virtual: it has no drive to match",
                    a.name
                ));
            }
            if a.dynamics.is_none() {
                return fail(format!(
                    "axis {} has no drive model: give it `dynamics = {{ delay_cycles = …, \
                     bandwidth_hz = … }}` to match it",
                    a.name
                ));
            }
            out.push(i);
        }
        if out.len() == 1 {
            return Err((
                list.span(),
                "planner.match_axes".into(),
                "one axis has nothing to be matched with: name two or more, or none".into(),
            ));
        }
        Ok(out)
    }
}
