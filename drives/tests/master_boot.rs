//! The master's boot against simulated drives on the simulated bus (virtual time): the full
//! shipped machine, the PDO mapping read back, enabling without motion, a drive in FAULT at
//! power-on, a late drive, SDO abort / timeout / segmented transfers.

// Several per-axis arrays are indexed together.
#![allow(clippy::needless_range_loop)]

mod master_common;

use std::time::Duration;

use cia402::{State, objects as obj};
use cnc402_drives::bus::{CanBus, Origin};
use cnc402_drives::master::{
    BlockingSdo, BootError, MasterOptions, Phase, SdoErrorKind, StopMode, TimedBus,
};
use cnc402_drives::sim::{FaultKind, PRODUCT_CODE, REVISION, SimDriveOptions, VENDOR_ID};
use cnc402_drives::wire::{AbortCode, CanFrame, Function, NodeId};
use master_common::Rig;

fn node(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

/// Reads with a blocking SDO; other frames are collected.
fn sdo<B: TimedBus>(bus: &mut B, f: impl FnOnce(&mut BlockingSdo<'_, B>)) -> Vec<CanFrame> {
    let mut other = Vec::new();
    let mut push = |fr: &CanFrame| other.push(*fr);
    let mut s = BlockingSdo::new(bus, Duration::from_millis(100), &mut push);
    f(&mut s);
    other
}

#[test]
fn full_boot_of_the_shipped_machine() {
    let mut rig = Rig::new(|_| SimDriveOptions::default());
    let report = rig.boot();
    assert_eq!(rig.master.phase(), Phase::Running);
    assert_eq!(report.drives.len(), 4);
    for (i, d) in report.drives.iter().enumerate() {
        let a = &rig.config.axes[i];
        assert_eq!(d.axis, a.name);
        assert_eq!(Some(d.node), a.node);
        assert_eq!(d.device_type & 0xFFFF, 0x0192);
        assert_eq!(d.vendor, VENDOR_ID);
        assert_eq!(d.product, Some(PRODUCT_CODE));
        assert_eq!(d.revision, Some(REVISION));
        assert_eq!(
            d.name.as_deref(),
            Some(format!("cnc402 simdrive {}", a.name).as_str())
        );
        assert!(d.fault_at_power_on.is_none());
        assert!(d.supervises_master && d.abort_connection_quick_stop);
        let drive = rig.drive(i);
        assert_eq!(drive.state(), State::OperationEnabled, "{}", a.name);
        let od = drive.od();
        // Watches node 127's heartbeat with the configured timeout, quick stop on its loss.
        assert_eq!(
            od.get_u64(obj::CONSUMER_HEARTBEAT_TIME, 1),
            Some(127 << 16 | 200)
        );
        assert_eq!(od.get_i64(obj::ABORT_CONNECTION_OPTION, 0), Some(3));
        assert_eq!(od.get_i64(obj::MODES_OF_OPERATION, 0), Some(8));
        assert_eq!(od.get_u64(obj::INTERPOLATION_TIME_PERIOD, 1), Some(1));
        assert_eq!(od.get_i64(obj::INTERPOLATION_TIME_PERIOD, 2), Some(-3));
        let window = (a.following_error_window * a.counts_per_unit).round() as u64;
        assert_eq!(od.get_u64(obj::FOLLOWING_ERROR_WINDOW, 0), Some(window));
        assert_eq!(od.get_u64(obj::FOLLOWING_ERROR_TIMEOUT, 0), Some(10));
        assert_eq!(od.get_u64(obj::PRODUCER_HEARTBEAT_TIME, 0), Some(50));
    }
    // The enable sequence took a handful of cycles, not the timeout.
    assert!(report.enable_cycles < 20, "{}", report.enable_cycles);
    assert!(
        report.enabled_at < cnc402_drives::Instant::from_millis(500),
        "{}",
        report.enabled_at
    );
}

#[test]
fn pdo_mapping_read_back_equals_what_was_written() {
    let mut rig = Rig::new(|_| SimDriveOptions::default());
    rig.boot();
    for n in 1..=4u8 {
        let id = n as u32;
        sdo(&mut rig.bus, |s| {
            let r = |s: &mut BlockingSdo<'_, _>, i, sub| s.read_u32(node(n), i, sub).unwrap();
            let r8 = |s: &mut BlockingSdo<'_, _>, i, sub| s.read_u8(node(n), i, sub).unwrap();
            assert_eq!(r8(s, 0x1600, 0), 2);
            assert_eq!(r(s, 0x1600, 1), 0x6040_0010);
            assert_eq!(r(s, 0x1600, 2), 0x607A_0020);
            assert_eq!(
                r(s, 0x1400, 1) & 0xBFFF_FFFF,
                0x200 + id,
                "valid, 0x200 + node"
            );
            assert_eq!(r8(s, 0x1400, 2), 1);
            assert_eq!(r8(s, 0x1A00, 0), 2);
            assert_eq!(r(s, 0x1A00, 1), 0x6041_0010);
            assert_eq!(r(s, 0x1A00, 2), 0x6064_0020);
            assert_eq!(r(s, 0x1800, 1) & 0xBFFF_FFFF, 0x180 + id);
            assert_eq!(r8(s, 0x1800, 2), 1);
            for p in 1..4u16 {
                assert_ne!(r(s, 0x1800 + p, 1) & 0x8000_0000, 0, "TPDO{} off", p + 1);
            }
        });
    }
}

#[test]
fn remap_follows_the_cia301_sequence() {
    let mut rig = Rig::new(|_| SimDriveOptions::default());
    rig.bus.start_trace();
    rig.boot();
    // The master's SDO writes to node 2's 0x1400/0x1600 in order.
    let writes: Vec<(u16, u8, u32)> = rig
        .bus
        .take_trace()
        .iter()
        .filter(|t| t.origin == Origin::Master && t.frame.id() == 0x602)
        .map(|t| t.frame.data().to_vec())
        .filter(|d| d[0] & 0xE0 == 0x20)
        .map(|d| {
            (
                u16::from_le_bytes([d[1], d[2]]),
                d[3],
                u32::from_le_bytes([d[4], d[5], d[6], d[7]]),
            )
        })
        .filter(|(i, _, _)| *i == 0x1400 || *i == 0x1600)
        .collect();
    assert_eq!(
        writes,
        vec![
            (0x1400, 1, 0x8000_0202),
            (0x1600, 0, 0),
            (0x1600, 1, 0x6040_0010),
            (0x1600, 2, 0x607A_0020),
            (0x1600, 0, 2),
            (0x1400, 2, 1),
            (0x1400, 1, 0x0000_0202),
        ]
        .into_iter()
        .map(|(i, s, v)| (i, s, v | (writes[0].2 & 0x4000_0000)))
        .collect::<Vec<_>>()
    );
}

#[test]
fn enabling_never_moves_a_drive() {
    let start = [123_456, -7_654_321, 42, i32::MAX - 1000];
    let mut rig = Rig::new(|i| SimDriveOptions {
        initial_position: start[i],
        ..SimDriveOptions::default()
    });
    rig.bus.start_trace();
    let report = rig.boot();
    let pos = rig.master.positions();
    for i in 0..4 {
        assert_eq!(report.drives[i].position_counts, start[i]);
        let cpu = rig.config.axes[i].counts_per_unit;
        assert!((pos[i] - start[i] as f64 / cpu).abs() < 1e-9);
        assert_eq!(rig.drive(i).position_actual(), start[i]);
        assert_eq!(rig.drive(i).target_position(), start[i]);
    }
    // Every RPDO1 the master sent while enabling carried target = the actual position.
    let mut rpdos = 0;
    for t in rig.bus.take_trace() {
        if let Function::Rpdo(1, n) = t.frame.function() {
            let d = t.frame.data();
            let target = i32::from_le_bytes([d[2], d[3], d[4], d[5]]);
            assert_eq!(target, start[n.get() as usize - 1]);
            rpdos += 1;
        }
    }
    assert!(rpdos >= 12, "{rpdos}");
    // Cycles with the positions the master reports as commands keep everything still.
    let cmd = rig.master.positions();
    for _ in 0..50 {
        let fb = rig.cycle(&cmd[..4]).unwrap();
        for i in 0..4 {
            assert_eq!(fb.state(i), Some(State::OperationEnabled));
        }
    }
    for i in 0..4 {
        assert_eq!(rig.drive(i).position_actual(), start[i], "axis {i}");
    }
}

#[test]
fn drive_in_fault_at_power_on_is_reset_then_enabled() {
    let mut rig = Rig::new(|i| SimDriveOptions {
        start_in_fault: (i == 1).then_some(0x2310),
        ..SimDriveOptions::default()
    });
    rig.bus.start_trace();
    let report = rig.boot();
    let y = &report.drives[1];
    assert_eq!(y.initial_statusword.state(), Some(State::Fault));
    // The EMCY the drive sent when it came up in FAULT is in the report.
    assert_eq!(y.fault_at_power_on.flatten().map(|e| e.code), Some(0x2310));
    assert_eq!(rig.drive(1).state(), State::OperationEnabled);
    // A fault reset edge (0x80) went to node 2 and nothing else got one.
    let resets: Vec<u16> = rig
        .bus
        .take_trace()
        .iter()
        .filter(|t| matches!(t.frame.function(), Function::Rpdo(1, _)))
        .filter(|t| t.frame.data()[0] & 0x80 != 0)
        .map(|t| t.frame.id())
        .collect();
    assert!(!resets.is_empty());
    assert!(resets.iter().all(|&id| id == 0x202), "{resets:x?}");
}

#[test]
fn persistent_fault_at_power_on_fails_naming_node_and_state() {
    let mut rig = Rig::with_config(
        cnc402_config::MachineConfig::default_machine(),
        |_| SimDriveOptions::default(),
        MasterOptions {
            enable_timeout: Duration::from_millis(300),
            ..MasterOptions::default()
        },
    );
    rig.inject(2, FaultKind::PersistentFault(0x4310));
    let err = rig.master.boot(&mut rig.bus).unwrap_err();
    let BootError::Enable {
        node,
        axis,
        statusword,
        ..
    } = &err
    else {
        panic!("{err}")
    };
    assert_eq!((*node, *axis), (3, 'Z'));
    assert_eq!(statusword.and_then(|s| s.state()), Some(State::Fault));
    let text = err.to_string();
    assert!(text.contains("node 3") && text.contains("FAULT"), "{text}");
}

#[test]
fn late_drive_is_waited_for() {
    let mut rig = Rig::new(|i| SimDriveOptions {
        boot_delay: if i == 2 {
            Duration::from_secs(2)
        } else {
            Duration::from_millis(1)
        },
        ..SimDriveOptions::default()
    });
    let report = rig.boot();
    assert!(report.drives[2].seen_at >= cnc402_drives::Instant::from_millis(2000));
    assert!(report.drives[0].seen_at < cnc402_drives::Instant::from_millis(100));
    assert_eq!(rig.drive(2).state(), State::OperationEnabled);
}

#[test]
fn drive_that_never_boots_is_named() {
    let mut rig = Rig::with_config(
        cnc402_config::MachineConfig::default_machine(),
        |i| SimDriveOptions {
            boot_delay: if i == 3 {
                Duration::from_secs(60)
            } else {
                Duration::from_millis(1)
            },
            ..SimDriveOptions::default()
        },
        MasterOptions {
            boot_timeout: Duration::from_secs(1),
            stop_mode: StopMode::QuickStop,
            ..MasterOptions::default()
        },
    );
    let err = rig.master.boot(&mut rig.bus).unwrap_err();
    assert_eq!(
        err,
        BootError::NoBootUp {
            axis: 'C',
            node: 4,
            waited: Duration::from_secs(1)
        }
    );
    assert!(err.to_string().contains("node 4"), "{err}");
}

#[test]
fn sdo_abort_is_decoded_and_named() {
    let mut rig = Rig::new(|_| SimDriveOptions::default());
    rig.power_on();
    sdo(&mut rig.bus, |s| {
        let e = s.read_u32(node(1), 0x2345, 0).unwrap_err();
        assert_eq!(e.abort_code(), Some(AbortCode::NoObject));
        let t = e.to_string();
        assert!(t.contains("node 1") && t.contains("0x2345:00"), "{t}");
        assert!(
            t.contains("0x06020000") && t.contains("object does not exist"),
            "{t}"
        );
        let e = s.read_u32(node(1), 0x1018, 9).unwrap_err();
        assert_eq!(e.abort_code(), Some(AbortCode::NoSubIndex));
        let e = s.write_u16(node(1), 0x6041, 0, 0).unwrap_err();
        assert_eq!(e.abort_code(), Some(AbortCode::WriteReadOnly));
    });
}

#[test]
fn sdo_timeout_sends_an_abort_to_the_silent_drive() {
    let mut rig = Rig::new(|_| SimDriveOptions::default());
    rig.power_on();
    rig.inject(1, FaultKind::SdoSilence);
    rig.bus.start_trace();
    let t0 = rig.bus.now();
    sdo(&mut rig.bus, |s| {
        let e = s.read_u32(node(2), 0x1000, 0).unwrap_err();
        assert_eq!(
            e.kind,
            SdoErrorKind::Timeout {
                after: Duration::from_millis(100)
            }
        );
        assert!(e.to_string().contains("node 2"), "{e}");
    });
    let waited = rig.bus.now().saturating_since(t0);
    assert!(
        waited >= Duration::from_millis(100) && waited < Duration::from_millis(102),
        "{waited:?}"
    );
    rig.bus.advance(rig.bus.now() + Duration::from_millis(1));
    let aborts: Vec<String> = rig
        .bus
        .take_trace()
        .iter()
        .filter(|t| t.origin == Origin::Master && t.frame.id() == 0x602)
        .map(|t| t.frame.to_string())
        .collect();
    assert_eq!(aborts, vec!["602#4000100000000000", "602#8000100000000405"]);
}

#[test]
fn segmented_upload_of_the_device_name_and_other_frames_kept() {
    let mut rig = Rig::new(|_| SimDriveOptions::default());
    rig.power_on();
    // Heartbeats at 1 ms so some arrive while the transfer runs.
    sdo(&mut rig.bus, |s| {
        s.write_u16(node(4), 0x1017, 0, 1).unwrap()
    });
    let other = sdo(&mut rig.bus, |s| {
        let name = s.read_string(node(4), 0x1008, 0).unwrap();
        assert_eq!(name, "cnc402 simdrive C");
        let raw = s.upload(node(4), 0x1008, 0).unwrap();
        assert_eq!(raw.len(), 17);
    });
    assert!(
        other
            .iter()
            .any(|f| f.function() == Function::Heartbeat(node(4))),
        "heartbeats during the transfer were handed back: {other:?}"
    );
    let _ = rig.bus.counters();
}

/// A simulated drive without 0x1016 (and, if `no_6007`, without 0x6007; otherwise one whose
/// 0x6007 refuses quick stop): SDO requests for them get an abort.
struct Unsupervised {
    drive: cnc402_drives::sim::SimDrive,
    no_6007: bool,
}

impl cnc402_drives::bus::CanDevice for Unsupervised {
    fn on_frame(
        &mut self,
        frame: &CanFrame,
        now: cnc402_drives::Instant,
        tx: &mut dyn cnc402_drives::bus::FrameSink,
    ) {
        let n = self.drive.node().get() as u16;
        let d = frame.data();
        if frame.id() == 0x600 + n && d.len() == 8 {
            let index = u16::from_le_bytes([d[1], d[2]]);
            let abort: Option<u32> = match index {
                0x1016 => Some(0x0602_0000),
                0x6007 if self.no_6007 => Some(0x0602_0000),
                0x6007 => Some(0x0609_0030),
                _ => None,
            };
            if let Some(code) = abort {
                let mut r = [0x80, d[1], d[2], d[3], 0, 0, 0, 0];
                r[4..].copy_from_slice(&code.to_le_bytes());
                tx.transmit(&CanFrame::new(0x580 + n, &r).unwrap(), now)
                    .unwrap();
                return;
            }
        }
        self.drive.on_frame(frame, now, tx);
    }
    fn poll(&mut self, now: cnc402_drives::Instant, tx: &mut dyn cnc402_drives::bus::FrameSink) {
        self.drive.poll(now, tx);
    }
}

#[test]
fn a_drive_that_cannot_watch_the_master_is_reported_not_refused() {
    let config = cnc402_config::MachineConfig::default_machine();
    let period = Duration::from_micros(config.bus.period_us as u64);
    let mut bus = cnc402_drives::bus::SimBus::new(config.bus.bitrate);
    for (i, a) in config.axes.iter().enumerate() {
        let drive = cnc402_drives::sim::SimDrive::new(a, node(a.node.unwrap()), period);
        bus.attach(Unsupervised {
            drive,
            no_6007: i % 2 == 0,
        });
    }
    let mut master = cnc402_drives::master::Master::new(&config).unwrap();
    let report = master
        .boot(&mut bus)
        .unwrap_or_else(|e| panic!("boot: {e}"));
    assert_eq!(master.phase(), Phase::Running);
    for d in &report.drives {
        assert!(!d.supervises_master, "{}", d.axis);
        assert!(!d.abort_connection_quick_stop, "{}", d.axis);
    }
}
