//! Crash safety of the non-volatile variables file: a writer process (this test binary, run
//! as `writer_child`) saves ever-increasing values; it is killed (SIGKILL) at random moments
//! hundreds of times. After every kill the file must load (checksum good) and hold either the
//! last value the writer reported saved or the one it was saving — never a torn or mixed file.
//! A kill between a save's create and rename leaves its temporary file; the next start (taking
//! the write lock, as `cnc402 run` and every writer do first) must remove it.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use cnc402_interp::{NvTable, nvfile};

const ENV_FILE: &str = "CNC402_NV_WRITER_FILE";

/// One save: #500..#519 all hold `v` (a torn write would mix values).
fn table(v: f64) -> NvTable {
    let mut t = NvTable::default();
    for n in 500..520 {
        t.set(n, Some(v)).unwrap();
    }
    t
}

/// The writer: runs only when started by the kill test below.
#[test]
fn writer_child() {
    let Ok(path) = std::env::var(ENV_FILE) else {
        return;
    };
    let path = PathBuf::from(path);
    let mut v = NvTable::load(&path).unwrap().get(500).unwrap_or(0.0);
    loop {
        v += 1.0;
        table(v).save(&path).unwrap();
        // Reported only once the save has returned (is durable).
        println!("saved {v}");
    }
}

/// `saved 12` anywhere in a line (the harness prints `test writer_child ... ` before it).
fn saved(line: &str) -> Option<f64> {
    let i = line.find("saved ")?;
    line[i + 6..].trim().parse().ok()
}

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}

/// The temporary files of the variables file at `path` now in its folder.
fn temp_files(path: &Path) -> usize {
    let name = path.file_name().unwrap().to_str().unwrap();
    std::fs::read_dir(path.parent().unwrap())
        .unwrap()
        .filter(|e| {
            let f = e.as_ref().unwrap().file_name();
            f.to_str().is_some_and(|f| nvfile::is_temp_file_of(name, f))
        })
        .count()
}

fn check(path: &Path, last_saved: f64) -> f64 {
    let t = NvTable::load(path).unwrap_or_else(|e| panic!("unreadable after a kill: {e}"));
    let v = t.get(500).expect("#500 set");
    for n in 501..520 {
        assert_eq!(t.get(n), Some(v), "mixed values in one file");
    }
    assert!(
        v == last_saved || v == last_saved + 1.0,
        "file holds {v}, the writer last reported {last_saved}"
    );
    v
}

#[test]
fn kill_9_of_a_writer_leaves_old_or_new_and_no_temp_files_after_the_next_start() {
    let dir = std::env::temp_dir().join(format!("cnc402-nv-crash-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("vars.txt");
    table(0.0).save(&path).unwrap();
    let seed = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(1, |d| d.as_nanos() as u64)
        | 1;
    // Printed first, so that a failure can be replayed with the same kill points.
    eprintln!("seed {seed}");
    let mut rng = Rng(seed);
    let exe = std::env::current_exe().unwrap();
    let t0 = Instant::now();
    let mut kills = 0;
    let mut value = 0.0;
    // Temporary files found after a kill (all removed by the next start).
    let mut stale = 0;
    // 300 kills, or at least 100 whatever the time: a loaded machine takes longer per child
    // but must still make the 100 (the 120 s cap only guards against a hang).
    while kills < 300
        && (t0.elapsed() < Duration::from_secs(15)
            || (kills < 100 && t0.elapsed() < Duration::from_secs(120)))
    {
        let mut child = Command::new(&exe)
            .args(["writer_child", "--exact", "--nocapture", "--test-threads=1"])
            .env(ENV_FILE, &path)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // Wait for the first save so that the kill lands inside the save loop, then a random
        // 0-3 ms more.
        let mut out = BufReader::new(child.stdout.take().unwrap());
        let mut last = value;
        loop {
            let mut line = String::new();
            if out.read_line(&mut line).unwrap() == 0 {
                break;
            }
            if let Some(v) = saved(&line) {
                last = v;
                break;
            }
        }
        std::thread::sleep(Duration::from_micros(rng.next() % 3000));
        child.kill().unwrap();
        child.wait().unwrap();
        for l in out.lines() {
            if let Some(v) = saved(&l.unwrap()) {
                last = v;
            }
        }
        value = check(&path, last);
        let left = temp_files(&path);
        stale += left;
        drop(nvfile::WriteLock::acquire(&path).unwrap());
        assert_eq!(
            temp_files(&path),
            0,
            "{left} temporary files left after the next start"
        );
        kills += 1;
    }
    assert!(kills >= 100, "only {kills} kills in the time");
    assert!(value > 0.0);
    std::fs::remove_dir_all(&dir).unwrap();
    eprintln!("{kills} kills, {value} saves, {stale} stale temporary files removed, seed {seed}");
}
