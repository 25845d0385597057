//! `cnc402 post`: a job posted for one target control and proven by reading it back
//! (cnc402_post; docs/post.md).

use std::path::PathBuf;

use cnc402_post::{PostError, Target};

use crate::CliError;

#[derive(clap::Args, Debug)]
pub struct PostArgs {
    /// The control to post for.
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(Target::ALL.map(Target::name)))]
    target: String,
    /// The job: any program cnc402 reads.
    job: PathBuf,
    /// The tool table of CL jobs' cutting data (`[tool.N] diameter = mm, teeth = n`):
    /// `SPINDL/ vc, SMM` → rpm = 1000·Vc/(π·D), `FEDRAT/ fz, MMPT` → F = fz·z·n.
    #[arg(long, value_name = "FILE.toml")]
    tools: Option<PathBuf>,
    /// Write the posted program here (`-`: standard output).
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    output: PathBuf,
}

/// Posts `args.job` and writes the result; a job the target cannot express is exit 2.
pub fn post(cfg: &cnc402_config::MachineConfig, args: PostArgs) -> Result<(), CliError> {
    let target = Target::from_name(&args.target)
        .ok_or_else(|| CliError::Usage(format!("no target {}", args.target)))?;
    let tools = match &args.tools {
        None => cnc402_post::input::tools::ToolTable::default(),
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .map_err(|e| CliError::Io(format!("{}: {e}", path.display())))?;
            cnc402_post::input::tools::ToolTable::parse(&text)
                .map_err(|e| CliError::Usage(format!("{}: {e}", path.display())))?
        }
    };
    let src = crate::load_program(&args.job)?;
    let posted =
        cnc402_post::post_with(cfg, &src.name, &src.text, target, &tools).map_err(|e| match e {
            PostError::Job(e) => CliError::Program(e),
            e => CliError::Refused(e.to_string()),
        })?;
    if args.output.as_os_str() == "-" {
        print!("{posted}");
        return Ok(());
    }
    std::fs::write(&args.output, posted)
        .map_err(|e| CliError::Io(format!("{}: {e}", args.output.display())))
}
