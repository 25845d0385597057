//! Homing mode (0x6060 = 6): the homing methods (0x6098) this project runs and simulates, and
//! what the statusword says during homing (bits 10, 12 and 13, CiA 402-2 §7.7). The master
//! starts homing with controlword bit 4 ([`HOMING_START`]) and reads [`HomingStatus`].

use core::fmt;

use crate::Statusword;

/// Controlword bit 4 in homing mode: homing operation start (acts on its rising edge).
pub const HOMING_START: u16 = 1 << 4;
/// Statusword bit 12 in homing mode: homing attained.
pub const HOMING_ATTAINED: u16 = 1 << 12;
/// Statusword bit 13 in homing mode: homing error.
pub const HOMING_ERROR: u16 = 1 << 13;

/// Which way the drive moves first (in the drive's own direction, after 0x607E).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Towards lower positions.
    Negative,
    /// Towards higher positions.
    Positive,
}

impl Direction {
    /// −1 or +1.
    pub const fn sign(self) -> f64 {
        match self {
            Direction::Negative => -1.0,
            Direction::Positive => 1.0,
        }
    }
}

/// What a homing method looks for (CiA 402-2, homing methods 1..=37).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum HomingTarget {
    /// The limit switch on the given side, then (with `index`) the first index pulse after
    /// leaving it; without, the switch's edge.
    LimitSwitch { side: Direction, index: bool },
    /// The edge of a home switch active on the given side of its edge (19/20: active above,
    /// 21/22: below); found from either side.
    HomeSwitch { active_side: Direction },
    /// The first index pulse in the given direction.
    Index { direction: Direction },
    /// The current position (no motion).
    CurrentPosition,
}

/// A homing method (0x6098) this project supports: run by the master, simulated by
/// `SimDrive`. Others are refused at config load with the list of these.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct HomingMethod(i8);

impl HomingMethod {
    /// Every supported method number, ascending.
    pub const SUPPORTED: [i8; 12] = [1, 2, 17, 18, 19, 20, 21, 22, 33, 34, 35, 37];

    /// The method with number `n`, if supported.
    pub const fn new(n: i8) -> Option<HomingMethod> {
        let mut k = 0;
        while k < Self::SUPPORTED.len() {
            if Self::SUPPORTED[k] == n {
                return Some(HomingMethod(n));
            }
            k += 1;
        }
        None
    }

    /// The 0x6098 value.
    pub const fn number(self) -> i8 {
        self.0
    }

    /// What the method looks for.
    pub const fn target(self) -> HomingTarget {
        use Direction::*;
        match self.0 {
            1 => HomingTarget::LimitSwitch {
                side: Negative,
                index: true,
            },
            2 => HomingTarget::LimitSwitch {
                side: Positive,
                index: true,
            },
            17 => HomingTarget::LimitSwitch {
                side: Negative,
                index: false,
            },
            18 => HomingTarget::LimitSwitch {
                side: Positive,
                index: false,
            },
            19 | 20 => HomingTarget::HomeSwitch {
                active_side: Positive,
            },
            21 | 22 => HomingTarget::HomeSwitch {
                active_side: Negative,
            },
            33 => HomingTarget::Index {
                direction: Negative,
            },
            34 => HomingTarget::Index {
                direction: Positive,
            },
            _ => HomingTarget::CurrentPosition,
        }
    }

    /// Whether the drive moves (35 and 37 do not).
    pub const fn moves(self) -> bool {
        !matches!(self.target(), HomingTarget::CurrentPosition)
    }

    /// The supported numbers as text, for messages ("1, 2, 17, …").
    pub fn supported_list() -> String {
        let v: Vec<String> = Self::SUPPORTED.iter().map(|n| n.to_string()).collect();
        v.join(", ")
    }
}

impl fmt::Display for HomingMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let what = match self.target() {
            HomingTarget::LimitSwitch {
                side: Direction::Negative,
                index: true,
            } => "negative limit switch and index pulse",
            HomingTarget::LimitSwitch {
                side: Direction::Positive,
                index: true,
            } => "positive limit switch and index pulse",
            HomingTarget::LimitSwitch {
                side: Direction::Negative,
                index: false,
            } => "negative limit switch",
            HomingTarget::LimitSwitch {
                side: Direction::Positive,
                index: false,
            } => "positive limit switch",
            HomingTarget::HomeSwitch {
                active_side: Direction::Positive,
            } => "positive home switch",
            HomingTarget::HomeSwitch {
                active_side: Direction::Negative,
            } => "negative home switch",
            HomingTarget::Index {
                direction: Direction::Negative,
            } => "index pulse, negative direction",
            HomingTarget::Index {
                direction: Direction::Positive,
            } => "index pulse, positive direction",
            HomingTarget::CurrentPosition => "current position",
        };
        write!(f, "method {} ({what})", self.0)
    }
}

/// The homing state bits 13, 12 and 10 of a statusword in homing mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum HomingStatus {
    /// 0 0 0: homing in progress.
    InProgress,
    /// 0 0 1: homing interrupted or not started.
    Idle,
    /// 0 1 0: homing attained, target not reached (still moving to the home position).
    AttainedMoving,
    /// 0 1 1: homing completed successfully.
    Completed,
    /// 1 x x: homing error (velocity zero when bit 10 is set).
    Error,
}

impl HomingStatus {
    /// Decodes bits 13, 12 and 10 of `sw`.
    pub const fn of(sw: Statusword) -> HomingStatus {
        let reached = sw.has(Statusword::TARGET_REACHED);
        if sw.has(HOMING_ERROR) {
            return HomingStatus::Error;
        }
        match (sw.has(HOMING_ATTAINED), reached) {
            (false, false) => HomingStatus::InProgress,
            (false, true) => HomingStatus::Idle,
            (true, false) => HomingStatus::AttainedMoving,
            (true, true) => HomingStatus::Completed,
        }
    }

    /// The statusword bits (13, 12, 10) of this status.
    pub const fn bits(self) -> u16 {
        match self {
            HomingStatus::InProgress => 0,
            HomingStatus::Idle => Statusword::TARGET_REACHED,
            HomingStatus::AttainedMoving => HOMING_ATTAINED,
            HomingStatus::Completed => HOMING_ATTAINED | Statusword::TARGET_REACHED,
            HomingStatus::Error => HOMING_ERROR | Statusword::TARGET_REACHED,
        }
    }
}

impl fmt::Display for HomingStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            HomingStatus::InProgress => "homing in progress",
            HomingStatus::Idle => "homing not started or interrupted",
            HomingStatus::AttainedMoving => "home found, moving to it",
            HomingStatus::Completed => "homing completed",
            HomingStatus::Error => "homing error",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_listed_methods_are_supported() {
        for n in i8::MIN..=i8::MAX {
            let m = HomingMethod::new(n);
            assert_eq!(m.is_some(), HomingMethod::SUPPORTED.contains(&n), "{n}");
            if let Some(m) = m {
                assert_eq!(m.number(), n);
            }
        }
        assert_eq!(
            HomingMethod::supported_list(),
            "1, 2, 17, 18, 19, 20, 21, 22, 33, 34, 35, 37"
        );
    }

    #[test]
    fn method_targets_follow_cia402() {
        use Direction::*;
        let t = |n| HomingMethod::new(n).unwrap().target();
        assert_eq!(
            t(1),
            HomingTarget::LimitSwitch {
                side: Negative,
                index: true
            }
        );
        assert_eq!(
            t(18),
            HomingTarget::LimitSwitch {
                side: Positive,
                index: false
            }
        );
        assert_eq!(
            t(19),
            HomingTarget::HomeSwitch {
                active_side: Positive
            }
        );
        assert_eq!(
            t(22),
            HomingTarget::HomeSwitch {
                active_side: Negative
            }
        );
        assert_eq!(
            t(34),
            HomingTarget::Index {
                direction: Positive
            }
        );
        assert_eq!(t(35), HomingTarget::CurrentPosition);
        assert_eq!(t(37), HomingTarget::CurrentPosition);
        assert!(!HomingMethod::new(37).unwrap().moves());
        assert!(HomingMethod::new(2).unwrap().moves());
        assert_eq!(
            HomingMethod::new(33).unwrap().to_string(),
            "method 33 (index pulse, negative direction)"
        );
    }

    #[test]
    fn statusword_homing_bits_decode_every_combination() {
        let enabled = 0x0237u16;
        let cases = [
            (0, HomingStatus::InProgress),
            (1 << 10, HomingStatus::Idle),
            (1 << 12, HomingStatus::AttainedMoving),
            ((1 << 12) | (1 << 10), HomingStatus::Completed),
            (1 << 13, HomingStatus::Error),
            ((1 << 13) | (1 << 10), HomingStatus::Error),
            ((1 << 13) | (1 << 12), HomingStatus::Error),
        ];
        for (bits, status) in cases {
            assert_eq!(
                HomingStatus::of(Statusword(enabled | bits)),
                status,
                "{bits:#x}"
            );
        }
        for s in [
            HomingStatus::InProgress,
            HomingStatus::Idle,
            HomingStatus::AttainedMoving,
            HomingStatus::Completed,
            HomingStatus::Error,
        ] {
            assert_eq!(HomingStatus::of(Statusword(enabled | s.bits())), s);
        }
        assert_eq!(HOMING_START, 0x10);
    }
}
