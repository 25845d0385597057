//! Issue 15, the language side: source 000's regression-test program
//! (`examples/axioma/regression_test.nc`) on a scripted two-channel machine through every
//! path of its method, `@CH[n]` against the machine's channels, channel calls in program
//! order with the motion, wait marks (`wait_mark`, Fanuc `M100 P12`) as segments, and `$`
//! globals shared between the interpreters of two channels.

#![allow(clippy::result_large_err)]

mod chan_common;

use std::sync::{Arc, Mutex};

use chan_common::{FakeChannels, ROOT, Script};
use cnc402_config::MachineConfig;
use cnc402_interp::{
    ChannelMode, ChannelState, Interpreter, MotionSync, SharedGlobals, segment_to_json,
};
use cnc402_lang::{NcError, SourceFile};
use cnc402_motion::segment::{AxisPos, Segment, SegmentKind, StopKind};

fn cfg() -> MachineConfig {
    MachineConfig::default_machine()
}

/// Runs `text` (named `name`) on channel 0 of the scripted machine: its segments or its
/// error, and the calls it made on the channels.
fn run_on(name: &str, text: &str, script: Script) -> (Result<Vec<Segment>, NcError>, Vec<String>) {
    let (fake, log) = FakeChannels::new(script);
    let mut it = Interpreter::new(&cfg());
    it.set_channels(Box::new(fake));
    let src = SourceFile::new(name, text);
    let program = cnc402_interp::parse_program(&cfg(), &src, None).unwrap();
    it.load(src, program);
    let r = it.by_ref().collect();
    let calls = log.lock().unwrap().clone();
    (r, calls)
}

fn example(name: &str) -> (String, String) {
    let path = format!("{ROOT}/examples/axioma/{name}");
    let text = std::fs::read_to_string(&path).unwrap();
    (path, text)
}

/// Runs the example program `name` on the scripted machine.
fn run_example(name: &str, script: Script) -> (Result<Vec<Segment>, NcError>, Vec<String>) {
    let (path, text) = example(name);
    run_on(&path, &text, script)
}

/// The 1-based line of the first line of `name` holding `needle`.
fn line_of(name: &str, needle: &str) -> u32 {
    let (_, text) = example(name);
    text.lines().position(|l| l.contains(needle)).unwrap() as u32 + 1
}

fn msgs(segs: &[Segment]) -> Vec<String> {
    segs.iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Message { text } => Some(text.clone()),
            _ => None,
        })
        .collect()
}

#[test]
fn the_seed_program_passes_when_both_part_programs_run() {
    let (r, calls) = run_example("regression_test.nc", Script::default());
    let segs = r.unwrap();
    assert_eq!(
        msgs(&segs),
        [
            "Auto mode",
            "Kanal gotov",
            "Kanal zagrujen",
            "Kanal zapuwen",
            "Kanal zagrujen",
            "Kanal zapuwen"
        ]
    );
    assert_eq!(
        calls,
        [
            "mode 1",
            "state 1",
            "load 1 01.nc",
            "start 1 01.nc",
            "wait 1",
            "load 1 02.nc",
            "start 1 02.nc",
            "wait 1"
        ]
    );
}

#[test]
fn a_failed_load_is_retried_once_after_a_reset_and_a_10_ms_sleep() {
    let script = Script {
        load_fails: 1,
        ..Script::default()
    };
    let (r, calls) = run_example("regression_test.nc", script);
    let segs = r.unwrap();
    assert_eq!(
        calls[2..7],
        [
            "load 1 01.nc",
            "reset 1",
            "load 1 01.nc",
            "wait 1",
            "start 1 01.nc"
        ]
    );
    let sleep_line = line_of("regression_test.nc", "    sleep(10 *msSleep);");
    let dwell = segs
        .iter()
        .find(|s| matches!(s.kind, SegmentKind::Dwell { .. }))
        .unwrap();
    assert_eq!(dwell.kind, SegmentKind::Dwell { seconds: 0.01 });
    assert_eq!(dwell.source.line, sleep_line);
    assert_eq!(msgs(&segs).len(), 6, "{:?}", msgs(&segs));
}

#[test]
fn a_load_that_fails_twice_terminates_5556() {
    let script = Script {
        load_fails: 2,
        ..Script::default()
    };
    let (r, _) = run_example("regression_test.nc", script);
    let e = r.unwrap_err();
    assert_eq!(e.line, line_of("regression_test.nc", "terminate(5556"));
    assert!(
        e.message
            .contains("terminate 5556: Ne udalos zagruzit kanal"),
        "{e}"
    );
}

#[test]
fn a_run_that_fails_twice_terminates_5558_at_its_line() {
    let script = Script {
        run_fails: 2,
        ..Script::default()
    };
    let (r, calls) = run_example("regression_test.nc", script);
    let e = r.unwrap_err();
    assert_eq!(e.line, line_of("regression_test.nc", "terminate(5558"));
    assert_eq!(
        (e.col, e.message.as_str()),
        (13, "terminate 5558: Ne udalos zapustit")
    );
    assert_eq!(
        calls[2..],
        [
            "load 1 01.nc",
            "start 1 01.nc",
            "wait 1",
            "reset 1",
            "start 1 01.nc",
            "wait 1"
        ]
    );
}

#[test]
fn a_run_that_fails_once_passes_on_the_retry() {
    let script = Script {
        run_fails: 1,
        ..Script::default()
    };
    let (r, calls) = run_example("regression_test.nc", script);
    assert_eq!(msgs(&r.unwrap()).len(), 6);
    assert_eq!(calls.iter().filter(|c| *c == "reset 1").count(), 1);
}

#[test]
fn the_part_program_with_zero_feed_fails_for_real_and_ends_the_test_with_5558() {
    let (r, calls) = run_example("regression_test_fails.nc", Script::default());
    let e = r.unwrap_err();
    assert_eq!(
        e.line,
        line_of("regression_test_fails.nc", "terminate(5558")
    );
    assert!(e.message.contains("terminate 5558"), "{e}");
    // 01.nc and 02.nc passed; 03_zero_feed.nc failed twice at its G1 without F (line 5).
    let errors: Vec<_> = calls.iter().filter(|c| c.starts_with("error")).collect();
    assert_eq!(errors.len(), 2, "{calls:?}");
    assert!(
        errors[0].starts_with("error 5:zero feed in a motion block"),
        "{calls:?}"
    );
    assert_eq!(calls.iter().filter(|c| *c == "wait 1").count(), 4);
}

#[test]
fn the_part_programs_run_on_channel_1s_axes() {
    let c1 = chan_common::channel_1_config();
    for p in ["01.nc", "02.nc"] {
        let (path, text) = example(p);
        let segs = cnc402_interp::run_program(&c1, &SourceFile::new(path, text)).unwrap();
        assert!(segs.len() > 5, "{p}");
    }
}

#[test]
fn a_channel_not_in_auto_terminates_5554_and_one_not_ready_5555() {
    let manual = Script {
        mode: ChannelMode::Manual,
        ..Script::default()
    };
    let (r, calls) = run_example("regression_test.nc", manual);
    let e = r.unwrap_err();
    assert_eq!(e.line, line_of("regression_test.nc", "terminate(5554"));
    assert!(e.message.contains("terminate 5554"), "{e}");
    assert_eq!(calls, ["mode 1"]);
    for state in [
        ChannelState::Reset,
        ChannelState::Running,
        ChannelState::Error,
        ChannelState::Waiting,
    ] {
        let s = Script {
            state,
            ..Script::default()
        };
        let (r, _) = run_example("regression_test.nc", s);
        let e = r.unwrap_err();
        assert_eq!(e.line, line_of("regression_test.nc", "terminate(5555"));
        assert!(e.message.contains("terminate 5555"), "{state:?}: {e}");
    }
}

#[test]
fn mode_and_state_read_the_numbers_of_the_contract() {
    let s = Script {
        state: ChannelState::Error,
        ..Script::default()
    };
    let (r, _) = run_on(
        "t.nc",
        "MSG(\"\" + @CH[0].MODE + @CH[0].STATE + @CH[1].MODE + @CH[1].STATE);\n",
        s,
    );
    assert_eq!(msgs(&r.unwrap()), ["1314"]);
}

#[test]
fn a_channel_past_the_machines_channels_is_an_error_at_its_column() {
    let cases = [
        (
            "int n = @CH[9].MODE;\n",
            9,
            "@CH[9]: this machine has 2 channels (0..=1)",
        ),
        (
            "int n = 2;\nint m = @CH[n - 3].STATE;\n",
            9,
            "@CH[-1]: channels are numbered from 0",
        ),
        (
            "bool b = channel_run(2, \"01.nc\");\n",
            10,
            "channel_run(2): this machine has 2 channels (0..=1)",
        ),
        (
            "$gProg = 5;\nbool b = channel_load(1, $gProg);\n",
            10,
            "channel_load: the program must be a file name, not a int",
        ),
        (
            "bool b = channel_start(1, \" \");\n",
            10,
            "channel_start: the program must be a file name, not an empty string",
        ),
        ("channel_reset(0);\n", 1, "channel 0 is the calling channel"),
    ];
    for (text, col, want) in cases {
        let (r, calls) = run_on("t.nc", text, Script::default());
        let e = r.unwrap_err();
        assert_eq!(e.col, col, "{text}: {e}");
        assert!(e.message.contains(want), "{text}: {e}");
        assert!(e.to_string().starts_with("t.nc:"), "{e}");
        assert!(calls.is_empty() || text.contains("(0)"), "{calls:?}");
    }
}

/// A motion sync that notes in the channel log each time the interpreter waits for motion.
struct LoggingSync(Arc<Mutex<Vec<String>>>);

impl MotionSync for LoggingSync {
    fn wait_motion_done(&mut self, programmed: &AxisPos) -> Result<AxisPos, String> {
        self.0
            .lock()
            .unwrap()
            .push(format!("motion done at X{}", programmed[0]));
        Ok(*programmed)
    }
}

#[test]
fn a_channel_call_waits_for_the_motion_before_it_and_runs_in_program_order() {
    let (fake, log) = FakeChannels::new(Script::default());
    let mut it = Interpreter::new(&cfg());
    it.set_channels(Box::new(fake));
    it.set_motion_sync(Box::new(LoggingSync(log.clone())));
    let main = format!("{ROOT}/examples/axioma/t.nc");
    let text =
        "G90 G1 X10 F1000\nbool b = channel_start(1, \"01.nc\");\nG1 X20\nchannel_wait(1);\n";
    let src = SourceFile::new(main, text);
    let program = cnc402_interp::parse_program(&cfg(), &src, None).unwrap();
    it.load(src, program);
    let first = it.next_segment().unwrap().unwrap();
    assert_eq!(first.source.line, 1);
    // The interpreter has read past the call, but the other channel has not started: the
    // G1 X10 before it has only been handed out, not executed.
    assert!(log.lock().unwrap().is_empty(), "{:?}", log.lock().unwrap());
    let second = it.next_segment().unwrap().unwrap();
    assert_eq!(second.source.line, 3);
    assert_eq!(
        *log.lock().unwrap(),
        ["motion done at X10", "start 1 01.nc"]
    );
    assert_eq!(it.next_segment().unwrap(), None);
    assert_eq!(log.lock().unwrap()[2..], ["motion done at X20", "wait 1"]);
}

/// The `WaitMark` stops of `segs` as (mark, channels, line).
fn waits(segs: &[Segment]) -> Vec<(u16, u16, u32)> {
    segs.iter()
        .filter_map(|s| match s.kind {
            SegmentKind::Stop {
                kind: StopKind::WaitMark { mark, channels },
            } => Some((mark, channels, s.source.line)),
            _ => None,
        })
        .collect()
}

#[test]
fn wait_marks_are_stops_in_the_segment_dump() {
    let text =
        "G90 G1 X5 F500\nwait_mark(7);\nwait_mark(8, 3);\nG1 X6\nM100 P12\nN40 G1 X7 M101\nM199\n";
    let (r, _) = run_on("t.nc", text, Script::default());
    let segs = r.unwrap();
    assert_eq!(
        waits(&segs),
        [(7, 0, 2), (8, 3, 3), (100, 3, 5), (101, 0, 6), (199, 0, 7)]
    );
    // A wait M code in a block with motion waits after the motion.
    let at = segs.iter().position(|s| s.source.line == 6).unwrap();
    assert!(matches!(segs[at].kind, SegmentKind::Linear { .. }));
    let json = segment_to_json(&segs[at + 1], &cfg());
    assert!(
        json.contains("\"stop\":\"wait_mark\",\"mark\":101,\"channels\":0"),
        "{json}"
    );
    // Fanuc programs the same: paths 1 and 2 are channels 0 and 1.
    let fanuc = "G90 G1 X5 F500\nM150 P21\nM150\nM30\n";
    let (r, _) = run_on("f.nc", fanuc, Script::default());
    assert_eq!(waits(&r.unwrap()), [(150, 3, 2), (150, 0, 3)]);
}

#[test]
fn a_one_channel_machine_passes_wait_marks_to_the_runtime_and_refuses_other_channels() {
    let segs =
        cnc402_interp::run_program(&cfg(), &SourceFile::new("t.nc", "M100\nwait_mark(3, 1);\n"))
            .unwrap();
    assert_eq!(waits(&segs), [(100, 0, 1), (3, 1, 2)]);
    let e = cnc402_interp::run_program(&cfg(), &SourceFile::new("t.nc", "G0 X1\nM100 P12\n"))
        .unwrap_err();
    assert_eq!((e.line, e.col), (2, 6), "{e}");
    assert!(
        e.message
            .contains("path 2 is not one of this machine's paths"),
        "{e}"
    );
}

#[test]
fn bad_waits_are_errors_at_file_line_col() {
    let cases = [
        (
            "G0 X1\nM100 P13\n",
            (2, 6),
            "M100 P13: path 3 is not one of this machine's paths (1..=2",
        ),
        (
            "M120 P2\n",
            (1, 6),
            "M120 P2: leaves out path 1 (channel 0), the one waiting",
        ),
        ("M100 P1.5\n", (1, 6), "P lists the waiting paths"),
        ("M100 P102\n", (1, 6), "path 0 is not one of"),
        ("M100 M101\n", (1, 6), "M100 and M101 are both waits"),
        ("M100 M30\n", (1, 6), "M30 ends the program"),
        (
            "M98 M100 P12\n",
            (1, 1),
            "M98 takes a P word too: the wait M100",
        ),
        (
            "wait_mark(1, 2);\n",
            (1, 1),
            "channel mask 2 leaves out channel 0, the one waiting",
        ),
        (
            "wait_mark(1, 4);\n",
            (1, 1),
            "channel mask 4 names channel 2; this machine has 2 channels",
        ),
        (
            "wait_mark(70000);\n",
            (1, 1),
            "wait_mark(70000): a mark is 0..65535",
        ),
        (
            "wait_mark(1, 2, 3);\n",
            (1, 1),
            "takes 1 argument(s), not 3",
        ),
        (
            "G1 X1 F100\nM100 P12\nwait_mark(\"a\");\n",
            (3, 11),
            "must be a number",
        ),
    ];
    for (text, (l, c), want) in cases {
        let (r, _) = run_on("t.nc", text, Script::default());
        let e = r.unwrap_err();
        assert!(e.message.contains(want), "{text:?}: {e}");
        assert_eq!((e.line, e.col), (l, c), "{text:?}: {e}");
    }
}

#[test]
fn an_m_code_mapped_in_mcodes_or_outside_the_range_is_not_a_wait() {
    let base = std::fs::read_to_string(format!("{ROOT}/config/machine.toml")).unwrap();
    let text = base
        .replacen("[interp]\n", "[interp]\nwait_mcodes = [200, 209]\n", 1)
        .replacen(
            "[mcodes]\n",
            "[mcodes]\n205 = { action = \"ignore\", note = \"not a wait here\" }\n",
            1,
        );
    let c = MachineConfig::parse(&text, std::path::Path::new("m.toml")).unwrap();
    let run = |p: &str| cnc402_interp::run_program(&c, &SourceFile::new("t.nc", p));
    assert_eq!(
        waits(&run("M200 P1\nM209\n").unwrap()),
        [(200, 1, 1), (209, 0, 2)]
    );
    let segs = run("M205\n").unwrap();
    assert!(waits(&segs).is_empty() && msgs(&segs)[0].contains("not a wait here"));
    let e = run("M100\n").unwrap_err();
    assert!(e.message.contains("unknown M code M100"), "{e}");
    // LinuxCNC's M100-M199 are user programs, not waits.
    let e = cnc402_interp::run_program(
        &cfg(),
        &SourceFile::new("l.ngc", "(dialect: linuxcnc)\nM100\n"),
    )
    .unwrap_err();
    assert!(e.message.contains("unknown M code M100"), "{e}");
    let off = base.replacen("[interp]\n", "[interp]\nwait_mcodes = []\n", 1);
    let c = MachineConfig::parse(&off, std::path::Path::new("m.toml")).unwrap();
    let e = cnc402_interp::run_program(&c, &SourceFile::new("t.nc", "M150\n")).unwrap_err();
    assert!(e.message.contains("unknown M code M150"), "{e}");
}

/// Loads `text` into `it` and runs it to its end.
fn run_in(it: &mut Interpreter, text: &str) -> Result<Vec<Segment>, NcError> {
    let src = SourceFile::new("g.nc", text);
    let program = cnc402_interp::parse_program(&cfg(), &src, None).unwrap();
    it.load(src, program);
    it.by_ref().collect()
}

#[test]
fn two_interpreters_sharing_the_globals_see_each_others_flags() {
    let shared = SharedGlobals::default();
    let mut ch0 = Interpreter::new(&cfg());
    let mut ch1 = Interpreter::new(&cfg());
    ch0.set_shared_globals(shared.clone());
    ch1.set_shared_globals(shared.clone());
    run_in(
        &mut ch0,
        "$nFlag = 1;\n$dPerm[3] = 2.5;\n$sName = \"01.nc\";\n$bDone = 2 > 1;\n",
    )
    .unwrap();
    let segs = run_in(
        &mut ch1,
        "MSG(\"\" + $nFlag + \" \" + $dPerm[3] + \" \" + $sName + \" \" + $bDone);\n$nFlag += 1;\n",
    )
    .unwrap();
    assert_eq!(msgs(&segs), ["1 2.5 01.nc true"]);
    assert_eq!(
        shared.get("nFlag", 0),
        Some(cnc402_interp::host::channels::SharedValue::Int(2))
    );
    assert_eq!(
        cnc402_interp::hll::global_number(&ch0, "dPerm", Some(3)),
        Some(2.5)
    );
    // Set from outside (the runtime), read by a program.
    shared
        .set(
            "dLimit",
            0,
            cnc402_interp::host::channels::SharedValue::Double(4.0),
        )
        .unwrap();
    let segs = run_in(&mut ch0, "MSG(\"\" + $dLimit);\n").unwrap();
    assert_eq!(msgs(&segs), ["4"]);
    // A third interpreter without the table keeps its own globals.
    let mut alone = Interpreter::new(&cfg());
    let e = run_in(&mut alone, "int n = $nFlag;\n").unwrap_err();
    assert!(e.message.contains("$nFlag has no value"), "{e}");
}

#[test]
fn the_shared_globals_are_bounded() {
    use cnc402_interp::host::channels::{SHARED_GLOBALS_LIMIT, SharedValue};
    let shared = SharedGlobals::default();
    // Index 0 of a name not yet an array would be its scalar: the array starts at 1.
    for i in 1..=SHARED_GLOBALS_LIMIT {
        shared.set("nA", i, SharedValue::Int(1)).unwrap();
    }
    // Changing a value still works; a new one does not, from the API or from a program.
    shared.set("nA", 5, SharedValue::Int(2)).unwrap();
    let e = shared.set("nB", 0, SharedValue::Int(1)).unwrap_err();
    assert!(
        e.contains("the $ globals hold 1048576 values already"),
        "{e}"
    );
    let mut it = Interpreter::new(&cfg());
    it.set_shared_globals(shared);
    let e = run_in(
        &mut it,
        "$nA[5] += 1;
MSG(\"\" + $nA[5]);
$nA[-1] = 0;
",
    )
    .unwrap_err();
    assert_eq!((e.line, e.col), (3, 1), "{e}");
    let e = run_in(&mut it, "$nNew = 1;\n").unwrap_err();
    assert!(e.message.contains("$nNew: the $ globals hold"), "{e}");
}

#[test]
fn a_dry_run_follows_the_success_path_and_finds_bad_channels() {
    use cnc402_interp::host::channels::DryChannels;
    let (path, text) = example("regression_test.nc");
    let mut it = Interpreter::new(&cfg());
    it.set_channels(Box::new(DryChannels { count: 2, this: 0 }));
    let src = SourceFile::new(path, text);
    let program = cnc402_interp::parse_program(&cfg(), &src, None).unwrap();
    it.load(src, program);
    let segs: Vec<_> = it.by_ref().collect::<Result<_, _>>().unwrap();
    assert_eq!(msgs(&segs).len(), 6);
    let mut dry = DryChannels { count: 2, this: 1 };
    let e = run_in_with(&mut dry, "bool b = channel_load(1, \"01.nc\");\n").unwrap_err();
    assert!(
        e.message
            .contains("channel 1 is the channel running this program"),
        "{e}"
    );
    let e = run_in_with(&mut dry, "int n = @CH[2].STATE;\n").unwrap_err();
    assert!(
        e.message.contains("@CH[2]: this machine has 2 channels"),
        "{e}"
    );
    assert_eq!(
        msgs(&run_in_with(&mut dry, "MSG(\"\" + @CH[0].STATE + @CH[1].STATE);\n").unwrap()),
        ["23"]
    );
}

/// Runs `text` on an interpreter whose channels are a copy of `dry`.
fn run_in_with(
    dry: &mut cnc402_interp::host::channels::DryChannels,
    text: &str,
) -> Result<Vec<Segment>, NcError> {
    let mut it = Interpreter::new(&cfg());
    it.set_channels(Box::new(*dry));
    run_in(&mut it, text)
}

#[test]
fn wait_marks_are_in_the_canonical_dump_with_their_line() {
    let (fake, _) = FakeChannels::new(Script::default());
    let mut it = Interpreter::new(&cfg());
    it.set_channels(Box::new(fake));
    let src = SourceFile::new("c.nc", "G90 G1 X5 F500\nN20 M130 P21\nwait_mark(9, 1);\n");
    let program = cnc402_interp::parse_program(&cfg(), &src, None).unwrap();
    it.load(src, program);
    let mut ops = Vec::new();
    while let Some(op) = it.next_canon().unwrap() {
        ops.push(op);
    }
    let dump = cnc402_interp::dump::canon::canon_to_jsonl(&ops, &cfg());
    let waits: Vec<&str> = dump.lines().filter(|l| l.contains("wait_mark")).collect();
    assert_eq!(waits.len(), 2, "{dump}");
    assert!(
        waits[0].contains("\"mark\":130,\"channels\":3"),
        "{}",
        waits[0]
    );
    assert!(waits[0].contains("\"line\":2"), "{}", waits[0]);
    assert!(
        waits[1].contains("\"mark\":9,\"channels\":1"),
        "{}",
        waits[1]
    );
}
