//! The non-volatile macro variables `#500–#999` in a text file with a CRC-32. [`NvTable`] is the
//! table; [`crate::host_fs::FileVarStore`] plugs it into the interpreter.
//!
//! Durability: a write goes to `.<name>.tmp<pid>` beside the file, is fsynced, renamed over
//! the file, and the directory is fsynced, so a crash or `kill -9` at any instant leaves the
//! old or the new file, never a torn one; a damaged file is an error at load, never silent
//! zeros. A crash between create and rename leaves the temporary file behind: the next writer
//! removes such files (only names of that pattern, only beside this file) once it holds the
//! lock, when no other writer can be between create and rename.
//!
//! One writer at a time: every write is a read-modify-write under an exclusive advisory lock
//! (`flock`, [`std::fs::File::lock`]) on `.<name>.lock` beside the file, across processes
//! ([`WriteLock`]). Each writer re-reads the file under the lock and changes only its own
//! variables, so writers of different variables never lose each other's values; for one
//! variable the last writer wins. Readers take no lock: the rename makes every read see a
//! whole file. The lock file is never removed (removing it would let two writers lock two
//! different files).

use std::fmt;
use std::fs::{self, File, OpenOptions};
use std::path::{Path, PathBuf};

use cnc402_durable::{StaleRule, dir_and_name, remove_stale_temps};

/// First non-volatile variable number.
pub const NV_FIRST: u32 = 500;
/// Last non-volatile variable number.
pub const NV_LAST: u32 = 999;
const NV_COUNT: usize = (NV_LAST - NV_FIRST + 1) as usize;
const MAGIC: &str = "cnc402-vars 1";

/// `#500–#999`; `None` is vacant.
#[derive(Clone, Debug, PartialEq)]
pub struct NvTable {
    vals: Box<[Option<f64>; NV_COUNT]>,
}

impl Default for NvTable {
    fn default() -> Self {
        NvTable {
            vals: Box::new([None; NV_COUNT]),
        }
    }
}

/// Why the variables file could not be read or written.
#[derive(Debug)]
pub enum VarFileError {
    Io {
        path: PathBuf,
        err: std::io::Error,
    },
    /// The file exists but is not a valid table (checksum, syntax); `line` 0 = whole file.
    Damaged {
        path: PathBuf,
        line: usize,
        why: String,
    },
    /// A variable number outside `#500–#999`.
    NotNonVolatile(u32),
}

impl fmt::Display for VarFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            VarFileError::Io { path, err } => write!(f, "variables file {}: {err}", path.display()),
            VarFileError::Damaged { path, line: 0, why } => write!(
                f,
                "variables file {} is damaged: {why} (restore it from a backup or clear it with `cnc402 vars clear`)",
                path.display()
            ),
            VarFileError::Damaged { path, line, why } => write!(
                f,
                "variables file {}:{line} is damaged: {why} (restore it from a backup or clear it with `cnc402 vars clear`)",
                path.display()
            ),
            VarFileError::NotNonVolatile(n) => write!(
                f,
                "#{n} is not a non-volatile variable (#{NV_FIRST}..#{NV_LAST})"
            ),
        }
    }
}

impl std::error::Error for VarFileError {}

impl NvTable {
    /// `#n`, `None` when vacant or not a non-volatile number.
    pub fn get(&self, n: u32) -> Option<f64> {
        Self::index(n).and_then(|i| self.vals[i])
    }

    /// Sets `#n` (`None` makes it vacant).
    pub fn set(&mut self, n: u32, v: Option<f64>) -> Result<(), VarFileError> {
        let i = Self::index(n).ok_or(VarFileError::NotNonVolatile(n))?;
        self.vals[i] = v;
        Ok(())
    }

    fn index(n: u32) -> Option<usize> {
        (NV_FIRST..=NV_LAST)
            .contains(&n)
            .then(|| (n - NV_FIRST) as usize)
    }

    /// The whole table, `[0]` is `#500`.
    pub fn as_slice(&self) -> &[Option<f64>] {
        &self.vals[..]
    }

    /// A table from a slice as given to [`crate::host::PersistentVars::store`].
    pub fn from_slice(vals: &[Option<f64>]) -> Self {
        let mut t = NvTable::default();
        for (d, s) in t.vals.iter_mut().zip(vals) {
            *d = *s;
        }
        t
    }

    /// The set variables, in order.
    pub fn iter(&self) -> impl Iterator<Item = (u32, f64)> + '_ {
        self.vals
            .iter()
            .enumerate()
            .filter_map(|(i, v)| v.map(|v| (NV_FIRST + i as u32, v)))
    }

    /// The file text: magic line, `n value` lines, `crc32 xxxxxxxx` over everything before it.
    pub fn to_text(&self) -> String {
        let mut s = format!("{MAGIC}\n");
        for (n, v) in self.iter() {
            // `{:?}` of f64 prints the shortest text that reads back to the same bits.
            s.push_str(&format!("{n} {v:?}\n"));
        }
        let c = crc32(s.as_bytes());
        s.push_str(&format!("crc32 {c:08x}\n"));
        s
    }

    /// Parses [`to_text`](Self::to_text)'s format; any damage is an error naming the line.
    pub fn from_text(path: &Path, text: &str) -> Result<Self, VarFileError> {
        let damaged = |line: usize, why: String| VarFileError::Damaged {
            path: path.to_path_buf(),
            line,
            why,
        };
        let body_end = text
            .rfind("crc32 ")
            .filter(|&i| i == 0 || text.as_bytes()[i - 1] == b'\n')
            .ok_or_else(|| damaged(0, "no checksum line (the file is cut short)".into()))?;
        let (body, tail) = text.split_at(body_end);
        let want = tail
            .strip_prefix("crc32 ")
            .and_then(|t| t.strip_suffix('\n'))
            .and_then(|h| u32::from_str_radix(h, 16).ok())
            .ok_or_else(|| damaged(0, "malformed checksum line".into()))?;
        let got = crc32(body.as_bytes());
        if got != want {
            return Err(damaged(
                0,
                format!("checksum mismatch (file says {want:08x}, contents give {got:08x})"),
            ));
        }
        let mut lines = body.lines().enumerate();
        match lines.next() {
            Some((_, l)) if l == MAGIC => {}
            _ => return Err(damaged(1, format!("first line is not `{MAGIC}`"))),
        }
        let mut t = NvTable::default();
        for (i, l) in lines {
            let bad = || damaged(i + 1, format!("expected `number value`, found {l:?}"));
            let (n, v) = l.split_once(' ').ok_or_else(bad)?;
            let n: u32 = n.parse().map_err(|_| bad())?;
            let v: f64 = v.parse().map_err(|_| bad())?;
            if !v.is_finite() {
                return Err(bad());
            }
            t.set(n, Some(v))
                .map_err(|e| damaged(i + 1, e.to_string()))?;
        }
        Ok(t)
    }

    /// Reads `path`; a missing file is an empty table (a new machine), a damaged one an error.
    pub fn load(path: &Path) -> Result<Self, VarFileError> {
        let io = |err| VarFileError::Io {
            path: path.to_path_buf(),
            err,
        };
        match fs::read(path) {
            Ok(b) => {
                let text = String::from_utf8(b).map_err(|_| VarFileError::Damaged {
                    path: path.to_path_buf(),
                    line: 0,
                    why: "not UTF-8 text".into(),
                })?;
                Self::from_text(path, &text)
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(NvTable::default()),
            Err(e) => Err(io(e)),
        }
    }

    /// Replaces the whole file at `path` with this table, under the [`WriteLock`], durably
    /// (returns when the new contents would survive a power cut). To change some variables and
    /// keep the others use [`update`].
    pub fn save(&self, path: &Path) -> Result<(), VarFileError> {
        let _lock = WriteLock::acquire(path)?;
        self.write_durably(path)
    }

    /// Temporary file, fsync, rename over `path`, fsync the directory
    /// ([`cnc402_durable::write_atomic`]). The caller holds the [`WriteLock`].
    fn write_durably(&self, path: &Path) -> Result<(), VarFileError> {
        cnc402_durable::write_atomic(path, self.to_text().as_bytes()).map_err(|err| {
            VarFileError::Io {
                path: path.to_path_buf(),
                err,
            }
        })
    }
}

/// True for the name of a temporary file of the variables file `name`: `.<name>.tmp<digits>`.
pub fn is_temp_file_of(name: &str, candidate: &str) -> bool {
    cnc402_durable::temp_file_pid(name, candidate).is_some()
}

/// The exclusive right to write the variables file: an advisory lock (`flock`) on
/// `.<name>.lock` beside it, held until dropped (the kernel also drops it when the process
/// dies, `kill -9` included). Acquiring waits for the current writer, whose hold lasts one
/// read, one write and two fsyncs. Locks are per open file, so two threads with their own
/// `WriteLock`s exclude each other too; taking a second one in a thread that holds one
/// would wait forever, which is why only this module takes them.
#[derive(Debug)]
pub struct WriteLock {
    _file: File,
}

impl WriteLock {
    /// Waits for and takes the lock of the variables file `path`, then removes the
    /// temporary files a writer killed mid-save left behind (none can be in use now).
    pub fn acquire(path: &Path) -> Result<WriteLock, VarFileError> {
        let (dir, name) = dir_and_name(path);
        let lock_path = dir.join(format!(".{name}.lock"));
        let io = |err| VarFileError::Io {
            path: lock_path.clone(),
            err,
        };
        // The first write creates the file's folder too (a fresh config's `var/`).
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(&dir).map_err(|err| VarFileError::Io {
                path: dir.clone(),
                err,
            })?;
        }
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&lock_path)
            .map_err(io)?;
        file.lock().map_err(io)?;
        // Under the lock no other writer is between create and rename: every temp is stale.
        remove_stale_temps(&dir, &name, StaleRule::All).map_err(|err| VarFileError::Io {
            path: dir.clone(),
            err,
        })?;
        Ok(WriteLock { _file: file })
    }
}

/// The read-modify-write behind every change of the file: under the [`WriteLock`], reads the
/// file as it is now (a missing file is an empty table), applies `change`, writes durably.
/// Variables `change` does not touch keep what other writers gave them. Nothing is written
/// if `change` fails.
pub fn update(
    path: &Path,
    change: impl FnOnce(&mut NvTable) -> Result<(), VarFileError>,
) -> Result<NvTable, VarFileError> {
    let _lock = WriteLock::acquire(path)?;
    let mut t = NvTable::load(path)?;
    change(&mut t)?;
    t.write_durably(path)?;
    Ok(t)
}

/// Sets variables in the file at `path` ([`update`]): the library call behind
/// `cnc402 vars set 520=3 521=800`. Nothing is written if any number is out of range.
pub fn set_vars(path: &Path, sets: &[(u32, Option<f64>)]) -> Result<NvTable, VarFileError> {
    update(path, |t| {
        for &(n, v) in sets {
            t.set(n, v)?;
        }
        Ok(())
    })
}

/// Makes `#from..=#to` vacant in the file (`cnc402 vars clear [N..M]`). A damaged file can be
/// cleared as a whole (`from..=to` covering 500..=999) without reading it.
pub fn clear_vars(path: &Path, from: u32, to: u32) -> Result<NvTable, VarFileError> {
    for n in [from, to] {
        if NvTable::index(n).is_none() {
            return Err(VarFileError::NotNonVolatile(n));
        }
    }
    if from <= NV_FIRST && to >= NV_LAST {
        let t = NvTable::default();
        t.save(path)?;
        return Ok(t);
    }
    update(path, |t| {
        for n in from..=to {
            t.set(n, None)?;
        }
        Ok(())
    })
}

/// CRC-32 (IEEE 802.3, reflected, as zlib's `crc32`). Written out (twenty lines) rather than a
/// dependency: it checks a few kilobytes at start and on each write.
pub fn crc32(data: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in data {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                (c >> 1) ^ 0xEDB8_8320
            } else {
                c >> 1
            };
        }
    }
    !c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc32_check_value() {
        // The standard check value of CRC-32/ISO-HDLC.
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn round_trip_and_damage_detection() {
        let p = Path::new("v.txt");
        let mut t = NvTable::default();
        t.set(520, Some(3.0)).unwrap();
        t.set(999, Some(-0.1)).unwrap();
        t.set(500, Some(1e-300)).unwrap();
        let text = t.to_text();
        assert_eq!(NvTable::from_text(p, &text).unwrap(), t);
        // Every single-byte change and every truncation is detected.
        for i in 0..text.len() {
            let mut b = text.clone().into_bytes();
            b[i] ^= 0x01;
            if let Ok(s) = String::from_utf8(b) {
                assert!(NvTable::from_text(p, &s).is_err(), "flip at {i}");
            }
            assert!(NvTable::from_text(p, &text[..i]).is_err(), "cut at {i}");
        }
        assert!(t.set(499, Some(1.0)).is_err());
        assert!(t.set(1000, Some(1.0)).is_err());
    }

    #[test]
    fn save_load_set_clear_on_disk() {
        let dir = std::env::temp_dir().join(format!("cnc402-nv-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let p = dir.join("vars.txt");
        let _ = fs::remove_file(&p);
        assert_eq!(NvTable::load(&p).unwrap(), NvTable::default());
        set_vars(&p, &[(520, Some(3.0)), (521, Some(800.0))]).unwrap();
        let t = NvTable::load(&p).unwrap();
        assert_eq!(
            (t.get(520), t.get(521), t.get(522)),
            (Some(3.0), Some(800.0), None)
        );
        clear_vars(&p, 521, 530).unwrap();
        let t = NvTable::load(&p).unwrap();
        assert_eq!((t.get(520), t.get(521)), (Some(3.0), None));
        fs::write(&p, "cnc402-vars 1\n520 3\ncrc32 00000000\n").unwrap();
        let e = NvTable::load(&p).unwrap_err().to_string();
        assert!(e.contains("checksum mismatch"), "{e}");
        clear_vars(&p, 500, 999).unwrap();
        assert_eq!(NvTable::load(&p).unwrap(), NvTable::default());
        fs::remove_dir_all(&dir).unwrap();
    }

    fn fresh_dir(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("cnc402-nv-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn concurrent_set_vars_of_different_variables_lose_none() {
        // Each thread opens its own lock file handle (flock is per open file), as separate
        // processes would; tests/vars_cli.rs does the same with `cnc402 vars set` processes.
        let dir = fresh_dir("threads");
        let p = dir.join("vars.txt");
        const WRITERS: u32 = 4;
        const SETS: u32 = 40;
        std::thread::scope(|s| {
            for w in 0..WRITERS {
                let p = &p;
                s.spawn(move || {
                    for i in 1..=SETS {
                        set_vars(p, &[(500 + w, Some(f64::from(i)))]).unwrap();
                    }
                });
            }
        });
        let t = NvTable::load(&p).unwrap();
        for w in 0..WRITERS {
            assert_eq!(t.get(500 + w), Some(f64::from(SETS)), "#{}", 500 + w);
        }
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn stale_temp_files_are_removed_by_the_next_writer_and_nothing_else() {
        let dir = fresh_dir("stale");
        let p = dir.join("vars.txt");
        let stale = [".vars.txt.tmp123", ".vars.txt.tmp7"];
        let others = [
            ".vars.txt.tmp",
            ".vars.txt.tmpx1",
            "vars.txt.tmp5",
            ".other.txt.tmp5",
            ".vars.txt.lock2",
        ];
        for f in stale.iter().chain(&others) {
            fs::write(dir.join(f), "x").unwrap();
        }
        set_vars(&p, &[(500, Some(1.0))]).unwrap();
        for f in stale {
            assert!(!dir.join(f).exists(), "{f} left");
        }
        for f in others {
            assert!(dir.join(f).exists(), "{f} removed");
        }
        assert!(is_temp_file_of("v", ".v.tmp0"));
        assert!(!is_temp_file_of("v", ".v.tmp0a"));
        fs::remove_dir_all(&dir).unwrap();
    }
}
