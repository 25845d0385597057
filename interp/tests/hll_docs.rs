//! Runs every example of `docs/language.md` on the shipped machine: `nc` blocks must run to
//! their end and show each `// prints:` text as a message, in order; `nc-error` blocks must
//! stop with an error containing their `// error:` text. Blocks marked `two-channel` run on
//! channel 0 of the scripted two-channel machine of `chan_common` (named as if they stood in
//! `examples/axioma/`, where its part programs are).

#![allow(clippy::result_large_err)]

mod chan_common;

use cnc402_config::MachineConfig;
use cnc402_lang::SourceFile;
use cnc402_motion::segment::SegmentKind;

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/..");

/// (line of the fence, info string, body) of every fenced block.
fn blocks(doc: &str) -> Vec<(usize, String, String)> {
    let mut out = Vec::new();
    let mut cur: Option<(usize, String, String)> = None;
    for (i, l) in doc.lines().enumerate() {
        if let Some(info) = l.strip_prefix("```") {
            match cur.take() {
                Some(b) => out.push(b),
                None => cur = Some((i + 1, info.trim().to_string(), String::new())),
            }
        } else if let Some((_, _, body)) = cur.as_mut() {
            body.push_str(l);
            body.push('\n');
        }
    }
    out
}

#[test]
fn every_example_in_the_language_reference_runs_as_documented() {
    let doc = std::fs::read_to_string(format!("{ROOT}/docs/language.md")).unwrap();
    let cfg = MachineConfig::load(format!("{ROOT}/config/machine.toml")).unwrap();
    let mut ran = 0;
    for (line, info, body) in blocks(&doc) {
        let (info, two_channel) = match info.strip_suffix(" two-channel") {
            Some(i) => (i.to_string(), true),
            None => (info, false),
        };
        if info != "nc" && info != "nc-error" {
            continue;
        }
        let r = if two_channel {
            let src = SourceFile::new(
                format!("{ROOT}/examples/axioma/example-{line}.nc"),
                body.clone(),
            );
            let (fake, _) = chan_common::FakeChannels::new(chan_common::Script::default());
            let mut it = cnc402_interp::Interpreter::new(&cfg);
            it.set_channels(Box::new(fake));
            cnc402_interp::parse_program(&cfg, &src, None).and_then(|p| {
                it.load(src, p);
                it.collect()
            })
        } else {
            // Named as if it stood in docs/ (so `#use` looks there, then in the library folder).
            let src = SourceFile::new(format!("{ROOT}/docs/example-{line}.nc"), body.clone());
            cnc402_interp::host_fs::run_program(&cfg, &src)
        };
        let want = |tag: &str| -> Vec<String> {
            body.lines()
                .filter_map(|l| l.trim().strip_prefix(tag).map(|t| t.trim().to_string()))
                .collect()
        };
        if info == "nc" {
            let segs = r.unwrap_or_else(|e| panic!("docs/language.md:{line}: {e}"));
            let msgs: Vec<String> = segs
                .iter()
                .filter_map(|s| match &s.kind {
                    SegmentKind::Message { text } => Some(text.clone()),
                    _ => None,
                })
                .collect();
            let prints = want("// prints:");
            let mut at = 0;
            for p in &prints {
                match msgs[at..].iter().position(|m| m == p) {
                    Some(k) => at += k + 1,
                    None => {
                        panic!("docs/language.md:{line}: no message {p:?} in order; got {msgs:?}")
                    }
                }
            }
        } else {
            let e = match r {
                Ok(_) => panic!("docs/language.md:{line}: ran without the documented error"),
                Err(e) => e.to_string(),
            };
            let w = want("// error:");
            assert_eq!(w.len(), 1, "docs/language.md:{line}: one `// error:` line");
            assert!(
                e.contains(&w[0]),
                "docs/language.md:{line}: {e}\nwanted: {}",
                w[0]
            );
        }
        ran += 1;
    }
    assert!(ran >= 20, "only {ran} examples found");
}
