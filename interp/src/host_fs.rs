//! The file-system implementations of the [`crate::host`] traits, for binaries to construct and
//! inject: [`FsLibrary`] (programs and `#use` files from folders), [`ProgramDir`] (one folder of
//! `O<number>` files) and [`FileVarStore`] (the durable variables file). The interpreter never
//! constructs these itself: its defaults do no I/O.

use std::path::{Path, PathBuf};

use cnc402_config::MachineConfig;
use cnc402_lang::SourceFile;

use crate::block::Options;
use crate::flow::Interpreter;
use crate::host::{PersistentVars, ProgramLibrary, UsedFile};
use crate::vars::nv::{self, NV_FIRST, NV_LAST, NvTable, VarFileError};

/// Extensions a program file may have (compared case-insensitively); the config checks
/// `[mcodes]` macro targets by the same rule.
pub use cnc402_config::PROGRAM_EXTENSIONS;

/// A directory of program files named after their number: `O9001.CNC`, `o9001.nc`, `O1.nc`
/// (with or without leading zeros to four digits), extension case-insensitive. As a
/// [`ProgramLibrary`] it finds programs in this folder only and resolves no `#use`.
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
        cnc402_config::program_file(&self.dir, number)
    }

    /// Program `number`'s file, read (`Ok(None)`: the folder has none).
    pub fn read(&self, number: u32) -> Result<Option<SourceFile>, String> {
        let Some(p) = self.path_of(number)? else {
            return Ok(None);
        };
        read_source(&p).map(Some)
    }
}

fn read_source(p: &Path) -> Result<SourceFile, String> {
    let bytes = std::fs::read(p).map_err(|e| format!("{}: {e}", p.display()))?;
    Ok(SourceFile::from_bytes(p.display().to_string(), bytes))
}

impl ProgramLibrary for ProgramDir {
    fn find(&mut self, number: u32, _main: &str) -> Result<Option<SourceFile>, String> {
        self.read(number)
    }

    fn resolve_use(&mut self, _path: &str, _including: &str) -> Result<Option<UsedFile>, String> {
        Ok(None)
    }

    fn describe(&self) -> String {
        format!("in the program directory {}", self.dir.display())
    }
}

/// Programs and `#use` files from the file system, the way `cnc402 run` and `cnc402 segments`
/// find them: `O<number>` in the main program's folder, then in `program_dir`; `#use "f"` next
/// to the including file, then in `library_dir`.
#[derive(Clone, Debug, Default)]
pub struct FsLibrary {
    pub program_dir: Option<PathBuf>,
    pub library_dir: Option<PathBuf>,
}

impl FsLibrary {
    /// The config's `interp.program_dir` and `interp.library_dir` (resolved against the config
    /// file's folder).
    pub fn from_config(cfg: &MachineConfig) -> Self {
        FsLibrary {
            program_dir: Some(cfg.program_dir()),
            library_dir: cfg.library_dir(),
        }
    }
}

fn canonical(p: &Path) -> String {
    std::fs::canonicalize(p)
        .unwrap_or_else(|_| p.to_path_buf())
        .display()
        .to_string()
}

/// The folder of the file named `name` (`None` for a bare name: the caller decides).
fn folder_of(name: &str) -> Option<PathBuf> {
    Path::new(name)
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .map(Path::to_path_buf)
}

impl ProgramLibrary for FsLibrary {
    fn find(&mut self, number: u32, main: &str) -> Result<Option<SourceFile>, String> {
        // A bare name (`m.nc`) is in the working directory: its folder is `.`, not none.
        let here = folder_of(main).unwrap_or_else(|| PathBuf::from("."));
        if let Some(f) = ProgramDir::new(here).read(number)? {
            return Ok(Some(f));
        }
        match &self.program_dir {
            Some(d) => ProgramDir::new(d).read(number),
            None => Ok(None),
        }
    }

    fn resolve_use(&mut self, path: &str, including: &str) -> Result<Option<UsedFile>, String> {
        let here = folder_of(including).unwrap_or_default();
        let mut candidates = vec![here.join(path)];
        if let Some(lib) = &self.library_dir {
            candidates.push(lib.join(path));
        }
        let Some(p) = candidates.iter().find(|c| c.is_file()) else {
            return Ok(None);
        };
        Ok(Some(UsedFile {
            key: canonical(p),
            file: read_source(p).map_err(|e| format!("#use \"{path}\": {e}"))?,
        }))
    }

    fn key_of(&mut self, name: &str) -> String {
        canonical(Path::new(name))
    }

    fn describe(&self) -> String {
        let mut s = "next to the main program".to_string();
        if let Some(d) = &self.program_dir {
            s += &format!(" or in the program directory {}", d.display());
        }
        if let Some(d) = &self.library_dir {
            s += &format!(" (#use: or in the library folder {})", d.display());
        }
        s
    }
}

/// The interpreter's [`PersistentVars`] on a file, shared with other writers (`cnc402 vars
/// set` during a run, another run): each store is an [`nv::update`] that writes only the
/// variables this program changed since the store last read or wrote them, merged into the
/// file as it is now. A variable written from outside meanwhile keeps the outside value
/// unless the program writes it again (per variable, the last writer wins); the program sees
/// outside values when the table is read again (at the resume of a program stop).
#[derive(Clone, Debug)]
pub struct FileVarStore {
    pub path: PathBuf,
    /// The table as the program last gave it to this store (or as opened): what it has
    /// changed since is what differs from this.
    seen: NvTable,
}

impl FileVarStore {
    /// Opens the store and reads its table (missing file: empty; damaged: error).
    pub fn open(path: impl Into<PathBuf>) -> Result<(Self, NvTable), VarFileError> {
        let path = path.into();
        let t = NvTable::load(&path)?;
        Ok((
            FileVarStore {
                path,
                seen: t.clone(),
            },
            t,
        ))
    }

    /// Merges into the file the variables of `vars` that differ from what this store last
    /// saw, and `#written` if given (a write of an unchanged value still wins).
    fn merge(&mut self, written: Option<u32>, vars: &[Option<f64>]) -> Result<(), String> {
        let now = NvTable::from_slice(vars);
        let same = |a: Option<f64>, b: Option<f64>| a.map(f64::to_bits) == b.map(f64::to_bits);
        let changed: Vec<(u32, Option<f64>)> = (NV_FIRST..=NV_LAST)
            .filter(|&n| Some(n) == written || !same(now.get(n), self.seen.get(n)))
            .map(|n| (n, now.get(n)))
            .collect();
        nv::set_vars(&self.path, &changed).map_err(|e| e.to_string())?;
        self.seen = now;
        Ok(())
    }
}

impl PersistentVars for FileVarStore {
    fn store(&mut self, vars: &[Option<f64>]) -> Result<(), String> {
        self.merge(None, vars)
    }

    fn store_write(&mut self, n: u32, vars: &[Option<f64>]) -> Result<(), String> {
        self.merge(Some(n), vars)
    }
}

/// How a run may use the config's variables file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VarsAccess {
    /// Read at start, every write stored durably (`cnc402 run`).
    Write,
    /// Read at start, writes stay in memory (`cnc402 segments`, dry runs): repeatable.
    ReadOnly,
}

/// Gives `it` the non-volatile variables of the config's `interp.variables_file` (nothing if
/// the config names none). A damaged file is not an error here: it becomes the first
/// `next_segment` error of every program `it` loads, at the main file. With
/// [`VarsAccess::Write`] the start also removes temporary files a writer killed mid-save left
/// (see [`nv::WriteLock::acquire`]).
pub fn attach_variables_file(it: &mut Interpreter, cfg: &MachineConfig, access: VarsAccess) {
    let Some(path) = cfg.variables_file() else {
        return;
    };
    if access == VarsAccess::Write {
        // Best effort: a folder where the lock cannot be taken fails the program's first
        // write with that error at its line; a program that writes nothing must still run.
        drop(nv::WriteLock::acquire(&path));
    }
    match FileVarStore::open(&path) {
        Ok((store, table)) => {
            let store: Option<Box<dyn PersistentVars>> = match access {
                VarsAccess::Write => Some(Box::new(store)),
                VarsAccess::ReadOnly => None,
            };
            it.set_persistent_vars(table, store);
        }
        Err(e) => it.set_persistent_vars_error(e.to_string()),
    }
}

/// An interpreter for `cfg` with the file system injected: [`FsLibrary::from_config`] and the
/// variables file with `access`. What the `cnc402` binaries use.
pub fn interpreter(cfg: &MachineConfig, opts: Options, access: VarsAccess) -> Interpreter {
    let mut it = Interpreter::with_options(cfg, opts);
    it.set_program_library(Some(Box::new(FsLibrary::from_config(cfg))));
    attach_variables_file(&mut it, cfg, access);
    it
}

/// [`crate::run_program`] with the file system injected, variables read-only (for tests and
/// tools that run a program file: sub-programs and `#use` files are found next to it).
pub fn run_program(
    cfg: &MachineConfig,
    src: &SourceFile,
) -> Result<Vec<cnc402_motion::segment::Segment>, cnc402_lang::NcError> {
    let program = crate::flow::parse_program(cfg, src, None)?;
    let mut it = interpreter(cfg, Options::default(), VarsAccess::ReadOnly);
    it.load(src.clone(), program);
    it.collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fresh_file(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("cnc402-host-fs-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir.join("vars.txt")
    }

    /// Steps `it` until the `nth` dwell (1-based) has been given out.
    fn to_dwell(it: &mut Interpreter, nth: usize) {
        let mut seen = 0;
        while seen < nth {
            let seg = it.next_segment().unwrap().expect("program ended early");
            if matches!(seg.kind, cnc402_motion::segment::SegmentKind::Dwell { .. }) {
                seen += 1;
            }
        }
    }

    #[test]
    fn vars_set_during_a_run_is_not_overwritten_by_the_runs_next_save() {
        let path = fresh_file("merge");
        nv::set_vars(&path, &[(510, Some(5.0))]).unwrap();
        let mut cfg = MachineConfig::default_machine();
        cfg.interp.variables_file = Some(path.clone());
        let mut it = Interpreter::new(&cfg);
        attach_variables_file(&mut it, &cfg, VarsAccess::Write);
        // The program writes #500 between dwells and re-writes #503 with the value it holds.
        let text = "#500=1\n#503=4\nG4 P10\n#500=2\nG4 P10\n#500=3\n#503=#503\nG4 P10\nM30\n";
        let src = SourceFile::new("p.nc", text);
        it.load(src.clone(), cnc402_lang::parse(&src).unwrap());
        to_dwell(&mut it, 1);
        // The operator, while the program runs: a variable the program never writes, one it
        // writes again later (#500: the program's later write wins) and one it writes again
        // with the value it already had (#503: still the program's, the last writer).
        let at_set = nv::set_vars(
            &path,
            &[(501, Some(7.0)), (500, Some(99.0)), (503, Some(8.0))],
        )
        .unwrap();
        assert!(at_set.get(500) == Some(99.0), "{at_set:?}");
        while it.next_segment().unwrap().is_some() {}
        let t = NvTable::load(&path).unwrap();
        let got: Vec<_> = t.iter().collect();
        assert_eq!(got, [(500, 3.0), (501, 7.0), (503, 4.0), (510, 5.0)]);
        // What the operator set is what the program reads once the table is read again.
        assert_eq!(it.var(501), None, "not seen before a re-read");
        std::fs::remove_dir_all(path.parent().unwrap()).unwrap();
    }

    #[test]
    fn a_store_of_the_whole_table_keeps_outside_values_the_program_did_not_change() {
        let path = fresh_file("untouched");
        nv::set_vars(&path, &[(520, Some(1.0))]).unwrap();
        let (mut store, _) = FileVarStore::open(&path).unwrap();
        nv::set_vars(&path, &[(521, Some(2.0))]).unwrap();
        // The store's table still has #521 vacant: unchanged, so the outside value stays.
        let mut vars = vec![None; (NV_LAST - NV_FIRST + 1) as usize];
        vars[20] = Some(1.0);
        store.store(&vars).unwrap();
        let t = NvTable::load(&path).unwrap();
        assert_eq!((t.get(520), t.get(521)), (Some(1.0), Some(2.0)));
        std::fs::remove_dir_all(path.parent().unwrap()).unwrap();
    }
}
