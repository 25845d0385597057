//! NC program parser: ISO 7-bit / DIN 66025 text to the AST in [`ast`], with byte spans.

pub mod ast;
