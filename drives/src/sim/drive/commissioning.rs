//! What the simulated drive offers commissioning: store to "non-volatile memory" (0x1010,
//! signature "save") that a reboot keeps, restore of the factory defaults (0x1011, "load",
//! effective at the next reset as CiA 301 says), and a fixed PDO mapping (a drive that refuses
//! remapping, to test the master against one).

use super::SimDrive;
use crate::od::{Access, Entry, Value};
use crate::sim::objects;
use crate::wire::{AbortCode, MappingEntry};

use crate::od::{LOAD_SIGNATURE, RESTORE_DEFAULTS, SAVE_SIGNATURE, STORE_PARAMETERS};

/// Objects a store does not keep: process data the master drives every cycle, and the
/// commands themselves.
fn volatile(index: u16) -> bool {
    matches!(
        index,
        cia402::objects::CONTROLWORD
            | cia402::objects::TARGET_POSITION
            | STORE_PARAMETERS
            | RESTORE_DEFAULTS
    )
}

/// 0x1010 and 0x1011 with sub 1 "all parameters" (reads 1: the device saves on command).
pub(crate) fn insert_store_objects(od: &mut crate::od::ObjectDictionary) {
    for (index, what) in [(STORE_PARAMETERS, "save"), (RESTORE_DEFAULTS, "restore")] {
        od.insert(
            index,
            0,
            Entry::new("highest sub-index", Access::Const, Value::U8(1)),
        );
        let name = if what == "save" {
            "save all parameters"
        } else {
            "restore all default parameters"
        };
        od.insert(index, 1, Entry::new(name, Access::ReadWrite, Value::U32(1)));
    }
}

impl SimDrive {
    /// A write to 0x1010/0x1011 sub ≥ 1: the signature runs the command (nothing else is
    /// written); any other value is refused with 0x08000020 (CiA 301).
    pub(super) fn store_command(&mut self, index: u16, value: u32) -> Result<(), AbortCode> {
        match (index, value) {
            (STORE_PARAMETERS, SAVE_SIGNATURE) => {
                self.store_parameters();
                Ok(())
            }
            (RESTORE_DEFAULTS, LOAD_SIGNATURE) => {
                // Effective at the next reset: the running values stay until then.
                self.defaults = objects::build(&self.params);
                insert_store_objects(&mut self.defaults);
                self.reapply_fixed_mapping();
                self.stores = self.stores.wrapping_add(1);
                Ok(())
            }
            _ => Err(AbortCode::CannotStore),
        }
    }

    /// Copies every writable, non-volatile value into the power-on dictionary.
    fn store_parameters(&mut self) {
        let indices: Vec<u16> = self.od.indices().filter(|i| !volatile(*i)).collect();
        for index in indices {
            let subs: Vec<u8> = self.od.subs(index).collect();
            for sub in subs {
                if let Ok(e) = self.od.entry(index, sub)
                    && e.access.writable()
                {
                    let v = e.value.clone();
                    let _ = self.defaults.set(index, sub, v);
                }
            }
        }
        self.stores = self.stores.wrapping_add(1);
    }

    /// Store and restore commands the drive carried out.
    pub fn stores(&self) -> u64 {
        self.stores
    }

    /// Makes PDO mapping `mapping` (0x1600.. or 0x1A00..) fixed to `entries`: the drive
    /// reports them and refuses every write to the mapping (abort 0x06010002), as drives with
    /// a hard-wired process image do. Call before power-on; survives resets.
    pub fn fix_pdo_mapping(&mut self, mapping: u16, entries: &[MappingEntry]) {
        let n = entries.len().min(8);
        self.fixed.retain(|(m, _)| *m != mapping);
        self.fixed.push((mapping, entries[..n].to_vec()));
        self.reapply_fixed_mapping();
        self.od = self.defaults.clone();
        self.reload_pdos();
    }

    fn reapply_fixed_mapping(&mut self) {
        for (mapping, entries) in &self.fixed {
            let count = Value::U8(entries.len() as u8);
            let fixed = |name, v| Entry::new(name, Access::Const, v);
            self.defaults
                .insert(*mapping, 0, fixed("number of mapped objects", count));
            for sub in 1..=8u8 {
                let v = entries.get(sub as usize - 1).map_or(0, |e| e.to_u32());
                self.defaults
                    .insert(*mapping, sub, fixed("mapped object", Value::U32(v)));
            }
        }
    }
}
