//! What the interpreter needs from the machine around it, as traits: motion sync for position
//! variables ([`MotionSync`]), program and `#use` file lookup ([`ProgramLibrary`]) and durable
//! non-volatile variables ([`PersistentVars`]). The interpreter's defaults do no I/O: exact
//! stop, no library, variables in memory. File-system implementations: [`crate::host_fs`].

pub mod channels;

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

/// Where programs come from besides the running file: `M98 P9001` / `G65 P9001` look up
/// `O9001` here, and a C-like `#use "cycles.c"` names a file resolved here. The interpreter has
/// none by default (every lookup fails); [`crate::host_fs::FsLibrary`] is the file system's.
pub trait ProgramLibrary: Send {
    /// The file holding program `O<number>`, `Ok(None)` if there is none. `main` is the name
    /// of the main program's file (a file-system library searches its folder first).
    fn find(&mut self, number: u32, main: &str) -> Result<Option<SourceFile>, String>;

    /// The file that `#use "path"` in the file named `including` means, `Ok(None)` if there is
    /// none. The key identifies the file (two `#use`s with the same key load it once).
    fn resolve_use(&mut self, path: &str, including: &str) -> Result<Option<UsedFile>, String>;

    /// The identity of the file named `name` (as [`UsedFile::key`]), so that a `#use` of the
    /// main program itself is seen as a cycle. Default: the name.
    fn key_of(&mut self, name: &str) -> String {
        name.to_string()
    }

    /// Where this library looks, for not-found messages (e.g. "next to it or in the program
    /// directory /srv/nc").
    fn describe(&self) -> String;
}

/// A file found for `#use`: its identity (a canonical path for files) and its text.
#[derive(Clone, Debug)]
pub struct UsedFile {
    pub key: String,
    pub file: SourceFile,
}

/// Makes the non-volatile variables `#500–#999` durable.
pub trait PersistentVars: Send {
    /// Stores the whole table (`vars[0]` is `#500`); returns only when the values would
    /// survive a power cut. An `Err` stops the program at the writing line.
    fn store(&mut self, vars: &[Option<f64>]) -> Result<(), String>;

    /// Stores the table after the program wrote `#n` (even a write of the value it already
    /// had: for a store shared with other writers, such as the variables file, that write is
    /// the newest and must win). Default: [`store`](Self::store).
    fn store_write(&mut self, n: u32, vars: &[Option<f64>]) -> Result<(), String> {
        let _ = n;
        self.store(vars)
    }
}
