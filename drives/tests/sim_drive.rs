//! The simulated drive driven only through CAN frames on the simulated bus: small helpers
//! send SDO requests, NMT, SYNC and RPDOs like a master would, and the assertions look at the
//! frames that come back.

use std::time::Duration;

use cnc402_config::{AxisConfig, MachineConfig, SimDynamics};
use cnc402_drives::Instant;
use cnc402_drives::bus::{CanBus, SimBus};
use cnc402_drives::sim::{FaultKind, NmtStatus, SimDrive, SimDriveOptions};
use cnc402_drives::wire::{
    AbortCode, CanFrame, EmcyRepr, ExpeditedData, HeartbeatRepr, InitiateKind, NmtCommand, NmtRepr,
    NmtState, NmtTarget, NodeId, SdoRequest, SdoResponse, SdoSegment, SyncRepr,
};

const PERIOD: Duration = Duration::from_millis(1);

struct Rig {
    bus: SimBus<SimDrive>,
    now: Instant,
    node: NodeId,
    rx: Vec<(Instant, CanFrame)>,
}

fn axis(delay_cycles: u32, bandwidth_hz: f64) -> AxisConfig {
    let mut a = MachineConfig::default_machine().axes[0].clone();
    a.sim = SimDynamics {
        delay_cycles,
        bandwidth_hz,
        ..SimDynamics::default()
    };
    a
}

impl Rig {
    fn new() -> Rig {
        Rig::with(axis(0, 0.0), SimDriveOptions::default())
    }

    fn with(axis: AxisConfig, options: SimDriveOptions) -> Rig {
        let node = NodeId::new(5).unwrap();
        let mut bus = SimBus::new(1_000_000);
        bus.attach(SimDrive::with_options(&axis, node, PERIOD, options));
        let mut rig = Rig {
            bus,
            now: Instant::ZERO,
            node,
            rx: vec![],
        };
        rig.step(Duration::ZERO);
        rig
    }

    /// A rig that has booted, with the boot-up frame consumed.
    fn booted() -> Rig {
        let mut r = Rig::new();
        r.run(Duration::from_millis(5));
        assert!(r.take(0x705).len() == 1);
        r
    }

    fn drive(&self) -> &SimDrive {
        self.bus.device(0).unwrap()
    }

    fn drive_mut(&mut self) -> &mut SimDrive {
        self.bus.device_mut(0).unwrap()
    }

    fn inject(&mut self, kind: FaultKind) {
        let now = self.now;
        self.drive_mut().inject(kind, now);
    }

    fn step(&mut self, d: Duration) {
        self.now += d;
        self.bus.advance(self.now);
        while let Some(f) = self.bus.recv().unwrap() {
            self.rx.push((self.now, f));
        }
    }

    fn run(&mut self, d: Duration) {
        let end = self.now + d;
        while self.now < end {
            self.step(Duration::from_micros(100));
        }
    }

    /// Removes and returns received frames with this id.
    fn take(&mut self, id: u16) -> Vec<CanFrame> {
        let (hit, keep): (Vec<_>, Vec<_>) = self.rx.drain(..).partition(|(_, f)| f.id() == id);
        self.rx = keep;
        hit.into_iter().map(|(_, f)| f).collect()
    }

    fn send(&mut self, f: CanFrame) {
        self.bus.send(&f).unwrap();
    }

    fn nmt(&mut self, command: NmtCommand) {
        self.send(
            NmtRepr {
                command,
                target: NmtTarget::Node(self.node),
            }
            .emit(),
        );
        self.run(Duration::from_millis(1));
    }

    fn sync(&mut self) {
        self.send(SyncRepr { counter: None }.emit());
        self.run(PERIOD);
    }

    fn rpdo1(&mut self, data: &[u8]) {
        self.send(CanFrame::new(0x200 + self.node.get() as u16, data).unwrap());
    }

    /// One SDO exchange: the server's response, or `None` after 50 ms.
    fn sdo(&mut self, req: SdoRequest) -> Option<SdoResponse> {
        self.take(0x585);
        self.send(req.emit(self.node));
        for _ in 0..500 {
            self.step(Duration::from_micros(100));
            if let Some(f) = self.take(0x585).first() {
                return Some(SdoResponse::parse(f).unwrap().1);
            }
        }
        None
    }

    fn read(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode> {
        match self
            .sdo(SdoRequest::InitiateUpload { index, sub })
            .expect("no SDO response")
        {
            SdoResponse::InitiateUpload {
                index: i,
                sub: s,
                kind,
            } => {
                assert_eq!((i, s), (index, sub), "response names another object");
                match kind {
                    InitiateKind::Expedited(e) => Ok(e.bytes().to_vec()),
                    InitiateKind::Segmented { size } => {
                        let mut out = vec![];
                        let mut toggle = false;
                        loop {
                            match self
                                .sdo(SdoRequest::UploadSegment { toggle })
                                .expect("no segment")
                            {
                                SdoResponse::UploadSegment(seg) => {
                                    assert_eq!(seg.toggle, toggle);
                                    out.extend_from_slice(seg.data());
                                    if seg.last {
                                        break;
                                    }
                                }
                                SdoResponse::Abort { code, .. } => return Err(code),
                                other => panic!("{other:?}"),
                            }
                            toggle = !toggle;
                        }
                        assert_eq!(Some(out.len() as u32), size);
                        Ok(out)
                    }
                }
            }
            SdoResponse::Abort {
                index: i,
                sub: s,
                code,
            } => {
                assert_eq!((i, s), (index, sub));
                Err(code)
            }
            other => panic!("{other:?}"),
        }
    }

    fn read_u32(&mut self, index: u16, sub: u8) -> u32 {
        let b = self.read(index, sub).unwrap();
        let mut a = [0u8; 4];
        a[..b.len()].copy_from_slice(&b);
        u32::from_le_bytes(a)
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        if !data.is_empty() && data.len() <= 4 {
            let kind = InitiateKind::Expedited(ExpeditedData::new(data).unwrap());
            return match self
                .sdo(SdoRequest::InitiateDownload { index, sub, kind })
                .expect("no SDO response")
            {
                SdoResponse::InitiateDownload { index: i, sub: s } => {
                    assert_eq!((i, s), (index, sub));
                    Ok(())
                }
                SdoResponse::Abort { code, .. } => Err(code),
                other => panic!("{other:?}"),
            };
        }
        let kind = InitiateKind::Segmented {
            size: Some(data.len() as u32),
        };
        match self
            .sdo(SdoRequest::InitiateDownload { index, sub, kind })
            .expect("no SDO response")
        {
            SdoResponse::InitiateDownload { .. } => {}
            SdoResponse::Abort { code, .. } => return Err(code),
            other => panic!("{other:?}"),
        }
        let chunks: Vec<&[u8]> = if data.is_empty() {
            vec![&[]]
        } else {
            data.chunks(7).collect()
        };
        for (i, c) in chunks.iter().enumerate() {
            let toggle = i % 2 == 1;
            let seg = SdoSegment::new(toggle, i + 1 == chunks.len(), c).unwrap();
            match self
                .sdo(SdoRequest::DownloadSegment(seg))
                .expect("no SDO response")
            {
                SdoResponse::DownloadSegment { toggle: t } => assert_eq!(t, toggle),
                SdoResponse::Abort { code, .. } => return Err(code),
                other => panic!("{other:?}"),
            }
        }
        Ok(())
    }

    fn w32(&mut self, index: u16, sub: u8, v: u32) -> Result<(), AbortCode> {
        self.write(index, sub, &v.to_le_bytes())
    }

    fn w8(&mut self, index: u16, sub: u8, v: u8) -> Result<(), AbortCode> {
        self.write(index, sub, &[v])
    }

    /// The CiA 301 remap sequence: RPDO1 = controlword + target, TPDO1 = statusword +
    /// position actual, both synchronous with transmission type `ttype`.
    fn map_csp_pdos(&mut self, ttype: u8) {
        let id = self.node.get() as u32;
        for (comm, map, cob, entries) in [
            (0x1400, 0x1600, 0x200 + id, [0x6040_0010u32, 0x607A_0020]),
            (0x1800, 0x1A00, 0x180 + id, [0x6041_0010, 0x6064_0020]),
        ] {
            self.w32(comm, 1, 0x8000_0000 | cob).unwrap();
            self.w8(map, 0, 0).unwrap();
            self.w32(map, 1, entries[0]).unwrap();
            self.w32(map, 2, entries[1]).unwrap();
            self.w8(map, 0, 2).unwrap();
            self.w8(comm, 2, ttype).unwrap();
            self.w32(comm, 1, cob).unwrap();
        }
    }

    /// Booted, CSP mapped (type 1), mode 8, operational.
    fn operational() -> Rig {
        let mut r = Rig::booted();
        r.map_csp_pdos(1);
        r.w8(0x6060, 0, 8).unwrap();
        r.nmt(NmtCommand::Start);
        r
    }

    fn rpdo_csp(&mut self, cw: u16, target: i32) {
        let mut d = [0u8; 6];
        d[..2].copy_from_slice(&cw.to_le_bytes());
        d[2..].copy_from_slice(&target.to_le_bytes());
        self.rpdo1(&d);
    }

    /// One cycle: RPDO then SYNC; returns the TPDO1 (statusword, position) sent after it.
    fn cycle(&mut self, cw: u16, target: i32) -> Option<(u16, i32)> {
        self.take(0x185);
        self.rpdo_csp(cw, target);
        self.sync();
        let t = self.take(0x185);
        t.last().map(|f| {
            let d = f.data();
            (
                u16::from_le_bytes([d[0], d[1]]),
                i32::from_le_bytes([d[2], d[3], d[4], d[5]]),
            )
        })
    }

    /// Enables with target = actual; returns the position.
    fn enable(&mut self) -> i32 {
        let (_, pos) = self.cycle(0x06, 0).unwrap();
        self.cycle(0x07, pos);
        let (sw, _) = self.cycle(0x0F, pos).unwrap();
        assert_eq!(sw & 0x6F, 0x27, "{sw:#x}");
        pos
    }

    fn emcys(&mut self) -> Vec<EmcyRepr> {
        self.take(0x085)
            .iter()
            .map(|f| EmcyRepr::parse(f).unwrap())
            .collect()
    }
}

// ---- NMT and boot ------------------------------------------------------------------------

#[test]
fn boots_with_boot_up_message_and_is_silent_before() {
    let mut r = Rig::with(
        axis(0, 0.0),
        SimDriveOptions {
            boot_delay: Duration::from_millis(300),
            ..Default::default()
        },
    );
    // Before boot it answers nothing.
    r.send(
        SdoRequest::InitiateUpload {
            index: 0x1000,
            sub: 0,
        }
        .emit(r.node),
    );
    r.run(Duration::from_millis(299));
    assert!(r.rx.is_empty(), "{:?}", r.rx);
    r.run(Duration::from_millis(2));
    let boot = r.take(0x705);
    assert_eq!(boot.len(), 1);
    assert_eq!(
        HeartbeatRepr::parse(&boot[0]).unwrap().state,
        NmtState::BootUp
    );
    assert_eq!(r.drive().nmt(), NmtStatus::PreOperational);
    assert_eq!(r.drive().state(), cia402::State::SwitchOnDisabled);
    assert_eq!(r.read_u32(0x1000, 0), 0x0002_0192);
}

#[test]
fn heartbeat_at_the_configured_period_with_the_nmt_state() {
    let mut r = Rig::booted();
    r.run(Duration::from_millis(200));
    assert!(r.take(0x705).is_empty(), "0x1017 = 0: no heartbeat");
    r.write(0x1017, 0, &50u16.to_le_bytes()).unwrap();
    r.take(0x705);
    r.run(Duration::from_millis(1000));
    let hb = r.take(0x705);
    assert!((19..=21).contains(&hb.len()), "{}", hb.len());
    assert!(hb.iter().all(|f| f.data() == [0x7F]));
    r.nmt(NmtCommand::Start);
    r.take(0x705);
    r.run(Duration::from_millis(100));
    assert!(r.take(0x705).iter().all(|f| f.data() == [0x05]));
    r.nmt(NmtCommand::Stop);
    r.take(0x705);
    r.run(Duration::from_millis(100));
    let hb = r.take(0x705);
    assert!(!hb.is_empty() && hb.iter().all(|f| f.data() == [0x04]));
}

#[test]
fn stopped_ignores_sdo_and_pdo_and_reset_communication_restores_pdo_defaults() {
    let mut r = Rig::booted();
    r.map_csp_pdos(1);
    r.nmt(NmtCommand::Stop);
    assert_eq!(r.drive().nmt(), NmtStatus::Stopped);
    assert_eq!(
        r.sdo(SdoRequest::InitiateUpload {
            index: 0x1000,
            sub: 0
        }),
        None
    );
    r.nmt(NmtCommand::EnterPreOperational);
    assert_eq!(r.read_u32(0x1600, 2), 0x607A_0020);
    r.take(0x705);
    r.nmt(NmtCommand::ResetCommunication);
    assert_eq!(r.take(0x705).len(), 1, "boot-up after reset communication");
    assert_eq!(r.read_u32(0x1600, 0), 1);
    assert_eq!(r.read_u32(0x1600, 1), 0x6040_0010);
    assert_eq!(r.read_u32(0x1600, 2), 0);
}

#[test]
fn reset_node_restores_the_application_but_not_the_motor_position() {
    let mut r = Rig::operational();
    let p0 = r.enable();
    for k in 1..=10 {
        r.cycle(0x0F, p0 + k * 100);
    }
    assert_eq!(r.drive().position_actual(), p0 + 1000);
    r.take(0x705);
    r.nmt(NmtCommand::ResetNode);
    assert_eq!(r.take(0x705).len(), 1);
    assert_eq!(r.drive().nmt(), NmtStatus::PreOperational);
    assert_eq!(r.drive().state(), cia402::State::SwitchOnDisabled);
    assert_eq!(r.read(0x6060, 0).unwrap(), vec![0]);
    assert_eq!(r.read_u32(0x6064, 0) as i32, p0 + 1000);
}

// ---- SDO server ---------------------------------------------------------------------------

#[test]
fn identity_name_and_sdo_abort_codes() {
    let mut r = Rig::booted();
    assert_eq!(r.read_u32(0x1018, 0), 4);
    assert_eq!(r.read_u32(0x1018, 1), cnc402_drives::sim::VENDOR_ID);
    assert_eq!(r.read_u32(0x1018, 4), 5, "serial = node id");
    assert_eq!(
        r.read(0x1008, 0).unwrap(),
        b"cnc402 simdrive X".to_vec(),
        "segmented upload"
    );
    // CSP (bit 7) and homing (bit 5): the simulated drive homes (issue 17).
    assert_eq!(r.read_u32(0x6502, 0), 0xA0);
    assert_eq!(r.read_u32(0x60C2, 1), 1);
    assert_eq!(r.read(0x60C2, 2).unwrap(), vec![(-3i8) as u8]);
    assert_eq!(r.read(0x2345, 0), Err(AbortCode::NoObject));
    assert_eq!(r.read(0x1018, 9), Err(AbortCode::NoSubIndex));
    assert_eq!(r.write(0x6041, 0, &[0, 0]), Err(AbortCode::WriteReadOnly));
    assert_eq!(r.write(0x1000, 0, &[0; 4]), Err(AbortCode::WriteReadOnly));
    assert_eq!(
        r.write(0x1008, 0, b"a longer name"),
        Err(AbortCode::WriteReadOnly)
    );
    assert_eq!(r.write(0x6040, 0, &[0; 4]), Err(AbortCode::LengthTooHigh));
    assert_eq!(r.write(0x6040, 0, &[0]), Err(AbortCode::LengthTooLow));
    assert_eq!(
        r.write(0x6060, 0, &[1]),
        Err(AbortCode::InvalidValue),
        "only CSP supported"
    );
    assert_eq!(
        r.write(0x605A, 0, &9i16.to_le_bytes()),
        Err(AbortCode::ValueTooHigh)
    );
    assert_eq!(r.write(0x1003, 0, &[3]), Err(AbortCode::InvalidValue));
    assert_eq!(
        r.read(0x1003, 1),
        Err(AbortCode::NoData),
        "empty error history"
    );
    // Block download initiate (ccs 6) is not supported.
    let mut d = [0u8; 8];
    d[0] = 0xC6;
    d[1] = 0x08;
    d[2] = 0x10;
    r.send(CanFrame::new(0x605, &d).unwrap());
    r.run(Duration::from_millis(1));
    let f = r.take(0x585);
    assert_eq!(
        SdoResponse::parse(&f[0]).unwrap().1,
        SdoResponse::Abort {
            index: 0x1008,
            sub: 0,
            code: AbortCode::BadCommand
        }
    );
    // A short SDO frame is counted, not answered.
    r.send(CanFrame::new(0x605, &[0x40, 0, 0x10]).unwrap());
    r.run(Duration::from_millis(1));
    assert!(r.take(0x585).is_empty());
    assert!(r.drive().stats().unexpected_frames >= 1);
}

#[test]
fn expedited_download_without_size_takes_the_type_length() {
    let mut r = Rig::booted();
    let kind = InitiateKind::Expedited(ExpeditedData::without_size([8, 0xAA, 0xBB, 0xCC]));
    let resp = r.sdo(SdoRequest::InitiateDownload {
        index: 0x6060,
        sub: 0,
        kind,
    });
    assert_eq!(
        resp,
        Some(SdoResponse::InitiateDownload {
            index: 0x6060,
            sub: 0
        })
    );
    assert_eq!(r.read(0x6061, 0).unwrap(), vec![8], "mode display follows");
}

#[test]
fn segmented_transfers_of_any_length_via_the_error_history() {
    // 0x1008 is constant, so exercise segmented download framing on a 4-byte object too:
    // a segmented download of exactly 4 bytes is legal.
    let mut r = Rig::booted();
    let kind = InitiateKind::Segmented { size: Some(4) };
    assert_eq!(
        r.sdo(SdoRequest::InitiateDownload {
            index: 0x607A,
            sub: 0,
            kind
        }),
        Some(SdoResponse::InitiateDownload {
            index: 0x607A,
            sub: 0
        })
    );
    let seg = SdoSegment::new(false, true, &(-7i32).to_le_bytes()).unwrap();
    assert_eq!(
        r.sdo(SdoRequest::DownloadSegment(seg)),
        Some(SdoResponse::DownloadSegment { toggle: false })
    );
    assert_eq!(r.read_u32(0x607A, 0) as i32, -7);
    // Size mismatch announced at initiate.
    let kind = InitiateKind::Segmented { size: Some(9) };
    assert!(matches!(
        r.sdo(SdoRequest::InitiateDownload {
            index: 0x607A,
            sub: 0,
            kind
        }),
        Some(SdoResponse::Abort {
            code: AbortCode::LengthTooHigh,
            ..
        })
    ));
}

// ---- PDO mapping rules ----------------------------------------------------------------------

#[test]
fn remap_sequence_is_accepted_and_read_back() {
    let mut r = Rig::booted();
    r.map_csp_pdos(1);
    assert_eq!(r.read_u32(0x1600, 0), 2);
    assert_eq!(r.read_u32(0x1A00, 2), 0x6064_0020);
    assert_eq!(r.read_u32(0x1800, 1) & 0x8000_07FF, 0x185);
    assert_eq!(r.read_u32(0x1800, 2), 1);
}

#[test]
fn remap_rules_are_enforced_with_their_abort_codes() {
    let mut r = Rig::booted();
    // RPDO1 is valid at power-on: its mapping cannot change.
    assert_eq!(r.w8(0x1600, 0, 0), Err(AbortCode::DeviceState));
    assert_eq!(r.w32(0x1600, 2, 0x607A_0020), Err(AbortCode::DeviceState));
    // Changing the COB-ID of a valid PDO is refused; setting bit 29 too.
    assert_eq!(r.w32(0x1400, 1, 0x305), Err(AbortCode::InvalidValue));
    assert_eq!(r.w32(0x1400, 1, 0xA000_0205), Err(AbortCode::InvalidValue));
    r.w32(0x1400, 1, 0x8000_0205).unwrap();
    // Mapping still enabled (sub 0 = 1): entries cannot change.
    assert_eq!(r.w32(0x1600, 2, 0x607A_0020), Err(AbortCode::DeviceState));
    r.w8(0x1600, 0, 0).unwrap();
    assert_eq!(
        r.w32(0x1600, 1, 0x1000_0020),
        Err(AbortCode::CannotMap),
        "not mappable"
    );
    assert_eq!(
        r.w32(0x1600, 1, 0x6041_0010),
        Err(AbortCode::CannotMap),
        "read-only in an RPDO"
    );
    assert_eq!(
        r.w32(0x1600, 1, 0x607A_0010),
        Err(AbortCode::ParameterIncompatible),
        "wrong length"
    );
    assert_eq!(r.w32(0x1600, 1, 0x2345_0010), Err(AbortCode::NoObject));
    assert_eq!(r.w32(0x1600, 1, 0x6040_0110), Err(AbortCode::NoSubIndex));
    for (sub, e) in [(1, 0x607A_0020), (2, 0x6064_0020)] {
        let _ = r.w32(0x1600, sub, e);
    }
    assert_eq!(
        r.w32(0x1600, 2, 0x6064_0020),
        Err(AbortCode::CannotMap),
        "0x6064 read-only"
    );
    r.w32(0x1600, 2, 0x607A_0020).unwrap();
    r.w32(0x1600, 3, 0x6040_0010).unwrap();
    // 32 + 32 + 16 = 80 bits > 64.
    assert_eq!(r.w8(0x1600, 0, 3), Err(AbortCode::MappingTooLong));
    assert_eq!(r.w8(0x1600, 0, 9), Err(AbortCode::MappingTooLong));
    // An empty entry inside 1..=n.
    r.w32(0x1600, 3, 0).unwrap();
    assert_eq!(r.w8(0x1600, 0, 3), Err(AbortCode::ParameterIncompatible));
    r.w8(0x1600, 0, 2).unwrap();
    // Transmission types: 252/253 (RTR) and 241..251 refused.
    assert_eq!(r.w8(0x1400, 2, 252), Err(AbortCode::InvalidValue));
    assert_eq!(r.w8(0x1400, 2, 241), Err(AbortCode::InvalidValue));
    r.w8(0x1400, 2, 1).unwrap();
    r.w32(0x1400, 1, 0x205).unwrap();
    // A TPDO maps readable objects only.
    r.w32(0x1801, 1, 0x8000_0285).unwrap();
    assert_eq!(r.w32(0x1A01, 1, 0x6064_0020), Ok(()));
    // PDO configuration only in PRE-OPERATIONAL.
    r.nmt(NmtCommand::Start);
    assert_eq!(r.w32(0x1401, 1, 0x8000_0305), Err(AbortCode::DeviceState));
    assert_eq!(r.w8(0x1A01, 0, 1), Err(AbortCode::DeviceState));
}

// ---- PDO timing ---------------------------------------------------------------------------

#[test]
fn synchronous_rpdo_takes_effect_at_the_next_sync_only() {
    let mut r = Rig::operational();
    r.rpdo_csp(0x06, 12345);
    r.run(Duration::from_millis(3));
    assert_eq!(r.drive().target_position(), 0, "not before SYNC");
    assert_eq!(r.drive().state(), cia402::State::SwitchOnDisabled);
    r.sync();
    assert_eq!(r.drive().target_position(), 12345);
    assert_eq!(r.drive().state(), cia402::State::ReadyToSwitchOn);
}

#[test]
fn pdos_are_ignored_before_start_and_rpdo_length_errors_raise_emcy() {
    let mut r = Rig::booted();
    r.map_csp_pdos(1);
    r.rpdo_csp(0x06, 1);
    r.sync();
    assert!(r.take(0x185).is_empty(), "no TPDO in PRE-OPERATIONAL");
    assert_eq!(r.drive().state(), cia402::State::SwitchOnDisabled);
    r.nmt(NmtCommand::Start);
    r.rpdo1(&[0x06, 0, 1, 2, 3]);
    r.run(Duration::from_millis(1));
    r.rpdo1(&[0x06, 0, 1, 2, 3, 4, 5]);
    r.run(Duration::from_millis(1));
    let codes: Vec<u16> = r.emcys().iter().map(|e| e.code).collect();
    assert_eq!(codes, vec![0x8210, 0x8220]);
    assert_eq!(r.drive().stats().pdo_length_errors, 2);
    r.sync();
    assert_eq!(
        r.drive().state(),
        cia402::State::SwitchOnDisabled,
        "bad RPDOs not applied"
    );
}

#[test]
fn tpdo_every_nth_sync_and_sent_after_the_sync() {
    let mut r = Rig::booted();
    r.map_csp_pdos(3);
    r.nmt(NmtCommand::Start);
    r.bus.start_trace();
    for _ in 0..9 {
        r.sync();
    }
    let trace = r.bus.take_trace();
    let syncs: Vec<_> = trace
        .iter()
        .filter(|t| t.frame.id() == 0x80)
        .map(|t| t.at)
        .collect();
    let tpdos: Vec<_> = trace
        .iter()
        .filter(|t| t.frame.id() == 0x185)
        .map(|t| t.at)
        .collect();
    assert_eq!(tpdos.len(), 3);
    // The 3rd, 6th and 9th SYNC are each followed by a TPDO.
    for (k, t) in tpdos.iter().enumerate() {
        let s = syncs[3 * k + 2];
        assert!(
            *t > s && *t - s < Duration::from_micros(300),
            "{t} after {s}"
        );
    }
}

// ---- CiA 402 and CSP ----------------------------------------------------------------------

#[test]
fn enable_then_follow_ideal_and_with_dynamics() {
    let mut r = Rig::operational();
    let p0 = r.enable();
    let mut target = p0;
    for _ in 0..50 {
        target += 1000;
        let (sw, pos) = r.cycle(0x0F, target).unwrap();
        assert_eq!(
            pos, target,
            "ideal dynamics: actual = target in the same cycle"
        );
        assert_eq!(sw & 0x1000, 0x1000, "bit 12: follows the command");
    }

    // One cycle of pure delay and 150 Hz tracking: lag = delay + v(1-α)/α.
    let mut r = Rig::with(axis(1, 150.0), SimDriveOptions::default());
    r.run(Duration::from_millis(5));
    r.map_csp_pdos(1);
    r.w8(0x6060, 0, 8).unwrap();
    r.nmt(NmtCommand::Start);
    let p0 = r.enable();
    let mut target = p0;
    let mut last = (0, 0);
    for _ in 0..300 {
        target += 1000;
        last = r.cycle(0x0F, target).unwrap();
    }
    let alpha = 1.0 - (-2.0 * std::f64::consts::PI * 150.0 * 0.001f64).exp();
    let expected = 1000.0 + 1000.0 * (1.0 - alpha) / alpha;
    let lag = (target - last.1) as f64;
    assert!((lag - expected).abs() <= 2.0, "{lag} vs {expected}");
}

#[test]
fn stale_target_at_enable_makes_a_following_error_fault_with_emcy_8611() {
    let mut r = Rig::with(
        axis(0, 20.0),
        SimDriveOptions {
            initial_position: 50_000,
            ..Default::default()
        },
    );
    r.run(Duration::from_millis(5));
    r.map_csp_pdos(1);
    r.w8(0x6060, 0, 8).unwrap();
    r.nmt(NmtCommand::Start);
    // The master forgets target = actual: target 0, motor at 50 000 (window 5000 counts).
    r.cycle(0x06, 0);
    r.cycle(0x07, 0);
    let mut sws = vec![];
    for _ in 0..400 {
        if let Some((sw, _)) = r.cycle(0x0F, 0) {
            sws.push(sw);
        }
        if r.drive().state() == cia402::State::Fault {
            break;
        }
    }
    assert!(
        sws.iter().any(|sw| sw & 0x2000 != 0),
        "bit 13 while outside the window"
    );
    assert_eq!(r.drive().state(), cia402::State::Fault);
    let e = r.emcys();
    assert_eq!(e.len(), 1);
    assert_eq!(e[0].code, 0x8611);
    assert_eq!(e[0].register & 0x01, 0x01);
    assert_eq!(r.read_u32(0x1001, 0) & 0x01, 1);
    assert_eq!(r.read_u32(0x1003, 0), 1);
    assert_eq!(r.read_u32(0x1003, 1), 0x8611);
    assert_eq!(r.read_u32(0x603F, 0), 0x8611);
    assert_eq!(r.drive().fault_code(), Some(0x8611));
    // Timeout 10 ms: not before ~10 cycles outside the window.
    let first_out = sws.iter().position(|sw| sw & 0x2000 != 0).unwrap();
    let fault_at = sws
        .iter()
        .position(|sw| sw & 0x4F == 0x08 || sw & 0x4F == 0x0F)
        .unwrap();
    assert!(fault_at - first_out >= 10, "{first_out} {fault_at}");
}

#[test]
fn quick_stop_decelerates_then_switch_on_disabled_or_stays_per_option() {
    for (option, end) in [
        (2i16, cia402::State::SwitchOnDisabled),
        (6, cia402::State::QuickStopActive),
    ] {
        let mut r = Rig::operational();
        r.write(0x605A, 0, &option.to_le_bytes()).unwrap();
        let p0 = r.enable();
        let mut t = p0;
        // 2000 counts/ms = 200 mm/s; quick stop deceleration 2 × 2000 mm/s² → 50 ms.
        for _ in 0..20 {
            t += 2_000;
            r.cycle(0x0F, t);
        }
        let (sw, _) = r.cycle(0x02, t).unwrap();
        assert_eq!(sw & 0x6F, 0x07, "QUICK STOP ACTIVE {sw:#x}");
        let mut positions = vec![];
        for _ in 0..80 {
            if let Some((_, p)) = r.cycle(0x02, t) {
                positions.push(p);
            }
        }
        // It keeps moving forward and slows down, instead of jumping to the target.
        let steps: Vec<i32> = positions.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(steps.windows(2).all(|s| s[1] <= s[0]), "{steps:?}");
        assert_eq!(*steps.last().unwrap(), 0);
        assert_eq!(r.drive().state(), end);
    }
}

#[test]
fn injected_fault_emcy_and_fault_reset_edge_via_rpdo() {
    let mut r = Rig::operational();
    r.enable();
    r.inject(FaultKind::Fault(0x7300));
    r.run(Duration::from_millis(1));
    let e = r.emcys();
    assert_eq!(e.iter().map(|e| e.code).collect::<Vec<_>>(), vec![0x7300]);
    let pos = r.drive().position_actual();
    let (sw, _) = r.cycle(0x0F, pos).unwrap();
    assert_eq!(sw & 0x4F, 0x08, "FAULT after the reaction {sw:#x}");
    // Bit 7 high → edge → SWITCH ON DISABLED and an EMCY error reset.
    let (sw, _) = r.cycle(0x80, pos).unwrap();
    assert_eq!(sw & 0x4F, 0x40, "{sw:#x}");
    assert_eq!(
        r.emcys().iter().map(|e| e.code).collect::<Vec<_>>(),
        vec![0x0000]
    );
    assert_eq!(r.read_u32(0x1001, 0), 0);
    // A persistent fault comes back after the reset.
    r.inject(FaultKind::PersistentFault(0x5530));
    r.cycle(0x00, pos);
    r.cycle(0x00, pos);
    r.cycle(0x80, pos);
    let (sw, _) = r.cycle(0x00, pos).unwrap();
    assert_eq!(sw & 0x08, 0x08, "still faulted {sw:#x}");
    assert_eq!(r.read_u32(0x1003, 0), 3, "0x7300, 0x5530, 0x5530");
    assert_eq!(r.read_u32(0x1003, 1), 0x5530);
    assert_eq!(r.read_u32(0x1003, 3), 0x7300);
}

#[test]
fn starts_in_fault_and_boots_late() {
    let mut r = Rig::with(
        axis(0, 0.0),
        SimDriveOptions {
            start_in_fault: Some(0x2310),
            boot_delay: Duration::from_millis(500),
            initial_position: 0,
        },
    );
    r.run(Duration::from_millis(400));
    assert!(r.rx.is_empty());
    r.run(Duration::from_millis(200));
    assert_eq!(r.take(0x705).len(), 1);
    assert_eq!(
        r.emcys().iter().map(|e| e.code).collect::<Vec<_>>(),
        vec![0x2310]
    );
    assert_eq!(r.read_u32(0x6041, 0) & 0x4F, 0x08);
    // Fault reset over SDO (controlword edge), then enable over SDO.
    r.write(0x6040, 0, &0x80u16.to_le_bytes()).unwrap();
    assert_eq!(r.read_u32(0x6041, 0) & 0x4F, 0x40);
    for cw in [0x06u16, 0x07, 0x0F] {
        r.write(0x6040, 0, &cw.to_le_bytes()).unwrap();
    }
    assert_eq!(r.read_u32(0x6041, 0) & 0x6F, 0x27);
}

#[test]
fn heartbeat_silence_sdo_silence_and_dropped_tpdos() {
    let mut r = Rig::operational();
    r.write(0x1017, 0, &10u16.to_le_bytes()).unwrap();
    r.run(Duration::from_millis(50));
    assert!(!r.take(0x705).is_empty());
    assert!(r.cycle(0x06, 0).is_some());
    r.inject(FaultKind::HeartbeatSilence);
    r.run(Duration::from_millis(50));
    assert!(r.take(0x705).is_empty());
    r.inject(FaultKind::DropTpdos);
    assert!(r.cycle(0x06, 0).is_none());
    assert!(r.drive().stats().tpdos_dropped >= 1);
    r.inject(FaultKind::SdoSilence);
    assert_eq!(
        r.sdo(SdoRequest::InitiateUpload {
            index: 0x1000,
            sub: 0
        }),
        None
    );
    r.drive_mut().clear_injected();
    assert_eq!(r.read_u32(0x1000, 0), 0x0002_0192);
    assert!(r.cycle(0x06, 0).is_some());
}

#[test]
fn position_wraps_past_i32_max_without_fault() {
    let mut r = Rig::with(
        axis(1, 150.0),
        SimDriveOptions {
            initial_position: i32::MAX - 200_000,
            ..Default::default()
        },
    );
    r.run(Duration::from_millis(5));
    r.map_csp_pdos(1);
    r.w8(0x6060, 0, 8).unwrap();
    r.nmt(NmtCommand::Start);
    let p0 = r.enable();
    let mut t = p0;
    let mut last = p0;
    for _ in 0..200 {
        t = t.wrapping_add(2_000);
        let (sw, pos) = r.cycle(0x0F, t).unwrap();
        assert_eq!(sw & 0x6F, 0x27, "{sw:#x}");
        let step = pos.wrapping_sub(last);
        assert!((0..=4_000).contains(&step), "{step}");
        last = pos;
    }
    assert!(last < 0, "crossed 2^31");
    assert_eq!(r.drive().state(), cia402::State::OperationEnabled);
}

#[test]
fn garbage_frames_never_panic_and_the_drive_keeps_answering() {
    let mut r = Rig::operational();
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    for _ in 0..5000 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let ids = [0x000, 0x080, 0x205, 0x305, 0x605, 0x705, 0x085, 0x185];
        let id = ids[(x % ids.len() as u64) as usize];
        let len = ((x >> 8) % 9) as usize;
        let bytes = (x >> 16).to_le_bytes();
        // Keep the node alive: no NMT reset/stop to this node in the fuzz.
        if id == 0 && len >= 1 && matches!(bytes[0], 0x02 | 0x81 | 0x82) {
            continue;
        }
        r.send(CanFrame::new(id, &bytes[..len]).unwrap());
        r.step(Duration::from_micros(200));
    }
    r.nmt(NmtCommand::EnterPreOperational);
    assert_eq!(r.read_u32(0x1000, 0), 0x0002_0192);
}

#[test]
fn fault_injector_between_master_and_drive() {
    use cnc402_drives::bus::{Action, Direction, FaultInjector, FaultRule, FrameFilter};
    let mut r = Rig::operational();
    r.enable();
    // Move the rig's bus into a fault injector: TPDO1 of node 5 dropped on the way back,
    // every RPDO truncated to 5 bytes on the way out.
    let bus = std::mem::replace(&mut r.bus, SimBus::new(0));
    let mut f = FaultInjector::new(bus);
    let drop = f.add_rule(FaultRule::new(
        FrameFilter::id(0x185),
        Direction::Rx,
        Action::Drop,
    ));
    let cut = f.add_rule(
        FaultRule::new(
            FrameFilter::class(0x200),
            Direction::Tx,
            Action::Truncate { len: 5 },
        )
        .limit(1),
    );
    let mut now = r.now;
    let mut got = vec![];
    for _ in 0..3 {
        f.send(&CanFrame::new(0x205, &[0x0F, 0, 0, 0, 0, 0]).unwrap())
            .unwrap();
        f.send(&SyncRepr { counter: None }.emit()).unwrap();
        now += Duration::from_millis(1);
        f.inner_mut().advance(now);
        while let Some(fr) = f.recv().unwrap() {
            got.push(fr);
        }
    }
    assert!(got.iter().all(|fr| fr.id() != 0x185), "TPDOs dropped");
    assert_eq!(f.applied(drop), 3);
    assert_eq!(f.applied(cut), 1);
    let emcy: Vec<u16> = got
        .iter()
        .filter(|fr| fr.id() == 0x085)
        .map(|fr| EmcyRepr::parse(fr).unwrap().code)
        .collect();
    assert_eq!(emcy, vec![0x8210], "the truncated RPDO is reported");
    assert!(f.inner().device(0).unwrap().stats().tpdos_sent >= 3);
}

#[test]
fn injected_reboot_announces_itself_and_forgets_its_configuration() {
    let mut r = Rig::operational();
    let p0 = r.enable();
    r.write(0x1017, 0, &10u16.to_le_bytes()).unwrap();
    r.cycle(0x0F, p0 + 100);
    r.take(0x705);
    r.inject(FaultKind::Reboot);
    r.run(Duration::from_millis(2));
    let boot_up = r.take(0x705);
    assert_eq!(boot_up.first().map(|f| f.data().to_vec()), Some(vec![0]));
    assert_eq!(r.drive().nmt(), NmtStatus::PreOperational);
    assert_eq!(r.drive().state(), cia402::State::SwitchOnDisabled);
    // The producer heartbeat time is back at its default and no PDO flows.
    assert_eq!(r.read(0x1017, 0).unwrap(), vec![0, 0]);
    assert!(r.cycle(0x0F, p0 + 200).is_none());
    assert_eq!(r.drive().position_actual(), p0 + 100, "the motor stays put");
}

#[test]
fn emcy_storm_sends_one_emcy_per_sync_and_the_drive_keeps_following() {
    let mut r = Rig::operational();
    let p0 = r.enable();
    r.take(0x85);
    r.inject(FaultKind::EmcyStorm(0x5530));
    for k in 1..=5 {
        assert!(r.cycle(0x0F, p0 + k * 10).is_some());
    }
    let emcys = r.take(0x85);
    assert_eq!(emcys.len(), 5);
    assert!(
        emcys
            .iter()
            .all(|f| EmcyRepr::parse(f).is_ok_and(|e| e.code == 0x5530))
    );
    assert_eq!(r.drive().state(), cia402::State::OperationEnabled);
    assert_eq!(r.drive().position_actual(), p0 + 50);
}

#[test]
fn a_drive_deaf_to_sync_applies_no_rpdo_and_sends_no_tpdo() {
    let mut r = Rig::operational();
    let p0 = r.enable();
    r.inject(FaultKind::StopSync);
    assert!(r.cycle(0x0F, p0 + 100).is_none());
    assert_eq!(r.drive().position_actual(), p0);
    assert_eq!(r.drive().state(), cia402::State::OperationEnabled);
    // SDO still answers; clearing the injection brings SYNC back.
    assert_eq!(r.read_u32(0x1000, 0), 0x0002_0192);
    r.drive_mut().clear_injected();
    assert!(r.cycle(0x0F, p0 + 100).is_some());
}

#[test]
fn injected_device_type_survives_a_reset() {
    let mut r = Rig::booted();
    r.inject(FaultKind::DeviceType(0x0001_0191));
    assert_eq!(r.read_u32(0x1000, 0), 0x0001_0191);
    r.nmt(NmtCommand::ResetNode);
    assert_eq!(r.read_u32(0x1000, 0), 0x0001_0191);
}

#[test]
fn injected_identity_survives_a_reset_and_keeps_what_it_does_not_name() {
    let mut r = Rig::booted();
    r.inject(FaultKind::Identity {
        vendor: 0x9A,
        product: 0x0003_0924,
        revision: None,
    });
    r.nmt(NmtCommand::ResetNode);
    assert_eq!(r.read_u32(0x1018, 1), 0x9A);
    assert_eq!(r.read_u32(0x1018, 2), 0x0003_0924);
    assert_eq!(r.read_u32(0x1018, 3), cnc402_drives::sim::REVISION);
}

#[test]
fn new_fault_kinds_parse_and_bad_ones_are_refused() {
    for (s, k) in [
        ("reboot", FaultKind::Reboot),
        ("emcy-storm", FaultKind::EmcyStorm(0x1000)),
        ("emcy-storm:0x5530", FaultKind::EmcyStorm(0x5530)),
        ("stop-sync", FaultKind::StopSync),
        ("device-type:0x20191", FaultKind::DeviceType(0x20191)),
        ("device-type:4294967295", FaultKind::DeviceType(u32::MAX)),
        (
            "identity:0x9a:0x30924",
            FaultKind::Identity {
                vendor: 0x9a,
                product: 0x30924,
                revision: None,
            },
        ),
        (
            "identity:1:2:0x20000",
            FaultKind::Identity {
                vendor: 1,
                product: 2,
                revision: Some(0x20000),
            },
        ),
    ] {
        assert_eq!(s.parse::<FaultKind>(), Ok(k), "{s}");
    }
    for s in [
        "device-type",
        "fault:0x10000",
        "emcy-storm:x",
        "reboot:1",
        "stop-sync:0",
        "device-type:0x100000000",
        "identity",
        "identity:1",
        "identity:1:0x100000000",
        "identity:1:2:3:4",
    ] {
        assert!(s.parse::<FaultKind>().is_err(), "{s}");
    }
}
