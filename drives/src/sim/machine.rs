//! A simulated machine: one [`SimDrive`] per configured axis with a node id, on a
//! [`SimBus`] at the configured bit rate and period — what `cnc402 run` uses when the bus
//! interface is `"sim"`.

use core::time::Duration;

use cnc402_config::MachineConfig;

use super::{SimDrive, SimDriveOptions};
use crate::bus::SimBus;
use crate::wire::NodeId;

/// The simulated bus with a drive for every axis that has a node id, attached in axis order.
/// Axes whose node id is outside 1..=127 (the config validates this) are skipped.
pub fn simulated_machine(cfg: &MachineConfig) -> SimBus<SimDrive> {
    simulated_machine_with(cfg, |_, _| SimDriveOptions::default())
}

/// Like [`simulated_machine`], with start options per axis (`options(axis_index, node)`),
/// e.g. a drive that boots late or starts in FAULT.
pub fn simulated_machine_with(
    cfg: &MachineConfig,
    mut options: impl FnMut(usize, NodeId) -> SimDriveOptions,
) -> SimBus<SimDrive> {
    let period = Duration::from_micros(cfg.bus.period_us as u64);
    let mut bus = SimBus::new(cfg.bus.bitrate);
    for (i, axis) in cfg.axes.iter().enumerate() {
        let Some(node) = axis.node.and_then(|n| NodeId::new(n).ok()) else {
            continue;
        };
        bus.attach(SimDrive::with_options(axis, node, period, options(i, node)));
    }
    bus
}

/// The device number of the drive with node id `node` on a bus built here.
pub fn device_of(bus: &SimBus<SimDrive>, node: NodeId) -> Option<usize> {
    bus.devices().iter().position(|d| d.node() == node)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_drive_per_axis_with_a_node() {
        let cfg = MachineConfig::default_machine();
        let bus = simulated_machine(&cfg);
        let nodes: Vec<u8> = bus.devices().iter().map(|d| d.node().get()).collect();
        let expected: Vec<u8> = cfg.axes.iter().filter_map(|a| a.node).collect();
        assert_eq!(nodes, expected);
        assert_eq!(bus.bitrate(), cfg.bus.bitrate);
        let n = NodeId::new(expected[1]).unwrap();
        assert_eq!(device_of(&bus, n), Some(1));
        assert_eq!(
            bus.device(1).unwrap().name(),
            format!("cnc402 simdrive {}", cfg.axes[1].name)
        );
    }
}
