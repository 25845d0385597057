//! Crash safety of the writers of reports and traces (`cnc402 run --report/--trace`, plots,
//! simdrive's report: all go through `cnc402_durable`): a writer process (this test binary,
//! run as `writer_child`) writes ever-newer generations of a JSON-like report with
//! [`write_atomic`] and of a streamed trace with [`AtomicFile`] (committed when dropped, as the
//! run's trace is), and is killed (SIGKILL) at random moments hundreds of times. After every
//! kill each file must be one whole generation — the last the writer reported done or the one
//! it was writing — never torn or mixed; the temporary file a kill left is removed by the next
//! writer of that file.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use cnc402_durable::{AtomicFile, temp_file_pid, write_atomic};

const ENV_DIR: &str = "CNC402_DURABLE_WRITER_DIR";
/// Rows of one report and of one trace: a few kB, so that kills land in every phase (write,
/// fsync, rename) often.
const REPORT_LINES: u32 = 60;
const TRACE_ROWS: u32 = 150;

fn report_text(g: u64) -> String {
    let mut s = format!("{{\"generation\": {g},\n");
    for i in 0..REPORT_LINES {
        s.push_str(&format!("  \"k{i}\": {g},\n"));
    }
    s.push_str(&format!("  \"end\": {g}}}\n"));
    s
}

/// The writer: runs only when started by the kill test below.
#[test]
fn writer_child() {
    let Ok(dir) = std::env::var(ENV_DIR) else {
        return;
    };
    let dir = PathBuf::from(dir);
    let (report, trace) = (dir.join("run.json"), dir.join("trace.csv"));
    let mut g = generation(&report)
        .unwrap_or(0)
        .max(generation(&trace).unwrap_or(0));
    loop {
        g += 1;
        write_atomic(&report, report_text(g).as_bytes()).unwrap();
        println!("report {g}");
        {
            let mut t = AtomicFile::create(&trace).unwrap().commit_on_drop();
            writeln!(t, "t,generation").unwrap();
            for row in 0..TRACE_ROWS {
                writeln!(t, "{row},{g}").unwrap();
            }
            writeln!(t, "end,{g}").unwrap();
        }
        println!("trace {g}");
    }
}

/// The one generation a whole file holds; panics on a torn or mixed file.
fn generation(path: &Path) -> Option<u64> {
    let text = std::fs::read_to_string(path).ok()?;
    let csv = path.extension().is_some_and(|e| e == "csv");
    let (values, lines): (Vec<u64>, usize) = if csv {
        let rows: Vec<&str> = text.lines().skip(1).collect();
        let v = rows
            .iter()
            .map(|r| r.rsplit(',').next().unwrap().parse().unwrap())
            .collect();
        assert!(
            text.ends_with('\n') && rows.last()?.starts_with("end,"),
            "torn trace:\n{text}"
        );
        (v, rows.len() + 1)
    } else {
        let v = text
            .lines()
            .filter_map(|l| l.rsplit(": ").next())
            .map(|v| v.trim_end_matches([',', '}']).parse().unwrap())
            .collect();
        assert!(text.ends_with("}\n"), "torn report:\n{text}");
        (v, text.lines().count())
    };
    let want = if csv {
        TRACE_ROWS + 2
    } else {
        REPORT_LINES + 2
    } as usize;
    assert_eq!(lines, want, "{} has {lines} lines:\n{text}", path.display());
    assert!(
        values.windows(2).all(|w| w[0] == w[1]),
        "mixed generations in {}",
        path.display()
    );
    values.first().copied()
}

/// `report 12` / `trace 12` anywhere in a line (the harness prints `test writer_child ... `
/// before it).
fn done(line: &str, what: &str) -> Option<u64> {
    let i = line.find(what)?;
    line[i + what.len()..].trim().parse().ok()
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

fn temp_files(dir: &Path) -> usize {
    std::fs::read_dir(dir)
        .unwrap()
        .filter(|e| {
            let f = e.as_ref().unwrap().file_name();
            let f = f.to_str().unwrap();
            temp_file_pid("run.json", f).is_some() || temp_file_pid("trace.csv", f).is_some()
        })
        .count()
}

#[test]
fn kill_9_of_a_report_and_trace_writer_leaves_old_or_new_whole_files() {
    let dir = std::env::temp_dir().join(format!("cnc402-durable-kill9-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let seed = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(1, |d| d.as_nanos() as u64)
        | 1;
    eprintln!("seed {seed}");
    let mut rng = Rng(seed);
    let exe = std::env::current_exe().unwrap();
    let t0 = Instant::now();
    let (mut kills, mut stale) = (0, 0);
    let (mut report_g, mut trace_g) = (0, 0);
    // 300 kills, or at least 100 whatever the time (the 120 s cap only guards against a hang).
    while kills < 300
        && (t0.elapsed() < Duration::from_secs(20)
            || (kills < 100 && t0.elapsed() < Duration::from_secs(120)))
    {
        let mut child = Command::new(&exe)
            .args(["writer_child", "--exact", "--nocapture", "--test-threads=1"])
            .env(ENV_DIR, &dir)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // Wait for the first report so that the kill lands inside the loop, then 0-3 ms more.
        let mut out = BufReader::new(child.stdout.take().unwrap());
        let mut line = String::new();
        while out.read_line(&mut line).unwrap() > 0 && done(&line, "report ").is_none() {
            line.clear();
        }
        std::thread::sleep(Duration::from_micros(rng.next() % 3000));
        child.kill().unwrap();
        child.wait().unwrap();
        let (mut last_report, mut last_trace) = (report_g, trace_g);
        let lines: Vec<String> = std::iter::once(Ok(line))
            .chain(out.lines())
            .map(Result::unwrap)
            .collect();
        for l in &lines {
            last_report = done(l, "report ").unwrap_or(last_report);
            last_trace = done(l, "trace ").unwrap_or(last_trace);
        }
        let r = generation(&dir.join("run.json")).expect("a report");
        assert!(
            r == last_report || r == last_report + 1,
            "report {r}, last done {last_report}"
        );
        // Old: the last trace reported done; new: the one being written, whose report was
        // written just before it (a trace done and its next report written is reported done).
        if let Some(t) = generation(&dir.join("trace.csv")) {
            assert!(
                t == last_trace || t == r,
                "trace {t}, last done {last_trace}, report {r}: {lines:?}"
            );
            trace_g = t;
        }
        report_g = r;
        stale += temp_files(&dir);
        kills += 1;
    }
    // The next writer of each file removes what the killed ones left.
    write_atomic(&dir.join("run.json"), report_text(report_g + 1).as_bytes()).unwrap();
    drop(AtomicFile::create(&dir.join("trace.csv")).unwrap());
    assert_eq!(
        temp_files(&dir),
        0,
        "temporary files left after the next writes"
    );
    eprintln!(
        "{kills} kills in {:.1} s: report generation {report_g}, trace {trace_g}, {stale} \
         temporary files seen after kills",
        t0.elapsed().as_secs_f64()
    );
    assert!(kills >= 100, "only {kills} kills in the time");
    assert!(report_g > 0 && trace_g > 0);
    let _ = std::fs::remove_dir_all(&dir);
}
