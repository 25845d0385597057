//! NC program parser: ISO 7-bit / DIN 66025 text to the AST in [`ast`], with byte spans.
//! [`parse`] reads a whole program; [`diag`] holds program locations and [`NcError`], the
//! error type every layer reuses.

pub mod ast;
pub mod diag;
pub mod dialect;
pub mod heidenhain;
mod parse;
pub mod plain;
pub mod stream;

pub use diag::{NcError, NcErrorFields, SourceFile};
pub use dialect::Dialect;
pub use parse::{
    HEADER_LINES, MAX_HEIGHT, choose_dialect, declared_dialect, parse, parse_expr, parse_in,
};
