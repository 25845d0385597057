//! Bus-load planning: the worst-case share of the CAN bus the configured traffic takes (SYNC,
//! each drive's cyclic PDOs, heartbeats, an SDO reserve) at `bus.bitrate` and `bus.period_us`.
//! A config whose plan exceeds 100 % is refused when it is read; the master takes its SDO
//! credit and `cyclic_load_percent` from the same figures, so the arithmetic lives here once.

pub use crate::bus::PdoLayout;
use crate::{AxisConfig, BusConfig};

/// Bits a classic 11-bit frame with `n` data bytes occupies, worst-case bit stuffing and
/// intermission included (≈ 55 + 10·n: SYNC 55, a 6-byte PDO 115, an 8-byte PDO 135).
pub const fn frame_bits(n: usize) -> u32 {
    55 + 10 * (if n > 8 { 8 } else { n }) as u32
}

/// Bits of one SDO request and its response (two 8-byte frames, worst-case stuffing).
pub const SDO_EXCHANGE_BITS: f64 = 2.0 * frame_bits(8) as f64;

/// The SDO reserve: one exchange per heartbeat period (per this many ms when heartbeats are
/// off). That is the rate of the master's in-cycle reads (status pages, `drivectl` while a
/// program runs, 0x603F after a fault) that must not starve the PDOs.
pub const SDO_RESERVE_PERIOD_MS_WITHOUT_HEARTBEAT: u32 = 100;

/// The step the suggested period is rounded up to (and a valid 0x60C2 period).
pub const PERIOD_STEP_US: u32 = 250;

/// The standard layout (drives/src/master/boot.rs): RPDO1 = controlword 0x6040 + target
/// 0x607A, TPDO1 = statusword 0x6041 + position 0x6064, both synchronous, every SYNC.
const STANDARD_PDO_BYTES: usize = 2 + 4;
/// The compact layout: target 0x607A alone in RPDO1, position 0x6064 alone in TPDO1.
const COMPACT_PDO_BYTES: usize = 4;
/// Compact layout's event-driven controlword (RPDO2) and statusword (TPDO2): 2 bytes each, at
/// most one per [`COMPACT_EVENT_INHIBIT_MS`] each (the statusword's inhibit time; the master
/// sends the controlword on change, which follows the statusword's state changes).
const COMPACT_EVENT_BYTES: usize = 2;
/// Inhibit time of the compact layout's statusword TPDO2 (0x1801:3 in 100 µs units = 100).
pub const COMPACT_EVENT_INHIBIT_MS: u32 = 10;

/// The compact layout's refresh (ms): the statusword TPDO2's event timer and the period the
/// master resends an unchanged controlword RPDO2 in: the heartbeat period, or
/// [`SDO_RESERVE_PERIOD_MS_WITHOUT_HEARTBEAT`] with heartbeats off.
pub fn event_refresh_ms(bus: &BusConfig) -> u16 {
    if bus.heartbeat_ms > 0 {
        bus.heartbeat_ms
    } else {
        SDO_RESERVE_PERIOD_MS_WITHOUT_HEARTBEAT as u16
    }
}

/// The planned load of one period, in bits, worst-case bit stuffing, per frame kind.
/// Heartbeats, the SDO reserve and event-driven PDOs are averaged over their own periods.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BusLoad {
    pub layout: PdoLayout,
    pub period_us: u32,
    pub bitrate: u32,
    /// Drives on the bus (axes with a node id; virtual axes send nothing).
    pub drives: usize,
    pub sync_bits: f64,
    /// Every drive's RPDO1 (the master's command).
    pub rpdo_bits: f64,
    /// Every drive's TPDO1 (its feedback).
    pub tpdo_bits: f64,
    /// The compact layout's event-driven controlword and statusword PDOs (0 for standard).
    pub event_bits: f64,
    /// The inputs TPDO3s (0x60FD, event-driven, at most one per
    /// [`COMPACT_EVENT_INHIBIT_MS`]) of the drives that send one.
    pub inputs_bits: f64,
    /// Drives that send an inputs TPDO3.
    pub input_drives: usize,
    /// The outputs RPDO3s (0x60FE:1, sent on a change and as a refresh, at most one per
    /// [`COMPACT_EVENT_INHIBIT_MS`]) of the drives with outputs.
    pub outputs_bits: f64,
    /// Drives that receive an outputs RPDO3.
    pub output_drives: usize,
    /// Every drive's heartbeat and the master's.
    pub heartbeat_bits: f64,
    pub sdo_reserve_bits: f64,
}

impl BusLoad {
    /// The plan for `drives` drives with `layout` on `bus` at `period_us`.
    pub fn plan(bus: &BusConfig, drives: usize, layout: PdoLayout, period_us: u32) -> BusLoad {
        let per_period = |bits: u32, every_ms: u32| {
            bits as f64 * period_us as f64 / (every_ms.max(1) as f64 * 1000.0)
        };
        let n = drives as f64;
        let pdo_bytes = match layout {
            PdoLayout::Standard => STANDARD_PDO_BYTES,
            PdoLayout::Compact => COMPACT_PDO_BYTES,
        };
        let event_bits = match layout {
            PdoLayout::Standard => 0.0,
            PdoLayout::Compact => {
                let every_ms = COMPACT_EVENT_INHIBIT_MS.min(event_refresh_ms(bus) as u32);
                2.0 * n * per_period(frame_bits(COMPACT_EVENT_BYTES), every_ms)
            }
        };
        let (heartbeat_bits, sdo_every_ms) = if bus.heartbeat_ms > 0 {
            let hb = (n + 1.0) * per_period(frame_bits(1), bus.heartbeat_ms as u32);
            (hb, bus.heartbeat_ms as u32)
        } else {
            (0.0, SDO_RESERVE_PERIOD_MS_WITHOUT_HEARTBEAT)
        };
        BusLoad {
            layout,
            period_us,
            bitrate: bus.bitrate,
            drives,
            sync_bits: frame_bits(0) as f64,
            rpdo_bits: n * frame_bits(pdo_bytes) as f64,
            tpdo_bits: n * frame_bits(pdo_bytes) as f64,
            event_bits,
            inputs_bits: 0.0,
            input_drives: 0,
            outputs_bits: 0.0,
            output_drives: 0,
            heartbeat_bits,
            sdo_reserve_bits: SDO_EXCHANGE_BITS * period_us as f64 / (sdo_every_ms as f64 * 1000.0),
        }
    }

    /// This plan with `k` drives sending the 4-byte inputs TPDO3 (0x60FD), each at most once
    /// per [`COMPACT_EVENT_INHIBIT_MS`] (its inhibit time).
    pub fn with_input_drives(mut self, k: usize) -> BusLoad {
        self.input_drives = k;
        self.inputs_bits = k as f64 * frame_bits(4) as f64 * self.period_us as f64
            / (COMPACT_EVENT_INHIBIT_MS as f64 * 1000.0);
        self
    }

    /// This plan with `k` drives receiving the 4-byte outputs RPDO3 (0x60FE:1), each at most
    /// once per [`COMPACT_EVENT_INHIBIT_MS`] (the master's own inhibit time).
    pub fn with_output_drives(mut self, k: usize) -> BusLoad {
        self.output_drives = k;
        self.outputs_bits = k as f64 * frame_bits(4) as f64 * self.period_us as f64
            / (COMPACT_EVENT_INHIBIT_MS as f64 * 1000.0);
        self
    }

    /// The plan of the drives of `axes` with `layout` at `bus.period_us`.
    pub fn of_config(bus: &BusConfig, axes: &[AxisConfig], layout: PdoLayout) -> BusLoad {
        let drives = axes.iter().filter(|a| a.node.is_some()).count();
        let inputs = axes
            .iter()
            .filter(|a| a.node.is_some() && a.inputs_pdo)
            .count();
        let outputs = axes
            .iter()
            .filter(|a| a.node.is_some() && a.outputs_pdo)
            .count();
        BusLoad::plan(bus, drives, layout, bus.period_us)
            .with_input_drives(inputs)
            .with_output_drives(outputs)
    }

    /// The plan of the configured machine (its `bus.pdo_layout`).
    pub fn of_machine(config: &crate::MachineConfig) -> BusLoad {
        BusLoad::of_config(&config.bus, &config.axes, config.bus.pdo_layout)
    }

    /// Bits the bus carries in one period.
    pub fn capacity_bits(&self) -> f64 {
        self.bitrate as f64 * self.period_us as f64 * 1e-6
    }

    /// Bits of the traffic that is always there: SYNC, PDOs, event PDOs, heartbeats (what the
    /// master leaves the SDO credit after).
    pub fn traffic_bits(&self) -> f64 {
        self.sync_bits
            + self.rpdo_bits
            + self.tpdo_bits
            + self.event_bits
            + self.inputs_bits
            + self.outputs_bits
            + self.heartbeat_bits
    }

    /// The planned worst case: the traffic and the SDO reserve.
    pub fn total_bits(&self) -> f64 {
        self.traffic_bits() + self.sdo_reserve_bits
    }

    /// [`traffic_bits`](Self::traffic_bits) as a share of the bus, percent.
    pub fn traffic_percent(&self) -> f64 {
        percent(self.traffic_bits(), self.capacity_bits())
    }

    /// [`total_bits`](Self::total_bits) as a share of the bus, percent.
    pub fn percent(&self) -> f64 {
        percent(self.total_bits(), self.capacity_bits())
    }

    pub fn fits(&self) -> bool {
        self.total_bits() <= self.capacity_bits()
    }

    /// The figures per frame kind, e.g. "SYNC 55 + RPDO 4×115 = 460 + …".
    pub fn breakdown(&self) -> String {
        let n = self.drives;
        let each = |b: f64| if n > 0 { b / n as f64 } else { 0.0 };
        let mut s = format!(
            "SYNC {:.0} + RPDO1 {n}×{:.0} + TPDO1 {n}×{:.0}",
            self.sync_bits,
            each(self.rpdo_bits),
            each(self.tpdo_bits)
        );
        if self.event_bits > 0.0 {
            s += &format!(" + event PDOs {:.1}", self.event_bits);
        }
        if self.inputs_bits > 0.0 {
            s += &format!(
                " + inputs TPDO3 {}×{:.1}",
                self.input_drives,
                self.inputs_bits / self.input_drives.max(1) as f64
            );
        }
        if self.outputs_bits > 0.0 {
            s += &format!(
                " + outputs RPDO3 {}×{:.1}",
                self.output_drives,
                self.outputs_bits / self.output_drives.max(1) as f64
            );
        }
        s += &format!(
            " + heartbeats {:.1} + SDO reserve {:.1}",
            self.heartbeat_bits, self.sdo_reserve_bits
        );
        s
    }

    /// The same traffic at another period.
    pub fn at_period(&self, bus: &BusConfig, period_us: u32) -> BusLoad {
        BusLoad::plan(bus, self.drives, self.layout, period_us)
            .with_input_drives(self.input_drives)
            .with_output_drives(self.output_drives)
    }

    /// The smallest period, a multiple of [`PERIOD_STEP_US`] the drives accept in 0x60C2,
    /// at which this layout fits (`None`: not even at 100 ms).
    pub fn smallest_period_us(&self, bus: &BusConfig) -> Option<u32> {
        (1..=100_000 / PERIOD_STEP_US)
            .map(|k| k * PERIOD_STEP_US)
            .filter(|&us| crate::bus::is_interpolation_period(us))
            .find(|&us| self.at_period(bus, us).fits())
    }
}

fn percent(bits: f64, capacity: f64) -> f64 {
    if capacity > 0.0 {
        100.0 * bits / capacity
    } else {
        f64::INFINITY
    }
}

/// The refusal of an overloaded config: the figures, the smallest period that fits and the
/// compact layout's load at the configured period.
pub(crate) fn check(bus: &BusConfig, axes: &[AxisConfig]) -> Result<(), String> {
    let plan = BusLoad::of_config(bus, axes, bus.pdo_layout);
    if plan.fits() {
        return Ok(());
    }
    let smallest = match plan.smallest_period_us(bus) {
        Some(us) => format!(
            "the smallest period that fits is {us} µs ({:.1} %)",
            plan.at_period(bus, us).percent()
        ),
        None => "no period up to 100000 µs fits: use fewer drives or a faster bitrate".into(),
    };
    let compact = match bus.pdo_layout {
        PdoLayout::Standard => format!(
            "; bus.pdo_layout = \"compact\" (targets and positions alone in the cyclic PDOs) \
             would need {:.1} % at {} µs",
            BusLoad::of_config(bus, axes, PdoLayout::Compact).percent(),
            bus.period_us
        ),
        PdoLayout::Compact => String::new(),
    };
    Err(format!(
        "the bus is overloaded: {} drives at {} bit/s with the {} PDO layout need {:.1} bits \
         per {} µs period, which carries {:.0}: {:.1} % worst case ({}); {smallest}{compact}",
        plan.drives,
        bus.bitrate,
        plan.layout.name(),
        plan.total_bits(),
        bus.period_us,
        plan.capacity_bits(),
        plan.percent(),
        plan.breakdown(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bus(bitrate: u32, period_us: u32, heartbeat_ms: u16) -> BusConfig {
        BusConfig {
            interface: "sim".into(),
            bitrate,
            period_us,
            heartbeat_ms,
            heartbeat_timeout_ms: 200,
            tpdo_timeout_cycles: 5,
            sdo_timeout_ms: 100,
            master_node_id: 127,
            pdo_layout: PdoLayout::Standard,
        }
    }

    #[test]
    fn frame_bits_by_length() {
        assert_eq!(frame_bits(0), 55);
        assert_eq!(frame_bits(6), 115);
        assert_eq!(frame_bits(8), 135);
        assert_eq!(frame_bits(12), 135);
        assert_eq!(SDO_EXCHANGE_BITS, 270.0);
    }

    /// 4 drives, 1 ms, 1 Mbit/s, heartbeats 50 ms (the shipped machine), by hand:
    /// SYNC 55 + 8 × 115 = 975; heartbeats 5 × 65 / 50 = 6.5; SDO 270 / 50 = 5.4 → 986.9.
    #[test]
    fn standard_four_drives_at_1ms() {
        let p = BusLoad::plan(&bus(1_000_000, 1000, 50), 4, PdoLayout::Standard, 1000);
        assert_eq!(p.capacity_bits(), 1000.0);
        assert!((p.traffic_bits() - 981.5).abs() < 1e-9, "{p:?}");
        assert!((p.total_bits() - 986.9).abs() < 1e-9, "{p:?}");
        assert!((p.percent() - 98.69).abs() < 1e-9);
        assert!(p.fits());
    }

    /// 5 drives: 55 + 10 × 115 = 1205 + 6 × 65 / 50 = 7.8 + 5.4 = 1218.2 bits → 121.82 %.
    /// At 1250 µs: 1205 + 9.75 + 6.75 = 1221.5 of 1250 = 97.72 %.
    #[test]
    fn five_drives_at_1ms_need_1250us() {
        let b = bus(1_000_000, 1000, 50);
        let p = BusLoad::plan(&b, 5, PdoLayout::Standard, 1000);
        assert!((p.total_bits() - 1218.2).abs() < 1e-9, "{p:?}");
        assert!(!p.fits());
        assert_eq!(p.smallest_period_us(&b), Some(1250));
        let at = BusLoad::plan(&b, 5, PdoLayout::Standard, 1250);
        assert!((at.percent() - 97.72).abs() < 1e-9, "{}", at.percent());
    }

    /// Compact, 4 drives, 1 ms, 1 Mbit/s: SYNC 55 + 8 × 95 = 815; event PDOs
    /// 2 × 4 × 75 / 10 = 60; heartbeats 6.5; SDO 5.4 → 886.9.
    #[test]
    fn compact_four_drives_at_1ms() {
        let p = BusLoad::plan(&bus(1_000_000, 1000, 50), 4, PdoLayout::Compact, 1000);
        assert!((p.total_bits() - 886.9).abs() < 1e-9, "{p:?}");
        println!(
            "compact 4 drives 1 ms 1 Mbit/s: {:.2} % ({})",
            p.percent(),
            p.breakdown()
        );
    }

    /// 500 kbit/s, 2 ms = 1000 bits: standard 55 + 920 + 13 + 10.8 = 998.8 (99.88 %);
    /// compact 55 + 760 + 120 + 13 + 10.8 = 958.8 (95.88 %). Both fit; at 1 ms neither does.
    #[test]
    fn four_drives_on_500k() {
        let b = bus(500_000, 2000, 50);
        let s = BusLoad::plan(&b, 4, PdoLayout::Standard, 2000);
        let c = BusLoad::plan(&b, 4, PdoLayout::Compact, 2000);
        assert!((s.total_bits() - 998.8).abs() < 1e-9, "{s:?}");
        assert!((c.total_bits() - 958.8).abs() < 1e-9, "{c:?}");
        assert!(s.fits() && c.fits());
        assert!(!BusLoad::plan(&b, 4, PdoLayout::Compact, 1000).fits());
        println!(
            "4 drives 500 kbit/s 2 ms: standard {:.2} %, compact {:.2} %",
            s.percent(),
            c.percent()
        );
    }

    #[test]
    fn no_heartbeat_reserves_sdo_per_100ms() {
        let p = BusLoad::plan(&bus(1_000_000, 1000, 0), 1, PdoLayout::Standard, 1000);
        assert_eq!(p.heartbeat_bits, 0.0);
        assert!((p.sdo_reserve_bits - 2.7).abs() < 1e-9);
    }

    #[test]
    fn hopeless_load_has_no_period() {
        let b = bus(10_000, 1000, 50);
        let p = BusLoad::plan(&b, 127, PdoLayout::Standard, 1000);
        assert_eq!(p.smallest_period_us(&b), None);
    }

    #[test]
    fn the_outputs_rpdo3_is_counted_once_per_10_ms_per_drive_and_kept_at_other_periods() {
        let b = bus(1_000_000, 1000, 50);
        let plain = BusLoad::plan(&b, 4, PdoLayout::Standard, 1000);
        let with = plain.with_output_drives(2);
        // 95 bits (4 data bytes) per 10 ms per drive: 19 bits per 1 ms period for two.
        assert!((with.traffic_bits() - plain.traffic_bits() - 19.0).abs() < 1e-9);
        assert!(
            with.breakdown().contains("outputs RPDO3 2×9.5"),
            "{}",
            with.breakdown()
        );
        assert_eq!(with.at_period(&b, 2000).output_drives, 2);
    }

    /// Source 001's machine, five feed axes and two spindles: seven drives. Standard at
    /// 1 ms: 55 + 14 × 115 = 1665 + heartbeats 8 × 65 / 50 = 10.4 + SDO 5.4 = 1680.8 bits
    /// (168.1 %); the smallest period is 1750 µs: 1665 + 18.2 + 9.45 = 1692.65 of 1750
    /// (96.72 %). Compact at 1750 µs: 55 + 14 × 95 = 1385 + events 2 × 7 × 75 × 0.175 =
    /// 183.75 + 18.2 + 9.45 = 1596.4 (91.22 %); at 1500 µs neither fits.
    #[test]
    fn five_feed_axes_and_two_spindles_need_1750us() {
        let b = bus(1_000_000, 1000, 50);
        let p = BusLoad::plan(&b, 7, PdoLayout::Standard, 1000);
        assert!((p.total_bits() - 1680.8).abs() < 1e-9, "{p:?}");
        assert_eq!(p.smallest_period_us(&b), Some(1750));
        let at = p.at_period(&b, 1750);
        assert!((at.percent() - 96.722_857).abs() < 1e-5, "{}", at.percent());
        let c = BusLoad::plan(&b, 7, PdoLayout::Compact, 1750);
        assert!((c.total_bits() - 1596.4).abs() < 1e-9, "{c:?}");
        assert_eq!(c.smallest_period_us(&b), Some(1750));
        for layout in [PdoLayout::Standard, PdoLayout::Compact] {
            assert!(!BusLoad::plan(&b, 7, layout, 1500).fits(), "{layout:?}");
        }
    }

    /// The shipped two-spindle example at 1000 µs is refused at `bus.period_us` with the
    /// period that fits.
    #[test]
    fn the_two_spindle_example_at_1ms_names_the_period_that_fits() {
        let text = include_str!("../../examples/two-spindles/machine.toml");
        let at_1ms = text.replace("period_us = 1750", "period_us = 1000");
        let path = std::path::Path::new("m.toml");
        let e = crate::MachineConfig::parse(&at_1ms, path).unwrap_err();
        assert_eq!(e.key, "bus.period_us", "{e}");
        let line = at_1ms
            .lines()
            .position(|l| l.starts_with("period_us"))
            .unwrap()
            + 1;
        assert_eq!(e.line, line, "{e}");
        assert!(e.message.contains("7 drives"), "{e}");
        assert!(
            e.message
                .contains("the smallest period that fits is 1750 µs"),
            "{e}"
        );
        let c = crate::MachineConfig::parse(text, path).unwrap();
        assert_eq!(c.spindle_axes(), [Some(5), Some(6)]);
    }
}
