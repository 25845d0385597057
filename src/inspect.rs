//! `cnc402 which` and `cnc402 view`: the verification views of a program (point → block, the
//! toolpath page) over the `cnc402-inspect` crate; a dry run of the interpreter, nothing
//! moves. A program error ends the path where it happened: what ran is still answered or
//! drawn, then the error is reported (exit 2).

use std::path::{Path, PathBuf};

use cnc402_config::MachineConfig;
use cnc402_inspect::breaks::{self, BreakSpec};
use cnc402_inspect::page::{self, PageInput};
use cnc402_inspect::source::SourceText;
use cnc402_inspect::{Frame, Toolpath, trace, which};
use cnc402_lang::ast::Program;
use cnc402_lang::{Dialect, SourceFile};

use crate::cli_error::CliError;

/// `cnc402 which` arguments.
#[derive(clap::Args, Debug)]
pub struct WhichArgs {
    /// The NC program.
    program: PathBuf,
    /// The point, in work coordinates of each block's offsets (with --machine: machine).
    #[arg(allow_negative_numbers = true)]
    x: f64,
    #[arg(allow_negative_numbers = true)]
    y: f64,
    #[arg(allow_negative_numbers = true)]
    z: f64,
    /// How many blocks to list, nearest first.
    #[arg(long, short = 'n', default_value_t = 5, value_name = "N")]
    count: usize,
    /// Exit 5 when no path passes within this distance of the point (mm).
    #[arg(long, default_value_t = 1.0, value_name = "MM")]
    within: f64,
    /// The point is in machine coordinates (what the drives are sent).
    #[arg(long)]
    machine: bool,
    /// Read the program in this dialect (fanuc, haas, linuxcnc).
    #[arg(long, value_name = "NAME")]
    dialect: Option<Dialect>,
}

/// `cnc402 view` arguments.
#[derive(clap::Args, Debug)]
pub struct ViewArgs {
    /// The NC program.
    program: PathBuf,
    /// The HTML file to write.
    #[arg(long, short = 'o', value_name = "FILE.html")]
    output: PathBuf,
    /// Mark a breakpoint: N<number> (N1700) or FILE:LINE (part.nc:42); repeatable.
    #[arg(long = "break", value_name = "N|FILE:LINE")]
    breaks: Vec<String>,
    /// Overlay a run's trace (`cnc402 run --trace FILE.csv`): actual and commanded positions.
    #[arg(long, value_name = "FILE.csv")]
    trace: Option<PathBuf>,
    /// Draw in machine coordinates instead of the blocks' work coordinates.
    #[arg(long)]
    machine: bool,
    /// Most vertices drawn; a longer path is merged within a tolerance (lookup stays exact).
    #[arg(long, default_value_t = 200_000, value_name = "N")]
    max_points: usize,
    /// Read the program in this dialect (fanuc, haas, linuxcnc).
    #[arg(long, value_name = "NAME")]
    dialect: Option<Dialect>,
}

/// Most trace rows drawn.
const TRACE_ROWS: usize = 50_000;

/// The program's toolpath by a dry run of the interpreter (at most as many segments as
/// `cnc402 run` checks before motion), with the parsed program and its source.
fn toolpath(
    cfg: &MachineConfig,
    program: &Path,
    dialect: Option<Dialect>,
    frame: Frame,
) -> Result<(Toolpath, Program, SourceFile), CliError> {
    let src = crate::load_program(program)?;
    let mut interp = cnc402_interp::host_fs::interpreter(
        cfg,
        cnc402_interp::Options::default(),
        cnc402_interp::host_fs::VarsAccess::ReadOnly,
    );
    // A Heidenhain program is read through its reader, line by line as `segments` reads
    // it (it has no N numbers: the parsed program is empty).
    let first = if src.line_count() > 0 {
        src.line_text(1)
    } else {
        ""
    };
    let ast = if cnc402_lang::heidenhain::is_heidenhain(&src.name, first) {
        let file = crate::open_program(program)?;
        interp
            .load_stream(src.name.to_string(), Box::new(file), dialect)
            .map_err(CliError::Program)?;
        Program {
            lines: Vec::new(),
            dialect: cnc402_lang::Dialect::Fanuc,
        }
    } else {
        let ast = cnc402_interp::parse_program(cfg, &src, dialect).map_err(CliError::Program)?;
        interp.load(src.clone(), ast.clone());
        ast
    };
    let tp = Toolpath::collect(
        cfg,
        &mut interp,
        frame,
        cnc402_runtime::feeder::DRY_RUN_MOVES,
    );
    if tp.truncated {
        eprintln!(
            "note: the program goes on past the first {} segments (what `cnc402 run` checks \
             before motion); only those are used",
            cnc402_runtime::feeder::DRY_RUN_MOVES
        );
    }
    Ok((tp, ast, src))
}

/// A coordinate to the µm, without a sign on a zero that rounding made negative.
fn mm(v: f64) -> String {
    let s = format!("{v:.3}");
    if s == "-0.000" { "0.000".into() } else { s }
}

fn frame(machine: bool) -> Frame {
    if machine { Frame::Machine } else { Frame::Work }
}

pub fn which(cfg: &MachineConfig, args: WhichArgs) -> Result<(), CliError> {
    if !(args.within.is_finite() && args.within >= 0.0) || args.count == 0 {
        return Err(CliError::Usage(
            "--within must be a distance ≥ 0 and --count at least 1".into(),
        ));
    }
    let point = [args.x, args.y, args.z];
    if point.iter().any(|v| !v.is_finite()) {
        return Err(CliError::Usage("the point's X Y Z must be numbers".into()));
    }
    let frame = frame(args.machine);
    let (mut tp, _, src) = toolpath(cfg, &args.program, args.dialect, frame)?;
    let mut text = SourceText::default();
    text.insert(src);
    let hits = which::nearest_blocks(&tp, &point, args.count);
    println!(
        "blocks nearest X{} Y{} Z{} ({} coordinates{}), nearest first:",
        args.x,
        args.y,
        args.z,
        frame.name(),
        if args.machine {
            ""
        } else {
            " of each block's offsets"
        }
    );
    for h in &hits {
        let b = &tp.blocks[h.block];
        let file = tp.files[b.file].clone();
        println!(
            "{:>10.3} mm  {}  {:<5}  at X{} Y{} Z{}  | {}",
            h.distance,
            tp.block_label(h.block),
            h.kind.name(),
            mm(h.nearest[0]),
            mm(h.nearest[1]),
            mm(h.nearest[2]),
            text.line(&file, b.line)
        );
    }
    if let Some(e) = tp.error.take() {
        eprintln!("the dry run stopped at an error; the path above is what ran before it");
        return Err(CliError::Program(e));
    }
    match hits.first() {
        None => Err(CliError::Far(
            "the program has no path (no rapid, feed, arc or tap move)".into(),
        )),
        Some(h) if h.distance > args.within => Err(CliError::Far(format!(
            "no path passes within {} mm of the point: the nearest is {} at {:.3} mm",
            args.within,
            tp.block_label(h.block),
            h.distance
        ))),
        Some(_) => Ok(()),
    }
}

/// The (N, line) pairs of the program's text.
fn numbered_lines(ast: &Program) -> Vec<(u32, u32)> {
    ast.lines
        .iter()
        .filter_map(|l| l.n.as_ref().map(|n| (n.value, l.line_no)))
        .collect()
}

pub fn view(cfg: &MachineConfig, args: ViewArgs) -> Result<(), CliError> {
    let specs = args
        .breaks
        .iter()
        .map(|s| BreakSpec::parse(s).map(|b| (s.clone(), b)))
        .collect::<Result<Vec<_>, _>>()
        .map_err(CliError::Usage)?;
    if args.max_points < 2 {
        return Err(CliError::Usage("--max-points must be at least 2".into()));
    }
    let (mut tp, ast, src) = toolpath(cfg, &args.program, args.dialect, frame(args.machine))?;
    let main_file = src.name.to_string();
    let numbered = numbered_lines(&ast);
    let resolved: Vec<breaks::Resolved> = specs
        .iter()
        .map(|(written, spec)| breaks::resolve(&tp, spec, written, &main_file, &numbered))
        .collect();
    for w in resolved.iter().filter_map(|r| r.warning.as_ref()) {
        eprintln!("warning: {w}");
    }
    let trace_rows = match &args.trace {
        None => None,
        Some(p) => {
            let f = std::fs::File::open(p)
                .map_err(|e| CliError::Io(format!("{}: {e}", p.display())))?;
            let mut rows = trace::read(std::io::BufReader::new(f), TRACE_ROWS)
                .map_err(|e| CliError::Io(format!("{}: {e}", p.display())))?;
            trace::to_frame(&mut rows, &tp, &main_file);
            Some(rows)
        }
    };
    let mut text = SourceText::default();
    text.insert(src);
    let input = PageInput {
        program: &main_file,
        breaks: &resolved,
        trace: trace_rows.as_deref(),
        max_points: args.max_points,
    };
    let (html, stats) = page::render(&tp, &input, &mut text);
    cnc402_durable::write_atomic(&args.output, html.as_bytes())
        .map_err(|e| CliError::Io(format!("{}: {e}", args.output.display())))?;
    eprintln!(
        "wrote {} ({} bytes): {} path pieces of {} blocks, {} of {} vertices drawn{}",
        args.output.display(),
        html.len(),
        stats.pieces,
        tp.blocks.len(),
        stats.drawn,
        stats.vertices,
        if stats.tolerance > 0.0 {
            format!(
                " (merged within {} mm; block lookup exact)",
                stats.tolerance
            )
        } else {
            String::new()
        }
    );
    match tp.error.take() {
        Some(e) => {
            eprintln!("the page shows the path up to this error, marked:");
            Err(CliError::Program(e))
        }
        None => Ok(()),
    }
}
