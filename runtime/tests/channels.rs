//! The runtime's `Channels` in a run of two channels: a stand-in for channel 0's program
//! (the test hook, until the interpreter calls it) loads, runs, waits for and resets
//! channel 1, which takes the programs one after another while channel 0 dwells; what each
//! call returns, what `@CH[1].STATE` reads, and where channel 1's axes end.

use std::path::{Path, PathBuf};
use std::sync::mpsc;

use cnc402_config::MachineConfig;
use cnc402_interp::{ChannelMode, ChannelState, Channels};
use cnc402_lang::SourceFile;
use cnc402_runtime::{ChannelsReport, ProgramInput, RunOptions, run_channels};

fn config() -> MachineConfig {
    MachineConfig::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../examples/axioma/two-channel.toml"
    ))
    .expect("config")
}

fn dir(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cnc402-rt-channels-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn parsed(name: &str, text: &str) -> ProgramInput {
    let src = SourceFile::new(name, text);
    let program = cnc402_lang::parse(&src).expect("parses");
    ProgramInput::Parsed { src, program }
}

/// Runs a dwell of `dwell_s` on channel 0 while `hook` drives the channels as channel 0's
/// program would; the hook's log and the report.
fn run_with(
    dwell_s: u32,
    hook: impl FnOnce(&mut dyn Channels) -> Vec<String> + Send + 'static,
) -> (Vec<String>, ChannelsReport) {
    let (tx, rx) = mpsc::channel();
    let opts = RunOptions {
        channels_hook: Some(Box::new(move |mut host: Box<dyn Channels>| {
            let _ = tx.send(hook(&mut *host));
        })),
        ..RunOptions::default()
    };
    let main = parsed("main.nc", &format!("G4 X{dwell_s}\nM30\n"));
    let report = run_channels(&config(), vec![Some(main)], opts, &mut |_| {}).expect("runs");
    (rx.recv().expect("the hook ran"), report)
}

fn write(d: &Path, name: &str, text: &str) {
    std::fs::write(d.join(name), text).unwrap();
}

fn final_position(r: &ChannelsReport, k: usize, axis: char) -> f64 {
    let rep = r.channels[k].result.as_ref().expect("a report");
    rep.axes
        .iter()
        .find(|a| a.name == axis)
        .unwrap()
        .final_position
}

#[test]
fn channel_load_run_wait_and_reset_with_the_seeds_meaning() {
    let d = dir("seed");
    write(&d, "part.nc", "G90 G1 U20 W-5 F3000\nM30\n");
    write(&d, "bad.nc", "G0 U(\n");
    write(&d, "limits.nc", "G90 G1 U10 F3000\nG0 U500\nM30\n");
    write(&d, "home.nc", "G90 G1 U0 W0 F3000\nM30\n");
    let main = d.join("main.nc").display().to_string();
    let (log, report) = run_with(20, move |ch| {
        let mut log = Vec::new();
        let mut say = |what: &str, v: String| log.push(format!("{what}={v}"));
        say("count", ch.count().to_string());
        say("mode", format!("{:?}", ch.mode(1)));
        say("state", format!("{:?}", ch.state(1)));
        say("state9", format!("{}", ch.state(9).is_err()));
        say("own", format!("{}", ch.load(0, "part.nc", &main).is_err()));
        say("missing", format!("{:?}", ch.load(1, "missing.nc", &main)));
        say("bad", format!("{:?}", ch.load(1, "bad.nc", &main)));
        say("run", format!("{:?}", ch.run(1, "part", &main)));
        say("limits", format!("{:?}", ch.run(1, "limits.nc", &main)));
        say("state", format!("{:?}", ch.state(1)));
        say("refused", format!("{:?}", ch.start(1, "part.nc", &main)));
        say("reset", format!("{:?}", ch.reset(1)));
        say("state", format!("{:?}", ch.state(1)));
        say("home", format!("{:?}", ch.run(1, "home.nc", &main)));
        log
    });
    assert_eq!(
        log,
        [
            "count=2",
            &format!("mode={:?}", Ok::<_, String>(ChannelMode::Auto)),
            &format!("state={:?}", Ok::<_, String>(ChannelState::Ready)),
            "state9=true",
            "own=true",
            "missing=Ok(false)",
            "bad=Ok(false)",
            "run=Ok(true)",
            "limits=Ok(false)",
            &format!("state={:?}", Ok::<_, String>(ChannelState::Error)),
            "refused=Ok(false)",
            "reset=Ok(true)",
            &format!("state={:?}", Ok::<_, String>(ChannelState::Ready)),
            "home=Ok(true)",
        ]
    );
    let ran = &report.channels[1].programs;
    assert_eq!(ran.len(), 3, "{ran:?}");
    assert!(
        ran[0].ends_with("part.nc: ok") && ran[2].ends_with("home.nc: ok"),
        "{ran:?}"
    );
    assert!(
        ran[1].contains("limits.nc: ") && ran[1].contains(":2:"),
        "{ran:?}"
    );
    assert!(report.ok(), "{:?}", report.error());
    assert_eq!(final_position(&report, 1, 'U'), 0.0);
    assert_eq!(final_position(&report, 1, 'W'), 0.0);
}

#[test]
fn channel_reset_stops_a_running_program_along_its_path() {
    let d = dir("reset");
    write(&d, "long.nc", "G90 G1 U150 F60\nM30\n");
    let main = d.join("main.nc").display().to_string();
    let (log, report) = run_with(20, move |ch| {
        let started = ch.start(1, "long.nc", &main);
        let running = ch.state(1);
        let reset = ch.reset(1);
        let after = ch.state(1);
        vec![format!("{started:?} {running:?} {reset:?} {after:?}")]
    });
    assert_eq!(
        log,
        [format!(
            "Ok(true) {:?} Ok(true) {:?}",
            Ok::<_, String>(ChannelState::Running),
            Ok::<_, String>(ChannelState::Ready)
        )]
    );
    // Reset before or during the move: it never reached its end.
    let u = final_position(&report, 1, 'U');
    assert!((0.0..150.0).contains(&u), "U at {u}");
    assert!(
        report.channels[1].programs[0].contains("reset"),
        "{:?}",
        report.channels[1].programs
    );
}

#[test]
fn a_wait_for_a_channel_with_nothing_to_do_returns_at_once() {
    let (log, report) = run_with(1, |ch| vec![format!("{:?}", ch.wait(1))]);
    assert_eq!(log, ["Ok(true)"]);
    assert!(report.ok());
}
