//! Machine outputs on the drives' 0x60FE (`[machine] outputs`: coolant, spindle enable, tool
//! clamp on bits 16..31 of sub 1, enabled by the sub 2 bit mask). Boot writes the mask and the
//! start values by SDO and maps RPDO3 = 0x60FE:1 (event-driven); in the cyclic phase the master
//! sends RPDO3 when the wanted value changes and as a refresh, at most once per 10 ms. An RPDO
//! rather than in-cycle SDO: 4 CSP axes at 1 ms on 1 Mbit/s (standard layout) leave ~2 % of
//! the bus, too little to drain an SDO exchange before the TPDO monitor trips, while one
//! 4-byte frame per 10 ms costs 0.8 % and is counted in the load plan (`outputs RPDO3`).

use cia402::objects as obj;
use cnc402_config::{MAX_AXES, MachineOutputs, OutputBit};

use core::time::Duration;

use super::boot::{EVENT_DRIVEN, MapPdoError, PdoSpec, map_pdo_exactly};
use super::sdo::{BlockingSdo, SdoError};
use super::{Master, TimedBus};
use crate::bus::{BusError, CanBus};
use crate::time::Instant;
use crate::wire::{CanFrame, MappingEntry, NodeId, PdoDirection, PdoLayout, PdoObject};

const OUTPUTS_MAPPING: [MappingEntry; 1] = [PdoObject::DigitalOutputs.entry()];

/// RPDO3: 0x60FE:1 alone (the frame is its 4 bytes, little-endian).
pub const OUTPUTS_LAYOUT: PdoLayout = match PdoLayout::new(PdoDirection::Rpdo, &OUTPUTS_MAPPING) {
    Ok(l) => l,
    Err(_) => panic!("the outputs RPDO mapping must be valid"),
};

/// A named machine output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Output {
    CoolantFlood,
    CoolantMist,
    SpindleEnable,
    ToolClamp,
}

impl Output {
    /// Its config name (`[machine] outputs`).
    pub fn name(self) -> &'static str {
        match self {
            Output::CoolantFlood => "coolant_flood",
            Output::CoolantMist => "coolant_mist",
            Output::SpindleEnable => "spindle_enable",
            Output::ToolClamp => "tool_clamp",
        }
    }

    fn bit(self, c: &MachineOutputs) -> Option<OutputBit> {
        match self {
            Output::CoolantFlood => c.coolant_flood,
            Output::CoolantMist => c.coolant_mist,
            Output::SpindleEnable => c.spindle_enable,
            Output::ToolClamp => c.tool_clamp,
        }
    }
}

/// The outputs RPDO: RPDO3 (0x1402 / 0x1602, COB-ID 0x400 + node).
pub const OUTPUTS_RPDO: u8 = 3;

/// At most one outputs RPDO per drive per this many ms (the load plan's figure).
const OUTPUTS_INHIBIT_MS: u64 = cnc402_config::busload::COMPACT_EVENT_INHIBIT_MS as u64;

/// What the master wants on each drive's 0x60FE:1 and what it last sent there.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct OutputState {
    pub(crate) config: MachineOutputs,
    /// Per drive, its configured output bits (its 0x60FE:2 mask).
    mask: [u32; MAX_AXES],
    wanted: [u32; MAX_AXES],
    sent: [u32; MAX_AXES],
    /// When each drive's outputs RPDO last went out.
    last_sent: [Option<Instant>; MAX_AXES],
}

impl OutputState {
    /// Outputs of `config`: every one off, the tool clamp clamped.
    pub(crate) fn new(config: MachineOutputs) -> OutputState {
        let mut s = OutputState {
            config,
            ..OutputState::default()
        };
        for b in config.all().iter().filter_map(|(_, b)| *b) {
            s.mask[b.axis] |= 1 << b.bit;
        }
        if let Some(b) = config.tool_clamp {
            s.wanted[b.axis] |= 1 << b.bit;
        }
        s
    }
}

impl Master {
    /// Switches output `which` from the next cycle on (its drive's RPDO3 when the value changes);
    /// `false` when the config does not name it. Allocation-free.
    pub fn set_output(&mut self, which: Output, on: bool) -> bool {
        let Some(b) = which.bit(&self.outputs.config) else {
            return false;
        };
        let w = &mut self.outputs.wanted[b.axis];
        if on {
            *w |= 1 << b.bit;
        } else {
            *w &= !(1 << b.bit);
        }
        true
    }

    /// Whether output `which` is on as last sent to its drive (`None`: not configured).
    pub fn output(&self, which: Output) -> Option<bool> {
        let b = which.bit(&self.outputs.config)?;
        Some(self.outputs.sent[b.axis] & (1 << b.bit) != 0)
    }

    /// Whether every wanted output value has been sent.
    pub fn outputs_settled(&self) -> bool {
        (0..self.n_axes).all(|i| self.outputs.wanted[i] == self.outputs.sent[i])
    }

    /// Boot: 0x60FE:2 = the configured bits of axis `i`'s drive, 0x60FE:1 = their start
    /// values, and RPDO3 = 0x60FE:1, event-driven (blocking SDO). Nothing on a drive with no
    /// output.
    pub(crate) fn set_up_outputs<B: TimedBus + ?Sized>(
        &mut self,
        bus: &mut B,
        i: usize,
        node: NodeId,
    ) -> Result<(), MapPdoError> {
        let (mask, value) = (self.outputs.mask[i], self.outputs.wanted[i]);
        if mask == 0 {
            return Ok(());
        }
        let p = u16::from(OUTPUTS_RPDO - 1);
        let spec = PdoSpec {
            comm: obj::RPDO_COMMUNICATION + p,
            mapping: obj::RPDO_MAPPING + p,
            cob_id: 0x200 + 0x100 * p + u16::from(node.get()),
            layout: &OUTPUTS_LAYOUT,
            transmission_type: EVENT_DRIVEN,
            event_timing: None,
        };
        self.with_sdo(bus, |sdo: &mut BlockingSdo<'_, B>| {
            sdo.write_u32(node, obj::DIGITAL_OUTPUTS, 2, mask)?;
            sdo.write_u32(node, obj::DIGITAL_OUTPUTS, 1, value)?;
            map_pdo_exactly(sdo, node, &spec, "0x60FE:1")
        })?;
        self.outputs.sent[i] = value;
        Ok(())
    }

    /// The send phase's outputs RPDO3s: to each drive with outputs whose wanted value changed,
    /// or whose refresh period passed, and not within 10 ms of the last. Allocation-free;
    /// returns the first send error.
    pub(crate) fn send_outputs<B: CanBus + ?Sized>(
        &mut self,
        bus: &mut B,
        now: Instant,
    ) -> Option<BusError> {
        let inhibit = Duration::from_millis(OUTPUTS_INHIBIT_MS);
        let refresh = Duration::from_millis(u64::from(self.event_refresh_ms));
        let mut err = None;
        for i in 0..self.n_axes {
            let Some(node) = self.axes[i].node else {
                continue;
            };
            let o = &mut self.outputs;
            if o.mask[i] == 0 {
                continue;
            }
            let since = o.last_sent[i].map(|t| now.saturating_since(t));
            let due = o.wanted[i] != o.sent[i] || since.is_none_or(|d| d >= refresh);
            if !due || since.is_some_and(|d| d < inhibit) {
                continue;
            }
            let id = 0x200 + 0x100 * u16::from(OUTPUTS_RPDO - 1) + u16::from(node.get());
            let Ok(frame) = CanFrame::new(id, &o.wanted[i].to_le_bytes()) else {
                continue;
            };
            match bus.send(&frame) {
                Ok(()) => {
                    o.sent[i] = o.wanted[i];
                    o.last_sent[i] = Some(now);
                }
                Err(e) => err = err.or(Some(e)),
            }
        }
        err
    }

    /// Blocking, after the cyclic phase: every output off except the tool clamp (which
    /// holds the tool), written by SDO as a safe rest.
    pub fn outputs_to_rest<B: TimedBus + ?Sized>(&mut self, bus: &mut B) -> Result<(), SdoError> {
        let clamp = self.outputs.config.tool_clamp;
        for i in 0..self.n_axes {
            let Some(node) = self.axes[i].node else {
                continue;
            };
            if self.outputs.mask[i] == 0 {
                continue;
            }
            let keep = clamp.filter(|b| b.axis == i).map_or(0, |b| 1 << b.bit);
            let rest = self.outputs.wanted[i] & keep;
            self.outputs.wanted[i] = rest;
            self.with_sdo(bus, |sdo: &mut BlockingSdo<'_, B>| {
                sdo.write_u32(node, obj::DIGITAL_OUTPUTS, 1, rest)
            })?;
            self.outputs.sent[i] = rest;
        }
        Ok(())
    }
}
