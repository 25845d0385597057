//! Machine inputs from the drives' 0x60FD (digital inputs): the limit switches of axes with
//! `limit_switch_inputs`, and the E-stop chain on one drive's bit (`[machine] estop_input`).
//! Boot maps 0x60FD alone into TPDO3 of those drives, event-driven (on change, at most every
//! 10 ms, and every refresh period); the cycle's monitors stop the machine on a limit switch
//! (not on an axis that is homing: it may be looking for that switch) or an open E-stop, and
//! start-up reads the E-stop bit by SDO before anything moves.

use cia402::QuickStopOption;
use cia402::objects as obj;
use cnc402_config::StopCategory;

use super::boot::{EVENT_DRIVEN, MapPdoError, PdoSpec, map_pdo_exactly};
use super::sdo::BlockingSdo;
use super::stop::StopReason;
use super::{Master, TimedBus};
use crate::wire::{MappingEntry, NodeId, PdoDirection, PdoLayout, PdoObject};

/// The TPDO that carries 0x60FD: TPDO3 (0x1802 / 0x1A02, COB-ID 0x380 + node).
pub const INPUTS_TPDO: u8 = 3;

const INPUTS_MAPPING: [MappingEntry; 1] = [MappingEntry::new(obj::DIGITAL_INPUTS, 0, 32)];

/// TPDO3: 0x60FD alone.
pub const INPUTS_LAYOUT: PdoLayout = match PdoLayout::new(PdoDirection::Tpdo, &INPUTS_MAPPING) {
    Ok(l) => l,
    Err(_) => panic!("the inputs TPDO mapping must be valid"),
};

/// The inputs TPDO's inhibit time (100 µs units): at most one frame per 10 ms.
const INPUTS_INHIBIT_100US: u16 = 100;

/// Maps TPDO3 = 0x60FD, event-driven, with the inhibit time above and `refresh_ms` as its
/// event timer (boot, before NMT start). A drive whose TPDO3 mapping is fixed is accepted
/// only when it carries 0x60FD alone: the monitor reads the frame by this layout.
pub(crate) fn map_inputs_tpdo<B: TimedBus + ?Sized>(
    sdo: &mut BlockingSdo<'_, B>,
    node: NodeId,
    refresh_ms: u16,
) -> Result<(), MapPdoError> {
    let p = u16::from(INPUTS_TPDO - 1);
    let spec = PdoSpec {
        comm: obj::TPDO_COMMUNICATION + p,
        mapping: obj::TPDO_MAPPING + p,
        cob_id: 0x180 + 0x100 * p + u16::from(node.get()),
        layout: &INPUTS_LAYOUT,
        transmission_type: EVENT_DRIVEN,
        event_timing: Some((INPUTS_INHIBIT_100US, refresh_ms.max(1))),
    };
    map_pdo_exactly(sdo, node, &spec, "0x60FD")
}

/// 0x60FD from a TPDO3, if its length is the layout's.
pub(crate) fn parse_inputs(data: &[u8]) -> Option<u32> {
    let v = INPUTS_LAYOUT.unpack(data).ok()?;
    v.get(PdoObject::DigitalInputs).map(|raw| raw as u32)
}

/// The drives' quick stop option (0x605A) an E-stop category needs: category 1 ramps down
/// and disables (2), category 2 ramps down and stays in QUICK STOP ACTIVE, powered (6);
/// category 0 disables voltage without a quick stop (nothing to write).
pub fn quick_stop_option_for(category: StopCategory) -> Option<QuickStopOption> {
    match category {
        StopCategory::Zero => None,
        StopCategory::One => QuickStopOption::from_i16(2),
        StopCategory::Two => QuickStopOption::from_i16(6),
    }
}

impl Master {
    /// The stop reaction of an open E-stop, by its category (see
    /// [`StopCategory`]): 0 takes every drive to SWITCH ON DISABLED at once (controlword
    /// "disable voltage"), 1 and 2 send every drive quick stop at once whatever the stop mode
    /// (an E-stop is no path stop); 0x605A, written at boot, then decides whether the drive
    /// disables itself at standstill (1) or holds there powered (2).
    pub(crate) fn estop_reaction(&mut self) {
        if self.estop_category == StopCategory::Zero {
            self.request_disable();
            return;
        }
        for a in self.axes[..self.n_axes].iter_mut() {
            a.quick_stop = true;
        }
    }

    /// Boot: the quick stop option the E-stop category needs, on every drive (when an
    /// E-stop input is configured).
    pub(crate) fn write_estop_option<B: TimedBus + ?Sized>(
        &mut self,
        bus: &mut B,
        node: crate::wire::NodeId,
    ) -> Result<(), super::sdo::SdoError> {
        if self.estop_input.is_none() {
            return Ok(());
        }
        let Some(option) = quick_stop_option_for(self.estop_category) else {
            return Ok(());
        };
        self.with_sdo(bus, |sdo| {
            sdo.write_i16(node, obj::QUICK_STOP_OPTION, 0, option.to_i16())
        })
    }

    /// The inputs monitor of drive axis `i` (its last 0x60FD): a limit switch, or the E-stop
    /// chain open.
    pub(crate) fn inputs_stop(&self, i: usize) -> Option<StopReason> {
        let a = &self.axes[i];
        let inputs = a.inputs?;
        if let Some((axis, bit)) = self.estop_input
            && axis == i
            && inputs & (1 << bit) == 0
        {
            return Some(StopReason::EstopOpen { bit });
        }
        if !a.watch_limit_switches || a.homing_active {
            return None;
        }
        if inputs & obj::INPUT_NEGATIVE_LIMIT != 0 {
            return Some(StopReason::LimitSwitch { positive: false });
        }
        if inputs & obj::INPUT_POSITIVE_LIMIT != 0 {
            return Some(StopReason::LimitSwitch { positive: true });
        }
        None
    }

    /// Start-up's E-stop check (blocking SDO read of the E-stop drive's 0x60FD): `Some` with
    /// the reason to refuse when the chain is open; `None` when it is closed or not
    /// configured.
    pub fn estop_open<B: TimedBus + ?Sized>(&mut self, bus: &mut B) -> Option<String> {
        let (i, bit) = self.estop_input?;
        let (axis, node) = (self.axes[i].name, self.axes[i].node?);
        match self.with_sdo(bus, |sdo| sdo.read_u32(node, obj::DIGITAL_INPUTS, 0)) {
            Ok(v) if v & (1 << bit) != 0 => None,
            Ok(v) => Some(format!(
                "E-stop open: axis {axis} (node {}) 0x60FD = {v:#010x}, bit {bit} is 0; close \
                 the E-stop chain ([machine] estop_input) before starting",
                node.get()
            )),
            Err(e) => Some(format!("E-stop input of axis {axis} cannot be read: {e}")),
        }
    }
}
