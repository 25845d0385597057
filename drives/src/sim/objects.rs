//! The simulated drive's object dictionary at power-on, built from the axis config.

use cia402::objects as o;
use cia402::{OperationMode, QuickStopOption};

use crate::od::{Access, Entry, ObjectDictionary, Value};
use crate::wire::NodeId;

/// Identity (0x1018) vendor id of the simulated drive.
pub const VENDOR_ID: u32 = 0x00C4_0402;
/// Identity product code.
pub const PRODUCT_CODE: u32 = 0x0000_0001;
/// Identity revision.
pub const REVISION: u32 = 0x0001_0000;

/// PDO COB-ID bit 31: PDO does not exist / is not valid.
pub const COB_INVALID: u32 = 1 << 31;
/// PDO COB-ID bit 30: no RTR allowed.
pub const COB_NO_RTR: u32 = 1 << 30;
/// PDO COB-ID bit 29: 29-bit identifier.
pub const COB_EXTENDED: u32 = 1 << 29;

/// Parameters the dictionary is built from.
#[derive(Clone, Debug)]
pub struct DriveParams {
    /// Node id.
    pub node: NodeId,
    /// 0x1008.
    pub name: String,
    /// 0x6065 in counts (0xFFFF_FFFF = off).
    pub following_error_window: u32,
    /// 0x6066 in ms.
    pub following_error_timeout_ms: u16,
    /// 0x6085 in counts/s².
    pub quick_stop_deceleration: u32,
    /// 0x60C2 as (value, exponent).
    pub interpolation_period: (u8, i8),
}

/// Builds the power-on dictionary.
pub fn build(p: &DriveParams) -> ObjectDictionary {
    let mut od = ObjectDictionary::new();
    insert_communication_area(&mut od, p);
    insert_pdo_parameters(&mut od, u32::from(p.node.get()));
    insert_device_profile(&mut od, p);
    od
}

/// Inserts a single-entry object (sub-index 0).
fn var(od: &mut ObjectDictionary, index: u16, e: Entry) {
    od.insert_var(index, e);
}

/// The communication profile area (0x1000..0x1018, CiA 301) but for the PDO parameters.
fn insert_communication_area(od: &mut ObjectDictionary, p: &DriveParams) {
    use Access::*;
    let id = u32::from(p.node.get());
    var(
        od,
        o::DEVICE_TYPE,
        Entry::new(
            "device type",
            Const,
            Value::U32(o::DEVICE_TYPE_CIA402_SERVO),
        ),
    );
    var(
        od,
        o::ERROR_REGISTER,
        Entry::new("error register", ReadOnly, Value::U8(0)),
    );
    od.insert(
        o::PREDEFINED_ERROR_FIELD,
        0,
        Entry::new("number of errors", ReadWrite, Value::U8(0)),
    );
    for sub in 1..=8 {
        od.insert(
            o::PREDEFINED_ERROR_FIELD,
            sub,
            Entry::new("standard error field", ReadOnly, Value::U32(0)),
        );
    }
    var(
        od,
        o::SYNC_COB_ID,
        Entry::new("COB-ID SYNC", ReadWrite, Value::U32(0x80)),
    );
    var(
        od,
        o::COMMUNICATION_CYCLE_PERIOD,
        Entry::new("communication cycle period", ReadWrite, Value::U32(0)),
    );
    var(
        od,
        o::DEVICE_NAME,
        Entry::new(
            "manufacturer device name",
            Const,
            Value::VisibleString(p.name.clone()),
        ),
    );
    var(
        od,
        0x1014,
        Entry::new("COB-ID EMCY", ReadOnly, Value::U32(0x80 + id)),
    );
    var(
        od,
        o::PRODUCER_HEARTBEAT_TIME,
        Entry::new("producer heartbeat time", ReadWrite, Value::U16(0)),
    );
    // Heartbeat consumer (one entry: the master) and what the drive does when it misses it.
    od.insert(
        o::CONSUMER_HEARTBEAT_TIME,
        0,
        Entry::new("consumer heartbeat entries", Const, Value::U8(1)),
    );
    od.insert(
        o::CONSUMER_HEARTBEAT_TIME,
        1,
        Entry::new("consumer heartbeat time 1", ReadWrite, Value::U32(0)),
    );
    var(
        od,
        o::ABORT_CONNECTION_OPTION,
        Entry::new("abort connection option code", ReadWrite, Value::I16(1)).range(0, 3),
    );
    od.insert(
        o::IDENTITY,
        0,
        Entry::new("identity entries", Const, Value::U8(4)),
    );
    od.insert(
        o::IDENTITY,
        1,
        Entry::new("vendor id", ReadOnly, Value::U32(VENDOR_ID)),
    );
    od.insert(
        o::IDENTITY,
        2,
        Entry::new("product code", ReadOnly, Value::U32(PRODUCT_CODE)),
    );
    od.insert(
        o::IDENTITY,
        3,
        Entry::new("revision number", ReadOnly, Value::U32(REVISION)),
    );
    od.insert(
        o::IDENTITY,
        4,
        Entry::new("serial number", ReadOnly, Value::U32(id)),
    );
}

/// The PDO communication and mapping parameters (0x1400.., 0x1600.., 0x1800.., 0x1A00..).
fn insert_pdo_parameters(od: &mut ObjectDictionary, id: u32) {
    use Access::*;
    for n in 0..4u16 {
        // Pre-defined connection set; PDO 1 valid (RPDO1 = controlword, TPDO1 = statusword,
        // event driven), PDOs 2..4 exist but are invalid and unmapped.
        let valid = if n == 0 { 0 } else { COB_INVALID };
        let rpdo_cob = valid | (0x200 + 0x100 * n as u32 + id);
        let tpdo_cob = valid | COB_NO_RTR | (0x180 + 0x100 * n as u32 + id);
        let rc = o::RPDO_COMMUNICATION + n;
        od.insert(
            rc,
            0,
            Entry::new("RPDO comm highest sub", Const, Value::U8(2)),
        );
        od.insert(
            rc,
            1,
            Entry::new("RPDO COB-ID", ReadWrite, Value::U32(rpdo_cob)),
        );
        od.insert(
            rc,
            2,
            Entry::new("RPDO transmission type", ReadWrite, Value::U8(255)),
        );
        let tc = o::TPDO_COMMUNICATION + n;
        od.insert(
            tc,
            0,
            Entry::new("TPDO comm highest sub", Const, Value::U8(5)),
        );
        od.insert(
            tc,
            1,
            Entry::new("TPDO COB-ID", ReadWrite, Value::U32(tpdo_cob)),
        );
        od.insert(
            tc,
            2,
            Entry::new("TPDO transmission type", ReadWrite, Value::U8(255)),
        );
        od.insert(
            tc,
            3,
            Entry::new("TPDO inhibit time", ReadWrite, Value::U16(0)),
        );
        od.insert(
            tc,
            5,
            Entry::new("TPDO event timer", ReadWrite, Value::U16(0)),
        );
        for (base, first) in [
            (o::RPDO_MAPPING, 0x6040_0010u32),
            (o::TPDO_MAPPING, 0x6041_0010u32),
        ] {
            let m = base + n;
            od.insert(
                m,
                0,
                Entry::new(
                    "number of mapped objects",
                    ReadWrite,
                    Value::U8(u8::from(n == 0)),
                ),
            );
            for sub in 1..=8u8 {
                let v = if n == 0 && sub == 1 { first } else { 0 };
                od.insert(
                    m,
                    sub,
                    Entry::new("mapped object", ReadWrite, Value::U32(v)),
                );
            }
        }
    }
}

/// The CiA 402 device profile area (0x603F..).
fn insert_device_profile(od: &mut ObjectDictionary, p: &DriveParams) {
    use Access::*;
    var(
        od,
        o::ERROR_CODE,
        Entry::new("error code", ReadOnly, Value::U16(0)),
    );
    var(
        od,
        o::CONTROLWORD,
        Entry::new("controlword", ReadWrite, Value::U16(0)).mappable(),
    );
    var(
        od,
        o::STATUSWORD,
        Entry::new("statusword", ReadOnly, Value::U16(0)).mappable(),
    );
    var(
        od,
        o::QUICK_STOP_OPTION,
        Entry::new(
            "quick stop option code",
            ReadWrite,
            Value::I16(QuickStopOption::QuickStopRamp.to_i16()),
        )
        .range(0, 8),
    );
    var(
        od,
        o::MODES_OF_OPERATION,
        Entry::new("modes of operation", ReadWrite, Value::I8(0)).mappable(),
    );
    var(
        od,
        o::MODES_OF_OPERATION_DISPLAY,
        Entry::new("modes of operation display", ReadOnly, Value::I8(0)).mappable(),
    );
    var(
        od,
        o::POSITION_DEMAND,
        Entry::new("position demand value", ReadOnly, Value::I32(0)).mappable(),
    );
    var(
        od,
        o::POSITION_ACTUAL,
        Entry::new("position actual value", ReadOnly, Value::I32(0)).mappable(),
    );
    var(
        od,
        o::FOLLOWING_ERROR_WINDOW,
        Entry::new(
            "following error window",
            ReadWrite,
            Value::U32(p.following_error_window),
        ),
    );
    var(
        od,
        o::FOLLOWING_ERROR_TIMEOUT,
        Entry::new(
            "following error time out",
            ReadWrite,
            Value::U16(p.following_error_timeout_ms),
        ),
    );
    var(
        od,
        o::VELOCITY_ACTUAL,
        Entry::new("velocity actual value", ReadOnly, Value::I32(0)).mappable(),
    );
    var(
        od,
        o::TARGET_POSITION,
        Entry::new("target position", ReadWrite, Value::I32(0)).mappable(),
    );
    var(
        od,
        o::QUICK_STOP_DECELERATION,
        Entry::new(
            "quick stop deceleration",
            ReadWrite,
            Value::U32(p.quick_stop_deceleration),
        )
        .range(1, u32::MAX as i64),
    );
    insert_interpolation_period(od, p.interpolation_period);
    var(
        od,
        o::FOLLOWING_ERROR_ACTUAL,
        Entry::new("following error actual value", ReadOnly, Value::I32(0)).mappable(),
    );
    var(
        od,
        o::SUPPORTED_DRIVE_MODES,
        Entry::new(
            "supported drive modes",
            Const,
            Value::U32(
                OperationMode::CyclicSyncPosition.supported_bit()
                    | OperationMode::Homing.supported_bit(),
            ),
        ),
    );
    insert_homing_and_scaling(od);
}

/// Homing (0x607C, 0x6098, 0x6099, 0x609A), polarity (0x607E), the factor group's gear ratio
/// and feed constant (0x6091, 0x6092: stored, the simulated motor counts in position units
/// whatever they say), the digital inputs (0x60FD) and outputs (0x60FE, read back as written).
fn insert_homing_and_scaling(od: &mut ObjectDictionary) {
    use Access::*;
    var(
        od,
        o::HOME_OFFSET,
        Entry::new("home offset", ReadWrite, Value::I32(0)),
    );
    var(
        od,
        o::POLARITY,
        Entry::new("polarity", ReadWrite, Value::U8(0)),
    );
    var(
        od,
        o::HOMING_METHOD,
        Entry::new("homing method", ReadWrite, Value::I8(0)),
    );
    var(
        od,
        o::HOMING_ACCELERATION,
        Entry::new("homing acceleration", ReadWrite, Value::U32(0)),
    );
    var(
        od,
        o::DIGITAL_INPUTS,
        Entry::new("digital inputs", ReadOnly, Value::U32(0)).mappable(),
    );
    od.insert(
        o::DIGITAL_OUTPUTS,
        0,
        Entry::new("digital outputs", Const, Value::U8(2)),
    );
    for (sub, name) in [(1, "physical outputs"), (2, "bit mask")] {
        od.insert(
            o::DIGITAL_OUTPUTS,
            sub,
            Entry::new(name, ReadWrite, Value::U32(0)).mappable(),
        );
    }
    for (index, name, subs) in [
        (
            o::GEAR_RATIO,
            "gear ratio",
            ["motor revolutions", "shaft revolutions"],
        ),
        (
            o::FEED_CONSTANT,
            "feed constant",
            ["feed", "shaft revolutions"],
        ),
        (
            o::HOMING_SPEEDS,
            "homing speeds",
            [
                "speed during search for switch",
                "speed during search for zero",
            ],
        ),
    ] {
        od.insert(index, 0, Entry::new(name, Const, Value::U8(2)));
        let default = if index == o::HOMING_SPEEDS { 0 } else { 1 };
        for (sub, sub_name) in (1u8..).zip(subs) {
            od.insert(
                index,
                sub,
                Entry::new(sub_name, ReadWrite, Value::U32(default)),
            );
        }
    }
}

/// 0x60C2, the interpolation time period as (value, exponent) (CiA 402).
fn insert_interpolation_period(od: &mut ObjectDictionary, (value, exponent): (u8, i8)) {
    use Access::*;
    od.insert(
        o::INTERPOLATION_TIME_PERIOD,
        0,
        Entry::new("interpolation time period entries", Const, Value::U8(2)),
    );
    od.insert(
        o::INTERPOLATION_TIME_PERIOD,
        o::INTERPOLATION_TIME_PERIOD_VALUE_SUB,
        Entry::new(
            "interpolation time period value",
            ReadWrite,
            Value::U8(value),
        ),
    );
    od.insert(
        o::INTERPOLATION_TIME_PERIOD,
        o::INTERPOLATION_TIME_PERIOD_INDEX_SUB,
        Entry::new("interpolation time index", ReadWrite, Value::I8(exponent)).range(-6, 0),
    );
}

/// 0x60C2 (value, exponent) for a period in µs: the largest exponent that represents it
/// exactly in a UINT8 mantissa, else the nearest 1 µs-resolution value (clamped to 255).
pub fn interpolation_period(period_us: u32) -> (u8, i8) {
    for (exp, unit_us) in [
        (0i8, 1_000_000u32),
        (-1, 100_000),
        (-2, 10_000),
        (-3, 1_000),
        (-4, 100),
        (-5, 10),
        (-6, 1),
    ] {
        if period_us.is_multiple_of(unit_us)
            && period_us / unit_us <= 255
            && period_us / unit_us >= 1
        {
            return ((period_us / unit_us) as u8, exp);
        }
    }
    // Not exact: 10 µs units up to 2.55 ms, then 1 ms units.
    if period_us <= 2550 {
        ((period_us / 10).clamp(1, 255) as u8, -5)
    } else {
        ((period_us / 1000).clamp(1, 255) as u8, -3)
    }
}

/// Seconds of a 0x60C2 (value, exponent) pair.
pub fn interpolation_seconds(value: u8, exponent: i8) -> f64 {
    value as f64 * 10f64.powi(exponent as i32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_period_encoding() {
        assert_eq!(interpolation_period(1000), (1, -3));
        assert_eq!(interpolation_period(2000), (2, -3));
        assert_eq!(interpolation_period(250), (25, -5));
        assert_eq!(interpolation_period(500), (5, -4));
        assert_eq!(interpolation_period(125), (125, -6));
        assert!((interpolation_seconds(1, -3) - 0.001).abs() < 1e-12);
    }
}
