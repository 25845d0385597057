//! The two fixed-capacity SPSC rings between the loop and the rest of the program: planned
//! moves in, status records out.

// `ringbuf` (0.6) rather than `rtrb` (0.4): both are lock-free single-producer single-consumer
// rings that allocate once at construction and whose `try_push`/`try_pop` never block,
// allocate or make a system call, which is all the loop needs. `ringbuf` is the design card's
// named choice and already a workspace dependency, so taking it adds no crate; `rtrb` would
// buy nothing measurable here (one move in per segment, one `Copy` record out per tick).

use ringbuf::HeapRb;
use ringbuf::traits::Split;

use cnc402_motion::PlannedMove;

use crate::status::Status;

pub use ringbuf::traits::{Consumer, Observer, Producer};

/// What the feeder gives the loop.
// A move travels by value through the fixed-capacity ring: boxing it would allocate.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LoopInput {
    /// The next move, in program order.
    Move(PlannedMove),
    /// The program has no more moves.
    End,
}

/// Producer end of the move ring (feeder side).
pub type MoveProducer = ringbuf::HeapProd<LoopInput>;
/// Consumer end of the move ring (loop side).
pub type MoveConsumer = ringbuf::HeapCons<LoopInput>;
/// Producer end of the status ring (loop side).
pub type StatusProducer = ringbuf::HeapProd<Status>;
/// Consumer end of the status ring (reporting side).
pub type StatusConsumer = ringbuf::HeapCons<Status>;

/// Capacity of the move ring: enough look-ahead for short moves at 1 ms.
pub const MOVE_RING: usize = 256;
/// Capacity of the status ring: 8 s of records at 1 ms, so a slow reporter does not drop any.
pub const STATUS_RING: usize = 8192;

/// A new move ring of `cap` entries.
pub fn move_ring(cap: usize) -> (MoveProducer, MoveConsumer) {
    HeapRb::<LoopInput>::new(cap.max(2)).split()
}

/// A new status ring of `cap` entries.
pub fn status_ring(cap: usize) -> (StatusProducer, StatusConsumer) {
    HeapRb::<Status>::new(cap.max(2)).split()
}
