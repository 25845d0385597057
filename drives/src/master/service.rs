//! Service helpers for tools that talk to one drive at a time outside the cyclic loop
//! (`drivectl`, commissioning): NMT commands, and the CiA 402 state machine driven step by
//! step over SDO (0x6040 written, 0x6041 read) with the [`EnableSequencer`], reporting each
//! step and, when the drive does not get there, the state it is stuck in and why.

use core::fmt;
use core::time::Duration;

use cia402::{Controlword, EnableSequencer, Goal, Progress, Statusword, Stuck, objects as obj};

use super::sdo::{BlockingSdo, SdoError};
use super::timed::TimedBus;
use crate::bus::{BusError, CanBus};
use crate::wire::{NmtCommand, NmtRepr, NmtTarget, NodeId};

/// Sends an NMT command to one node or all.
pub fn send_nmt<B: CanBus + ?Sized>(
    bus: &mut B,
    command: NmtCommand,
    target: NmtTarget,
) -> Result<(), BusError> {
    bus.send(&NmtRepr { command, target }.emit())
}

/// Why [`sequence_over_sdo`] did not reach its goal.
#[derive(Clone, Debug, PartialEq)]
pub enum SequenceError {
    /// An SDO transfer failed.
    Sdo(SdoError),
    /// The transport failed while waiting.
    Bus(BusError),
    /// The drive did not reach the goal within the timeout.
    Stuck {
        /// The drive.
        node: u8,
        /// The sequencer's diagnosis (state, reason, statusword bits).
        stuck: Stuck,
    },
}

impl fmt::Display for SequenceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SequenceError::Sdo(e) => write!(f, "{e}"),
            SequenceError::Bus(e) => write!(f, "{e}"),
            SequenceError::Stuck { node, stuck } => write!(f, "node {node}: {stuck}"),
        }
    }
}

impl std::error::Error for SequenceError {}

impl From<SdoError> for SequenceError {
    fn from(e: SdoError) -> SequenceError {
        SequenceError::Sdo(e)
    }
}

/// Takes drive `node` to `goal` over SDO: every `interval`, reads the statusword, asks the
/// sequencer for the next controlword and writes it; `on_step(statusword, controlword)` sees
/// each step. Before the step that enables operation, 0x607A is set to 0x6064 so the drive
/// does not jump to a stale target. Gives up after `timeout` with the sequencer's diagnosis.
/// Returns the statusword in the goal state.
pub fn sequence_over_sdo<B: TimedBus + ?Sized>(
    sdo: &mut BlockingSdo<'_, B>,
    node: NodeId,
    goal: Goal,
    interval: Duration,
    timeout: Duration,
    on_step: &mut dyn FnMut(Statusword, Controlword),
) -> Result<Statusword, SequenceError> {
    // Patience is the caller's time-out, not a step count (an SDO round trip per step makes
    // steps longer than `interval`); the sequencer diagnoses the state when time runs out.
    let mut seq = EnableSequencer::new(goal).with_patience(u32::MAX);
    let t0 = sdo.now();
    let mut steps = 0u32;
    loop {
        let sw = Statusword(sdo.read_u16(node, obj::STATUSWORD, 0)?);
        if sdo.now().saturating_since(t0) > timeout {
            let mut probe = seq.clone().with_patience(1);
            let stuck = match probe.step(sw).progress {
                Progress::Reached => return Ok(sw),
                Progress::Stuck(s) => s,
                Progress::Moving(state) => Stuck {
                    state,
                    statusword: sw,
                    goal,
                    reason: cia402::StuckReason::CommandIgnored {
                        command: seq.last_controlword().command(),
                    },
                    steps,
                },
            };
            return Err(SequenceError::Stuck {
                node: node.get(),
                stuck,
            });
        }
        let step = seq.step(sw);
        steps = steps.saturating_add(1);
        if step.progress == Progress::Reached {
            return Ok(sw);
        }
        if step.enables_operation(sw) {
            let actual = sdo.read_i32(node, obj::POSITION_ACTUAL, 0)?;
            sdo.write_i32(node, obj::TARGET_POSITION, 0, actual)?;
        }
        sdo.write_u16(node, obj::CONTROLWORD, 0, step.controlword.bits())?;
        on_step(sw, step.controlword);
        sdo.wait(interval).map_err(SequenceError::Bus)?;
    }
}
