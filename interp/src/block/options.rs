//! The operator switches a run is started with ([`Options`]); the block layer reads them
//! (M1, block delete) and the program flow reads [`MainM99`].

use cnc402_motion::segment::AxisPos;

/// Operator switches that change how a program runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Block delete switch: when on, lines starting with `/` are skipped. Default on.
    pub block_delete: bool,
    /// Optional stop switch: when on, M1 stops like M0; when off, M1 does nothing. Default on.
    pub optional_stop: bool,
    /// Machine position of every axis when the program starts (default all 0). C, the spindle,
    /// is the program's view and should start at 0.
    pub start: AxisPos,
    /// What `M99` without `P` does in the main program. Default [`MainM99::End`].
    pub main_m99: MainM99,
    /// The spindle a program starts with selected (1..=2; default 1): a channel that owns
    /// spindle 2 starts its programs on it. A number the machine lacks leaves spindle 1.
    pub default_spindle: u8,
}

/// `M99` (without `P`) in the main program.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MainM99 {
    /// The program ends there after one pass (a segment dump, a dry run), and
    /// [`Interpreter::main_m99_line`](crate::Interpreter::main_m99_line) says where.
    #[default]
    End,
    /// As on a Fanuc control: the main program starts over from its first block, endlessly,
    /// with its modal state and variables as they are (a machine run; it ends by M2/M30 in a
    /// branch, an alarm, or the operator).
    Repeat,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            block_delete: true,
            optional_stop: true,
            start: AxisPos::default(),
            main_m99: MainM99::End,
            default_spindle: 1,
        }
    }
}
