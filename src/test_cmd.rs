//! `cnc402 test PROGRAM…`: source 000's regression-test method as a tool. Each program runs as
//! `cnc402 run` runs it (dry run, then the machine; the embedded simulator by default), one
//! after another; a program passes when it ends without a program error, a fault or a stop.
//! One line per program, a summary, optionally JUnit XML ([`junit`]) for a CI; exit 0 only
//! when every program passed.

mod junit;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use cnc402_config::MachineConfig;
use cnc402_runtime::{AtStop, FaultPlan, Progress, RunError, RunOptions, RunReport, Timing};

use crate::cli_error::CliError;

/// Default `--max-time`: an hour of program time, longer than any one part program a test
/// list holds, short enough that an endless one fails within minutes of wall clock.
const DEFAULT_MAX_TIME_S: f64 = 3600.0;

/// The largest `--max-time` (a week of program time).
const MAX_MAX_TIME_S: f64 = 7.0 * 86_400.0;

#[derive(clap::Args, Debug)]
pub struct TestArgs {
    /// The NC programs, run in this order (a glob is the shell's to expand).
    #[arg(required = true, value_name = "PROGRAM")]
    programs: Vec<PathBuf>,
    /// Write the results as JUnit XML to FILE (`-`: stdout; the per-program lines then go to
    /// stderr).
    #[arg(long, value_name = "FILE")]
    junit: Option<PathBuf>,
    /// A program that has not ended after SECONDS of program time fails (virtual time on the
    /// embedded simulator: an endless program fails quickly; a main program ending in M99
    /// starts over endlessly).
    #[arg(long, value_name = "SECONDS", default_value_t = DEFAULT_MAX_TIME_S)]
    max_time: f64,
    /// Read every program in this dialect (fanuc, haas, linuxcnc), whatever its header or the
    /// config's `interp.dialect` says.
    #[arg(long, value_name = "NAME")]
    dialect: Option<cnc402_lang::Dialect>,
    /// Testing: make drive NODE fault with EMCY CODE (hex) SECONDS after enable, in every
    /// program's run (as `run --inject-fault`).
    #[arg(long, hide = true, value_name = "NODE:CODE@SECONDS")]
    inject_fault: Option<String>,
}

/// What became of one program.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Verdict {
    /// Ended cleanly; `notes` say what a person at the machine would have done differently
    /// (program stops passed, manual tool changes taken as done).
    Pass {
        blocks: Option<BlockCount>,
        notes: Vec<String>,
    },
    /// The program is wrong or the machine stopped (JUnit `<failure>`).
    Fail(Failure),
    /// The program could not be tried: unreadable file, the bus or the run's own machinery
    /// (JUnit `<error>`).
    Error(Failure),
    /// Not run: Ctrl-C ended the whole run first (JUnit `<skipped>`).
    NotRun,
}

/// Why a program did not pass.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Failure {
    /// The kind, as JUnit's `type`: `program`, `fault`, `time-limit`, `interrupted`, `io`.
    pub kind: &'static str,
    /// One line: `file:line:col: what` (or `file:line: what` for a stop at a block).
    pub message: String,
    /// The whole text (the block, what was expected), for JUnit's body.
    pub detail: String,
}

/// Blocks a program ran (counted by the interpreter over one pass of the program).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum BlockCount {
    Exact(u64),
    /// The program goes on past the moves the dry run checks.
    AtLeast(u64),
}

/// One program's result.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct TestResult {
    /// The program's path as given.
    pub name: String,
    pub verdict: Verdict,
    /// Program time of the run (s; 0 when it never moved).
    pub program_time_s: f64,
    /// Wall-clock time the test took (s), JUnit's `time`.
    pub wall_s: f64,
}

/// Runs every program and reports; see the subcommand's help.
pub fn test(cfg: &MachineConfig, args: TestArgs) -> Result<(), CliError> {
    if !(args.max_time.is_finite() && args.max_time > 0.0 && args.max_time <= MAX_MAX_TIME_S) {
        return Err(CliError::Usage(format!(
            "--max-time {}: expected seconds of program time, more than 0 and at most {}",
            args.max_time, MAX_MAX_TIME_S
        )));
    }
    let fault = match &args.inject_fault {
        Some(s) => Some(crate::run::parse_fault(s).map_err(CliError::Usage)?),
        None => None,
    };
    if fault.is_some() && !cfg.bus.is_sim() {
        return Err(CliError::Usage(
            "--inject-fault needs the simulated drives (bus.interface = \"sim\")".into(),
        ));
    }
    // A JUnit file that cannot be written fails now, not after an hour of tests.
    let junit_file = match &args.junit {
        Some(p) if p.as_os_str() != "-" => Some(
            cnc402_durable::AtomicFile::create(p)
                .map_err(|e| CliError::Io(format!("--junit {}: {e}", p.display())))?,
        ),
        _ => None,
    };
    if !cfg.bus.is_sim() {
        // No CAN interface, no test at all (exit 4), rather than each program failing alike;
        // the link is dropped again at once, as `run` does before its dry run.
        cnc402_runtime::make_link(cfg, None, None).map_err(|e| match e {
            RunError::Program(e) => CliError::Program(e),
            RunError::Io(m) | RunError::Clock(m) => CliError::Io(m),
        })?;
    }
    if let Err(e) = cnc402_runtime::rt::install_sigint_handler() {
        log::warn!("cannot install the SIGINT handler: {e}");
    }
    // With `--junit -` stdout is the XML's alone.
    let to_stderr = args.junit.as_deref().is_some_and(|p| p.as_os_str() == "-");
    let say = |line: &str| {
        if to_stderr {
            eprintln!("{line}");
        } else {
            println!("{line}");
        }
    };
    let started = Instant::now();
    let mut results = Vec::with_capacity(args.programs.len());
    for program in &args.programs {
        let result = if cnc402_runtime::rt::sigint_seen() {
            TestResult {
                name: program.display().to_string(),
                verdict: Verdict::NotRun,
                program_time_s: 0.0,
                wall_s: 0.0,
            }
        } else {
            test_one(cfg, program, &args, fault)
        };
        say(&result.line());
        results.push(result);
    }
    let wall_s = started.elapsed().as_secs_f64();
    let summary = Summary::of(&results);
    say(&summary.line(wall_s));
    if let Some(p) = &args.junit {
        write_junit(p, junit_file, &junit::document(&results, wall_s))?;
    }
    if summary.passed == results.len() {
        Ok(())
    } else {
        // Exit 1 whatever made a program fail: each line (and the JUnit file) says why.
        Err(CliError::Fault(format!(
            "{} of {} programs did not pass",
            results.len() - summary.passed,
            results.len()
        )))
    }
}

/// Writes the JUnit document into the file opened before the run (put in place whole), or
/// to stdout for `--junit -`.
fn write_junit(
    path: &Path,
    file: Option<cnc402_durable::AtomicFile>,
    xml: &str,
) -> Result<(), CliError> {
    let io = |e: std::io::Error| CliError::Io(format!("--junit {}: {e}", path.display()));
    match file {
        Some(mut f) => {
            f.write_all(xml.as_bytes()).map_err(io)?;
            f.commit().map_err(io)
        }
        None => {
            let mut out = std::io::stdout().lock();
            out.write_all(xml.as_bytes()).map_err(io)?;
            out.flush().map_err(io)
        }
    }
}

/// Counts of a whole run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Summary {
    pub passed: usize,
    pub failed: usize,
    pub errors: usize,
    pub not_run: usize,
}

impl Summary {
    pub(crate) fn of(results: &[TestResult]) -> Summary {
        let mut s = Summary::default();
        for r in results {
            match r.verdict {
                Verdict::Pass { .. } => s.passed += 1,
                Verdict::Fail(_) => s.failed += 1,
                Verdict::Error(_) => s.errors += 1,
                Verdict::NotRun => s.not_run += 1,
            }
        }
        s
    }

    /// The last line: `test result: ok. 3 passed; 0 failed …` (FAILED when any did not pass).
    fn line(&self, wall_s: f64) -> String {
        let all = self.passed + self.failed + self.errors + self.not_run;
        let mut s = format!(
            "test result: {}. {} passed; {} failed; {} could not run",
            if self.passed == all { "ok" } else { "FAILED" },
            self.passed,
            self.failed,
            self.errors
        );
        if self.not_run > 0 {
            s.push_str(&format!(
                "; {} not run (interrupted by Ctrl-C)",
                self.not_run
            ));
        }
        let programs = if all == 1 { "program" } else { "programs" };
        s.push_str(&format!("; {all} {programs} in {wall_s:.2} s"));
        s
    }
}

impl TestResult {
    /// The program's line: `PASS name (…)` or `FAIL name: …`.
    pub(crate) fn line(&self) -> String {
        match &self.verdict {
            Verdict::Pass { blocks, notes } => {
                let blocks = match blocks {
                    Some(BlockCount::Exact(n)) => format!(", {n} blocks"),
                    Some(BlockCount::AtLeast(n)) => format!(", at least {n} blocks"),
                    None => String::new(),
                };
                let mut s = format!(
                    "PASS {} (program time {:.3} s{blocks})",
                    self.name, self.program_time_s
                );
                for n in notes {
                    s.push_str("; ");
                    s.push_str(n);
                }
                s
            }
            Verdict::Fail(f) | Verdict::Error(f) => format!("FAIL {}: {}", self.name, f.message),
            Verdict::NotRun => format!("SKIP {}: not run (interrupted by Ctrl-C)", self.name),
        }
    }
}

/// Runs one program to its verdict.
fn test_one(
    cfg: &MachineConfig,
    program: &Path,
    args: &TestArgs,
    fault: Option<FaultPlan>,
) -> TestResult {
    let t0 = Instant::now();
    let name = program.display().to_string();
    let (verdict, program_time_s) = match crate::open_program(program) {
        Err(e) => (Verdict::Error(io_failure(e)), 0.0),
        Ok(_) => {
            let pass = count_blocks(cfg, program, args.dialect);
            run_verdict(cfg, program, args, pass, fault)
        }
    };
    TestResult {
        name,
        verdict,
        program_time_s,
        wall_s: t0.elapsed().as_secs_f64(),
    }
}

/// A file that cannot be opened, as a failure of its own.
fn io_failure(e: CliError) -> Failure {
    let message = match e {
        CliError::Io(m) => m,
        other => format!("{other:?}"),
    };
    Failure {
        kind: "io",
        detail: message.clone(),
        message,
    }
}

/// What one pass of the interpreter over the program found before the run.
struct OnePass {
    blocks: Option<BlockCount>,
    /// The main program's M99 line (it starts over there, endlessly).
    m99_line: Option<u32>,
}

impl OnePass {
    /// Why the program may run forever: a main program's M99, or more moves than the dry run
    /// checks (an endless loop with motion, or a very long program).
    fn endless_why(&self) -> Option<String> {
        match (self.m99_line, self.blocks) {
            (Some(l), _) => Some(format!(
                "the main program's M99 at line {l} starts it over endlessly"
            )),
            (None, Some(BlockCount::AtLeast(_))) => Some(format!(
                "it runs on past the first {} moves, as an endless loop would",
                cnc402_runtime::feeder::DRY_RUN_MOVES
            )),
            _ => None,
        }
    }
}

/// Counts the blocks of one pass of the program with the interpreter alone (the variables file
/// read, never written), at most as many moves as the run's dry run checks. A program error
/// here is left to the run to report.
fn count_blocks(
    cfg: &MachineConfig,
    program: &Path,
    dialect: Option<cnc402_lang::Dialect>,
) -> OnePass {
    let none = OnePass {
        blocks: None,
        m99_line: None,
    };
    let Ok(file) = crate::open_program(program) else {
        return none;
    };
    let mut interp = cnc402_interp::host_fs::interpreter(
        cfg,
        cnc402_interp::Options::default(),
        cnc402_interp::host_fs::VarsAccess::ReadOnly,
    );
    let name = program.display().to_string();
    if interp.load_stream(name, Box::new(file), dialect).is_err() {
        return none;
    }
    for _ in 0..cnc402_runtime::feeder::DRY_RUN_MOVES {
        match interp.next_segment() {
            Ok(Some(_)) => {}
            Ok(None) => {
                return OnePass {
                    blocks: Some(BlockCount::Exact(interp.block_serial())),
                    m99_line: interp.main_m99_line(),
                };
            }
            Err(_) => return none,
        }
    }
    OnePass {
        blocks: Some(BlockCount::AtLeast(interp.block_serial())),
        m99_line: None,
    }
}

/// The options of a test run: `cnc402 run`'s with no operator terminal (M0 and a manual M6
/// go on; the verdict notes them), nothing read from stdin, no trace.
fn run_options(
    cfg: &MachineConfig,
    stop_request: Arc<AtomicBool>,
    fault: Option<FaultPlan>,
) -> RunOptions {
    // The test doubles' fields exist when a workspace test build turns on the runtime's
    // `testing` feature; in a plain build every field is named here.
    #[allow(clippy::needless_update)]
    RunOptions {
        timing: if cfg.bus.is_sim() {
            Timing::Virtual
        } else {
            Timing::RealTime
        },
        stop_request,
        fault,
        at_stop: AtStop::Continue,
        // The stops passed are in the verdict's notes, not on stderr one by one.
        no_operator_terminal: false,
        ..RunOptions::default()
    }
}

/// Runs `program` (through the entry point `cnc402 run` uses) and judges the result; the
/// program time limit is watched in the progress callback.
fn run_verdict(
    cfg: &MachineConfig,
    program: &Path,
    args: &TestArgs,
    pass: OnePass,
    fault: Option<FaultPlan>,
) -> (Verdict, f64) {
    let stop_request = Arc::new(AtomicBool::new(false));
    let opts = run_options(cfg, stop_request.clone(), fault);
    let input = cnc402_runtime::ProgramInput::File {
        path: program.to_path_buf(),
        dialect: args.dialect,
    };
    let period_s = cfg.bus.period_s();
    let mut over_time = false;
    let mut on_progress = |p: &Progress| {
        if p.tick as f64 * period_s > args.max_time && !over_time {
            over_time = true;
            stop_request.store(true, Ordering::SeqCst);
        }
    };
    // On a multi-channel machine each program runs on channel 0 (and starts what it runs
    // on the others), as `cnc402 run` runs it there.
    let result = if cfg.channel_count() > 1 {
        cnc402_runtime::run_channels(cfg, vec![Some(input)], opts, &mut on_progress)
            .and_then(cnc402_runtime::ChannelsReport::into_main)
    } else {
        cnc402_runtime::run_input(cfg, input, opts, &mut on_progress)
    };
    match result {
        Err(e) => (Verdict::from_run_error(e), 0.0),
        Ok(report) if report.ok && report.error.is_none() => (
            Verdict::Pass {
                blocks: pass.blocks,
                notes: stop_notes(&report),
            },
            report.program_time_s,
        ),
        Ok(report) => {
            let why = if over_time {
                Stopped::OverTime {
                    max_time_s: args.max_time,
                    endless: pass.endless_why(),
                }
            } else if cnc402_runtime::rt::sigint_seen() {
                Stopped::Interrupted
            } else {
                Stopped::Fault
            };
            (Verdict::Fail(why.failure(&report)), report.program_time_s)
        }
    }
}

/// The stops a test run passed without an operator, as notes for the PASS line.
fn stop_notes(report: &RunReport) -> Vec<String> {
    report
        .stops
        .iter()
        .map(|s| match s.kind {
            "M6" => format!(
                "manual tool change M6 at line {} taken as done (no operator)",
                s.line
            ),
            kind => format!("{kind} at line {} passed (no operator terminal)", s.line),
        })
        .collect()
}

/// Why a run that produced a report did not pass.
enum Stopped {
    /// The test's program time limit stopped it.
    OverTime {
        max_time_s: f64,
        /// Why the program may never end, when one pass of the interpreter told.
        endless: Option<String>,
    },
    /// Ctrl-C.
    Interrupted,
    /// A fault or safety reaction.
    Fault,
}

impl Stopped {
    fn failure(&self, report: &RunReport) -> Failure {
        let (location, block) = match &report.stop {
            Some(s) => (format!("{}: ", s.location), s.block.trim().to_string()),
            None => (String::new(), String::new()),
        };
        let (kind, what) = match self {
            Stopped::OverTime {
                max_time_s,
                endless,
            } => {
                let why = endless
                    .as_ref()
                    .map_or_else(String::new, |e| format!(" ({e})"));
                (
                    "time-limit",
                    format!("still running after {max_time_s} s of program time (--max-time){why}"),
                )
            }
            Stopped::Interrupted => ("interrupted", "interrupted by Ctrl-C".to_string()),
            Stopped::Fault => (
                "fault",
                report
                    .error
                    .clone()
                    .unwrap_or_else(|| "the machine stopped".into()),
            ),
        };
        // A fault's text names its line already ("… while executing file:line: block").
        let message = match &report.stop {
            Some(s) if what.contains(&s.location) => what,
            _ => format!("{location}{what}"),
        };
        let detail = if block.is_empty() {
            message.clone()
        } else {
            format!("{message}\n    {block}")
        };
        Failure {
            kind,
            message,
            detail,
        }
    }
}

impl Verdict {
    /// A run that produced no report: the program is wrong (a failure), or the run's
    /// machinery could not go on (an error).
    fn from_run_error(e: RunError) -> Verdict {
        match e {
            RunError::Program(e) => {
                let mut message = format!("{}: {}", e.location(), e.message);
                if let Some(x) = &e.expected {
                    message.push_str(&format!(" (expected {x})"));
                }
                Verdict::Fail(Failure {
                    kind: "program",
                    detail: e.to_string(),
                    message,
                })
            }
            RunError::Io(m) => Verdict::Error(Failure {
                kind: "io",
                detail: m.clone(),
                message: m,
            }),
            RunError::Clock(m) => Verdict::Fail(Failure {
                kind: "fault",
                detail: m.clone(),
                message: m,
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn result(verdict: Verdict) -> TestResult {
        TestResult {
            name: "part.nc".into(),
            verdict,
            program_time_s: 12.3456,
            wall_s: 0.5,
        }
    }

    #[test]
    fn lines_say_pass_fail_or_skip_with_what_a_person_needs() {
        let pass = result(Verdict::Pass {
            blocks: Some(BlockCount::Exact(40)),
            notes: vec!["M0 at line 7 passed (no operator terminal)".into()],
        });
        assert_eq!(
            pass.line(),
            "PASS part.nc (program time 12.346 s, 40 blocks); M0 at line 7 passed (no operator \
             terminal)"
        );
        let long = result(Verdict::Pass {
            blocks: Some(BlockCount::AtLeast(1_000_000)),
            notes: vec![],
        });
        assert_eq!(
            long.line(),
            "PASS part.nc (program time 12.346 s, at least 1000000 blocks)"
        );
        let failure = Failure {
            kind: "program",
            message: "part.nc:3:5: zero feed in a motion block".into(),
            detail: String::new(),
        };
        assert_eq!(
            result(Verdict::Fail(failure.clone())).line(),
            "FAIL part.nc: part.nc:3:5: zero feed in a motion block"
        );
        assert_eq!(
            result(Verdict::Error(failure)).line(),
            "FAIL part.nc: part.nc:3:5: zero feed in a motion block"
        );
        assert_eq!(
            result(Verdict::NotRun).line(),
            "SKIP part.nc: not run (interrupted by Ctrl-C)"
        );
    }

    #[test]
    fn the_summary_counts_each_kind_and_says_ok_only_when_all_passed() {
        let pass = result(Verdict::Pass {
            blocks: None,
            notes: vec![],
        });
        let s = Summary::of(std::slice::from_ref(&pass));
        assert_eq!(
            s.line(1.0),
            "test result: ok. 1 passed; 0 failed; 0 could not run; 1 program in 1.00 s"
        );
        let s = Summary::of(&[pass, result(Verdict::NotRun)]);
        assert_eq!(
            s,
            Summary {
                passed: 1,
                failed: 0,
                errors: 0,
                not_run: 1
            }
        );
        assert_eq!(
            s.line(2.5),
            "test result: FAILED. 1 passed; 0 failed; 0 could not run; 1 not run (interrupted \
             by Ctrl-C); 2 programs in 2.50 s"
        );
    }

    #[test]
    fn an_endless_program_is_explained_by_its_m99_or_its_length() {
        let pass = |blocks, m99_line| OnePass { blocks, m99_line };
        assert_eq!(
            pass(Some(BlockCount::Exact(3)), Some(3)).endless_why(),
            Some("the main program's M99 at line 3 starts it over endlessly".into())
        );
        assert_eq!(
            pass(Some(BlockCount::AtLeast(2_000_000)), None).endless_why(),
            Some("it runs on past the first 1000000 moves, as an endless loop would".into())
        );
        assert_eq!(pass(Some(BlockCount::Exact(3)), None).endless_why(), None);
        assert_eq!(pass(None, None).endless_why(), None);
    }
}
