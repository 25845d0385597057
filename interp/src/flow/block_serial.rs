//! Block identity for the operator's breakpoints and single block: a serial that grows by one
//! for every block (or C-like statement acting on the machine) the interpreter executes, so
//! that two passes of one line in a loop tell apart although their `Source` is the same.

use super::Interpreter;

impl Interpreter {
    /// Blocks executed so far since [`load`](Self::load). Read right after
    /// [`next_segment`](Self::next_segment) refilled its operations, it names the block whose
    /// operation came out (without cutter compensation holding operations back, exactly;
    /// with it, the serial may run a few blocks ahead, the line still tells the block).
    pub fn block_serial(&self) -> u64 {
        self.flow.runaway.total + self.hll.requests()
    }
}
