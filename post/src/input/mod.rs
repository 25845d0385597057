//! The job: any program cnc402 reads (ISO, Macro B, the C-like language) run by the
//! interpreter as far as the canonical layer ([`CanonOp`]: cycles, taps, tool calls, offsets
//! and compensation kept as operations, macros and loops already evaluated).

use cnc402_config::MachineConfig;
use cnc402_interp::canon::CanonOp;
use cnc402_interp::host_fs::{VarsAccess, interpreter};
use cnc402_interp::{Interpreter, Options};
use cnc402_lang::SourceFile;

use crate::PostError;

pub mod apt;
pub mod calls;
pub mod tools;

/// A job's operations, and whether it was CL data (its segments are then the operations'
/// lowering, there being no program text to run again).
pub struct Job {
    pub ops: Vec<CanonOp>,
    pub cl: bool,
    /// The job's own cycle programs and their calls (marked in `ops` by messages).
    pub cycles: Option<calls::Marked>,
    /// The job's sub-programs whose runs are marked in `ops` (iTNC labels).
    pub subs: Vec<calls::SubBody>,
}

/// The job in `text`: CL data ([`apt::is_cl`]) or a program cnc402 runs.
pub fn job(
    cfg: &MachineConfig,
    name: &str,
    text: &str,
    tools: &tools::ToolTable,
) -> Result<Job, PostError> {
    if is_heidenhain_job(name, text) {
        return plain_job(cfg, name, text);
    }
    if apt::is_cl(name, text) {
        Ok(Job {
            ops: apt::read_cl(cfg, name, text, tools)?,
            cl: true,
            cycles: None,
            subs: Vec::new(),
        })
    } else if let Some(marked) = calls::mark(text) {
        let ops = read_marked(cfg, name, text, &marked.text, &marked.line_of)?;
        let cycles = ops.1.then_some(marked);
        Ok(Job {
            ops: ops.0,
            cl: false,
            cycles,
            subs: Vec::new(),
        })
    } else {
        Ok(Job {
            ops: read_job(cfg, name, text)?,
            cl: false,
            cycles: None,
            subs: Vec::new(),
        })
    }
}

/// The job for a target that writes the job's sub-programs as its own (the iTNC's labels):
/// each run of a sub-program `M98` calls begins with a marker ([`calls::mark_subs`]).
pub fn job_with_subs(
    cfg: &MachineConfig,
    name: &str,
    text: &str,
    tools: &tools::ToolTable,
) -> Result<Job, PostError> {
    let marked = match calls::mark_subs(text) {
        Some(m) if !apt::is_cl(name, text) && !is_heidenhain_job(name, text) => m,
        _ => return job(cfg, name, text, tools),
    };
    let (ops, was_marked) = read_marked(cfg, name, text, &marked.text, &marked.line_of)?;
    Ok(Job {
        ops,
        cl: false,
        cycles: None,
        subs: if was_marked {
            marked.bodies
        } else {
            Vec::new()
        },
    })
}

/// The operations of `marked` (the job `text` with marker lines), at the job's own line
/// numbers, and `true`; or, when the marked text does not run, the job's as written (its
/// error at the job's own lines) and `false`.
fn read_marked(
    cfg: &MachineConfig,
    name: &str,
    text: &str,
    marked: &str,
    line_of: &[u32],
) -> Result<(Vec<CanonOp>, bool), PostError> {
    let Ok(mut ops) = read_job(cfg, name, marked) else {
        return Ok((read_job(cfg, name, text)?, false));
    };
    // Back to the job's line numbers (the markers are lines of their own).
    for op in &mut ops {
        if op.source.file.as_ref() == name
            && let Some(&line) = (op.source.line as usize)
                .checked_sub(1)
                .and_then(|i| line_of.get(i))
        {
            op.source.line = line;
        }
    }
    Ok((ops, true))
}

/// A Heidenhain program (by its `BEGIN PGM` line or `.h` name): read through the reader's
/// translation; its labels and cycles come out as the target's from the operations (no ISO
/// text to mark calls in).
fn is_heidenhain_job(name: &str, text: &str) -> bool {
    cnc402_lang::heidenhain::is_heidenhain(name, text.lines().next().unwrap_or(""))
}

fn plain_job(cfg: &MachineConfig, name: &str, text: &str) -> Result<Job, PostError> {
    Ok(Job {
        ops: read_job(cfg, name, text)?,
        cl: false,
        cycles: None,
        subs: Vec::new(),
    })
}

/// The most operations one job may have: a program looping forever with motion (M99 in a
/// main program is one pass here) ends in an error instead of filling memory.
pub const MAX_OPERATIONS: usize = 2_000_000;

/// An interpreter with the file system (sub-programs, `#use` files, variables read-only),
/// loaded with `text`.
pub fn load(cfg: &MachineConfig, name: &str, text: &str) -> Result<Interpreter, PostError> {
    // A Heidenhain job is read as `cnc402 run` reads it: line by line through the reader's
    // translation (a conversion from iTNC to an ISO target).
    if is_heidenhain_job(name, text) {
        let mut it = interpreter(cfg, Options::default(), VarsAccess::ReadOnly);
        let input = Box::new(std::io::Cursor::new(text.to_owned()));
        it.load_stream(name, input, None).map_err(PostError::Job)?;
        return Ok(it);
    }
    let src = SourceFile::new(name, text);
    let program = cnc402_interp::parse_program(cfg, &src, None).map_err(PostError::Job)?;
    let mut it = interpreter(cfg, Options::default(), VarsAccess::ReadOnly);
    it.load(src, program);
    Ok(it)
}

/// The job's canonical operations, in order.
pub fn read_job(cfg: &MachineConfig, name: &str, text: &str) -> Result<Vec<CanonOp>, PostError> {
    let mut it = load(cfg, name, text)?;
    let mut ops = Vec::new();
    while let Some(op) = it.next_canon().map_err(PostError::Job)? {
        if ops.len() == MAX_OPERATIONS {
            return Err(PostError::Target {
                target: "any",
                source: Some(op.source),
                message: format!("the job has more than {MAX_OPERATIONS} operations"),
            });
        }
        ops.push(op);
    }
    Ok(ops)
}
