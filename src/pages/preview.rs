//! The preview before motion: the package's main program dry-run through the interpreter
//! with the page values in an in-memory variables table (nothing written), collecting the hole
//! positions of its canned cycles and rigid-tap strokes from the canonical operations, or the
//! package's own alarm (`#3000`, `G65 H99`). Printed as text, drawn as SVG.

use std::fmt::Write as _;
use std::path::Path;

use cnc402_config::MachineConfig;
use cnc402_interp::canon::{CanonKind, CanonOp};
use cnc402_interp::host_fs::FsLibrary;
use cnc402_interp::{Interpreter, NvTable, Options};
use cnc402_motion::segment::SegmentKind;

use super::spec::fmt_num;
use super::state::PagesState;
use crate::cli_error::CliError;

/// At most this many holes are collected (a pattern of more is cut short and says so).
pub const MAX_HOLES: usize = 100_000;

/// One hole the program will machine (work coordinates of the plane's two axes).
#[derive(Clone, Debug, PartialEq)]
pub struct Hole {
    pub x: f64,
    pub y: f64,
    /// `G81` … `G89`, or `tap` for a programmed rigid-tap stroke.
    pub cycle: String,
    /// R level, bottom and return level along the drilling axis (work coordinates); `None`
    /// for a tap stroke (it has only its bottom).
    pub r: Option<f64>,
    pub bottom: f64,
    pub ret: Option<f64>,
}

/// What a dry run of the package found.
#[derive(Clone, Debug, PartialEq)]
pub struct Preview {
    pub holes: Vec<Hole>,
    /// The names of the two plane axes the holes are given in (X, Y in G17).
    pub axes: [char; 2],
    /// The error that ends the program with these values (the package's alarm), as
    /// `file:line: message`.
    pub alarm: Option<String>,
    /// The dry run stopped at the operation limit before the program ended.
    pub truncated: bool,
}

/// The preview of the pages' values (over the other variables of `file`), the alarm with
/// the pages' words for it.
pub fn of_pages(
    cfg: &MachineConfig,
    state: &PagesState,
    file: &NvTable,
) -> Result<Preview, CliError> {
    let mut p = dry_run(cfg, &state.spec.main, state.table(file.clone()))?;
    p.alarm = p.alarm.map(|a| state.spec.explain(&a));
    Ok(p)
}

/// Runs `main` with the non-volatile variables `table` and no store (the file is not
/// touched), as `cnc402 segments` would, and collects the holes. An unreadable program is an
/// error; anything the program itself ends with is the preview's alarm.
pub fn dry_run(cfg: &MachineConfig, main: &Path, table: NvTable) -> Result<Preview, CliError> {
    let src = crate::load_program(main)?;
    let mut preview = Preview {
        holes: Vec::new(),
        axes: ['X', 'Y'],
        alarm: None,
        truncated: false,
    };
    let ast = match cnc402_interp::parse_program(cfg, &src, None) {
        Ok(a) => a,
        Err(e) => {
            preview.alarm = Some(first_line(&e));
            return Ok(preview);
        }
    };
    let mut it = Interpreter::with_options(cfg, Options::default());
    it.set_program_library(Some(Box::new(FsLibrary::from_config(cfg))));
    it.set_persistent_vars(table, None);
    it.load(src, ast);
    let xy = [cfg.axis_index('X'), cfg.axis_index('Y')];
    // As many operations as `cnc402 run` checks before motion (an endless M99 package ends
    // there; its holes so far are the preview).
    for _ in 0..cnc402_runtime::feeder::DRY_RUN_MOVES {
        match it.next_canon() {
            Ok(Some(op)) => {
                collect(cfg, &op, xy, &mut preview);
                if preview.holes.len() >= MAX_HOLES {
                    preview.holes.truncate(MAX_HOLES);
                    preview.truncated = true;
                    return Ok(preview);
                }
            }
            Ok(None) => return Ok(preview),
            Err(e) => {
                preview.alarm = Some(first_line(&e));
                return Ok(preview);
            }
        }
    }
    preview.truncated = true;
    Ok(preview)
}

fn first_line(e: &cnc402_lang::NcError) -> String {
    e.to_string().lines().next().unwrap_or("").to_string()
}

fn collect(cfg: &MachineConfig, op: &CanonOp, xy: [Option<usize>; 2], p: &mut Preview) {
    match &op.kind {
        CanonKind::CannedCycle(c) => {
            let name = |i: usize| cfg.axes.get(i).map_or('?', |a| a.name);
            p.axes = [name(c.axes[0]), name(c.axes[1])];
            for h in &c.holes {
                p.holes.push(Hole {
                    x: h[0],
                    y: h[1],
                    cycle: format!("G{}", c.code),
                    r: Some(c.r_level),
                    bottom: c.bottom,
                    ret: Some(c.return_level),
                });
            }
        }
        CanonKind::Single(SegmentKind::Tap(t)) => {
            let (Some(x), Some(y)) = (xy[0], xy[1]) else {
                return;
            };
            let (hx, hy, depth) = (t.end.0[x], t.end.0[y], t.end.0[t.tool as usize]);
            // The stroke down and the one back up share the hole: count it once, at its
            // deepest point.
            if let Some(last) = p.holes.last_mut()
                && last.cycle == "tap"
                && last.x == hx
                && last.y == hy
            {
                last.bottom = last.bottom.min(depth);
                return;
            }
            p.holes.push(Hole {
                x: hx,
                y: hy,
                cycle: "tap".into(),
                r: None,
                bottom: depth,
                ret: None,
            });
        }
        CanonKind::Single(_) => {}
    }
}

/// The preview as text: the cycle and one line per hole (`--check`).
pub fn text(p: &Preview) -> String {
    let mut s = String::new();
    let [a, b] = p.axes;
    let _ = writeln!(s, "holes: {}", p.holes.len());
    if !p.holes.is_empty() {
        let _ = writeln!(
            s,
            "{:>5} {:>12} {:>12}  cycle {:>10} {:>10} {:>10}",
            "hole", a, b, "R", "bottom", "return"
        );
    }
    let opt = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
    for (i, h) in p.holes.iter().enumerate() {
        let _ = writeln!(
            s,
            "{:>5} {:>12.3} {:>12.3}  {:<5} {:>10} {:>10.3} {:>10}",
            i + 1,
            h.x,
            h.y,
            h.cycle,
            opt(h.r),
            h.bottom,
            opt(h.ret)
        );
    }
    if p.truncated {
        let _ = writeln!(
            s,
            "(the dry run stopped at its limit of {MAX_HOLES} holes or {} operations; the program goes on)",
            cnc402_runtime::feeder::DRY_RUN_MOVES
        );
    }
    if let Some(a) = &p.alarm {
        let _ = writeln!(s, "alarm: {a}");
    }
    s
}

/// The bounding box of the holes and the work zero, with a margin (never empty).
pub fn bounds(p: &Preview) -> (f64, f64, f64, f64) {
    let (mut x0, mut x1, mut y0, mut y1) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for h in &p.holes {
        (x0, x1, y0, y1) = (x0.min(h.x), x1.max(h.x), y0.min(h.y), y1.max(h.y));
    }
    let m = ((x1 - x0).max(y1 - y0) * 0.08).max(1.0);
    (x0 - m, x1 + m, y0 - m, y1 + m)
}

/// The preview as an SVG drawing: the work zero, the holes in machining order joined by the
/// path between them, each numbered, and the alarm if any.
pub fn svg(p: &Preview, title: &str) -> String {
    let (x0, x1, y0, y1) = bounds(p);
    let size = 600.0;
    let scale = (size - 80.0) / (x1 - x0).max(y1 - y0);
    // Work Y up, SVG y down.
    let px = |x: f64| 40.0 + (x - x0) * scale;
    let py = |y: f64| 60.0 + (y1 - y) * scale;
    let mut s = String::new();
    let h = 60.0 + (y1 - y0) * scale + 40.0;
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{size}\" height=\"{h:.0}\" font-family=\"sans-serif\" font-size=\"11\">"
    );
    let _ = writeln!(s, "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>");
    let _ = writeln!(
        s,
        "<text x=\"10\" y=\"20\" font-size=\"14\">{}</text>",
        xml(title)
    );
    let [a, b] = p.axes;
    let summary = match p.holes.first() {
        Some(h) => format!("{} holes, {}", p.holes.len(), h.cycle),
        None => "no holes".into(),
    };
    let _ = writeln!(s, "<text x=\"10\" y=\"38\">{}</text>", xml(&summary));
    if let Some(al) = &p.alarm {
        let _ = writeln!(
            s,
            "<text x=\"10\" y=\"54\" fill=\"red\">alarm: {}</text>",
            xml(al)
        );
    }
    let (zx, zy) = (px(0.0), py(0.0));
    let _ = writeln!(
        s,
        "<g stroke=\"#888\"><line x1=\"{:.1}\" y1=\"{zy:.1}\" x2=\"{:.1}\" y2=\"{zy:.1}\"/><line x1=\"{zx:.1}\" y1=\"{:.1}\" x2=\"{zx:.1}\" y2=\"{:.1}\"/></g>",
        zx - 12.0,
        zx + 12.0,
        zy - 12.0,
        zy + 12.0
    );
    let _ = writeln!(
        s,
        "<text x=\"{:.1}\" y=\"{:.1}\" fill=\"#888\">{a}0 {b}0</text>",
        zx + 4.0,
        zy + 14.0
    );
    if p.holes.len() > 1 {
        let pts: Vec<String> = p
            .holes
            .iter()
            .map(|h| format!("{:.2},{:.2}", px(h.x), py(h.y)))
            .collect();
        let _ = writeln!(
            s,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"#9ab\" stroke-dasharray=\"4 3\"/>",
            pts.join(" ")
        );
    }
    for (i, h) in p.holes.iter().enumerate() {
        let (cx, cy) = (px(h.x), py(h.y));
        let _ = writeln!(
            s,
            "<circle cx=\"{cx:.2}\" cy=\"{cy:.2}\" r=\"5\" fill=\"none\" stroke=\"black\"><title>{} {a}{} {b}{}</title></circle>",
            i + 1,
            fmt_num(h.x),
            fmt_num(h.y)
        );
        let _ = writeln!(
            s,
            "<text x=\"{:.1}\" y=\"{:.1}\">{}</text>",
            cx + 6.0,
            cy - 6.0,
            i + 1
        );
    }
    s.push_str("</svg>\n");
    s
}

fn xml(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Writes the SVG whole or not at all.
pub fn write_svg(path: &Path, p: &Preview, title: &str) -> Result<(), CliError> {
    cnc402_durable::write_atomic(path, svg(p, title).as_bytes())
        .map_err(|e| CliError::Io(format!("{}: {e}", path.display())))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(tag: &str, program: &str, table: NvTable) -> Preview {
        let dir =
            std::env::temp_dir().join(format!("cnc402-pages-preview-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let main = dir.join("O0001.nc");
        std::fs::write(&main, program).unwrap();
        let p = dry_run(&MachineConfig::default_machine(), &main, table).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        p
    }

    #[test]
    fn holes_come_from_the_programs_cycles_with_the_table_in_memory() {
        let mut t = NvTable::default();
        t.set(500, Some(12.5)).unwrap();
        let p = run(
            "holes",
            "G90 G0 Z10\nG99 G81 X#500 Y1 R2 Z-3 F100\nX20 Y#501\nG80\nM30\n",
            t,
        );
        let xy: Vec<_> = p
            .holes
            .iter()
            .map(|h| (h.x, h.y, h.cycle.as_str(), h.r, h.bottom))
            .collect();
        assert_eq!(
            xy,
            [
                (12.5, 1.0, "G81", Some(2.0), -3.0),
                (20.0, 1.0, "G81", Some(2.0), -3.0)
            ]
        );
        assert_eq!((p.alarm, p.truncated), (None, false));
    }

    #[test]
    fn the_programs_alarm_is_the_previews() {
        let p = run(
            "alarm",
            "G90 G81 X1 R2 Z-3 F100\n#3000=7(VALUES WRONG)\nM30\n",
            NvTable::default(),
        );
        assert_eq!(p.holes.len(), 1);
        assert!(
            p.alarm
                .as_deref()
                .is_some_and(|a| a.ends_with(":2:1: alarm 3007: VALUES WRONG")),
            "{p:?}"
        );
    }

    #[test]
    fn a_pattern_of_more_holes_than_the_limit_is_cut_short_and_says_so() {
        let prog = "G91 G0 Z10\n#1=0\nWHILE[#1 LT 30]DO1\nG98 G81 X0.01 R-1 Z-2 K5000 F100\nG80 G0 X-50\n#1=#1+1\nEND1\nM30\n";
        let p = run("limit", prog, NvTable::default());
        assert_eq!((p.holes.len(), p.truncated), (MAX_HOLES, true));
        assert!(text(&p).contains("stopped at its limit of 100000 holes"));
    }
}
