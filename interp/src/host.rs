//! What the interpreter needs from the machine around it, as traits: motion sync for position
//! variables ([`MotionSync`]), sub-program lookup ([`ProgramLibrary`], default: the config's
//! `program_dir`) and durable non-volatile variables ([`PersistentVars`], see [`crate::nvfile`]).
//! The defaults keep `cnc402 segments` pure: exact stop means the programmed end is the actual.

use std::path::{Path, PathBuf};

use cnc402_lang::SourceFile;
use cnc402_motion::segment::AxisPos;

/// The interpreter runs ahead of motion; reading `#5021…` / `#5041…` (actual positions) is a
/// sync point where it calls [`wait_motion_done`](Self::wait_motion_done). Every segment
/// produced before the read has already been handed out by `next_segment` when it is called.
pub trait MotionSync: Send {
    /// Blocks until all motion handed out so far has been executed and returns the actual
    /// machine position of every axis. `programmed` is the interpreter's own end position (what
    /// an exact-stop machine reaches). An `Err` ends the program with the message at the line
    /// that read the variable.
    fn wait_motion_done(&mut self, programmed: &AxisPos) -> Result<AxisPos, String>;

    /// The path length (mm, linear axes; arcs along the arc) executed so far. `produced` is the
    /// length of all segments the interpreter has produced, which the default returns.
    fn path_length_done(&mut self, produced: f64) -> f64 {
        produced
    }
}

/// The default sync: no motion runs, the programmed position is the actual one.
#[derive(Clone, Copy, Debug, Default)]
pub struct ExactStop;

impl MotionSync for ExactStop {
    fn wait_motion_done(&mut self, programmed: &AxisPos) -> Result<AxisPos, String> {
        Ok(*programmed)
    }
}

/// Where `M98 P9001` / `G65 P9001` find `O9001` when the running file does not hold it.
pub trait ProgramLibrary: Send {
    /// The file holding program `O<number>`, `Ok(None)` if there is none.
    fn find(&mut self, number: u32) -> Result<Option<SourceFile>, String>;
}

/// Extensions a program file may have (compared case-insensitively).
pub const PROGRAM_EXTENSIONS: &[&str] = &["nc", "cnc", "ngc", "tap", "txt", "mpf", "spf"];

/// A directory of program files named after their number: `O9001.CNC`, `o9001.nc`, `O1.nc`
/// (with or without leading zeros to four digits), extension case-insensitive.
#[derive(Clone, Debug)]
pub struct ProgramDir {
    pub dir: PathBuf,
}

impl ProgramDir {
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        ProgramDir { dir: dir.into() }
    }

    /// The path of program `number`'s file, if the directory has one.
    pub fn path_of(&self, number: u32) -> Result<Option<PathBuf>, String> {
        let names = [format!("o{number:04}"), format!("o{number}")];
        let rd = match std::fs::read_dir(&self.dir) {
            Ok(rd) => rd,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(format!("program directory {}: {e}", self.dir.display())),
        };
        let mut found: Vec<PathBuf> = Vec::new();
        for ent in rd.flatten() {
            let p = ent.path();
            if matches_name(&p, &names) {
                found.push(p);
            }
        }
        found.sort();
        Ok(found.into_iter().next())
    }
}

fn matches_name(p: &Path, names: &[String]) -> bool {
    let (Some(stem), Some(ext)) = (
        p.file_stem().and_then(|s| s.to_str()),
        p.extension().and_then(|s| s.to_str()),
    ) else {
        return false;
    };
    names.iter().any(|n| stem.eq_ignore_ascii_case(n))
        && PROGRAM_EXTENSIONS
            .iter()
            .any(|e| ext.eq_ignore_ascii_case(e))
}

impl ProgramLibrary for ProgramDir {
    fn find(&mut self, number: u32) -> Result<Option<SourceFile>, String> {
        let Some(p) = self.path_of(number)? else {
            return Ok(None);
        };
        let bytes = std::fs::read(&p).map_err(|e| format!("{}: {e}", p.display()))?;
        let text = String::from_utf8_lossy(&bytes).into_owned();
        Ok(Some(SourceFile::new(p.display().to_string(), text)))
    }
}

/// Makes the non-volatile variables `#500–#999` durable.
pub trait PersistentVars: Send {
    /// Stores the whole table (`vars[0]` is `#500`); returns only when the values would
    /// survive a power cut. An `Err` stops the program at the writing line.
    fn store(&mut self, vars: &[Option<f64>]) -> Result<(), String>;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn program_files_match_case_insensitively() {
        let n = |s: &str| matches_name(Path::new(s), &["o9001".into(), "o9001".into()]);
        assert!(n("/x/O9001.CNC"));
        assert!(n("/x/o9001.nc"));
        assert!(n("O9001.Nc"));
        assert!(!n("O9001"));
        assert!(!n("O9001.bak"));
        assert!(!n("O90011.nc"));
    }
}
