//! The text of the blocks a toolpath names, read from the files the interpreter read (the
//! main program, sub-programs, `#use` files), each file once.

use std::collections::HashMap;

use cnc402_lang::SourceFile;

/// Files read by name, kept for the next block of the same file.
#[derive(Default)]
pub struct SourceText {
    files: HashMap<String, Option<SourceFile>>,
}

impl SourceText {
    /// Uses `src` for its file name instead of reading the file again.
    pub fn insert(&mut self, src: SourceFile) {
        self.files.insert(src.name.to_string(), Some(src));
    }

    /// The text of `line` (1-based) of the file named `file`, trimmed; empty when the file
    /// cannot be read (it was read a moment ago by the interpreter, so rarely).
    pub fn line(&mut self, file: &str, line: u32) -> String {
        let src = self.files.entry(file.to_string()).or_insert_with(|| {
            std::fs::read(file)
                .ok()
                .map(|b| SourceFile::from_bytes(file.to_string(), b))
        });
        match src {
            Some(s) if line >= 1 && line <= s.line_count() => s.line_text(line).trim().to_string(),
            _ => String::new(),
        }
    }
}
