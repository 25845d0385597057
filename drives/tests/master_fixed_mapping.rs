//! Drives whose PDO mapping is fixed (the simulated drive's `fix_pdo_mapping`): the master
//! reads the mapping it cannot change, runs on it when it carries what the layout needs
//! (another order, an extra object), and refuses with node, PDO and what is missing when not.
//! Also the simulated drive's store (0x1010) and restore (0x1011).

mod master_common;

use cia402::State;
use cnc402_config::MachineConfig;
use cnc402_config::busload::PdoLayout;
use cnc402_drives::bus::SimBus;
use cnc402_drives::master::{BlockingSdo, BootError, Master, Phase};
use cnc402_drives::od::{LOAD_SIGNATURE, SAVE_SIGNATURE};
use cnc402_drives::sim::{FaultKind, SimDrive, SimDriveOptions};
use cnc402_drives::wire::{AbortCode, MappingEntry, NodeId};
use master_common::{Rig, sim_bus, smoothstep};

const CW: MappingEntry = MappingEntry::new(0x6040, 0, 16);
const MODE: MappingEntry = MappingEntry::new(0x6060, 0, 8);
const TARGET: MappingEntry = MappingEntry::new(0x607A, 0, 32);
const SW: MappingEntry = MappingEntry::new(0x6041, 0, 16);
const POS: MappingEntry = MappingEntry::new(0x6064, 0, 32);
const MODE_DISPLAY: MappingEntry = MappingEntry::new(0x6061, 0, 8);
const DIGITAL_INPUTS: MappingEntry = MappingEntry::new(0x60FD, 0, 32);

/// The shipped machine whose drive on axis 0 has `fixed` mappings (index, entries).
fn rig_with_fixed(config: MachineConfig, fixed: &[(u16, &[MappingEntry])]) -> Rig {
    let mut bus: SimBus<SimDrive> = sim_bus(&config, |_| SimDriveOptions::default());
    for (mapping, entries) in fixed {
        bus.device_mut(0)
            .unwrap()
            .fix_pdo_mapping(*mapping, entries);
    }
    let master = Master::new(&config).unwrap();
    Rig {
        config,
        bus,
        master,
        next: cnc402_drives::Instant::ZERO,
    }
}

/// Moves X by 10 mm over 0.3 s; returns X's last actual position.
fn move_x(rig: &mut Rig) -> f64 {
    let start = rig.master.positions();
    let mut last = 0.0;
    for k in 0..400 {
        let mut cmd = start;
        cmd[0] += 10.0 * smoothstep(k as f64 / 300.0);
        let fb = rig
            .cycle(&cmd[..rig.axes()])
            .unwrap_or_else(|s| panic!("{s}"));
        last = fb.actual()[0];
    }
    last - start[0]
}

#[test]
fn a_usable_fixed_mapping_in_another_order_is_used() {
    // TPDO1: position first, then statusword, then the mode display; RPDO1: the mode
    // (which the master sends as CSP), target, controlword.
    let mut rig = rig_with_fixed(
        MachineConfig::default_machine(),
        &[
            (0x1600, &[MODE, TARGET, CW]),
            (0x1A00, &[POS, SW, MODE_DISPLAY]),
        ],
    );
    rig.boot();
    assert_eq!(rig.master.phase(), Phase::Running);
    assert_eq!(rig.drive(0).state(), State::OperationEnabled);
    let moved = move_x(&mut rig);
    assert!((moved - 10.0).abs() < 0.01, "X moved {moved}");
    // The mapping is the drive's own, unchanged.
    assert_eq!(
        rig.drive(0).od().get_u64(0x1A00, 1),
        Some(POS.to_u32() as u64)
    );
    assert_eq!(rig.drive(0).od().get_i64(0x6060, 0), Some(8));
}

#[test]
fn a_fixed_mapping_works_with_the_compact_layout_too() {
    let mut config = MachineConfig::default_machine();
    config.bus.pdo_layout = PdoLayout::Compact;
    // TPDO1 fixed with statusword and position: the statusword also comes every SYNC.
    let mut rig = rig_with_fixed(config, &[(0x1A00, &[SW, POS])]);
    rig.boot();
    let moved = move_x(&mut rig);
    assert!((moved - 10.0).abs() < 0.01, "X moved {moved}");
}

#[test]
fn an_unusable_fixed_mapping_is_refused_naming_node_pdo_and_what_is_missing() {
    let mut rig = rig_with_fixed(
        MachineConfig::default_machine(),
        &[(0x1A00, &[SW, MODE_DISPLAY])],
    );
    let e = rig.master.boot(&mut rig.bus).unwrap_err();
    match &e {
        BootError::FixedMapping {
            axis,
            node,
            pdo,
            found,
            problem,
        } => {
            assert_eq!((*axis, *node, pdo.as_str()), ('X', 1, "TPDO1"));
            assert_eq!(found, &vec![SW, MODE_DISPLAY]);
            assert!(problem.contains("PositionActual 0x6064"), "{problem}");
        }
        other => panic!("{other}"),
    }
    let text = e.to_string();
    assert!(text.contains("node 1") && text.contains("TPDO1"), "{text}");
    assert!(text.contains("0x6041:00/16, 0x6061:00/8"), "{text}");
    // An object the master does not drive in an RPDO, or one it does not know.
    let mut rig = rig_with_fixed(
        MachineConfig::default_machine(),
        &[(0x1600, &[CW, TARGET, MappingEntry::new(0x60B1, 0, 32)])],
    );
    let e = rig.master.boot(&mut rig.bus).unwrap_err();
    assert!(
        matches!(&e, BootError::FixedMapping { pdo, .. } if pdo == "RPDO1"),
        "{e}"
    );
    let mut rig = rig_with_fixed(
        MachineConfig::default_machine(),
        &[(0x1A00, &[SW, POS, DIGITAL_INPUTS])],
    );
    let e = rig.master.boot(&mut rig.bus).unwrap_err();
    assert!(e.to_string().contains("0x60fd"), "{e}");
}

fn node1() -> NodeId {
    NodeId::new(1).unwrap()
}

#[test]
fn store_survives_a_reboot_and_restore_brings_the_defaults_back() {
    let mut rig = Rig::for_machine(MachineConfig::default_machine());
    rig.power_on();
    let window_default = rig.drive(0).od().get_u64(0x6065, 0).unwrap();
    let mut other = |_: &cnc402_drives::wire::CanFrame| {};
    {
        let mut sdo = BlockingSdo::new(
            &mut rig.bus,
            std::time::Duration::from_millis(100),
            &mut other,
        );
        sdo.write_u32(node1(), 0x6065, 0, 4321).unwrap();
        // A wrong signature is refused (CiA 301: 0x08000020).
        let e = sdo.write_u32(node1(), 0x1010, 1, 0x1234).unwrap_err();
        assert_eq!(e.abort_code(), Some(AbortCode::CannotStore));
        assert_eq!(
            sdo.read_u32(node1(), 0x1010, 1).unwrap(),
            1,
            "saves on command"
        );
        sdo.write_u32(node1(), 0x1010, 1, SAVE_SIGNATURE).unwrap();
        sdo.write_u32(node1(), 0x6065, 0, 99).unwrap();
    }
    assert_eq!(rig.drive(0).stores(), 1);
    let now = rig.bus.now();
    rig.bus
        .device_mut(0)
        .unwrap()
        .inject(FaultKind::Reboot, now);
    assert_eq!(
        rig.drive(0).od().get_u64(0x6065, 0),
        Some(4321),
        "the stored value"
    );
    // Restore: the defaults come back at the next reset, not before.
    BlockingSdo::new(
        &mut rig.bus,
        std::time::Duration::from_millis(100),
        &mut other,
    )
    .write_u32(node1(), 0x1011, 1, LOAD_SIGNATURE)
    .unwrap();
    assert_eq!(rig.drive(0).od().get_u64(0x6065, 0), Some(4321));
    let now = rig.bus.now();
    rig.bus
        .device_mut(0)
        .unwrap()
        .inject(FaultKind::Reboot, now);
    assert_eq!(rig.drive(0).od().get_u64(0x6065, 0), Some(window_default));
}

/// The machine outputs' RPDO3 on a drive whose RPDO3 mapping is fixed: used when it is
/// 0x60FE:1 alone (boot had refused every fixed RPDO3 before), refused naming RPDO3 when not.
#[test]
fn a_fixed_outputs_rpdo3_is_used_when_it_is_0x60fe_alone() {
    const OUTPUTS: MappingEntry = MappingEntry::new(0x60FE, 1, 32);
    let mut config = MachineConfig::default_machine();
    config.machine.outputs.coolant_flood = Some(cnc402_config::OutputBit { axis: 0, bit: 16 });
    let mut rig = rig_with_fixed(config.clone(), &[(0x1602, &[OUTPUTS])]);
    rig.boot();
    assert!(
        rig.master
            .set_output(cnc402_drives::master::Output::CoolantFlood, true)
    );
    let hold = rig.master.positions();
    for _ in 0..20 {
        rig.cycle(&hold[..rig.axes()]).unwrap();
    }
    assert!(rig.master.outputs_settled());
    assert_eq!(
        rig.drive(0).od().get_u64(0x60FE, 1),
        Some(1 << 16),
        "coolant on through the drive's own RPDO3"
    );
    let mut rig = rig_with_fixed(config, &[(0x1602, &[OUTPUTS, CW])]);
    let e = rig.master.boot(&mut rig.bus).unwrap_err();
    assert!(
        matches!(&e, BootError::FixedMapping { pdo, node: 1, .. } if pdo == "RPDO3"),
        "{e}"
    );
}
