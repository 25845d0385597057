//! Verification views of an NC program, from its lowered segments without running motion:
//! [`toolpath`] collects the path (lines, arcs, helices, taps, cycles expanded) in work or
//! machine coordinates with the block of every piece; [`which`] finds the blocks nearest a
//! point; [`page`] writes the self-contained toolpath page; [`breaks`] resolves breakpoints
//! against the program; [`trace`] reads a run's `--trace` CSV for the page's overlay.

pub mod breaks;
pub mod geom;
pub mod page;
pub mod source;
pub mod toolpath;
pub mod trace;
pub mod which;

pub use toolpath::{Frame, Piece, PieceKind, Toolpath};
