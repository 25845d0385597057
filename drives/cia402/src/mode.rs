//! Modes of operation (0x6060 / 0x6061) and the quick stop option code (0x605A).

use core::fmt;

/// A CiA 402 mode of operation as written to 0x6060 and read from 0x6061 (INT8).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OperationMode {
    /// 1: profile position.
    ProfilePosition,
    /// 3: profile velocity.
    ProfileVelocity,
    /// 4: profile torque.
    ProfileTorque,
    /// 6: homing.
    Homing,
    /// 7: interpolated position.
    InterpolatedPosition,
    /// 8: cyclic synchronous position (the mode this project drives).
    CyclicSyncPosition,
    /// 9: cyclic synchronous velocity.
    CyclicSyncVelocity,
    /// 10: cyclic synchronous torque.
    CyclicSyncTorque,
}

impl OperationMode {
    /// All modes this type names, in 0x6060 value order.
    pub const ALL: [OperationMode; 8] = [
        OperationMode::ProfilePosition,
        OperationMode::ProfileVelocity,
        OperationMode::ProfileTorque,
        OperationMode::Homing,
        OperationMode::InterpolatedPosition,
        OperationMode::CyclicSyncPosition,
        OperationMode::CyclicSyncVelocity,
        OperationMode::CyclicSyncTorque,
    ];

    /// The 0x6060 value. `OperationMode::CyclicSyncPosition.to_i8() == 8`.
    pub const fn to_i8(self) -> i8 {
        match self {
            OperationMode::ProfilePosition => 1,
            OperationMode::ProfileVelocity => 3,
            OperationMode::ProfileTorque => 4,
            OperationMode::Homing => 6,
            OperationMode::InterpolatedPosition => 7,
            OperationMode::CyclicSyncPosition => 8,
            OperationMode::CyclicSyncVelocity => 9,
            OperationMode::CyclicSyncTorque => 10,
        }
    }

    /// Decodes a 0x6060/0x6061 value; `None` for 0 (no mode), reserved and
    /// manufacturer-specific (negative) values.
    pub const fn from_i8(v: i8) -> Option<OperationMode> {
        Some(match v {
            1 => OperationMode::ProfilePosition,
            3 => OperationMode::ProfileVelocity,
            4 => OperationMode::ProfileTorque,
            6 => OperationMode::Homing,
            7 => OperationMode::InterpolatedPosition,
            8 => OperationMode::CyclicSyncPosition,
            9 => OperationMode::CyclicSyncVelocity,
            10 => OperationMode::CyclicSyncTorque,
            _ => return None,
        })
    }

    /// This mode's bit in 0x6502 supported drive modes (bit `mode - 1`; CSP = 0x80).
    pub const fn supported_bit(self) -> u32 {
        1u32 << (self.to_i8() as u32 - 1)
    }

    /// Whether a 0x6502 value says this mode is supported.
    pub const fn is_supported_by(self, supported_modes: u32) -> bool {
        supported_modes & self.supported_bit() != 0
    }
}

impl fmt::Display for OperationMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            OperationMode::ProfilePosition => "profile position",
            OperationMode::ProfileVelocity => "profile velocity",
            OperationMode::ProfileTorque => "profile torque",
            OperationMode::Homing => "homing",
            OperationMode::InterpolatedPosition => "interpolated position",
            OperationMode::CyclicSyncPosition => "cyclic synchronous position",
            OperationMode::CyclicSyncVelocity => "cyclic synchronous velocity",
            OperationMode::CyclicSyncTorque => "cyclic synchronous torque",
        };
        write!(f, "{s} ({})", self.to_i8())
    }
}

/// Quick stop option code 0x605A (INT16): how the drive stops on a quick stop command and
/// which state it ends in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum QuickStopOption {
    /// 0: disable the drive function at once (coast); goes to SWITCH ON DISABLED.
    DisableDrive,
    /// 1: slow down on the slow-down ramp, then SWITCH ON DISABLED.
    SlowDownRamp,
    /// 2: slow down on the quick stop ramp, then SWITCH ON DISABLED.
    QuickStopRamp,
    /// 3: stop at the current limit, then SWITCH ON DISABLED.
    CurrentLimit,
    /// 4: stop at the voltage limit, then SWITCH ON DISABLED.
    VoltageLimit,
    /// 5: slow-down ramp, stay in QUICK STOP ACTIVE.
    SlowDownRampStay,
    /// 6: quick stop ramp, stay in QUICK STOP ACTIVE.
    QuickStopRampStay,
    /// 7: current limit, stay in QUICK STOP ACTIVE.
    CurrentLimitStay,
    /// 8: voltage limit, stay in QUICK STOP ACTIVE.
    VoltageLimitStay,
}

impl QuickStopOption {
    /// Decodes a 0x605A value; `None` for reserved / manufacturer-specific codes.
    pub const fn from_i16(v: i16) -> Option<QuickStopOption> {
        Some(match v {
            0 => QuickStopOption::DisableDrive,
            1 => QuickStopOption::SlowDownRamp,
            2 => QuickStopOption::QuickStopRamp,
            3 => QuickStopOption::CurrentLimit,
            4 => QuickStopOption::VoltageLimit,
            5 => QuickStopOption::SlowDownRampStay,
            6 => QuickStopOption::QuickStopRampStay,
            7 => QuickStopOption::CurrentLimitStay,
            8 => QuickStopOption::VoltageLimitStay,
            _ => return None,
        })
    }

    /// The 0x605A value.
    pub const fn to_i16(self) -> i16 {
        match self {
            QuickStopOption::DisableDrive => 0,
            QuickStopOption::SlowDownRamp => 1,
            QuickStopOption::QuickStopRamp => 2,
            QuickStopOption::CurrentLimit => 3,
            QuickStopOption::VoltageLimit => 4,
            QuickStopOption::SlowDownRampStay => 5,
            QuickStopOption::QuickStopRampStay => 6,
            QuickStopOption::CurrentLimitStay => 7,
            QuickStopOption::VoltageLimitStay => 8,
        }
    }

    /// Options 5..=8 keep the drive in QUICK STOP ACTIVE after it stopped (and allow
    /// transition 16 back to OPERATION ENABLED).
    pub const fn stays_in_quick_stop(self) -> bool {
        self.to_i16() >= 5
    }

    /// Option 0 switches the power stage off at once instead of ramping down.
    pub const fn coasts(self) -> bool {
        matches!(self, QuickStopOption::DisableDrive)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mode_values_round_trip_and_csp_bit() {
        for m in OperationMode::ALL {
            assert_eq!(OperationMode::from_i8(m.to_i8()), Some(m));
        }
        assert_eq!(OperationMode::CyclicSyncPosition.to_i8(), 8);
        assert_eq!(OperationMode::CyclicSyncPosition.supported_bit(), 0x80);
        assert!(OperationMode::CyclicSyncPosition.is_supported_by(0x3A5));
        assert!(!OperationMode::CyclicSyncVelocity.is_supported_by(0x80));
        for v in [0i8, 2, 5, 11, -1, i8::MIN, i8::MAX] {
            assert_eq!(OperationMode::from_i8(v), None, "{v}");
        }
    }

    #[test]
    fn quick_stop_options() {
        for v in 0..=8 {
            let o = QuickStopOption::from_i16(v).unwrap();
            assert_eq!(o.to_i16(), v);
            assert_eq!(o.stays_in_quick_stop(), v >= 5);
        }
        assert_eq!(QuickStopOption::from_i16(9), None);
        assert_eq!(QuickStopOption::from_i16(-1), None);
    }
}
