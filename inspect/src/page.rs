//! The toolpath page: one self-contained HTML file (inline script and style, no network)
//! that draws a [`Toolpath`] in 3D (rapids, feeds and taps apart; rotate, zoom, pan), names
//! the block of a clicked point, and marks breakpoints, the dry run's error and a run's
//! trace.
//!
//! Size: the drawing holds at most `max_points` vertices; beyond that, runs of vertices of one
//! kind are merged while every dropped vertex stays within a tolerance of the drawn line
//! (doubled until the cap holds). Block lookup stays exact: the page also carries every
//! piece's exact geometry (ends in µm, arcs' centre, radii and sweep) and each drawn vertex
//! the piece it belongs to; a click picks the nearest drawn edge, then measures the exact
//! pieces that edge spans and names the nearest one's block.

use serde_json::{Value, json};

use crate::breaks::Resolved;
use crate::geom::{P3, Shape, dist};
use crate::source::SourceText;
use crate::toolpath::{PieceKind, Toolpath};
use crate::trace::TraceRow;

const TEMPLATE: &str = include_str!("page.html");
const SCRIPT: &str = include_str!("page.js");

/// Chord tolerance of drawn arcs (mm).
const ARC_TOLERANCE: f64 = 0.005;
/// First merging tolerance tried when the drawing is over its cap (mm).
const FIRST_DECIMATION: f64 = 0.002;
/// Most vertices one merged run spans (keeps merging linear in the vertex count).
const MERGE_WINDOW: usize = 64;
/// Most merging passes (the tolerance doubles each time: 0.002 mm · 2^24 ≈ 34 m).
const MAX_PASSES: u32 = 24;

/// What goes on the page besides the toolpath.
pub struct PageInput<'a> {
    /// The program as named on the command line (the page's title, the `which` hint).
    pub program: &'a str,
    pub breaks: &'a [Resolved],
    pub trace: Option<&'a [TraceRow]>,
    /// Most drawn vertices.
    pub max_points: usize,
}

/// What writing the page did to the drawing.
#[derive(Clone, Debug, PartialEq)]
pub struct PageStats {
    pub pieces: usize,
    /// Vertices before merging.
    pub vertices: usize,
    pub drawn: usize,
    /// The merging tolerance (mm), 0 when nothing was merged.
    pub tolerance: f64,
}

fn um(x: f64) -> i64 {
    (x * 1000.0).round() as i64
}

/// `values` (groups of three) as µm integers, each the difference from the value three
/// places before (paths are continuous, so the numbers stay short).
fn delta_um(values: &[P3]) -> Vec<i64> {
    let mut prev = [0i64; 3];
    let mut out = Vec::with_capacity(values.len() * 3);
    for p in values {
        for k in 0..3 {
            let v = um(p[k]);
            out.push(v - prev[k]);
            prev[k] = v;
        }
    }
    out
}

/// The drawing: polyline vertices, the piece each belongs to, and where a new strip starts.
struct Drawing {
    points: Vec<P3>,
    piece: Vec<u32>,
    /// Vertex starts a strip (no edge from the vertex before).
    starts: Vec<bool>,
}

fn drawing(tp: &Toolpath) -> Drawing {
    let mut d = Drawing {
        points: Vec::new(),
        piece: Vec::new(),
        starts: Vec::new(),
    };
    for (i, p) in tp.pieces.iter().enumerate() {
        let poly = p.path.polyline(ARC_TOLERANCE);
        let joined = d
            .points
            .last()
            .is_some_and(|last| dist(last, &poly[0]) < 1e-6);
        for (k, v) in poly.into_iter().enumerate() {
            if k == 0 && joined {
                continue;
            }
            d.points.push(v);
            d.piece.push(i as u32);
            d.starts.push(k == 0);
        }
    }
    d
}

/// Distance of `x` from the line through `a` and `b` (segment).
fn off_line(x: &P3, a: &P3, b: &P3) -> f64 {
    crate::geom::Path3 {
        start: *a,
        end: *b,
        shape: Shape::Line,
    }
    .nearest(x)
    .0
}

/// One merging pass at tolerance `tol`: a vertex is dropped when it lies within `tol` of the
/// line between the kept vertices around it, inside one strip and one kind.
fn merge(d: &Drawing, kinds: &[PieceKind], tol: f64) -> Vec<usize> {
    let n = d.points.len();
    let mut keep = Vec::with_capacity(n / 2 + 2);
    let mut k = 0;
    while k < n {
        keep.push(k);
        let mut j = k + 1;
        let mut best = k + 1;
        while j < n && j - k <= MERGE_WINDOW && !d.starts[j] {
            if kinds[d.piece[j] as usize] != kinds[d.piece[k + 1] as usize] {
                break;
            }
            if (k + 1..j).all(|m| off_line(&d.points[m], &d.points[k], &d.points[j]) <= tol) {
                best = j;
            } else {
                break;
            }
            j += 1;
        }
        k = best;
    }
    keep
}

/// The page's data: files, blocks with their text, pieces, drawing, marks, trace.
fn page_data(tp: &Toolpath, input: &PageInput, sources: &mut SourceText) -> (Value, PageStats) {
    let blocks: Vec<Value> = tp
        .blocks
        .iter()
        .map(|b| json!([b.file, b.line, b.n, sources.line(&tp.files[b.file], b.line)]))
        .collect();
    let ends: Vec<P3> = tp
        .pieces
        .iter()
        .flat_map(|p| [p.path.start, p.path.end])
        .collect();
    let kinds: Vec<PieceKind> = tp.pieces.iter().map(|p| p.kind).collect();
    let kind_str: String = kinds
        .iter()
        .map(|k| match k {
            PieceKind::Rapid => 'R',
            PieceKind::Feed => 'F',
            PieceKind::Tap => 'T',
        })
        .collect();
    let arcs: serde_json::Map<String, Value> = tp
        .pieces
        .iter()
        .enumerate()
        .filter_map(|(i, p)| {
            let (a, c, (p, q, _)) = p.path.arc_params()?;
            let c = [um(c[0]), um(c[1]), um(c[2])];
            Some((i.to_string(), json!([c, p, q, a.a0, a.r0, a.r1, a.sweep])))
        })
        .collect();
    let d = drawing(tp);
    let mut keep: Vec<usize> = (0..d.points.len()).collect();
    let mut tol = 0.0;
    let mut next = FIRST_DECIMATION;
    for _ in 0..MAX_PASSES {
        if keep.len() <= input.max_points.max(2) {
            break;
        }
        keep = merge(&d, &kinds, next);
        tol = next;
        next *= 2.0;
    }
    let drawn: Vec<P3> = keep.iter().map(|&i| d.points[i]).collect();
    let stats = PageStats {
        pieces: tp.pieces.len(),
        vertices: d.points.len(),
        drawn: drawn.len(),
        tolerance: tol,
    };
    let data = json!({
        "program": input.program,
        "frame": tp.frame.map_or("work", |f| f.name()),
        "files": tp.files.iter().map(|f| f.to_string()).collect::<Vec<_>>(),
        "blocks": blocks,
        "pieces": {"kind": kind_str, "block": tp.pieces.iter().map(|p| p.block).collect::<Vec<_>>(),
                   "ends": delta_um(&ends), "arcs": arcs},
        "draw": {"points": delta_um(&drawn),
                 "piece": keep.iter().map(|&i| d.piece[i]).collect::<Vec<_>>(),
                 "starts": keep.iter().enumerate().filter(|&(k, &i)| k == 0 || d.starts[i]).map(|(k, _)| k).collect::<Vec<_>>(),
                 "tolerance": tol},
        "breaks": input.breaks.iter().map(|r| json!({"spec": r.spec, "blocks": r.blocks, "warning": r.warning})).collect::<Vec<_>>(),
        "error": tp.error.as_ref().map(|e| json!({"file": e.file.to_string(), "line": e.line, "col": e.col,
            "message": e.message, "expected": e.expected, "block": e.block.trim(),
            "at": tp.pieces.last().map(|p| delta_um(&[p.path.end]))})),
        "truncated": tp.truncated,
        "trace": input.trace.map(|rows| json!({
            "cmd": delta_um(&rows.iter().map(|r| r.cmd).collect::<Vec<_>>()),
            "act": delta_um(&rows.iter().map(|r| r.act).collect::<Vec<_>>()),
        })),
    });
    (data, stats)
}

/// `s` safe inside an HTML element's text.
fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The whole page for `tp`.
pub fn render(tp: &Toolpath, input: &PageInput, sources: &mut SourceText) -> (String, PageStats) {
    let (data, stats) = page_data(tp, input, sources);
    // JSON inside <script>: a `</` would end the element.
    let data = data.to_string().replace("</", "<\\/");
    // The title first, its braces escaped, so that nothing inserted later is read as a mark.
    let title = html_escape(input.program).replace('{', "&#123;");
    let html = TEMPLATE
        .replace("{{TITLE}}", &title)
        .replace("{{SCRIPT}}", SCRIPT)
        .replace("{{DATA}}", &data);
    (html, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Path3;
    use crate::toolpath::{Block, Piece};

    fn zigzag(n: usize) -> Toolpath {
        let pieces = (0..n)
            .map(|i| Piece {
                block: i,
                kind: PieceKind::Feed,
                path: Path3 {
                    start: [i as f64 * 0.1, (i % 2) as f64 * 0.001, 0.0],
                    end: [(i + 1) as f64 * 0.1, ((i + 1) % 2) as f64 * 0.001, 0.0],
                    shape: Shape::Line,
                },
                offset: [0.0; 3],
            })
            .collect();
        Toolpath {
            files: vec!["z.nc".into()],
            blocks: (0..n)
                .map(|i| Block {
                    file: 0,
                    line: i as u32 + 1,
                    n: None,
                })
                .collect(),
            pieces,
            ..Toolpath::default()
        }
    }

    #[test]
    fn a_drawing_over_its_cap_is_merged_within_a_tolerance_and_lookup_stays_whole() {
        let tp = zigzag(5000);
        let input = PageInput {
            program: "z.nc",
            breaks: &[],
            trace: None,
            max_points: 500,
        };
        let (data, stats) = page_data(&tp, &input, &mut SourceText::default());
        assert!(stats.drawn <= 500 && stats.drawn > 10, "{stats:?}");
        assert!(
            stats.tolerance >= 0.001 && stats.tolerance < 0.01,
            "{stats:?}"
        );
        // Every piece keeps its exact ends: 2 points × 3 numbers.
        assert_eq!(data["pieces"]["ends"].as_array().unwrap().len(), 5000 * 6);
        let (_, small) = page_data(&zigzag(10), &input, &mut SourceText::default());
        assert_eq!((small.drawn, small.tolerance), (11, 0.0));
    }

    #[test]
    fn script_ends_inside_data_cannot_close_the_element() {
        let tp = zigzag(1);
        let input = PageInput {
            program: "</script><b>x.nc",
            breaks: &[],
            trace: None,
            max_points: 10,
        };
        let (html, _) = render(&tp, &input, &mut SourceText::default());
        assert_eq!(
            html.matches("</script>").count(),
            2,
            "the script and the data"
        );
        assert!(html.contains("&lt;/script&gt;&lt;b&gt;x.nc"));
    }
}
