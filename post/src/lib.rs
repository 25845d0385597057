//! The post-processor (issue 16, source 003): a job read at cnc402's canonical layer (moves,
//! arcs, taps and canned cycles as operations, tool calls, offsets, compensation, spindle,
//! coolant) becomes a program for one target control ([`rules::Target`]), built whole in
//! memory and assembled at the end, then read back by cnc402's own interpreter and compared
//! with the job segment by segment ([`verify`]) so that a posted program never moves
//! differently from its job without an error.

// NcError (lang's) is large; an error ends the post, so its size costs nothing that matters.
#![allow(clippy::result_large_err)]

pub mod assemble;
pub mod emit;
pub mod input;
pub mod rules;
pub mod verify;

use cnc402_config::MachineConfig;
use cnc402_motion::segment::Source;

pub use rules::{Rules, Target};

/// Why a job could not be posted.
#[derive(Debug)]
pub enum PostError {
    /// The job itself is wrong (it does not run in cnc402).
    Job(cnc402_lang::NcError),
    /// The target cannot express what the job does (at `source`, if one block is to blame).
    Target {
        target: &'static str,
        source: Option<Source>,
        message: String,
    },
}

impl PostError {
    pub fn target(rules: &Rules, source: Option<&Source>, message: impl Into<String>) -> Self {
        PostError::Target {
            target: rules.name,
            source: source.cloned(),
            message: message.into(),
        }
    }
}

impl std::fmt::Display for PostError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PostError::Job(e) => write!(f, "{e}"),
            PostError::Target {
                target,
                source,
                message,
            } => {
                if let Some(s) = source {
                    write!(f, "{}:{}: ", s.file, s.line)?;
                    if let Some(n) = s.n {
                        write!(f, "block N{n}: ")?;
                    }
                }
                // "any": the job's own input (CL data) is wrong, whatever the target.
                if *target == "any" {
                    write!(f, "{message}")
                } else {
                    write!(f, "{message} (target {target})")
                }
            }
        }
    }
}

impl std::error::Error for PostError {}

/// Posts the job `name` (its text `text`) for `target` on machine `cfg` and proves the result
/// by reading it back: the program text, or why it cannot be posted.
pub fn post(
    cfg: &MachineConfig,
    name: &str,
    text: &str,
    target: Target,
) -> Result<String, PostError> {
    post_with(cfg, name, text, target, &input::tools::ToolTable::default())
}

/// [`post`] with a tool table (cutting data of CL jobs: `SPINDL/… SMM`, `FEDRAT/… MMPT`).
pub fn post_with(
    cfg: &MachineConfig,
    name: &str,
    text: &str,
    target: Target,
    tools: &input::tools::ToolTable,
) -> Result<String, PostError> {
    let rules = target.rules();
    // Without a tool table of its own, the config's `[tool_offsets]` cutting data.
    let from_config;
    let tools = if tools.tool.is_empty() {
        from_config = input::tools::ToolTable::from_config(cfg);
        &from_config
    } else {
        tools
    };
    let job = read_job(cfg, name, text, target, tools)?;
    let posted = post_ops(cfg, &job, target)?;
    let job_segments = if job.cl {
        verify::lowered(cfg, &job.ops)
    } else {
        verify::segments(cfg, name, text, None)?
    };
    verify::same_as(cfg, &rules, job_segments, name, &posted)?;
    Ok(posted)
}

/// [`post`] without the read-back: the program as built (for looking into a refusal).
pub fn post_unproven(
    cfg: &MachineConfig,
    name: &str,
    text: &str,
    target: Target,
) -> Result<String, PostError> {
    let job = read_job(cfg, name, text, target, &input::tools::ToolTable::default())?;
    post_ops(cfg, &job, target)
}

/// The job as `target` takes it: the iTNC writes the job's sub-programs as labels.
fn read_job(
    cfg: &MachineConfig,
    name: &str,
    text: &str,
    target: Target,
    tools: &input::tools::ToolTable,
) -> Result<input::Job, PostError> {
    if target == Target::Itnc530 {
        input::job_with_subs(cfg, name, text, tools)
    } else {
        input::job(cfg, name, text, tools)
    }
}

/// The program of a job's operations for `target`, assembled.
fn post_ops(cfg: &MachineConfig, job: &input::Job, target: Target) -> Result<String, PostError> {
    let rules = target.rules();
    if target == Target::Itnc530 {
        let ops = input::calls::without_markers(&job.ops);
        let (program, inch) = emit::heidenhain::emit_itnc(cfg, &rules, &ops, &job.subs)?;
        return emit::heidenhain::assemble_itnc(&program, inch, &rules);
    }
    let program = emit::emit(cfg, &rules, &job.ops, job.cycles.as_ref())?;
    assemble::assemble_iso(&program, &rules)
}
