//! The robustness corpus (issue 18): programs that once hung, allocated without bound or put
//! `inf` into the output, each in `tests/corpus/NAME.nc` with its expected end in
//! `NAME.expect`: `ok` (ends, every number finite), `endless` (runs on with motion, never a
//! runaway), or `error [LINE:COL] MESSAGE-PREFIX`. Every file is replayed; the named tests
//! say which bug each is.

use std::path::{Path, PathBuf};

use cnc402_config::MachineConfig;
use cnc402_interp::Interpreter;
use cnc402_lang::SourceFile;
use cnc402_motion::segment::SegmentKind;

/// Segments pulled before a program counts as running on (`endless`); a program expected to
/// end must end before it.
const PULL: usize = 50_000;

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus")
}

fn finite(k: &SegmentKind) -> bool {
    let pos = |p: &cnc402_motion::segment::AxisPos| p.0.iter().all(|v| v.is_finite());
    match k {
        SegmentKind::Rapid { end } => pos(end),
        SegmentKind::Linear { end, feed } => pos(end) && feed.is_finite(),
        SegmentKind::Tap(t) => pos(&t.end) && t.feed.is_finite() && t.pitch.is_finite(),
        SegmentKind::Arc {
            end, center, feed, ..
        } => pos(end) && feed.is_finite() && center.iter().all(|c| c.is_finite()),
        SegmentKind::Dwell { seconds } => seconds.is_finite(),
        SegmentKind::Spindle { rpm, .. } => rpm.is_finite(),
        _ => true,
    }
}

/// Runs `NAME.nc` (block_limit 1000) and checks it ends as `NAME.expect` says.
fn replay(name: &str) {
    let dir = corpus();
    let text = std::fs::read_to_string(dir.join(format!("{name}.nc"))).expect("corpus file");
    let expect = std::fs::read_to_string(dir.join(format!("{name}.expect"))).expect("expect");
    let expect = expect.trim();
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.variables_file = None;
    cfg.interp.block_limit = 1000;
    let src = SourceFile::new(format!("{name}.nc"), text);
    let program = cnc402_lang::parse(&src).unwrap_or_else(|e| panic!("{name}: {e}"));
    let mut it = Interpreter::new(&cfg);
    it.set_program_library(None);
    it.load(src, program);
    let mut pulled = 0;
    let end = loop {
        if pulled == PULL {
            break None;
        }
        match it.next_segment() {
            Ok(Some(s)) => {
                assert!(finite(&s.kind), "{name}: a non-finite segment {s:?}");
                let json = cnc402_interp::dump::segment_to_json(&s, &cfg);
                assert!(
                    !json.contains("inf") && !json.contains("NaN"),
                    "{name}: {json}"
                );
                pulled += 1;
            }
            Ok(None) => break Some(Ok(())),
            Err(e) => break Some(Err(e)),
        }
    };
    match (expect, end) {
        ("ok", Some(Ok(()))) | ("endless", None) => {}
        (want, Some(Err(e))) if want.starts_with("error ") => {
            let mut want = &want[6..];
            if let Some((at, rest)) = want.split_once(' ')
                && at.contains(':')
                && at.chars().all(|c| c.is_ascii_digit() || c == ':')
            {
                assert_eq!(at, format!("{}:{}", e.line, e.col), "{name}: {e}");
                want = rest;
            }
            assert!(e.message.starts_with(want), "{name}: {e}");
        }
        (want, got) => panic!("{name}: expected {want}, got {got:?} after {pulled} segments"),
    }
}

#[test]
fn every_corpus_file_is_replayed() {
    let mut names: Vec<String> = std::fs::read_dir(corpus())
        .expect("corpus dir")
        .filter_map(|e| {
            let p = e.ok()?.path();
            (p.extension()? == "nc").then(|| p.file_stem()?.to_str().map(String::from))?
        })
        .collect();
    names.sort();
    assert!(names.len() >= 16);
    for n in &names {
        replay(n);
    }
}

#[test]
fn g83_tiny_q_makes_ten_million_pecks() {
    replay("g83_tiny_q_makes_ten_million_pecks");
}

#[test]
fn g73_modal_tiny_q_is_refused_at_the_next_hole() {
    replay("g73_modal_tiny_q_is_refused_at_the_next_hole");
}

#[test]
fn g84_peck_tap_tiny_q_is_refused() {
    replay("g84_peck_tap_tiny_q_is_refused");
}

#[test]
fn cycle_repeats_times_pecks_over_the_block_bound() {
    replay("cycle_repeats_times_pecks_over_the_block_bound");
}

#[test]
fn feed_literal_of_400_digits_is_not_inf() {
    replay("feed_literal_of_400_digits_is_not_inf");
}

#[test]
fn inch_feed_overflows_not_inf() {
    replay("inch_feed_overflows_not_inf");
}

#[test]
fn huge_finite_feed_prints_as_a_number() {
    replay("huge_finite_feed_prints_as_a_number");
}

#[test]
fn incremental_g10_offset_overflows() {
    replay("incremental_g10_offset_overflows");
}

#[test]
fn inch_offset_variable_overflows() {
    replay("inch_offset_variable_overflows");
}

#[test]
fn while_zero_length_move_is_runaway() {
    replay("while_zero_length_move_is_runaway");
}

#[test]
fn zero_dwell_and_message_loop_is_runaway() {
    replay("zero_dwell_and_message_loop_is_runaway");
}

#[test]
fn c_like_msg_loop_is_runaway() {
    replay("c_like_msg_loop_is_runaway");
}

#[test]
fn c_like_sleep0_loop_is_runaway() {
    replay("c_like_sleep0_loop_is_runaway");
}

#[test]
fn c_like_zero_move_loop_is_runaway() {
    replay("c_like_zero_move_loop_is_runaway");
}

#[test]
fn messages_between_moves_still_run() {
    replay("messages_between_moves_still_run");
}

#[test]
fn goto_loop_with_motion_is_endless() {
    replay("goto_loop_with_motion_is_endless");
}
