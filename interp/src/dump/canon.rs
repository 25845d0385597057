//! The canonical dump: one JSON object per canonical operation (JSON Lines), what
//! `cnc402 canon` prints and the golden tests compare. Same number format, key order and
//! per-kind keys as the segment dump; positions are work coordinates.
//!
//! Keys: `op` (`canned_cycle`, or the segment kind a single operation is: `rapid`, `linear`,
//! `tap`, `arc`, `dwell`…), `file`, `line`, `n`, then the operation's keys as the segment dump
//! writes them (`end`, `feed`, `center`…; a `tap` has `tool`, `spindle`, `pitch`). A `canned_cycle` has `cycle` (`G81`…), `words` (`R` `Z` `Q` `P` as programmed in
//! mm, `F`, `K`, `G91`, `G99`), `start`, `holes` (plane axes, one per repeat), `drill_axis`,
//! `levels` (`initial` `R` `bottom` `return`), `feed` and `tap` (`pitch` `dir` `peck`
//! `peck_retract`, or null), and `spindle` when it is not spindle 1. Last, `state`:
//! `plane` (`G17`…), `units`, `feed_mode`,
//! `path_mode` (`G61` `G63` `G64`, with `tolerance`), `work_offset` (`G54`…), `offset` (work →
//! machine per axis), `tool`, `tool_length_mode` (`G43` `G44` `G49`), `h`, `tool_length`.

use std::fmt::Write;

use cnc402_config::MachineConfig;
use cnc402_motion::segment::{Plane, SpindleDir};

use super::{axes_obj, kind_keys, kind_name, num, source_keys, spindle_number};
use crate::canon::{CannedCycle, CanonKind, CanonOp, CanonState, FeedMode, PathMode, ProgramUnits};

fn opt(v: Option<f64>) -> String {
    v.map_or_else(|| "null".into(), num)
}

/// One canonical operation as a single-line JSON object (no trailing newline).
///
/// ```
/// use cnc402_config::MachineConfig;
/// use cnc402_interp::dump::canon::canon_to_json;
/// use cnc402_interp::Interpreter;
/// use cnc402_lang::SourceFile;
/// let cfg = MachineConfig::default_machine();
/// let src = SourceFile::new("a.nc", "G55 G1 X10 F100\n");
/// let prog = cnc402_lang::parse(&src).unwrap();
/// let mut it = Interpreter::new(&cfg);
/// it.load(src, prog);
/// let op = it.next_canon().unwrap().unwrap();
/// let line = canon_to_json(&op, &cfg);
/// assert!(line.starts_with(r#"{"op":"linear","file":"a.nc","line":1,"n":null,"end":{"X":10,"#));
/// assert!(line.contains(r#""work_offset":"G55""#));
/// ```
pub fn canon_to_json(op: &CanonOp, cfg: &MachineConfig) -> String {
    let mut o = String::with_capacity(400);
    match &op.kind {
        CanonKind::Single(kind) => {
            source_keys(&mut o, "op", kind_name(kind), &op.source);
            kind_keys(&mut o, kind, cfg);
        }
        CanonKind::CannedCycle(cc) => {
            source_keys(&mut o, "op", "canned_cycle", &op.source);
            cycle_keys(&mut o, cc, cfg);
        }
    }
    state_obj(&mut o, &op.state, cfg);
    o.push('}');
    o
}

/// Operations as JSON Lines, one per line, each ending in `\n`.
pub fn canon_to_jsonl(ops: &[CanonOp], cfg: &MachineConfig) -> String {
    let mut s = String::new();
    for op in ops {
        s.push_str(&canon_to_json(op, cfg));
        s.push('\n');
    }
    s
}

fn cycle_keys(o: &mut String, cc: &CannedCycle, cfg: &MachineConfig) {
    let w = &cc.words;
    let _ = write!(
        o,
        ",\"cycle\":\"G{}\",\"words\":{{\"R\":{},\"Z\":{},\"Q\":{},\"P\":{},\"F\":{},\"K\":{},\"G91\":{},\"G99\":{}}}",
        cc.code,
        opt(w.r),
        opt(w.z),
        opt(w.q),
        opt(w.p),
        num(w.f),
        w.repeats,
        w.incremental,
        w.return_to_r
    );
    axes_obj(o, "start", &cc.start, cfg);
    let name = |i: usize| cfg.axes.get(i).map_or('?', |a| a.name);
    let (a, b, d) = (name(cc.axes[0]), name(cc.axes[1]), name(cc.axes[2]));
    o.push_str(",\"holes\":[");
    for (k, h) in cc.holes.iter().enumerate() {
        if k > 0 {
            o.push(',');
        }
        let _ = write!(o, "{{\"{a}\":{},\"{b}\":{}}}", num(h[0]), num(h[1]));
    }
    let _ = write!(
        o,
        "],\"drill_axis\":\"{d}\",\"levels\":{{\"initial\":{},\"R\":{},\"bottom\":{},\"return\":{}}},\"feed\":{}",
        num(cc.initial_level),
        num(cc.r_level),
        num(cc.bottom),
        num(cc.return_level),
        num(cc.feed)
    );
    match &cc.tap {
        Some(t) => {
            let dir = if t.dir == SpindleDir::Ccw {
                "ccw"
            } else {
                "cw"
            };
            let _ = write!(
                o,
                ",\"tap\":{{\"pitch\":{},\"dir\":\"{dir}\",\"peck\":{},\"peck_retract\":{}}}",
                num(t.pitch),
                opt(t.peck),
                num(t.peck_retract)
            );
        }
        None => o.push_str(",\"tap\":null"),
    }
    spindle_number(o, cc.plan.spindle);
}

fn state_obj(o: &mut String, st: &CanonState, cfg: &MachineConfig) {
    let plane = match st.plane {
        Plane::XY => "G17",
        Plane::ZX => "G18",
        Plane::YZ => "G19",
    };
    let units = match st.units {
        ProgramUnits::Mm => "G21",
        ProgramUnits::Inch => "G20",
    };
    let feed = match st.feed_mode {
        FeedMode::PerMinute => "G94",
        FeedMode::PerRevolution => "G95",
    };
    let _ = write!(
        o,
        ",\"state\":{{\"plane\":\"{plane}\",\"units\":\"{units}\",\"feed_mode\":\"{feed}\",\"path_mode\":\"G{}\"",
        st.path_mode.code()
    );
    if let PathMode::Continuous {
        tolerance,
        collinear,
    } = st.path_mode
    {
        let _ = write!(o, ",\"tolerance\":{}", num(tolerance));
        if collinear > 0.0 {
            let _ = write!(o, ",\"collinear\":{}", num(collinear));
        }
    }
    let _ = write!(o, ",\"work_offset\":\"G{}\"", 54 + st.work_offset);
    axes_obj(o, "offset", &st.offset, cfg);
    match st.tool {
        Some(t) => {
            let _ = write!(o, ",\"tool\":{t}");
        }
        None => o.push_str(",\"tool\":null"),
    }
    let _ = write!(
        o,
        ",\"tool_length_mode\":\"G{}\",\"h\":{},\"tool_length\":{}}}",
        st.tool_length_mode,
        st.h,
        num(st.tool_length)
    );
}
