//! `[bus]`: the CAN interface, the cycle period and the master's time-outs and node id.

use serde::Deserialize;
use toml::Spanned;

use crate::check::{Invalid, int_in, sp};

#[derive(Clone, Debug, PartialEq)]
pub struct BusConfig {
    /// `"sim"` or a SocketCAN interface name.
    pub interface: String,
    pub bitrate: u32,
    pub period_us: u32,
    pub heartbeat_ms: u16,
    pub heartbeat_timeout_ms: u32,
    pub tpdo_timeout_cycles: u32,
    pub sdo_timeout_ms: u32,
    /// The master's own node id: it produces its heartbeat on 0x700 + id and the drives
    /// consume it (0x1016). No axis may use it. Default 127.
    pub master_node_id: u8,
    /// What the cyclic PDOs carry (`"standard"`: control/status word with target/position
    /// every SYNC; `"compact"`: target/position alone, the words event-driven).
    pub pdo_layout: PdoLayout,
}

impl BusConfig {
    pub fn is_sim(&self) -> bool {
        self.interface == "sim"
    }
    pub fn period_s(&self) -> f64 {
        self.period_us as f64 * 1e-6
    }
}

/// What the cyclic PDOs carry (`bus.pdo_layout`; the load plan in `busload` counts each).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PdoLayout {
    /// Controlword + target, statusword + position, every SYNC (6 bytes each way).
    Standard,
    /// Target and position alone every SYNC (4 bytes each way); control and status words
    /// event-driven.
    Compact,
}

impl PdoLayout {
    /// As written in `bus.pdo_layout`.
    pub fn name(self) -> &'static str {
        match self {
            PdoLayout::Standard => "standard",
            PdoLayout::Compact => "compact",
        }
    }
}

/// `[bus]` as written, with spans.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawBus {
    interface: Spanned<String>,
    #[serde(default = "default_bitrate")]
    bitrate: Spanned<i64>,
    #[serde(default = "default_period")]
    period_us: Spanned<i64>,
    #[serde(default = "default_heartbeat")]
    heartbeat_ms: Spanned<i64>,
    #[serde(default = "default_heartbeat_timeout")]
    heartbeat_timeout_ms: Spanned<i64>,
    #[serde(default = "default_tpdo_timeout")]
    tpdo_timeout_cycles: Spanned<i64>,
    #[serde(default = "default_sdo_timeout")]
    sdo_timeout_ms: Spanned<i64>,
    #[serde(default = "default_master_node_id")]
    master_node_id: Spanned<i64>,
    #[serde(default = "default_pdo_layout")]
    pdo_layout: Spanned<String>,
}

fn default_bitrate() -> Spanned<i64> {
    sp(1_000_000)
}
fn default_period() -> Spanned<i64> {
    sp(1000)
}
fn default_heartbeat() -> Spanned<i64> {
    sp(50)
}
fn default_heartbeat_timeout() -> Spanned<i64> {
    sp(200)
}
fn default_tpdo_timeout() -> Spanned<i64> {
    sp(5)
}
fn default_sdo_timeout() -> Spanned<i64> {
    sp(100)
}
fn default_master_node_id() -> Spanned<i64> {
    sp(127)
}
fn default_pdo_layout() -> Spanned<String> {
    sp("standard".into())
}

impl RawBus {
    /// Where `period_us` is written (an overloaded bus is reported there).
    pub(crate) fn period_span(&self) -> std::ops::Range<usize> {
        self.period_us.span()
    }

    /// Checks each key's range and the heartbeat time-out against the heartbeat period.
    pub(crate) fn validate(&self) -> Result<BusConfig, Invalid> {
        let b = self;
        let interface = b.interface.get_ref().trim().to_string();
        if interface.is_empty() {
            return Err((
                b.interface.span(),
                "bus.interface".into(),
                "must name \"sim\" or a CAN interface".into(),
            ));
        }
        if interface != "sim" && !is_interface_name(&interface) {
            return Err((
                b.interface.span(),
                "bus.interface".into(),
                format!(
                    "{interface:?} cannot be a network interface: at most 15 bytes (Linux \
                     IFNAMSIZ), no '/', ':' or white space"
                ),
            ));
        }
        let bus = BusConfig {
            interface,
            bitrate: int_in(&b.bitrate, "bus.bitrate", 10_000, 1_000_000)? as u32,
            period_us: period_us(&b.period_us)?,
            heartbeat_ms: int_in(&b.heartbeat_ms, "bus.heartbeat_ms", 0, 65535)? as u16,
            heartbeat_timeout_ms: int_in(
                &b.heartbeat_timeout_ms,
                "bus.heartbeat_timeout_ms",
                1,
                60_000,
            )? as u32,
            tpdo_timeout_cycles: int_in(
                &b.tpdo_timeout_cycles,
                "bus.tpdo_timeout_cycles",
                1,
                10_000,
            )? as u32,
            sdo_timeout_ms: int_in(&b.sdo_timeout_ms, "bus.sdo_timeout_ms", 1, 60_000)? as u32,
            master_node_id: int_in(&b.master_node_id, "bus.master_node_id", 1, 127)? as u8,
            pdo_layout: match b.pdo_layout.get_ref().as_str() {
                "standard" => PdoLayout::Standard,
                "compact" => PdoLayout::Compact,
                other => {
                    return Err((
                        b.pdo_layout.span(),
                        "bus.pdo_layout".into(),
                        format!("must be \"standard\" or \"compact\", got {other:?}"),
                    ));
                }
            },
        };
        if bus.heartbeat_ms > 0 && bus.heartbeat_timeout_ms <= bus.heartbeat_ms as u32 {
            return Err((
                b.heartbeat_timeout_ms.span(),
                "bus.heartbeat_timeout_ms".into(),
                format!(
                    "must be longer than bus.heartbeat_ms ({})",
                    bus.heartbeat_ms
                ),
            ));
        }
        Ok(bus)
    }
}

/// `period_us`: in 100..=100 000 µs and exactly writable to 0x60C2 the way the master writes
/// it (`drives::master::InterpolationPeriod::from_micros`): a mantissa 1..=255 times
/// 10^-3, 10^-4, 10^-5 or 10^-6 s. So 1000, 250, 125, 2500 and 4000 are periods, 999, 1001
/// and 2560 are not (the drive would interpolate at a different period than the bus runs).
fn period_us(v: &Spanned<i64>) -> Result<u32, Invalid> {
    let us = int_in(v, "bus.period_us", 100, 100_000)? as u32;
    if is_interpolation_period(us) {
        Ok(us)
    } else {
        Err((
            v.span(),
            "bus.period_us".into(),
            format!(
                "{us} µs cannot be written to the drives' interpolation period 0x60C2 (a \
                 value 1..=255 times 1000, 100, 10 or 1 µs, e.g. 1000, 2500, 250, 125)"
            ),
        ))
    }
}

/// Whether `us` is a mantissa 1..=255 times 1000, 100, 10 or 1 µs (0x60C2 as the master
/// writes it).
pub(crate) fn is_interpolation_period(us: u32) -> bool {
    [1000, 100, 10, 1]
        .iter()
        .any(|&unit| us.is_multiple_of(unit) && (1..=255).contains(&(us / unit)))
}

/// A name Linux accepts for a network interface (SocketCAN opens it by this name).
fn is_interface_name(name: &str) -> bool {
    name.len() <= 15
        && name != "."
        && name != ".."
        && !name
            .chars()
            .any(|c| c == '/' || c == ':' || c.is_whitespace())
}
