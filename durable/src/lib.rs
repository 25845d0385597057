//! Crash-safe writes for every file the project writes (run reports, traces, plots, the
//! variables file, simdrive reports, fuzz findings): the new contents go to a temporary file
//! beside the target, are fsynced, renamed over it and the folder is fsynced. A reader — after
//! a `kill -9` or a power cut at any instant — sees the old whole file or the new whole file,
//! never a torn one. Temporary files a killed writer left behind are removed by the next one.

use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// What follows `.<name>` in a temporary file's name, before the writer's process id.
pub const TEMP_INFIX: &str = ".tmp";

/// Most directory entries one stale-temp sweep looks at: a folder of a million files is not
/// scanned whole on every write (the sweep is housekeeping, the next writer goes on).
const MAX_SWEEP_ENTRIES: usize = 100_000;

/// Replaces `path` with `bytes`, durably: returns when the new contents would survive a power
/// cut; until then (and if it fails) `path` keeps its old contents.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes)?;
    f.commit()
}

/// A file written in full under a temporary name and put in place by [`commit`](Self::commit)
/// (or, with [`commit_on_drop`](Self::commit_on_drop), when dropped: for a writer handed to
/// code that only knows `Write`). Dropped without a commit, the temporary file is removed
/// and the target is untouched. The temporary name is `.<name>.tmp<pid>` in the target's
/// folder (a rename is atomic only within one file system).
#[derive(Debug)]
pub struct AtomicFile {
    path: PathBuf,
    tmp: PathBuf,
    dir: PathBuf,
    out: Option<BufWriter<File>>,
    commit_on_drop: bool,
}

impl AtomicFile {
    /// Opens the temporary file for `path`, after removing the ones writers that no longer
    /// run left behind.
    pub fn create(path: &Path) -> io::Result<AtomicFile> {
        let (dir, name) = dir_and_name(path);
        let _ = remove_stale_temps(&dir, &name, StaleRule::DeadWriters);
        let tmp = temp_path(&dir, &name);
        let file = File::create(&tmp)?;
        Ok(AtomicFile {
            path: path.to_path_buf(),
            tmp,
            dir,
            out: Some(BufWriter::new(file)),
            commit_on_drop: false,
        })
    }

    /// Commit when dropped (errors then go to stderr): for streams such as the trace, which
    /// are complete when their writer is done with them, whatever way the run ended.
    pub fn commit_on_drop(mut self) -> AtomicFile {
        self.commit_on_drop = true;
        self
    }

    /// The temporary file being written (to watch a stream while it is written).
    pub fn temp_path(&self) -> &Path {
        &self.tmp
    }

    /// Flush, fsync, rename over the target, fsync the folder.
    pub fn commit(mut self) -> io::Result<()> {
        self.commit_now()
    }

    fn commit_now(&mut self) -> io::Result<()> {
        let Some(out) = self.out.take() else {
            return Ok(());
        };
        let result = out
            .into_inner()
            .map_err(|e| e.into_error())
            .and_then(|f| f.sync_all())
            .and_then(|()| fs::rename(&self.tmp, &self.path))
            .and_then(|()| File::open(&self.dir)?.sync_all());
        if result.is_err() {
            let _ = fs::remove_file(&self.tmp);
        }
        result
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match &mut self.out {
            Some(o) => o.write(buf),
            None => Err(io::Error::other("file already committed")),
        }
    }

    /// Flushes into the temporary file (which stays temporary: readers of the target see
    /// the old contents until the commit).
    fn flush(&mut self) -> io::Result<()> {
        match &mut self.out {
            Some(o) => o.flush(),
            None => Ok(()),
        }
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.out.is_none() {
            return;
        }
        if self.commit_on_drop {
            if let Err(e) = self.commit_now() {
                eprintln!("cannot write {}: {e}", self.path.display());
            }
        } else {
            self.out = None;
            let _ = fs::remove_file(&self.tmp);
        }
    }
}

/// The folder of `path` (`.` for a bare name) and its file name.
pub fn dir_and_name(path: &Path) -> (PathBuf, String) {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "file".into());
    (dir, name)
}

/// This process's temporary file for `name` in `dir`: `.<name>.tmp<pid>`.
pub fn temp_path(dir: &Path, name: &str) -> PathBuf {
    dir.join(format!(".{name}{TEMP_INFIX}{}", std::process::id()))
}

/// The writer's process id if `candidate` is a temporary file of `name`
/// (`.<name>.tmp<digits>`).
pub fn temp_file_pid(name: &str, candidate: &str) -> Option<u32> {
    candidate
        .strip_prefix('.')
        .and_then(|c| c.strip_prefix(name))
        .and_then(|c| c.strip_prefix(TEMP_INFIX))
        .filter(|pid| !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit()))
        .and_then(|pid| pid.parse().ok())
}

/// Which temporary files a sweep removes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StaleRule {
    /// Every one: the caller holds a lock that excludes every other writer of the file.
    All,
    /// Those whose writer process no longer runs (nor is this one).
    DeadWriters,
}

/// Removes the temporary files of `name` in `dir` that `rule` names stale; returns how many.
pub fn remove_stale_temps(dir: &Path, name: &str, rule: StaleRule) -> io::Result<usize> {
    let mut removed = 0;
    for ent in fs::read_dir(dir)?.take(MAX_SWEEP_ENTRIES) {
        let ent = ent?;
        let Some(pid) = ent
            .file_name()
            .to_str()
            .and_then(|f| temp_file_pid(name, f))
        else {
            continue;
        };
        let stale = match rule {
            StaleRule::All => true,
            StaleRule::DeadWriters => pid != std::process::id() && !process_runs(pid),
        };
        if stale {
            match fs::remove_file(ent.path()) {
                Ok(()) => removed += 1,
                Err(e) if e.kind() == io::ErrorKind::NotFound => {}
                Err(e) => return Err(e),
            }
        }
    }
    Ok(removed)
}

/// Whether process `pid` runs (Linux: `/proc/<pid>` exists; elsewhere assumed to, so
/// nothing another writer may be using is removed).
fn process_runs(pid: u32) -> bool {
    let proc = Path::new("/proc");
    !proc.join("self").exists() || proc.join(pid.to_string()).exists()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("cnc402-durable-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    fn entries(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn write_atomic_replaces_the_file_and_leaves_no_temp() {
        let d = scratch("replace");
        let p = d.join("r.json");
        write_atomic(&p, b"old").unwrap();
        write_atomic(&p, b"new").unwrap();
        assert_eq!(fs::read(&p).unwrap(), b"new");
        assert_eq!(entries(&d), ["r.json"]);
    }

    #[test]
    fn an_uncommitted_file_leaves_the_target_alone_and_removes_its_temp() {
        let d = scratch("drop");
        let p = d.join("t.csv");
        write_atomic(&p, b"old").unwrap();
        let mut f = AtomicFile::create(&p).unwrap();
        f.write_all(b"half").unwrap();
        f.flush().unwrap();
        assert!(f.temp_path().exists());
        assert_eq!(fs::read(&p).unwrap(), b"old");
        drop(f);
        assert_eq!(fs::read(&p).unwrap(), b"old");
        assert_eq!(entries(&d), ["t.csv"]);
        let mut f = AtomicFile::create(&p).unwrap().commit_on_drop();
        f.write_all(b"whole").unwrap();
        drop(f);
        assert_eq!(fs::read(&p).unwrap(), b"whole");
        assert_eq!(entries(&d), ["t.csv"]);
    }

    #[test]
    fn temps_of_dead_writers_are_removed_and_live_ones_kept() {
        let d = scratch("stale");
        // pid 0 never names a user process; our own pid runs.
        let dead = ".r.json.tmp0";
        let own = format!(".r.json.tmp{}", std::process::id());
        for f in [
            dead,
            own.as_str(),
            ".r.json.tmpx",
            "r.json.tmp5",
            ".q.json.tmp0",
        ] {
            fs::write(d.join(f), "x").unwrap();
        }
        assert_eq!(
            remove_stale_temps(&d, "r.json", StaleRule::DeadWriters).unwrap(),
            1
        );
        assert!(!d.join(dead).exists() && d.join(&own).exists());
        assert_eq!(remove_stale_temps(&d, "r.json", StaleRule::All).unwrap(), 1);
        assert_eq!(entries(&d), [".q.json.tmp0", ".r.json.tmpx", "r.json.tmp5"]);
    }

    #[test]
    fn temp_names_are_recognised_exactly() {
        assert_eq!(temp_file_pid("v", ".v.tmp12"), Some(12));
        for bad in [
            ".v.tmp",
            ".v.tmpx1",
            "v.tmp5",
            ".w.tmp5",
            ".v.tmp99999999999999",
        ] {
            assert_eq!(temp_file_pid("v", bad), None, "{bad}");
        }
    }
}
