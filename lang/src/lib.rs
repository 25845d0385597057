//! NC program parser: ISO 7-bit / DIN 66025 text to the AST in [`ast`], with byte spans.
//! [`diag`] holds program locations and [`NcError`], the error type every layer reuses.

pub mod ast;
pub mod diag;

pub use diag::{NcError, SourceFile};
