//! The drive's PDO runtime: the communication and mapping parameters as the device uses them
//! (reloaded from the dictionary after every change), and the CiA 301 remap rules checked on
//! every SDO write to 0x1400..=0x1BFF.

use cia402::objects as o;

use super::objects::{COB_EXTENDED, COB_INVALID};
use crate::od::{ObjectDictionary, Slot};
use crate::wire::{AbortCode, MappingEntry, PdoMap};

/// One RPDO as the device applies it.
#[derive(Clone, Copy, Debug, Default)]
pub struct RpdoSlot {
    /// Bit 31 of the COB-ID clear.
    pub valid: bool,
    /// 11-bit COB-ID.
    pub cob_id: u16,
    /// Transmission type (0..=240 synchronous, 254/255 event).
    pub transmission_type: u8,
    /// Mapping.
    pub map: PdoMap,
    /// Dictionary slots of the mapped entries, in mapping order.
    pub slots: [Option<Slot>; 8],
    /// Synchronous data received since the last SYNC (applied at the next SYNC).
    pub pending: Option<([u8; 8], usize)>,
}

/// One TPDO as the device produces it.
#[derive(Clone, Copy, Debug, Default)]
pub struct TpdoSlot {
    /// Bit 31 of the COB-ID clear.
    pub valid: bool,
    /// 11-bit COB-ID.
    pub cob_id: u16,
    /// Transmission type (0 acyclic sync, 1..=240 every n-th SYNC, 254/255 event).
    pub transmission_type: u8,
    /// Inhibit time, 100 µs units.
    pub inhibit_100us: u16,
    /// Event timer, ms (0 = off).
    pub event_timer_ms: u16,
    /// Mapping.
    pub map: PdoMap,
    /// Dictionary slots of the mapped entries, in mapping order.
    pub slots: [Option<Slot>; 8],
    /// SYNCs counted towards the next transmission.
    pub sync_count: u32,
    /// Data last sent.
    pub last_data: Option<([u8; 8], usize)>,
    /// Time of the last transmission (ns).
    pub last_tx_ns: Option<u64>,
}

/// Whether `index` is a PDO communication or mapping parameter (0x1400..=0x1BFF).
pub fn is_pdo_parameter(index: u16) -> bool {
    (0x1400..=0x1BFF).contains(&index)
}

fn u32_of(od: &ObjectDictionary, index: u16, sub: u8) -> u32 {
    od.get_u64(index, sub).unwrap_or(0) as u32
}

fn slots_of(od: &ObjectDictionary, map: &PdoMap) -> [Option<Slot>; 8] {
    let mut s = [None; 8];
    for (k, e) in map.entries().enumerate() {
        s[k] = od.slot(e.index, e.sub);
    }
    s
}

fn load_map(od: &ObjectDictionary, index: u16) -> PdoMap {
    let n = od.get_u64(index, 0).unwrap_or(0).min(8) as u8;
    let mut map = PdoMap::new();
    for sub in 1..=n {
        let e = MappingEntry::from_u32(u32_of(od, index, sub));
        // Entries were validated when written; a bad one is skipped rather than trusted.
        let _ = map.push(e);
    }
    map
}

/// Reloads RPDO slot `n` (0-based) from the dictionary, keeping no pending data.
pub fn load_rpdo(od: &ObjectDictionary, n: u16) -> RpdoSlot {
    let cob = u32_of(od, o::RPDO_COMMUNICATION + n, 1);
    let map = load_map(od, o::RPDO_MAPPING + n);
    RpdoSlot {
        valid: cob & COB_INVALID == 0,
        cob_id: (cob & 0x7FF) as u16,
        transmission_type: od.get_u64(o::RPDO_COMMUNICATION + n, 2).unwrap_or(255) as u8,
        slots: slots_of(od, &map),
        map,
        pending: None,
    }
}

/// Reloads TPDO slot `n` (0-based); counters restart.
pub fn load_tpdo(od: &ObjectDictionary, n: u16) -> TpdoSlot {
    let c = o::TPDO_COMMUNICATION + n;
    let cob = u32_of(od, c, 1);
    let map = load_map(od, o::TPDO_MAPPING + n);
    TpdoSlot {
        valid: cob & COB_INVALID == 0,
        cob_id: (cob & 0x7FF) as u16,
        transmission_type: od.get_u64(c, 2).unwrap_or(255) as u8,
        inhibit_100us: od.get_u64(c, 3).unwrap_or(0) as u16,
        event_timer_ms: od.get_u64(c, 5).unwrap_or(0) as u16,
        slots: slots_of(od, &map),
        map,
        sync_count: 0,
        last_data: None,
        last_tx_ns: None,
    }
}

/// Checks one mapping entry for an RPDO (`rpdo`) or TPDO.
pub fn check_entry(od: &ObjectDictionary, raw: u32, rpdo: bool) -> Result<MappingEntry, AbortCode> {
    let e = MappingEntry::from_u32(raw);
    let entry = od.entry(e.index, e.sub).map_err(|err| err.abort_code())?;
    let direction_ok = if rpdo {
        entry.access.writable()
    } else {
        entry.access.readable()
    };
    if !entry.pdo_mappable || !direction_ok {
        return Err(AbortCode::CannotMap);
    }
    match entry.value.data_type().pdo_bits() {
        Some(bits) if bits == e.bits => Ok(e),
        Some(_) => Err(AbortCode::ParameterIncompatible),
        None => Err(AbortCode::CannotMap),
    }
}

/// The CiA 301 rules for an SDO write of `value` to PDO parameter (index, sub). `operational`
/// refuses every PDO parameter change outside PRE-OPERATIONAL. Returns `Ok` when the write
/// may be stored.
pub fn check_write(
    od: &ObjectDictionary,
    index: u16,
    sub: u8,
    value: u32,
    operational: bool,
) -> Result<(), AbortCode> {
    if operational {
        return Err(AbortCode::DeviceState);
    }
    let n = index & 0x3;
    match index & 0xFE00 {
        // 0x1400 / 0x1800: communication parameters.
        0x1400 | 0x1800 if index & 0x01FC == 0 => {
            let cur = u32_of(od, index, 1);
            match sub {
                1 => {
                    if value & COB_EXTENDED != 0 {
                        return Err(AbortCode::InvalidValue);
                    }
                    let cur_valid = cur & COB_INVALID == 0;
                    let new_valid = value & COB_INVALID == 0;
                    // The COB-ID of a valid PDO cannot change; invalidate it first.
                    if cur_valid && new_valid && (cur & 0x7FF) != (value & 0x7FF) {
                        return Err(AbortCode::InvalidValue);
                    }
                    if new_valid && (value & 0x7FF == 0 || value & 0x7FF == 0x80) {
                        return Err(AbortCode::InvalidValue);
                    }
                    Ok(())
                }
                2 => {
                    let t = value as u8;
                    // 252/253 (RTR only) are not supported.
                    let ok = t <= 240 || t == 254 || t == 255;
                    if ok {
                        Ok(())
                    } else {
                        Err(AbortCode::InvalidValue)
                    }
                }
                3 => {
                    // Inhibit time may only change while the PDO is invalid.
                    if cur & COB_INVALID == 0 {
                        Err(AbortCode::InvalidValue)
                    } else {
                        Ok(())
                    }
                }
                _ => Ok(()),
            }
        }
        // 0x1600 / 0x1A00: mapping parameters.
        0x1600 | 0x1A00 if index & 0x01FC == 0 => {
            let rpdo = index < 0x1A00;
            let comm = if rpdo {
                o::RPDO_COMMUNICATION
            } else {
                o::TPDO_COMMUNICATION
            } + n;
            if u32_of(od, comm, 1) & COB_INVALID == 0 {
                // Remap sequence step 1 skipped: PDO still valid.
                return Err(AbortCode::DeviceState);
            }
            let count = od.get_u64(index, 0).unwrap_or(0);
            if sub == 0 {
                if value > 8 {
                    return Err(AbortCode::MappingTooLong);
                }
                let mut map = PdoMap::new();
                for s in 1..=value as u8 {
                    let raw = u32_of(od, index, s);
                    if raw == 0 {
                        return Err(AbortCode::ParameterIncompatible);
                    }
                    let e = check_entry(od, raw, rpdo)?;
                    map.push(e).map_err(|_| AbortCode::MappingTooLong)?;
                }
                Ok(())
            } else {
                if count != 0 {
                    // Remap sequence step 2 skipped: mapping still enabled (sub 0 ≠ 0).
                    return Err(AbortCode::DeviceState);
                }
                if value == 0 {
                    return Ok(());
                }
                check_entry(od, value, rpdo).map(|_| ())
            }
        }
        _ => Ok(()),
    }
}
