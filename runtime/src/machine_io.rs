//! The program's machine outputs in the loop: M7/M8/M9 switch the coolant outputs, a spindle
//! move with a speed switches the spindle enable on (off once an M5 move has ended), and M6
//! with `tool_change = "manual"` releases the tool clamp and holds as M0 does until the
//! operator continues, then clamps. The loop tells the link (`DriveLink::set_output`) and
//! puts the outputs' state in each status record, from which the run reports every change.

use cnc402_config::{MachineConfig, ToolChange};
use cnc402_drives::master::Output;
use cnc402_motion::{MoveEvent, MoveKind};

use crate::link::DriveLink;

/// Bits of [`OutputBits`], in [`OUTPUTS`]' order.
const FLOOD: u8 = 1;
const MIST: u8 = 2;
const SPINDLE: u8 = 4;
const CLAMP: u8 = 8;

/// Every output with its bit in a status record's `outputs`.
pub const OUTPUTS: [(Output, u8); 4] = [
    (Output::CoolantFlood, FLOOD),
    (Output::CoolantMist, MIST),
    (Output::SpindleEnable, SPINDLE),
    (Output::ToolClamp, CLAMP),
];

/// The loop's output state and what it owes after a tool change or a spindle stop.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LoopOutputs {
    manual_tool_change: bool,
    /// The outputs the config names (bits above): only they are switched and reported.
    configured: u8,
    /// The outputs as the program set them (bits above).
    pub(crate) state: u8,
    /// A manual tool change released the clamp: clamp when the hold ends.
    clamp_after_hold: bool,
    /// An M5 spindle move is running: the enable goes off when it has ended.
    spindle_off_after_move: bool,
    /// The spindles commanded to turn (bit number − 1): the one enable stays on while any
    /// does (an M5 of spindle 2 left spindle 1 turning without its enable).
    spindles_on: u8,
}

impl LoopOutputs {
    /// Outputs at the start of a run: all off, the tool clamped.
    pub(crate) fn new(cfg: &MachineConfig) -> LoopOutputs {
        let o = &cfg.machine.outputs;
        let configured = [
            o.coolant_flood,
            o.coolant_mist,
            o.spindle_enable,
            o.tool_clamp,
        ]
        .iter()
        .zip(OUTPUTS)
        .filter(|(b, _)| b.is_some())
        .fold(0, |m, (_, (_, bit))| m | bit);
        LoopOutputs {
            manual_tool_change: cfg.machine.tool_change == ToolChange::Manual,
            configured,
            state: CLAMP & configured,
            clamp_after_hold: false,
            spindle_off_after_move: false,
            spindles_on: 0,
        }
    }

    fn set<L: DriveLink>(&mut self, link: &mut L, bit: u8, on: bool) {
        let Some(&(which, _)) = OUTPUTS.iter().find(|(_, b)| *b == bit) else {
            return;
        };
        if self.configured & bit == 0 {
            return;
        }
        if on {
            self.state |= bit;
        } else {
            self.state &= !bit;
        }
        link.set_output(which, on);
    }

    /// The tick's program event; `true` when it is a manual tool change the loop must hold
    /// at (the clamp is released already).
    pub(crate) fn event<L: DriveLink>(&mut self, event: Option<MoveEvent>, link: &mut L) -> bool {
        match event {
            Some(MoveEvent::Coolant { mist, flood }) => {
                self.set(link, FLOOD, flood);
                self.set(link, MIST, mist);
                false
            }
            Some(MoveEvent::ToolChange { .. }) if self.manual_tool_change => {
                self.set(link, CLAMP, false);
                self.clamp_after_hold = true;
                true
            }
            _ => false,
        }
    }

    /// A move starts: the one before it has ended (an M5 ramp: enable off), and a spindle
    /// move with a speed switches the enable on before it ramps.
    pub(crate) fn move_started<L: DriveLink>(&mut self, kind: &MoveKind, link: &mut L) {
        if std::mem::take(&mut self.spindle_off_after_move) {
            self.set(link, SPINDLE, false);
        }
        if let MoveKind::Spindle {
            velocity, spindle, ..
        } = kind
        {
            let bit = 1u8 << (spindle.wrapping_sub(1) & 7);
            if *velocity != 0.0 {
                self.spindles_on |= bit;
                self.set(link, SPINDLE, true);
            } else {
                self.spindles_on &= !bit;
                if self.spindles_on == 0 && self.state & SPINDLE != 0 {
                    self.spindle_off_after_move = true;
                }
            }
        }
    }

    /// The loop is not held any more: a manual tool change clamps the new tool (`true`).
    pub(crate) fn hold_ended<L: DriveLink>(&mut self, link: &mut L) -> bool {
        let clamp = std::mem::take(&mut self.clamp_after_hold);
        if clamp {
            self.set(link, CLAMP, true);
        }
        clamp
    }

    /// The program's input has ended and the last move is done: an M5 ramp's enable off.
    pub(crate) fn program_done<L: DriveLink>(&mut self, link: &mut L) {
        if std::mem::take(&mut self.spindle_off_after_move) {
            self.set(link, SPINDLE, false);
        }
    }
}

/// The outputs' state at the start of a run of `cfg` (status record bits).
pub fn initial_outputs(cfg: &MachineConfig) -> u8 {
    LoopOutputs::new(cfg).state
}

/// The name of output bit `bit` of a status record (`coolant_flood` …).
pub fn output_name(bit: u8) -> &'static str {
    OUTPUTS
        .iter()
        .find(|(_, b)| *b == bit)
        .map_or("?", |(o, _)| o.name())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::ModelLink;

    /// Regression (m5_of_spindle_2_switched_spindle_1s_enable_off): the one enable output
    /// went off after an M5 of either spindle, with the other still turning.
    #[test]
    fn the_spindle_enable_stays_on_while_either_spindle_turns() {
        let text = include_str!("../../examples/two-spindles/machine.toml").replace(
            "[interp]",
            "[machine]\noutputs = { spindle_enable = { axis = \"Z\", bit = 16 } }\n\n[interp]",
        );
        let path = std::path::Path::new("../examples/two-spindles/machine.toml");
        let cfg = MachineConfig::parse(&text, path).unwrap();
        let mut link = ModelLink::new(&cfg, [0.0; cnc402_config::MAX_AXES], 1);
        let mut o = LoopOutputs::new(&cfg);
        let spin = |velocity, spindle| MoveKind::Spindle {
            velocity,
            acceleration: 1.0,
            jerk: 1.0,
            spindle,
        };
        let on = |o: &LoopOutputs| o.state & SPINDLE != 0;
        o.move_started(&spin(6000.0, 1), &mut link);
        o.move_started(&spin(-3000.0, 2), &mut link);
        o.move_started(&spin(0.0, 2), &mut link);
        o.move_started(&MoveKind::Message, &mut link);
        assert!(on(&o), "spindle 1 still turns");
        o.move_started(&spin(0.0, 1), &mut link);
        assert!(on(&o), "off once the M5 ramp has ended");
        o.move_started(&MoveKind::Message, &mut link);
        assert!(!on(&o));
    }
}
