//! The interpreter's modal state: every G group, F, S, T, the spindle, the canned-cycle data
//! Fanuc keeps between blocks, and the programmed position in machine coordinates. Later issues
//! read it for the Macro B system variables (`#4001…`, `#5001…`).

use cnc402_config::{MachineConfig, PlaneDefault, ReturnPlane, Units};
use cnc402_motion::segment::{AxisPos, Plane, SpindleDir};

/// Group 01 motion mode (what axis words do outside a canned cycle).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Motion {
    Rapid,
    Linear,
    ArcCw,
    ArcCcw,
}

/// A canned cycle of group 09 (G80 is "none").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cycle {
    G73,
    G74,
    G76,
    G81,
    G82,
    G83,
    G84,
    G85,
    G86,
    G87,
    G88,
    G89,
}

impl Cycle {
    pub fn from_code(code: u32) -> Option<Cycle> {
        Some(match code {
            73 => Cycle::G73,
            74 => Cycle::G74,
            76 => Cycle::G76,
            81 => Cycle::G81,
            82 => Cycle::G82,
            83 => Cycle::G83,
            84 => Cycle::G84,
            85 => Cycle::G85,
            86 => Cycle::G86,
            87 => Cycle::G87,
            88 => Cycle::G88,
            89 => Cycle::G89,
            _ => return None,
        })
    }
    pub fn code(self) -> u32 {
        match self {
            Cycle::G73 => 73,
            Cycle::G74 => 74,
            Cycle::G76 => 76,
            Cycle::G81 => 81,
            Cycle::G82 => 82,
            Cycle::G83 => 83,
            Cycle::G84 => 84,
            Cycle::G85 => 85,
            Cycle::G86 => 86,
            Cycle::G87 => 87,
            Cycle::G88 => 88,
            Cycle::G89 => 89,
        }
    }
}

/// The data Fanuc keeps while a canned cycle stays active (cleared by G80 and group 01 codes).
/// Lengths are in mm as programmed: absolute work values in G90, distances in G91.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct CycleData {
    /// R level (G90: work coordinate; G91: distance from the initial level).
    pub r: Option<f64>,
    /// Bottom (G90: work coordinate; G91: distance from the R level).
    pub z: Option<f64>,
    /// Peck depth (G73/G83/peck tapping) or shift amount (G76/G87), mm.
    pub q: Option<f64>,
    /// Dwell, seconds.
    pub p: Option<f64>,
    /// Machine position along the drilling axis when the cycle mode was entered.
    pub initial: f64,
}

/// Everything modal.
#[derive(Clone, Debug, PartialEq)]
pub struct ModalState {
    pub motion: Motion,
    pub cycle: Option<Cycle>,
    pub cycle_data: CycleData,
    pub plane: Plane,
    /// G20 (true) / G21.
    pub inch: bool,
    /// G91 (true) / G90.
    pub incremental: bool,
    /// G95 (true) / G94.
    pub feed_per_rev: bool,
    /// 0..=5 for G54..G59.
    pub work_offset: usize,
    /// G99 (true) / G98.
    pub return_to_r: bool,
    /// F in mm/min (G94) or mm/rev (G95), as last programmed.
    pub feed: f64,
    /// S, rpm.
    pub speed: f64,
    /// M3/M4/M5 as last programmed.
    pub spindle: SpindleDir,
    /// M29 rigid tapping mode (until G80 or a group 01 code).
    pub rigid: bool,
    /// T as last programmed (selected for the next M6).
    pub tool_selected: u32,
    /// The tool in the spindle after the last M6.
    pub tool_loaded: Option<u32>,
    /// Programmed position, machine coordinates, mm / degrees; C (the spindle) is the program's
    /// view, 0 at program start.
    pub pos: AxisPos,
}

impl ModalState {
    /// The state at program start: config defaults, G0, G94, G54, G80, spindle stopped.
    pub fn new(cfg: &MachineConfig, start: AxisPos) -> Self {
        ModalState {
            motion: Motion::Rapid,
            cycle: None,
            cycle_data: CycleData::default(),
            plane: match cfg.interp.plane {
                PlaneDefault::XY => Plane::XY,
                PlaneDefault::ZX => Plane::ZX,
                PlaneDefault::YZ => Plane::YZ,
            },
            inch: cfg.interp.units == Units::Inch,
            incremental: false,
            feed_per_rev: false,
            work_offset: 0,
            return_to_r: cfg.interp.return_plane == ReturnPlane::R,
            feed: 0.0,
            speed: 0.0,
            spindle: SpindleDir::Stop,
            rigid: false,
            tool_selected: 0,
            tool_loaded: None,
            pos: start,
        }
    }

    /// mm per program length unit.
    pub fn unit(&self) -> f64 {
        if self.inch { 25.4 } else { 1.0 }
    }

    /// The spindle is commanded to turn (M3/M4 with S > 0).
    pub fn spindle_turning(&self) -> bool {
        self.spindle != SpindleDir::Stop && self.speed > 0.0
    }
}
