//! What the C-like language tests share: run a program text on the default machine and read
//! the operator messages (`MSG(...)`) it produced, the way most of those tests observe it.

use cnc402_config::MachineConfig;
use cnc402_lang::SourceFile;
use cnc402_motion::segment::{Segment, SegmentKind};

pub fn cfg() -> MachineConfig {
    MachineConfig::default_machine()
}

/// Runs `text` as the file `t.nc` on the default machine.
pub fn run(text: &str) -> Result<Vec<Segment>, cnc402_lang::NcError> {
    cnc402_interp::run_program(&cfg(), &SourceFile::new("t.nc", text))
}

/// The texts of the message segments, in order.
pub fn msgs(segs: &[Segment]) -> Vec<String> {
    segs.iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Message { text } => Some(text.clone()),
            _ => None,
        })
        .collect()
}
