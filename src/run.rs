//! `cnc402 run`: arguments to [`cnc402_runtime::RunOptions`], a progress bar on a terminal, the
//! summary on stdout, and the report, trace and plot files.

use std::io::{IsTerminal, Write};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use cnc402_config::MachineConfig;
use cnc402_runtime::{
    AtStop, FaultPlan, LinkTimeouts, Progress, RunError, RunOptions, StatsSample, Timing,
};

use cnc402_runtime::operator::{BlockSpec, CommandInput, OperatorOptions, SearchError};

use crate::RunArgs;
use crate::cli_error::CliError;

/// Parses `NODE:CODE@SECONDS` (CODE in hex, with or without 0x), e.g. `3:8611@0.5`.
pub(crate) fn parse_fault(s: &str) -> Result<FaultPlan, String> {
    let bad = || format!("--inject-fault {s:?}: expected NODE:CODE@SECONDS, e.g. 3:8611@0.5");
    let (node, rest) = s.split_once(':').ok_or_else(bad)?;
    let (code, secs) = rest.split_once('@').ok_or_else(bad)?;
    let node: u8 = node.trim().parse().map_err(|_| bad())?;
    let code = code.trim().trim_start_matches("0x");
    let emcy = u16::from_str_radix(code, 16).map_err(|_| bad())?;
    let secs: f64 = secs.trim().parse().map_err(|_| bad())?;
    if !(secs.is_finite() && (0.0..1e9).contains(&secs)) || node == 0 || node > 127 {
        return Err(bad());
    }
    Ok(FaultPlan {
        node,
        at: Duration::from_secs_f64(secs),
        emcy,
    })
}

/// Parses a `--boot-timeout`/`--enable-timeout` value: seconds, more than 0 and at most a day.
fn parse_timeout(option: &str, secs: f64) -> Result<Duration, String> {
    if secs.is_finite() && secs > 0.0 && secs <= 86_400.0 {
        Ok(Duration::from_secs_f64(secs))
    } else {
        Err(format!(
            "--{option} {secs}: expected seconds, more than 0 and at most 86400"
        ))
    }
}

/// The start-up limits from the command line; `None` keeps the transport's defaults.
fn timeouts(args: &RunArgs) -> Result<Option<LinkTimeouts>, String> {
    if args.boot_timeout.is_none() && args.enable_timeout.is_none() {
        return Ok(None);
    }
    let mut t = LinkTimeouts::real_bus();
    if let Some(s) = args.boot_timeout {
        t.boot = parse_timeout("boot-timeout", s)?;
    }
    if let Some(s) = args.enable_timeout {
        t.enable = parse_timeout("enable-timeout", s)?;
    }
    Ok(Some(t))
}

/// A `--stats-every` value: seconds, at least 0.01 and at most a day.
fn parse_stats_every(secs: f64) -> Result<Duration, String> {
    if secs.is_finite() && (0.01..=86_400.0).contains(&secs) {
        Ok(Duration::from_secs_f64(secs))
    } else {
        Err(format!(
            "--stats-every {secs}: expected seconds, at least 0.01 and at most 86400"
        ))
    }
}

/// The `stats:` line of one `--stats-every` interval (key=value, for scripts: soak.sh).
fn stats_line(axes: &[char], s: &StatsSample) -> String {
    let fe: Vec<String> = axes
        .iter()
        .zip(s.following_error_max)
        .map(|(a, fe)| format!("{a}:{fe:.6}"))
        .collect();
    let wake = if s.real_time {
        format!(
            " wakeups={} late={} skipped={} wake_max_us={:.0}",
            s.wakeups, s.late, s.skipped, s.wake_max_us
        )
    } else {
        String::new()
    };
    format!(
        "stats: wall_s={:.1} tick={}{wake} fe_max={}",
        s.wall_s,
        s.tick,
        fe.join(",")
    )
}

/// The error of a run that could not go on; with `--report`, the report says why too (for
/// scripts that read only the report).
fn not_run(cfg: &MachineConfig, args: &RunArgs, e: RunError) -> CliError {
    let (msg, err) = match e {
        RunError::Program(e) => (
            e.to_string().lines().next().unwrap_or("").to_string(),
            CliError::Program(e),
        ),
        RunError::Io(m) => (m.clone(), CliError::Io(m)),
        // The loop stopped the machine: exit 1, as for any stop during a run.
        RunError::Clock(m) => (m.clone(), CliError::Fault(m)),
    };
    if let Some(p) = &args.report {
        let axes: Vec<char> = cfg.axes.iter().map(|a| a.name).collect();
        let r = cnc402_runtime::RunReport::not_run(cfg.bus.period_us, &axes, msg);
        if let Err(e) = write_report(p, &r) {
            return e;
        }
    }
    err
}

/// Writes the JSON report whole or not at all (a reader never sees half a report).
fn write_report(p: &Path, report: &cnc402_runtime::RunReport) -> Result<(), CliError> {
    let io = |e: &dyn std::fmt::Display| CliError::Io(format!("{}: {e}", p.display()));
    let text = serde_json::to_string_pretty(&report.to_json()).map_err(|e| io(&e))?;
    cnc402_durable::write_atomic(p, format!("{text}\n").as_bytes()).map_err(|e| io(&e))
}

/// The operator's controls from the command line, checked against the program: breakpoints
/// that name no block are warnings (the run starts), a search bound that names none is exit
/// 2, a search that runs backwards exit 64.
fn operator_options(
    args: &RunArgs,
    src: &cnc402_lang::SourceFile,
) -> Result<OperatorOptions, CliError> {
    let spec = |s: &String| BlockSpec::parse(s).map_err(CliError::Usage);
    let breaks = args
        .breaks
        .iter()
        .map(spec)
        .collect::<Result<Vec<_>, _>>()?;
    for w in cnc402_runtime::operator::check_breaks(&breaks, src) {
        eprintln!("warning: {w}");
    }
    let search = match &args.from {
        None => None,
        Some(from) => {
            let to = args.to.as_ref().map(spec).transpose()?;
            match cnc402_runtime::operator::resolve_search(spec(from)?, to, src) {
                Ok(s) => Some(s),
                Err(SearchError::NotFound(m)) => return Err(CliError::NoSuchBlock(m)),
                Err(SearchError::Backwards(m)) => return Err(CliError::Usage(m)),
            }
        }
    };
    let commands = match &args.commands {
        Some(p) => Some(Arc::new(CommandInput::open(p).map_err(|e| {
            CliError::Io(format!("--commands {}: {e}", p.display()))
        })?)),
        None => None,
    };
    // A command file's triggered panel commands (`at 1.5s hold`), checked before anything
    // moves: a bad one exits 64 naming its line.
    let schedule = match &commands {
        Some(c) => c
            .schedule()
            .map_err(|e| CliError::Usage(format!("--commands: {e}")))?,
        None => Default::default(),
    };
    // Panel commands from the terminal (or `--commands -`) act during motion.
    let from_stdin = args
        .commands
        .as_deref()
        .is_none_or(|p| p.as_os_str() == "-");
    let listen_stdin = from_stdin && (args.commands.is_some() || std::io::stdin().is_terminal());
    Ok(OperatorOptions {
        breaks,
        single_block: args.single_block,
        search,
        commands,
        schedule,
        listen_stdin,
    })
}

/// Runs the program and reports; see the subcommand's help.
pub fn run(cfg: &MachineConfig, args: &RunArgs) -> Result<(), CliError> {
    let fault = match &args.inject_fault {
        Some(s) => Some(parse_fault(s).map_err(CliError::Usage)?),
        None => None,
    };
    if fault.is_some() && !cfg.bus.is_sim() {
        return Err(CliError::Usage(format!(
            "--inject-fault needs the simulated drives (bus.interface = \"sim\", not {:?}); \
             on a CAN bus inject faults with simdrive --fault",
            cfg.bus.interface
        )));
    }
    if args.require_rt && !args.realtime && cfg.bus.is_sim() {
        return Err(CliError::Usage(
            "--require-rt needs a real-time loop: the embedded simulator runs in virtual time \
             unless --realtime is given"
                .into(),
        ));
    }
    let timeouts = timeouts(args).map_err(CliError::Usage)?;
    let stats_every = match args.stats_every {
        Some(s) => Some(parse_stats_every(s).map_err(CliError::Usage)?),
        None => None,
    };
    // Read line by line by the dry run and the run: memory bounded by the lookahead.
    crate::open_program(&args.program)?;
    let input = cnc402_runtime::ProgramInput::File {
        path: args.program.clone(),
        dialect: args.dialect,
    };
    let src = input.source();
    let trace: Option<Box<dyn Write>> = match &args.trace {
        // Written to `.<name>.tmp<pid>` while the run goes on, put in place when the run is
        // done with it, however it ended; a killed run leaves the previous trace.
        Some(p) => Some(Box::new(
            cnc402_durable::AtomicFile::create(p)
                .map_err(|e| CliError::Io(format!("{}: {e}", p.display())))?
                .commit_on_drop(),
        )),
        None => None,
    };
    if let Err(e) = cnc402_runtime::rt::install_sigint_handler() {
        log::warn!("cannot install the SIGINT handler: {e}");
    }
    // Breakpoints and search bounds are checked against the program's text: read whole for
    // that check only (and dropped), since the run itself streams the file.
    let operator = if args.breaks.is_empty() && args.from.is_none() {
        operator_options(args, &src)?
    } else {
        operator_options(args, &crate::load_program(&args.program)?)?
    };
    // M0 waits for the operator only when there is one at a terminal to press Enter (or a
    // command stream to read from).
    let asked = args.at_stop.map(|a| match a {
        crate::AtStopArg::Wait => AtStop::Wait,
        crate::AtStopArg::Continue => AtStop::Continue,
        crate::AtStopArg::End => AtStop::End,
    });
    let (at_stop, no_operator_terminal) = AtStop::for_run(
        asked,
        std::io::stdin().is_terminal() || operator.commands.is_some(),
    );
    // The test doubles' fields exist when a workspace test build turns on the runtime's
    // `testing` feature; in a plain build every field is named here.
    #[allow(clippy::needless_update)]
    let opts = RunOptions {
        // A real bus always runs against the clock.
        timing: if args.realtime || !cfg.bus.is_sim() {
            Timing::RealTime
        } else {
            Timing::Virtual
        },
        fault,
        trace,
        stop_request: Arc::new(AtomicBool::new(false)),
        timeouts,
        at_stop,
        optional_stop: args.optional_stop,
        no_operator_terminal,
        stats_every,
        require_rt: args.require_rt,
        operator,
        ..RunOptions::default()
    };

    let bar = if std::io::stderr().is_terminal() {
        let b = indicatif::ProgressBar::new(0);
        if let Ok(style) = indicatif::ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {msg} {wide_bar} {percent:>3}%",
        ) {
            b.set_style(style);
        }
        Some(b)
    } else {
        None
    };
    let name = src.name.clone();
    let axes: Vec<char> = cfg.axes.iter().map(|a| a.name).collect();
    let mut on_progress = |p: &Progress| {
        if let Some(s) = &p.stats {
            let line = stats_line(&axes, s);
            match &bar {
                Some(b) => b.println(line),
                None => eprintln!("{line}"),
            }
        }
        if let Some(b) = &bar {
            b.set_length(p.expected_ticks.max(p.tick + 1));
            b.set_position(p.tick);
            b.set_message(format!("{name}:{}", p.line));
        }
    };
    if cfg.channel_count() > 1 || !args.channels.is_empty() {
        return run_channels(cfg, args, (input, opts), &mut on_progress, bar.as_ref());
    }
    let result = cnc402_runtime::run_input(cfg, input, opts, &mut on_progress);
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let report = match result {
        Ok(r) => r,
        Err(e) => return Err(not_run(cfg, args, e)),
    };
    print!("{}", report.summary());
    if let Some(p) = &args.report {
        write_report(p, &report)?;
    }
    if let Some(p) = &args.plot {
        let title = format!("cnc402 run {}", args.program.display());
        cnc402_runtime::write_plot(p, &report, &title).map_err(CliError::Io)?;
    }
    if let Some(e) = &report.operator.command_error {
        return Err(CliError::Usage(format!("--commands: {e}")));
    }
    match report.error {
        None if report.ok => Ok(()),
        e => Err(CliError::Fault(
            e.unwrap_or_else(|| "the machine stopped".into()),
        )),
    }
}

/// The program of each channel: PROGRAM on channel 0, each `--channel N=FILE` on N.
fn channel_programs(
    cfg: &MachineConfig,
    args: &RunArgs,
    main: cnc402_runtime::ProgramInput,
) -> Result<Vec<Option<cnc402_runtime::ProgramInput>>, CliError> {
    let count = cfg.channel_count();
    let mut programs: Vec<Option<cnc402_runtime::ProgramInput>> = vec![None; count];
    programs[0] = Some(main);
    for c in &args.channels {
        let bad = |why: String| CliError::Usage(format!("--channel {c:?}: {why}"));
        let (n, file) = c
            .split_once('=')
            .ok_or_else(|| bad("expected N=FILE, e.g. 1=sub.nc".into()))?;
        let n: usize = n
            .trim()
            .parse()
            .map_err(|_| bad("N is a channel number".into()))?;
        if n == 0 {
            return Err(bad("channel 0 runs PROGRAM".into()));
        }
        if n >= count {
            return Err(bad(format!(
                "this machine has {count} channel(s) (0..={}); [[channel]] in the config adds more",
                count - 1
            )));
        }
        if programs[n].is_some() {
            return Err(bad(format!("channel {n} has a program already")));
        }
        let path = std::path::PathBuf::from(file);
        crate::open_program(&path)?;
        programs[n] = Some(cnc402_runtime::ProgramInput::File {
            path,
            dialect: args.dialect,
        });
    }
    Ok(programs)
}

/// `cnc402 run` of a machine with several channels (or with `--channel`): `main` on channel
/// 0, each `--channel N=FILE` on N.
fn run_channels(
    cfg: &MachineConfig,
    args: &RunArgs,
    (main, opts): (cnc402_runtime::ProgramInput, RunOptions),
    on_progress: &mut dyn FnMut(&Progress),
    bar: Option<&indicatif::ProgressBar>,
) -> Result<(), CliError> {
    let programs = channel_programs(cfg, args, main)?;
    let result = cnc402_runtime::run_channels(cfg, programs, opts, on_progress);
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    channels_done(cfg, args, result)
}

/// The summary and report of a run of several channels, and its exit.
fn channels_done(
    cfg: &MachineConfig,
    args: &RunArgs,
    result: Result<cnc402_runtime::ChannelsReport, RunError>,
) -> Result<(), CliError> {
    let report = match result {
        Ok(r) => r,
        Err(e) => return Err(not_run(cfg, args, e)),
    };
    print!("{}", report.summary());
    if let Some(p) = &args.report {
        let io = |e: &dyn std::fmt::Display| CliError::Io(format!("{}: {e}", p.display()));
        let text = serde_json::to_string_pretty(&report.to_json()).map_err(|e| io(&e))?;
        cnc402_durable::write_atomic(p, format!("{text}\n").as_bytes()).map_err(|e| io(&e))?;
    }
    if let Some(p) = &args.plot {
        let title = format!("cnc402 run {}", args.program.display());
        cnc402_runtime::write_channels_plot(p, &report, &title).map_err(CliError::Io)?;
    }
    let (ok, error) = (report.ok(), report.error());
    let program_error = report.channels.into_iter().find_map(|c| match c.result {
        Err(RunError::Program(e)) => Some(e),
        _ => None,
    });
    match (program_error, ok) {
        (Some(e), _) => Err(CliError::Program(e)),
        (None, true) => Ok(()),
        (None, false) => Err(CliError::Fault(
            error.unwrap_or_else(|| "the machine stopped".into()),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fault_option_parses_and_rejects() {
        let f = parse_fault("3:8611@0.5").unwrap();
        assert_eq!(
            (f.node, f.emcy, f.at),
            (3, 0x8611, Duration::from_millis(500))
        );
        assert_eq!(parse_fault("4:0x2310@2").unwrap().emcy, 0x2310);
        for bad in [
            "",
            "3",
            "3:8611",
            "0:8611@1",
            "128:1@1",
            "3:zz@1",
            "3:1@-1",
            "3:1@nan",
            "3:1@1e300",
        ] {
            assert!(parse_fault(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn stats_every_is_bounded_and_stats_line_is_key_value() {
        assert_eq!(parse_stats_every(60.0), Ok(Duration::from_secs(60)));
        for bad in [0.0, 0.001, -1.0, f64::NAN, f64::INFINITY, 1e9] {
            assert!(parse_stats_every(bad).is_err(), "{bad}");
        }
        let mut s = StatsSample {
            wall_s: 60.04,
            tick: 59_000,
            following_error_max: [0.0; cnc402_config::MAX_AXES],
            ..StatsSample::default()
        };
        s.following_error_max[1] = 0.0125;
        assert_eq!(
            stats_line(&['X', 'Z'], &s),
            "stats: wall_s=60.0 tick=59000 fe_max=X:0.000000,Z:0.012500"
        );
        s.real_time = true;
        (s.wakeups, s.late, s.skipped, s.wake_max_us) = (59_001, 12, 3, 1250.4);
        assert_eq!(
            stats_line(&['X'], &s),
            "stats: wall_s=60.0 tick=59000 wakeups=59001 late=12 skipped=3 wake_max_us=1250 \
             fe_max=X:0.000000"
        );
    }
}
