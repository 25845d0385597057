//! `[planner]`: the motion planner's lookahead, which blends G64 (continuous) blocks at the
//! programmed feed: how many path segments it may hold ahead of the machine.

use serde::Deserialize;
use toml::Spanned;

use crate::check::{Invalid, int_in, sp};

/// Most segments the lookahead may hold (memory stays bounded: about 1 KB a segment).
pub const MAX_LOOKAHEAD: i64 = 100_000;

#[derive(Clone, Debug, PartialEq)]
pub struct PlannerConfig {
    /// Path segments the lookahead holds (2..=[`MAX_LOOKAHEAD`]). It plans so that the machine
    /// can always stop within them, so a window shorter than the braking distance at the
    /// feed lowers the speed of fine-segment programs.
    pub lookahead: usize,
}

impl Default for PlannerConfig {
    fn default() -> Self {
        PlannerConfig {
            lookahead: DEFAULT_LOOKAHEAD as usize,
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
}

impl Default for RawPlanner {
    fn default() -> Self {
        RawPlanner {
            lookahead: default_lookahead(),
        }
    }
}

fn default_lookahead() -> Spanned<i64> {
    sp(DEFAULT_LOOKAHEAD)
}

impl RawPlanner {
    pub(crate) fn validate(&self) -> Result<PlannerConfig, Invalid> {
        Ok(PlannerConfig {
            lookahead: int_in(&self.lookahead, "planner.lookahead", 2, MAX_LOOKAHEAD)? as usize,
        })
    }
}
