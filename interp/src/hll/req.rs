//! What the executor thread asks of the G-code core ([`Req`]), so that the executor and the
//! core's side (`hll/mod.rs`) share it without using each other.

use cnc402_lang::NcError;
use cnc402_lang::ast::{Line, Span};
use cnc402_motion::segment::SegmentKind;

use super::ir;

/// A motion-dependent system variable read (answered after the queue is drained).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Read {
    ItpPath,
    Axis(usize),
}

/// A call on the machine's channels ([`crate::host::channels::Channels`]): made by the
/// interpreter when it reaches the call, after the motion before it (answered 1/0 for
/// true/false, or the mode or state number).
#[derive(Clone, Debug)]
pub(crate) enum ChannelCall {
    Mode(usize),
    State(usize),
    Load(usize, String),
    Start(usize, String),
    Run(usize, String),
    Wait(usize),
    Reset(usize),
}

/// What the executor thread asks of the interpreter.
pub(crate) enum Req {
    /// A G-code block with every value computed, for the G-code core.
    Block {
        file: ir::FileId,
        line: Box<Line>,
    },
    /// A segment made by a built-in (`MSG` → Message, `sleep` → Dwell).
    Seg {
        file: ir::FileId,
        span: Span,
        kind: SegmentKind,
    },
    Read(Read),
    Channel(ChannelCall),
    Error(Box<NcError>),
    End,
    /// Several of the above, in order.
    Batch(Vec<Req>),
}
