//! The SDO client and the service helpers over the simulated bus: long segmented transfers and
//! protocol violations against a scripted server, a device that is not CiA 402, timeouts
//! through the fault injector, and the CiA 402 state machine driven over SDO.

mod master_common;

use std::time::Duration;

use cia402::{Controlword, Goal, State, StuckReason};
use cnc402_config::MachineConfig;
use cnc402_drives::Instant;
use cnc402_drives::bus::{
    Action, CanBus, CanDevice, Direction, FaultInjector, FaultRule, FrameFilter, FrameSink, Origin,
    SimBus,
};
use cnc402_drives::master::{
    BlockingSdo, BootError, Master, MasterOptions, ProtocolViolation, SdoErrorKind, SequenceError,
    TimedBus, send_nmt, sequence_over_sdo,
};
use cnc402_drives::sim::{FaultKind, SimDrive, SimDriveOptions};
use cnc402_drives::wire::{
    AbortCode, CanFrame, ExpeditedData, HeartbeatRepr, InitiateKind, NmtCommand, NmtRepr, NmtState,
    NmtTarget, NodeId, SdoRequest, SdoResponse, SdoSegment,
};

fn node(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

/// How the scripted server misbehaves.
#[derive(Clone, Copy, PartialEq)]
enum Quirk {
    None,
    /// Answers every initiate upload for another sub-index.
    WrongSub,
    /// Repeats the toggle bit of the first upload segment.
    StuckToggle,
    /// Answers uploads expedited without the size bit (0x42).
    Unsized,
}

/// A minimal SDO server (one domain object 0x2000:0 of any length, 0x1000 = `device_type`)
/// that also boots up on NMT reset communication.
struct Scripted {
    node: NodeId,
    quirk: Quirk,
    device_type: u32,
    store: Vec<u8>,
    rx: Vec<u8>,
    tx_pos: usize,
    toggle: bool,
    /// Every request it received.
    log: Vec<SdoRequest>,
}

impl Scripted {
    fn new(n: u8, quirk: Quirk) -> Scripted {
        Scripted {
            node: node(n),
            quirk,
            device_type: 0x0002_0192,
            store: b"initial value, 20 b.".to_vec(),
            rx: vec![],
            tx_pos: 0,
            toggle: false,
            log: vec![],
        }
    }

    fn answer(&mut self, req: SdoRequest) -> Option<SdoResponse> {
        self.log.push(req);
        Some(match req {
            SdoRequest::InitiateUpload { index, sub } => {
                let data = match index {
                    0x1000 => self.device_type.to_le_bytes().to_vec(),
                    0x2000 => self.store.clone(),
                    _ => {
                        return Some(SdoResponse::Abort {
                            index,
                            sub,
                            code: AbortCode::NoObject,
                        });
                    }
                };
                let sub = if self.quirk == Quirk::WrongSub {
                    sub + 1
                } else {
                    sub
                };
                if data.len() <= 4 {
                    let e = if self.quirk == Quirk::Unsized {
                        let mut b = [0u8; 4];
                        b[..data.len()].copy_from_slice(&data);
                        ExpeditedData::without_size(b)
                    } else {
                        ExpeditedData::new(&data).unwrap()
                    };
                    SdoResponse::InitiateUpload {
                        index,
                        sub,
                        kind: InitiateKind::Expedited(e),
                    }
                } else {
                    self.tx_pos = 0;
                    self.toggle = false;
                    SdoResponse::InitiateUpload {
                        index,
                        sub,
                        kind: InitiateKind::Segmented {
                            size: Some(data.len() as u32),
                        },
                    }
                }
            }
            SdoRequest::UploadSegment { toggle } => {
                let end = (self.tx_pos + 7).min(self.store.len());
                let seg_toggle = if self.quirk == Quirk::StuckToggle {
                    false
                } else {
                    toggle
                };
                let seg = SdoSegment::new(
                    seg_toggle,
                    end == self.store.len(),
                    &self.store[self.tx_pos..end],
                )
                .unwrap();
                self.tx_pos = end;
                SdoResponse::UploadSegment(seg)
            }
            SdoRequest::InitiateDownload { index, sub, kind } => {
                self.rx.clear();
                if let InitiateKind::Expedited(e) = kind {
                    self.store = e.bytes().to_vec();
                }
                SdoResponse::InitiateDownload { index, sub }
            }
            SdoRequest::DownloadSegment(seg) => {
                self.rx.extend_from_slice(seg.data());
                if seg.last {
                    self.store = std::mem::take(&mut self.rx);
                }
                SdoResponse::DownloadSegment { toggle: seg.toggle }
            }
            SdoRequest::Abort { .. } => return None,
        })
    }
}

impl CanDevice for Scripted {
    fn on_frame(&mut self, frame: &CanFrame, now: Instant, tx: &mut dyn FrameSink) {
        if let Ok(nmt) = NmtRepr::parse(frame) {
            if nmt.command == NmtCommand::ResetCommunication && nmt.target.includes(self.node) {
                let f = HeartbeatRepr {
                    node: self.node,
                    state: NmtState::BootUp,
                }
                .emit();
                tx.transmit(&f, now).unwrap();
            }
            return;
        }
        if let Ok((n, req)) = SdoRequest::parse(frame)
            && n == self.node
            && let Some(resp) = self.answer(req)
        {
            tx.transmit(&resp.emit(self.node), now).unwrap();
        }
    }
    fn poll(&mut self, _now: Instant, _tx: &mut dyn FrameSink) {}
}

fn scripted_bus(quirk: Quirk) -> SimBus<Scripted> {
    let mut bus = SimBus::new(1_000_000);
    bus.attach(Scripted::new(7, quirk));
    bus
}

fn with_sdo<B: TimedBus, R>(bus: &mut B, f: impl FnOnce(&mut BlockingSdo<'_, B>) -> R) -> R {
    let mut ignore = |_: &CanFrame| {};
    let mut s = BlockingSdo::new(bus, Duration::from_millis(100), &mut ignore);
    f(&mut s)
}

#[test]
fn long_segmented_download_and_upload_round_trip() {
    let mut bus = scripted_bus(Quirk::None);
    let data: Vec<u8> = (0..1000u32).map(|i| (i * 7 + 3) as u8).collect();
    with_sdo(&mut bus, |s| {
        s.download(node(7), 0x2000, 0, &data).unwrap();
        assert_eq!(s.upload(node(7), 0x2000, 0).unwrap(), data);
        // Exactly 7 bytes fit one segment; 8 need two; 5 need one.
        for n in [5usize, 7, 8, 14, 15] {
            let d: Vec<u8> = (0..n as u8).collect();
            s.download(node(7), 0x2000, 0, &d).unwrap();
            assert_eq!(s.upload(node(7), 0x2000, 0).unwrap(), d, "{n} bytes");
        }
    });
    let dev = bus.device(0).unwrap();
    let segments = dev
        .log
        .iter()
        .filter(|r| matches!(r, SdoRequest::DownloadSegment(_)))
        .count();
    // 1000 bytes = 143 segments, then 1 + 1 + 2 + 2 + 3.
    assert_eq!(segments, 143 + 1 + 1 + 2 + 2 + 3);
}

#[test]
fn response_for_another_object_is_refused_with_an_abort() {
    let mut bus = scripted_bus(Quirk::WrongSub);
    bus.start_trace();
    let e = with_sdo(&mut bus, |s| s.read_u32(node(7), 0x1000, 0)).unwrap_err();
    assert_eq!(
        e.kind,
        SdoErrorKind::Protocol {
            sent: AbortCode::General,
            what: ProtocolViolation::WrongObject {
                index: 0x1000,
                sub: 1
            }
        }
    );
    bus.advance(bus.now() + Duration::from_millis(1));
    let last = bus
        .take_trace()
        .iter()
        .rev()
        .find(|t| t.origin == Origin::Master)
        .map(|t| t.frame.to_string());
    assert_eq!(last.as_deref(), Some("607#8000100000000008"));
}

#[test]
fn toggle_error_in_an_upload_aborts_with_05030000() {
    let mut bus = scripted_bus(Quirk::StuckToggle);
    let e = with_sdo(&mut bus, |s| s.upload(node(7), 0x2000, 0)).unwrap_err();
    assert!(
        matches!(
            e.kind,
            SdoErrorKind::Protocol {
                sent: AbortCode::ToggleNotAlternated,
                what: ProtocolViolation::Toggle
            }
        ),
        "{e}"
    );
    let t = bus.now();
    bus.advance(t + Duration::from_millis(1));
    let dev = bus.device(0).unwrap();
    assert!(matches!(
        dev.log.last(),
        Some(SdoRequest::Abort {
            code: AbortCode::ToggleNotAlternated,
            ..
        })
    ));
}

#[test]
fn expedited_upload_without_size_is_accepted() {
    let mut bus = scripted_bus(Quirk::Unsized);
    let v = with_sdo(&mut bus, |s| s.read_u32(node(7), 0x1000, 0)).unwrap();
    assert_eq!(v, 0x0002_0192);
}

#[test]
fn a_device_that_is_not_cia402_fails_boot_clearly() {
    let mut config = MachineConfig::default_machine();
    config.axes.truncate(1);
    config.axes[0].node = Some(7);
    let mut bus = scripted_bus(Quirk::None);
    bus.devices_mut_for_test().device_type = 0x0000_0191;
    let mut m = Master::new(&config).unwrap();
    let e = m.boot(&mut bus).unwrap_err();
    assert_eq!(
        e,
        BootError::NotCia402 {
            axis: 'X',
            node: 7,
            device_type: 0x191
        }
    );
    assert!(e.to_string().contains("not a CiA 402 drive"), "{e}");
}

trait FirstDevice {
    fn devices_mut_for_test(&mut self) -> &mut Scripted;
}
impl FirstDevice for SimBus<Scripted> {
    fn devices_mut_for_test(&mut self) -> &mut Scripted {
        self.device_mut(0).unwrap()
    }
}

#[test]
fn timeout_through_the_fault_injector_sends_the_abort() {
    let config = MachineConfig::default_machine();
    let mut inner: SimBus<SimDrive> = SimBus::new(1_000_000);
    inner.attach(SimDrive::new(
        &config.axes[0],
        node(1),
        Duration::from_millis(1),
    ));
    let mut bus = FaultInjector::new(inner);
    for ms in 0..10 {
        bus.inner_mut().advance(Instant::from_millis(ms));
    }
    while bus.recv().unwrap().is_some() {}
    // Responses to the master are lost on the way in.
    let rule = bus.add_rule(FaultRule::new(
        FrameFilter::id(0x581),
        Direction::Rx,
        Action::Drop,
    ));
    bus.inner_mut().start_trace();
    let e = with_sdo(&mut bus, |s| s.read_u32(node(1), 0x1000, 0)).unwrap_err();
    assert!(matches!(e.kind, SdoErrorKind::Timeout { .. }), "{e}");
    assert_eq!(bus.applied(rule), 1);
    let t = bus.inner().now();
    bus.inner_mut().advance(t + Duration::from_millis(1));
    let sent: Vec<String> = bus
        .inner_mut()
        .take_trace()
        .iter()
        .filter(|t| t.origin == Origin::Master)
        .map(|t| t.frame.to_string())
        .collect();
    assert_eq!(sent, vec!["601#4000100000000000", "601#8000100000000405"]);
}

fn one_drive(options: SimDriveOptions) -> SimBus<SimDrive> {
    let config = MachineConfig::default_machine();
    let mut bus = SimBus::new(1_000_000);
    bus.attach(SimDrive::with_options(
        &config.axes[2],
        node(3),
        Duration::from_millis(1),
        options,
    ));
    for ms in 0..10 {
        bus.advance(Instant::from_millis(ms));
    }
    while bus.recv().unwrap().is_some() {}
    bus
}

#[test]
fn state_machine_over_sdo_enables_step_by_step_without_moving() {
    let mut bus = one_drive(SimDriveOptions {
        initial_position: 5555,
        ..SimDriveOptions::default()
    });
    let mut steps = vec![];
    let sw = with_sdo(&mut bus, |s| {
        sequence_over_sdo(
            s,
            node(3),
            Goal::OperationEnabled,
            Duration::from_millis(2),
            Duration::from_millis(200),
            &mut |sw, cw| steps.push((sw.state(), cw)),
        )
    })
    .unwrap();
    assert_eq!(sw.state(), Some(State::OperationEnabled));
    assert_eq!(
        steps,
        vec![
            (Some(State::SwitchOnDisabled), Controlword(0x06)),
            (Some(State::ReadyToSwitchOn), Controlword(0x07)),
            (Some(State::SwitchedOn), Controlword(0x0F)),
        ]
    );
    let d = bus.device(0).unwrap();
    assert_eq!((d.target_position(), d.position_actual()), (5555, 5555));
}

#[test]
fn state_machine_over_sdo_resets_a_fault_and_names_a_persistent_one() {
    let mut bus = one_drive(SimDriveOptions {
        start_in_fault: Some(0x7300),
        ..SimDriveOptions::default()
    });
    with_sdo(&mut bus, |s| {
        sequence_over_sdo(
            s,
            node(3),
            Goal::SwitchedOn,
            Duration::from_millis(2),
            Duration::from_millis(200),
            &mut |_, _| {},
        )
    })
    .unwrap();
    assert_eq!(bus.device(0).unwrap().state(), State::SwitchedOn);

    let mut bus = one_drive(SimDriveOptions::default());
    let now = bus.now();
    bus.device_mut(0)
        .unwrap()
        .inject(FaultKind::PersistentFault(0x4310), now);
    let e = with_sdo(&mut bus, |s| {
        sequence_over_sdo(
            s,
            node(3),
            Goal::OperationEnabled,
            Duration::from_millis(2),
            Duration::from_millis(100),
            &mut |_, _| {},
        )
    })
    .unwrap_err();
    let SequenceError::Stuck { node: n, stuck } = &e else {
        panic!("{e}")
    };
    assert_eq!(*n, 3);
    assert_eq!(stuck.state, Some(State::Fault));
    assert!(
        matches!(stuck.reason, StuckReason::FaultPersists { .. }),
        "{e}"
    );
    let t = e.to_string();
    assert!(t.contains("node 3") && t.contains("stuck in FAULT"), "{t}");
}

#[test]
fn nmt_helper_puts_a_drive_into_operational() {
    let mut bus = one_drive(SimDriveOptions::default());
    send_nmt(&mut bus, NmtCommand::Start, NmtTarget::Node(node(3))).unwrap();
    let t = bus.now();
    bus.advance(t + Duration::from_millis(1));
    assert_eq!(
        bus.device(0).unwrap().nmt(),
        cnc402_drives::sim::NmtStatus::Operational
    );
    let _ = MasterOptions::default();
}
