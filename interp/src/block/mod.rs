//! Block execution: a block's words ([`words`]), the modal state ([`state`]), motion and arcs
//! ([`exec`], [`arc`]), the machine's own M codes (`mcodes`), cutter compensation modes (`comp`), canned cycles ([`cycles`]) and offsets ([`offsets`]: the one owner of
//! work offsets, G92 and tool length), held together by [`Machine`]. Uses the expression and
//! variable layers below it; knows nothing of program flow.

pub mod arc;
mod comp;
pub mod corner;
pub mod cycles;
pub(crate) mod exec;
pub(crate) mod machine;
pub(crate) mod mcodes;
pub mod offsets;
pub mod options;
pub(crate) mod plain;
pub mod state;
pub mod words;

pub use machine::Machine;
pub use options::{MainM99, Options};
