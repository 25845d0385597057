//! The SVG plot of a run (`cnc402 run --plot`): the toolpath from above (XY) and from the side
//! (XZ) coloured by path speed, every axis's commanded velocity and following error against
//! time, and, when the program taps, Z and C against time with the rigid-tap coupling error.
//! A run of several channels gets one such section per channel, on one time axis.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::recorder::PlotPoint;
use crate::report::RunReport;
use crate::run::{ChannelRun, ChannelsReport};

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;
type Err<'e> = &'e dyn Fn(&dyn std::fmt::Display) -> String;
type Xy =
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>;
/// A chart against time with a scale on each side.
type TimeChart<'a, 'b> = plotters::chart::DualCoordChartContext<'a, SVGBackend<'b>, Xy, Xy>;

/// Height of the toolpath row, of each time-series panel, and of the two tapping panels.
const PATH_H: u32 = 430;
const SERIES_H: u32 = 260;
const TAP_H: (u32, u32) = (430, 270);
const WIDTH: u32 = 1000;
/// Height of a line under a title (a channel's programs, its error) and of the run's title
/// above the channels' sections.
const LINE_H: u32 = 24;
const TITLE_H: u32 = 40;
/// A heading's lines hold at most this many characters (to fit the width), and a heading
/// at most this many lines.
const LINE_CHARS: usize = 100;
const MAX_LINES: usize = 8;
/// Path speeds are drawn in this many colours (blue: at rest, red: the run's fastest).
const SPEED_BUCKETS: usize = 12;

/// Draws the plot of `report` into an SVG file (see the module doc). The file is replaced
/// whole (drawn in memory, then written with [`cnc402_durable::write_atomic`]).
pub fn write_plot(path: &Path, report: &RunReport, title: &str) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let mut svg = String::new();
    let t_max = t_end(&report.plot);
    draw_plot(&mut svg, report, (title, &[]), t_max, &err)?;
    cnc402_durable::write_atomic(path, svg.as_bytes()).map_err(|e| err(&e))
}

/// Draws the plot of a run of several channels into one SVG file: `title`, then one section
/// per channel (`<g id="channel-K">`) headed by the channel, its program and how it ended,
/// with the resident channel's programs run, and that channel's panels as [`write_plot`]
/// draws them; a deadlock last (`<g id="deadlock">`). Every time panel spans the whole run,
/// so the channels line up in time.
pub fn write_channels_plot(
    path: &Path,
    report: &ChannelsReport,
    title: &str,
) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let t_max = report
        .channels
        .iter()
        .filter_map(|c| c.result.as_ref().ok())
        .map(|r| t_end(&r.plot))
        .fold(1e-3, f64::max);
    let title = format!(
        "{title}: {} channels, one time axis 0 to {t_max:.3} s",
        report.channels.len()
    );
    let mut lines = wrap(&title);
    let title = lines.remove(0);
    let mut top = String::new();
    let mut y = draw_lines(&mut top, (&title, &lines), &err)?;
    let mut body = String::new();
    let mut section = |id: String, svg: String, h: u32| {
        body.push_str(&format!(
            "<g id=\"{id}\" transform=\"translate(0,{y})\">\n{}\n</g>\n",
            svg.trim_end()
        ));
        y += h;
    };
    for c in &report.channels {
        let mut svg = String::new();
        let h = draw_channel(&mut svg, c, t_max, &err)?;
        section(format!("channel-{}", c.index), svg, h);
    }
    if let Some(d) = &report.deadlock {
        let mut svg = String::new();
        let h = draw_lines(&mut svg, ("deadlock", &wrap(d)), &err)?;
        section("deadlock".into(), svg, h);
    }
    // The sections are SVG documents of their own nested in one; each escapes its text.
    let svg = format!(
        "<svg width=\"{WIDTH}\" height=\"{y}\" viewBox=\"0 0 {WIDTH} {y}\" \
         xmlns=\"http://www.w3.org/2000/svg\">\n{}\n{body}</svg>\n",
        top.trim_end()
    );
    cnc402_durable::write_atomic(path, svg.as_bytes()).map_err(|e| err(&e))
}

/// Channel `c`'s section into `svg`: its panels, or (no report: an error before its run)
/// its headline alone. Returns the section's height.
fn draw_channel(svg: &mut String, c: &ChannelRun, t_max: f64, err: Err) -> Result<u32, String> {
    let mut lines = wrap(&c.headline());
    let title = lines.remove(0);
    if !c.programs.is_empty() {
        lines.extend(wrap(&format!("programs run: {}", c.programs.join("; "))));
    }
    match &c.result {
        Ok(r) if !moved(&r.plot) => {
            // A channel that only runs others (the seed's channel 0) has nothing to draw:
            // empty panels scaled -1…1 would read as a plot of a machine at rest.
            lines.push("no axis moved: no panels".into());
            draw_lines(svg, (&title, &lines), err)
        }
        Ok(r) => draw_plot(svg, r, (&title, &lines), t_max, err),
        Err(_) => draw_lines(svg, (&title, &lines), err),
    }
}

/// Whether any axis's commanded position changed over the plot's points.
fn moved(points: &[PlotPoint]) -> bool {
    points
        .first()
        .is_some_and(|a| points.iter().any(|p| p.cmd != a.cmd))
}

/// A band with a title and, under it, `detail`'s lines. Returns its height.
fn draw_lines(
    svg: &mut String,
    (title, detail): (&str, &[String]),
    err: Err,
) -> Result<u32, String> {
    let height = TITLE_H + LINE_H * detail.len() as u32;
    let root = SVGBackend::with_string(svg, (WIDTH, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    heading(root, (title, detail), err)?
        .present()
        .map_err(|e| err(&e))?;
    Ok(height)
}

/// `title` and `detail`'s lines drawn at the top of `area`; the area under them.
fn heading<'a>(
    area: Area<'a>,
    (title, detail): (&str, &[String]),
    err: Err,
) -> Result<Area<'a>, String> {
    let mut area = area
        .titled(title, ("sans-serif", 20))
        .map_err(|e| err(&e))?;
    for line in detail {
        area = area.titled(line, ("sans-serif", 15)).map_err(|e| err(&e))?;
    }
    Ok(area)
}

/// `text` in lines of at most [`LINE_CHARS`] characters (so that they fit the width), broken
/// after a space where a word would not fit (a word longer than a line where it falls); at
/// most [`MAX_LINES`], the last then ending in `…`.
fn wrap(text: &str) -> Vec<String> {
    let mut lines = vec![String::new()];
    let mut len = 0;
    for word in text.split_inclusive(' ') {
        let word_len = word.trim_end().chars().count();
        for (k, c) in word.chars().enumerate() {
            // A word that fits a line starts one when it does not fit this one; a longer one is
            // split wherever it falls.
            let word_moves =
                k == 0 && len > 0 && word_len > LINE_CHARS - len && word_len <= LINE_CHARS;
            if len == LINE_CHARS || word_moves {
                if lines.len() == MAX_LINES {
                    if let Some(last) = lines.last_mut() {
                        last.push('…');
                    }
                    return lines;
                }
                lines.push(String::new());
                len = 0;
            }
            if let Some(last) = lines.last_mut() {
                last.push(c);
            }
            len += 1;
        }
    }
    lines
}

/// The time of the last point of a series (the end of the run as plotted).
fn t_end(points: &[PlotPoint]) -> f64 {
    points.last().map_or(1.0, |p| p.t).max(1e-3)
}

/// The axes a toolpath is drawn in: X, Y, Z, or where an axis is missing its parallel
/// secondary axis U, V, W (ISO 841), as a second slide or channel has them.
fn plane_axes(names: &[char]) -> [Option<(usize, char)>; 3] {
    let find = |primary: char, secondary: char| {
        [primary, secondary]
            .into_iter()
            .find_map(|c| names.iter().position(|&n| n == c).map(|i| (i, c)))
    };
    [find('X', 'U'), find('Y', 'V'), find('Z', 'W')]
}

/// Draws `report`'s panels (see the module doc) under `title` (and `detail`'s lines), the
/// time panels from 0 to `t_max` s. Returns the height drawn.
fn draw_plot(
    svg: &mut String,
    report: &RunReport,
    (title, detail): (&str, &[String]),
    t_max: f64,
    err: Err,
) -> Result<u32, String> {
    let taps = !report.tapping.is_empty();
    let detail_h = LINE_H * detail.len() as u32;
    let height = detail_h + PATH_H + 2 * SERIES_H + if taps { TAP_H.0 + TAP_H.1 } else { 0 };
    let root = SVGBackend::with_string(svg, (WIDTH, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = heading(root, (title, detail), err)?;
    let (path_row, rest) = root.split_vertically(PATH_H - 30);
    let (vel, rest) = rest.split_vertically(SERIES_H);
    let (fe, rest) = rest.split_vertically(SERIES_H);
    let points: &[PlotPoint] = &report.plot;
    let names: Vec<char> = report.axes.iter().map(|a| a.name).collect();
    let v_max = points.iter().map(|p| p.speed).fold(0.0, f64::max);
    let (left, right) = path_row.split_horizontally(WIDTH / 2);
    let [across, along, up] = plane_axes(&names);
    for (area, view, (a, b)) in [
        (left, "from above", (across, along)),
        (right, "side view", (across, up)),
    ] {
        if let (Some((i, a)), Some((j, b))) = (a, b) {
            let caption =
                format!("toolpath {a}{b} ({view}), path speed blue 0 → red {v_max:.1} mm/s");
            toolpath(&area, points, [i, j], [a, b], v_max, &caption, err)?;
        }
    }
    let linear: Vec<bool> = names.iter().map(|&c| !matches!(c, 'A'..='C')).collect();
    let series = |area: &Area, caption: &str, unit: &str, f: fn(&PlotPoint, usize) -> f64| {
        time_series(
            area,
            points,
            &names,
            &linear,
            (caption, unit, t_max),
            f,
            err,
        )
    };
    series(&vel, "commanded velocity per axis", "/s", |p, i| p.vel[i])?;
    series(&fe, "following error per axis", "", |p, i| p.fe[i])?;
    if taps {
        let (top, bottom) = rest.split_vertically(TAP_H.0);
        tap_positions(&top, points, t_max, err)?;
        tap_coupling(&bottom, points, (report.coupling_bound_um, t_max), err)?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(height)
}

/// `lo..hi` of `values` with a 5 % margin (±1 around a constant, -1..1 for none).
fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
    if !lo.is_finite() {
        (-1.0, 1.0)
    } else if hi - lo < 1e-9 {
        (lo - 1.0, hi + 1.0)
    } else {
        let m = (hi - lo) * 0.05;
        (lo - m, hi + m)
    }
}

/// The toolpath in the plane of axes `ij`, at equal scale on both, each stretch drawn in the
/// colour of its path speed.
fn toolpath(
    area: &Area,
    points: &[PlotPoint],
    ij: [usize; 2],
    names: [char; 2],
    v_max: f64,
    caption: &str,
    err: Err,
) -> Result<(), String> {
    let (mut x0, mut x1) = range(points.iter().map(|p| p.cmd[ij[0]]));
    let (mut y0, mut y1) = range(points.iter().map(|p| p.cmd[ij[1]]));
    // Equal scale: widen the narrower range to the plotting area's aspect.
    let (w, h) = area.dim_in_pixel();
    let aspect = (w.saturating_sub(70)).max(1) as f64 / (h.saturating_sub(70)).max(1) as f64;
    if (x1 - x0) < (y1 - y0) * aspect {
        let grow = ((y1 - y0) * aspect - (x1 - x0)) / 2.0;
        (x0, x1) = (x0 - grow, x1 + grow);
    } else {
        let grow = ((x1 - x0) / aspect - (y1 - y0)) / 2.0;
        (y0, y1) = (y0 - grow, y1 + grow);
    }
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 14))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(50)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc(format!("{} [mm]", names[0]))
        .y_desc(format!("{} [mm]", names[1]))
        .draw()
        .map_err(|e| err(&e))?;
    let bucket = |v: f64| {
        let f = if v_max > 0.0 { v / v_max } else { 0.0 };
        ((f * SPEED_BUCKETS as f64) as usize).min(SPEED_BUCKETS - 1)
    };
    // One polyline per run of points in the same speed colour (joined to the run before).
    let mut start = 0;
    while start + 1 < points.len() {
        let b = bucket(points[start + 1].speed);
        let mut end = start + 1;
        while end + 1 < points.len() && bucket(points[end + 1].speed) == b {
            end += 1;
        }
        let hue = 0.66 * (1.0 - b as f64 / (SPEED_BUCKETS - 1) as f64);
        let colour = HSLColor(hue, 0.9, 0.45);
        chart
            .draw_series(LineSeries::new(
                points[start..=end]
                    .iter()
                    .map(|p| (p.cmd[ij[0]], p.cmd[ij[1]])),
                colour.stroke_width(2),
            ))
            .map_err(|e| err(&e))?;
        start = end;
    }
    Ok(())
}

/// `f(point, axis)` of every axis against time: linear axes on the left scale (mm), rotary
/// axes on the right (degrees).
fn time_series(
    area: &Area,
    points: &[PlotPoint],
    names: &[char],
    linear: &[bool],
    (caption, unit, t_max): (&str, &str, f64),
    f: fn(&PlotPoint, usize) -> f64,
    err: Err,
) -> Result<(), String> {
    let of = |lin: bool| {
        range(
            (0..names.len())
                .filter(|&i| linear[i] == lin)
                .flat_map(|i| points.iter().map(move |p| f(p, i))),
        )
    };
    let mut chart = time_chart(area, (caption, 14), t_max, [of(true), of(false)], err)?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc(format!("linear axes [mm{unit}]"))
        .draw()
        .map_err(|e| err(&e))?;
    if linear.iter().any(|l| !l) {
        chart
            .configure_secondary_axes()
            .y_desc(format!("rotary axes [deg{unit}]"))
            .draw()
            .map_err(|e| err(&e))?;
    }
    for (i, &name) in names.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        let line = LineSeries::new(points.iter().map(|p| (p.t, f(p, i))), colour);
        let drawn = if linear[i] {
            chart.draw_series(line)
        } else {
            chart.draw_secondary_series(line)
        };
        drawn
            .map_err(|e| err(&e))?
            .label(name.to_string())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
    }
    legend(&mut chart, err)
}

/// An empty chart on `area` from 0 to `t_max` s, with the left and right scales `lr`.
fn time_chart<'a, 'b>(
    area: &'a Area<'b>,
    (caption, size): (&str, u32),
    t_max: f64,
    [(l0, l1), (r0, r1)]: [(f64, f64); 2],
    err: Err,
) -> Result<TimeChart<'a, 'b>, String> {
    Ok(ChartBuilder::on(area)
        .caption(caption, ("sans-serif", size))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .right_y_label_area_size(70)
        .build_cartesian_2d(0.0..t_max, l0..l1)
        .map_err(|e| err(&e))?
        .set_secondary_coord(0.0..t_max, r0..r1))
}

/// The labels of `chart`'s series, boxed.
fn legend<'a, 'b: 'a>(chart: &mut TimeChart<'a, 'b>, err: Err) -> Result<(), String> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(&e))
}

/// Z and C setpoints against time, on two y axes.
fn tap_positions(area: &Area, points: &[PlotPoint], t_max: f64, err: Err) -> Result<(), String> {
    let ranges = [
        range(points.iter().map(|p| p.z)),
        range(points.iter().map(|p| p.c)),
    ];
    let caption = ("rigid tapping: Z and C setpoints", 16);
    let mut chart = time_chart(area, caption, t_max, ranges, err)?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc("Z [mm]")
        .draw()
        .map_err(|e| err(&e))?;
    chart
        .configure_secondary_axes()
        .y_desc("C [deg]")
        .draw()
        .map_err(|e| err(&e))?;
    chart
        .draw_series(LineSeries::new(points.iter().map(|p| (p.t, p.z)), &BLUE))
        .map_err(|e| err(&e))?
        .label("Z setpoint")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
    chart
        .draw_secondary_series(LineSeries::new(points.iter().map(|p| (p.t, p.c)), &RED))
        .map_err(|e| err(&e))?
        .label("C setpoint")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    legend(&mut chart, err)
}

/// The coupling error of the setpoints and of the actual positions in µm, with the
/// one-count bound.
fn tap_coupling(
    area: &Area,
    points: &[PlotPoint],
    (bound, t_max): (f64, f64),
    err: Err,
) -> Result<(), String> {
    let e_max = points
        .iter()
        .map(|p| p.coupling_um.abs().max(p.coupling_act_um.abs()))
        .fold(bound, f64::max)
        .max(0.1)
        * 1.1;
    let mut chart = ChartBuilder::on(area)
        .caption(
            "rigid-tap coupling error: setpoints (green), actual (purple), one count (dashed)",
            ("sans-serif", 16),
        )
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .right_y_label_area_size(70)
        .build_cartesian_2d(0.0..t_max, -e_max..e_max)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc("error [µm of Z]")
        .draw()
        .map_err(|e| err(&e))?;
    chart
        .draw_series(LineSeries::new(
            points.iter().map(|p| (p.t, p.coupling_act_um)),
            &MAGENTA.mix(0.8),
        ))
        .map_err(|e| err(&e))?;
    chart
        .draw_series(LineSeries::new(
            points.iter().map(|p| (p.t, p.coupling_um)),
            &GREEN.mix(0.9),
        ))
        .map_err(|e| err(&e))?;
    for b in [bound, -bound] {
        chart
            .draw_series(DashedLineSeries::new(
                [(0.0, b), (t_max, b)],
                6,
                4,
                BLACK.stroke_width(1),
            ))
            .map_err(|e| err(&e))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A heading's text is kept whole (up to its last line), in lines that fit, broken
    /// between words; a word longer than a line is split; the lines are bounded.
    #[test]
    fn wrap_keeps_the_text_in_bounded_lines_that_fit() {
        assert_eq!(wrap(""), [""]);
        assert_eq!(
            wrap("channel 0 (main): a.nc — finished"),
            ["channel 0 (main): a.nc — finished"]
        );
        let words: Vec<String> = (0..40).map(|k| format!("p{k}.nc: ok;")).collect();
        let text = words.join(" ");
        let lines = wrap(&text);
        assert!(lines.len() > 1 && lines.len() < MAX_LINES);
        assert_eq!(lines.concat(), text);
        for l in &lines {
            assert!(l.chars().count() <= LINE_CHARS, "{l}");
        }
        for pair in lines.windows(2) {
            assert!(
                pair[0].ends_with(' ') && !pair[1].starts_with(' '),
                "{pair:?}"
            );
        }
        let long = format!("name: {}", "é".repeat(LINE_CHARS * 3 / 2));
        let lengths: Vec<usize> = wrap(&long).iter().map(|l| l.chars().count()).collect();
        assert_eq!(lengths, [LINE_CHARS, LINE_CHARS / 2 + 6]);
        let lines = wrap(&"word ".repeat(10_000));
        assert_eq!(lines.len(), MAX_LINES);
        assert!(lines[MAX_LINES - 1].ends_with('…'));
    }

    /// A toolpath is drawn in X Y Z, or in the parallel U V W where a channel lacks them.
    #[test]
    fn the_toolpath_plane_falls_back_to_u_v_w() {
        assert_eq!(
            plane_axes(&['X', 'Y', 'Z', 'C']),
            [Some((0, 'X')), Some((1, 'Y')), Some((2, 'Z'))]
        );
        assert_eq!(
            plane_axes(&['U', 'V', 'W']),
            [Some((0, 'U')), Some((1, 'V')), Some((2, 'W'))]
        );
        assert_eq!(
            plane_axes(&['W', 'X', 'U']),
            [Some((1, 'X')), None, Some((0, 'W'))]
        );
        assert_eq!(plane_axes(&['C']), [None, None, None]);
    }
}
