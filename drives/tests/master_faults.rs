//! Faults at master level, on simulated drives in virtual time: the boot refusals (a second
//! device on a node id, a wrong device type, a drive silent to SDO) name the node and the
//! object, and a bus-off stops the machine as a bus error after which the next boot succeeds.
//! The run-level rows of docs/faults.md are in runtime/tests/faults.rs.

mod master_common;

use std::time::Duration;

use cnc402_config::{ExpectedIdentity, MachineConfig};
use cnc402_drives::bus::{BusError, FaultInjector};
use cnc402_drives::master::{BootError, Master, SdoErrorKind, StopReason};
use cnc402_drives::sim::{FaultKind, PRODUCT_CODE, REVISION, SimDrive, SimDriveOptions, VENDOR_ID};
use cnc402_drives::wire::NodeId;
use master_common::{FaultRig, Rig, sim_bus};

#[test]
fn a_second_device_on_a_node_id_refuses_boot_naming_the_node() {
    let config = MachineConfig::default_machine();
    let mut bus = sim_bus(&config, |_| SimDriveOptions::default());
    let period = Duration::from_micros(config.bus.period_us as u64);
    bus.attach(SimDrive::new(
        &config.axes[1],
        NodeId::new(2).unwrap(),
        period,
    ));
    let mut master = Master::new(&config).unwrap();
    let e = master.boot(&mut bus).unwrap_err();
    assert_eq!(
        e,
        BootError::DuplicateBootUp {
            axis: 'Y',
            node: 2,
            boot_ups: 2
        }
    );
    assert!(e.to_string().contains("two devices on node id 2"), "{e}");
}

#[test]
fn a_wrong_device_type_refuses_boot_naming_node_and_object() {
    let mut rig = Rig::new(|_| SimDriveOptions::default());
    rig.inject(2, FaultKind::DeviceType(0x0002_0191));
    let e = rig.master.boot(&mut rig.bus).unwrap_err();
    assert_eq!(
        e,
        BootError::NotCia402 {
            axis: 'Z',
            node: 3,
            device_type: 0x0002_0191
        }
    );
    assert!(e.to_string().contains("0x1000"), "{e}");
    // The value survives the reset communication boot sends: it is the drive's identity.
    assert_eq!(rig.drive(2).od().get_u64(0x1000, 0), Some(0x0002_0191));
}

/// The default machine with Z (node 3) expecting `identity`.
fn z_expecting(identity: ExpectedIdentity) -> Rig {
    let mut config = MachineConfig::default_machine();
    config.axes[2].identity = Some(identity);
    Rig::for_machine(config)
}

const SIM_IDENTITY: ExpectedIdentity = ExpectedIdentity {
    vendor: VENDOR_ID,
    product: Some(PRODUCT_CODE),
    revision_min: Some(REVISION),
};

#[test]
fn a_drive_of_the_expected_identity_boots() {
    let mut rig = z_expecting(SIM_IDENTITY);
    let report = rig.master.boot(&mut rig.bus).unwrap();
    assert_eq!(report.drives[2].vendor, VENDOR_ID);
    // A newer revision than the least one is fine; vendor alone is a valid expectation.
    for identity in [
        ExpectedIdentity {
            revision_min: Some(REVISION - 1),
            ..SIM_IDENTITY
        },
        ExpectedIdentity {
            vendor: VENDOR_ID,
            product: None,
            revision_min: None,
        },
    ] {
        let mut rig = z_expecting(identity);
        rig.master.boot(&mut rig.bus).unwrap();
    }
}

#[test]
fn a_wrong_identity_refuses_boot_naming_node_object_and_both_values() {
    // Another product of the same vendor on node 3.
    let mut rig = z_expecting(SIM_IDENTITY);
    rig.inject(
        2,
        FaultKind::Identity {
            vendor: VENDOR_ID,
            product: 0x0000_0002,
            revision: None,
        },
    );
    let e = rig.master.boot(&mut rig.bus).unwrap_err();
    assert_eq!(
        e,
        BootError::WrongIdentity {
            axis: 'Z',
            node: 3,
            sub: 2,
            expected: PRODUCT_CODE,
            actual: Some(2)
        }
    );
    let msg = e.to_string();
    for part in ["node 3", "0x1018:2", "0x00000002", "expects 0x00000001"] {
        assert!(msg.contains(part), "{msg} lacks {part}");
    }
    // Refused before it was configured or enabled.
    assert_eq!(rig.drive(2).state(), cia402::State::SwitchOnDisabled);

    // Another vendor, and a revision older than the least one.
    let mut rig = z_expecting(SIM_IDENTITY);
    rig.inject(
        2,
        FaultKind::Identity {
            vendor: 0x9A,
            product: PRODUCT_CODE,
            revision: None,
        },
    );
    let e = rig.master.boot(&mut rig.bus).unwrap_err();
    assert!(
        matches!(
            e,
            BootError::WrongIdentity {
                sub: 1,
                expected: VENDOR_ID,
                actual: Some(0x9A),
                ..
            }
        ),
        "{e:?}"
    );
    assert!(
        e.to_string().contains("0x1018:1 vendor id 0x0000009a"),
        "{e}"
    );
    let mut rig = z_expecting(SIM_IDENTITY);
    rig.inject(
        2,
        FaultKind::Identity {
            vendor: VENDOR_ID,
            product: PRODUCT_CODE,
            revision: Some(REVISION - 1),
        },
    );
    let e = rig.master.boot(&mut rig.bus).unwrap_err();
    assert!(
        e.to_string().contains(
            "0x1018:3 revision number 0x0000ffff, the config expects at least 0x00010000"
        ),
        "{e}"
    );
}

#[test]
fn a_drive_silent_to_sdo_at_boot_ends_boot_with_a_timeout_naming_node_and_object() {
    let mut rig = Rig::new(|_| SimDriveOptions::default());
    rig.inject(1, FaultKind::SdoSilence);
    let e = rig.master.boot(&mut rig.bus).unwrap_err();
    let BootError::Sdo(s) = &e else {
        panic!("{e:?}")
    };
    assert_eq!((s.node, s.index, s.sub), (2, 0x1000, 0));
    assert!(matches!(s.kind, SdoErrorKind::Timeout { .. }), "{s:?}");
    assert!(
        e.to_string().starts_with("node 2: SDO read of 0x1000:00"),
        "{e}"
    );
}

#[test]
fn bus_off_stops_as_a_bus_error_and_the_next_boot_succeeds() {
    let config = MachineConfig::default_machine();
    let mut rig = FaultRig::booted(&config, &[]);
    let hold = rig.master.positions();
    for _ in 0..50 {
        rig.cycle(&hold[..4]).unwrap();
    }
    // Off for 300 ms: longer than the drives' watch of the master's heartbeat.
    rig.bus.set_bus_off(rig.next, Duration::from_millis(300));
    let stop = rig.cycle(&hold[..4]).unwrap_err();
    assert_eq!(stop.reason, StopReason::Bus(BusError::BusOff));
    assert_eq!((stop.node, stop.axis), (None, None));
    assert!(stop.to_string().contains("bus-off"), "{stop}");
    // Later cycles keep trying; the stop is reported once.
    for _ in 0..299 {
        assert!(rig.cycle(&hold[..4]).is_ok_and(|f| f.stopping));
    }
    assert!(rig.bus.is_bus_off());
    for _ in 0..10 {
        let _ = rig.cycle(&hold[..4]);
    }
    assert!(!rig.bus.is_bus_off(), "recovered");
    // The next run: a new master boots the same drives (reset communication first).
    let FaultRig { mut bus, .. } = rig;
    let mut master = Master::new(&config).unwrap();
    let report = master
        .boot(&mut bus)
        .unwrap_or_else(|e| panic!("boot after recovery: {e}"));
    assert_eq!(report.drives.len(), 4);
}

#[test]
fn a_fault_injector_without_rules_changes_nothing() {
    // The embedded simulated machine always has the injector in front of its bus.
    let config = MachineConfig::default_machine();
    let mut bus = FaultInjector::new(sim_bus(&config, |_| SimDriveOptions::default()));
    let mut master = Master::new(&config).unwrap();
    master.boot(&mut bus).unwrap();
    assert_eq!(master.unexpected_frames(), 0);
}

#[test]
fn a_drive_powering_up_as_the_master_resets_it_is_no_duplicate() {
    // Boot-up at power-on (no delay), then the reset communication's: two boot-ups from one
    // device, and its SDO answers match the requests.
    let mut rig = Rig::new(|_| SimDriveOptions {
        boot_delay: Duration::ZERO,
        ..SimDriveOptions::default()
    });
    let report = rig
        .master
        .boot(&mut rig.bus)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(report.drives.len(), 4);
}
