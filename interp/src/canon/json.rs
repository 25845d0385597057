//! The canonical dump: one JSON object per canonical operation (JSON Lines), what
//! `cnc402 canon` prints and the golden tests compare. Same number format and fixed key order
//! as the segment dump ([`crate::dump`]); positions are work coordinates.
//!
//! Keys: `op` (see [`CanonKind::name`]), `file`, `line`, `n`, then the operation's own keys
//! (`end`, `feed`, `center`, `plane`, `dir`, `turns`, `pitch`, `tool_axis`, `spindle_axis`,
//! `seconds`, `rpm`, `angle`, `program`, `tool`, `mist`, `flood`, `stop`, `text`; a
//! `canned_cycle` adds `cycle` (`G81`…), `words`, `start`, `holes`, the `levels` and `tap`),
//! then `state`: `plane`, `units`, `feed_mode`, `path_mode` (`G61` `G63` `G64`, with
//! `tolerance`), `work_offset` (`G54`…), `offset` (work → machine per axis), `tool`,
//! `tool_length_mode` (`G43` `G44` `G49`), `h`, `tool_length`.

use std::fmt::Write;

use cnc402_config::MachineConfig;
use cnc402_motion::segment::{AxisPos, Plane};

use super::{CanonKind, CanonOp, CanonState, CannedCycle, PathMode};
use crate::dump::{arc_dir_name, json_str, num, plane_name, spindle_dir_name, stop_name};

fn axes_obj(o: &mut String, key: &str, p: &AxisPos, cfg: &MachineConfig) {
    let _ = write!(o, ",\"{key}\":{{");
    for (i, ax) in cfg.axes.iter().enumerate() {
        if i > 0 {
            o.push(',');
        }
        let _ = write!(o, "\"{}\":{}", ax.name, num(p[i]));
    }
    o.push('}');
}

fn opt(v: Option<f64>) -> String {
    v.map_or_else(|| "null".into(), num)
}

/// One canonical operation as a single-line JSON object (no trailing newline).
///
/// ```
/// use std::sync::Arc;
/// use cnc402_config::MachineConfig;
/// use cnc402_interp::canon::json::canon_to_json;
/// use cnc402_interp::Interpreter;
/// use cnc402_lang::SourceFile;
/// let cfg = MachineConfig::default_machine();
/// let src = SourceFile::new("a.nc", "G54 G1 X10 F100\n");
/// let prog = cnc402_lang::parse(&src).unwrap();
/// let mut it = Interpreter::new(&cfg);
/// it.load(src, prog);
/// let op = it.next_canon().unwrap().unwrap();
/// let line = canon_to_json(&op, &cfg);
/// assert!(line.starts_with(r#"{"op":"linear","file":"a.nc","line":1,"n":null,"end":{"X":10,"#));
/// ```
pub fn canon_to_json(op: &CanonOp, cfg: &MachineConfig) -> String {
    let mut o = String::with_capacity(320);
    let _ = write!(
        o,
        "{{\"op\":\"{}\",\"file\":{},\"line\":{},\"n\":",
        op.kind.name(),
        json_str(&op.source.file),
        op.source.line
    );
    match op.source.n {
        Some(n) => {
            let _ = write!(o, "{n}");
        }
        None => o.push_str("null"),
    }
    kind_keys(&mut o, &op.kind, cfg);
    state_obj(&mut o, &op.state, cfg);
    o.push('}');
    o
}

fn kind_keys(o: &mut String, kind: &CanonKind, cfg: &MachineConfig) {
    match kind {
        CanonKind::Rapid { end } => axes_obj(o, "end", end, cfg),
        CanonKind::Linear { end, feed } => {
            axes_obj(o, "end", end, cfg);
            let _ = write!(o, ",\"feed\":{}", num(*feed));
        }
        CanonKind::Arc {
            end,
            center,
            plane,
            dir,
            turns,
            feed,
        } => {
            axes_obj(o, "end", end, cfg);
            let _ = write!(
                o,
                ",\"center\":{{\"X\":{},\"Y\":{},\"Z\":{}}},\"plane\":\"{}\",\"dir\":\"{}\",\"turns\":{},\"feed\":{}",
                num(center[0]),
                num(center[1]),
                num(center[2]),
                plane_name(*plane),
                arc_dir_name(*dir),
                turns,
                num(*feed)
            );
        }
        CanonKind::RigidTap(t) => {
            axes_obj(o, "end", &t.end, cfg);
            let name = |i: u8| cfg.axes.get(i as usize).map_or('?', |a| a.name);
            let _ = write!(
                o,
                ",\"feed\":{},\"pitch\":{},\"tool_axis\":\"{}\",\"spindle_axis\":\"{}\"",
                num(t.feed),
                num(t.pitch),
                name(t.tool),
                name(t.spindle)
            );
        }
        CanonKind::CannedCycle(cc) => cycle_keys(o, cc, cfg),
        CanonKind::Dwell { seconds } => {
            let _ = write!(o, ",\"seconds\":{}", num(*seconds));
        }
        CanonKind::Spindle { rpm, dir } => {
            let _ = write!(
                o,
                ",\"rpm\":{},\"dir\":\"{}\"",
                num(*rpm),
                spindle_dir_name(*dir)
            );
        }
        CanonKind::SpindleOrient { angle, program } => {
            let _ = write!(o, ",\"angle\":{}", num(*angle));
            if let Some(c) = program {
                let _ = write!(o, ",\"program\":{}", num(*c));
            }
        }
        CanonKind::ToolChange { tool } => {
            let _ = write!(o, ",\"tool\":{tool}");
        }
        CanonKind::Coolant { mist, flood } => {
            let _ = write!(o, ",\"mist\":{mist},\"flood\":{flood}");
        }
        CanonKind::ProgramStop { kind } => {
            let _ = write!(o, ",\"stop\":\"{}\"", stop_name(*kind));
        }
        CanonKind::Message { text } => {
            let _ = write!(o, ",\"text\":{}", json_str(text));
        }
    }
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
            let _ = write!(
                o,
                ",\"tap\":{{\"pitch\":{},\"dir\":\"{}\",\"peck\":{},\"peck_retract\":{}}}",
                num(t.pitch),
                spindle_dir_name(t.dir),
                opt(t.peck),
                num(t.peck_retract)
            );
        }
        None => o.push_str(",\"tap\":null"),
    }
}

fn state_obj(o: &mut String, st: &CanonState, cfg: &MachineConfig) {
    let plane = match st.plane {
        Plane::XY => "G17",
        Plane::ZX => "G18",
        Plane::YZ => "G19",
    };
    let units = match st.units {
        super::ProgramUnits::Mm => "G21",
        super::ProgramUnits::Inch => "G20",
    };
    let feed = match st.feed_mode {
        super::FeedMode::PerMinute => "G94",
        super::FeedMode::PerRevolution => "G95",
    };
    let _ = write!(
        o,
        ",\"state\":{{\"plane\":\"{plane}\",\"units\":\"{units}\",\"feed_mode\":\"{feed}\",\"path_mode\":\"G{}\"",
        st.path_mode.code()
    );
    if let PathMode::Continuous { tolerance } = st.path_mode {
        let _ = write!(o, ",\"tolerance\":{}", num(tolerance));
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
