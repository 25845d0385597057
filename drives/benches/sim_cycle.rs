//! CPU time of one CSP cycle (RPDO in, SYNC, TPDO out) on one simulated drive, against the
//! same frames through canopen-rs 0.6.1's `Node` (which does PDO bookkeeping only: no state
//! machine, no motion), and one whole cycle of the in-process bus with the shipped 4-axis
//! machine.

use std::hint::black_box;
use std::time::Duration;

use canopen_rs::node::Node;
use canopen_rs::pdo::{MappingEntry as CoEntry, PdoMapping, TransmissionType};
use canopen_rs::{Address, Entry, NodeId as CoNode, ObjectDictionary, Value as CoValue};
use cnc402_config::MachineConfig;
use cnc402_drives::Instant;
use cnc402_drives::bus::{CanBus, CanDevice, SimBus};
use cnc402_drives::sim::{SimDrive, simulated_machine};
use cnc402_drives::wire::{
    CanFrame, ExpeditedData, InitiateKind, NmtCommand, NmtRepr, NmtTarget, NodeId, SdoRequest,
};
use criterion::{Criterion, criterion_group, criterion_main};

fn sdo_write(node: NodeId, index: u16, sub: u8, data: &[u8]) -> CanFrame {
    let kind = InitiateKind::Expedited(ExpeditedData::new(data).unwrap());
    SdoRequest::InitiateDownload { index, sub, kind }.emit(node)
}

fn csp_config(node: NodeId) -> Vec<CanFrame> {
    let id = node.get() as u32;
    let mut v = vec![];
    for (comm, map, cob, e) in [
        (
            0x1400u16,
            0x1600u16,
            0x200 + id,
            [0x6040_0010u32, 0x607A_0020],
        ),
        (0x1800, 0x1A00, 0x180 + id, [0x6041_0010, 0x6064_0020]),
    ] {
        v.push(sdo_write(node, comm, 1, &(0x8000_0000 | cob).to_le_bytes()));
        v.push(sdo_write(node, map, 0, &[0]));
        v.push(sdo_write(node, map, 1, &e[0].to_le_bytes()));
        v.push(sdo_write(node, map, 2, &e[1].to_le_bytes()));
        v.push(sdo_write(node, map, 0, &[2]));
        v.push(sdo_write(node, comm, 2, &[1]));
        v.push(sdo_write(node, comm, 1, &cob.to_le_bytes()));
    }
    v.push(sdo_write(node, 0x6060, 0, &[8]));
    v
}

fn start_all() -> CanFrame {
    NmtRepr {
        command: NmtCommand::Start,
        target: NmtTarget::All,
    }
    .emit()
}

fn rpdo(node: NodeId, cw: u16, target: i32) -> CanFrame {
    let mut d = [0u8; 6];
    d[..2].copy_from_slice(&cw.to_le_bytes());
    d[2..].copy_from_slice(&target.to_le_bytes());
    CanFrame::new(0x200 + node.get() as u16, &d).unwrap()
}

fn bench(c: &mut Criterion) {
    let cfg = MachineConfig::default_machine();
    let node = NodeId::new(1).unwrap();
    let sync = CanFrame::new(0x80, &[]).unwrap();

    // One SimDrive, frames fed directly.
    let mut drive = SimDrive::new(&cfg.axes[0], node, Duration::from_millis(1));
    let mut out: Vec<CanFrame> = Vec::with_capacity(64);
    let mut now = Instant::ZERO;
    drive.poll(now, &mut out);
    now += Duration::from_millis(2);
    drive.poll(now, &mut out);
    for f in csp_config(node) {
        drive.on_frame(&f, now, &mut out);
    }
    drive.on_frame(&start_all(), now, &mut out);
    for cw in [0x06, 0x07, 0x0F] {
        drive.on_frame(&rpdo(node, cw, 0), now, &mut out);
        drive.on_frame(&sync, now, &mut out);
    }
    assert_eq!(drive.state(), cia402::State::OperationEnabled);
    let mut target = 0i32;
    c.bench_function("SimDrive: RPDO + SYNC + TPDO", |b| {
        b.iter(|| {
            target = target.wrapping_add(100);
            now += Duration::from_millis(1);
            out.clear();
            drive.on_frame(&rpdo(node, 0x0F, target), now, &mut out);
            drive.on_frame(&sync, now, &mut out);
            black_box(out.len())
        })
    });

    // The peer: canopen-rs Node with the same PDO layout.
    let mut od = ObjectDictionary::<16>::new();
    for (i, v) in [
        (0x6040u16, CoValue::Unsigned16(0)),
        (0x607A, CoValue::Integer32(0)),
        (0x6041, CoValue::Unsigned16(0x237)),
        (0x6064, CoValue::Integer32(0)),
    ] {
        od.insert(Address::new(i, 0), Entry::rw(v)).unwrap();
    }
    let mut peer = Node::new(CoNode::new(1).unwrap(), od);
    let mut m = PdoMapping::new();
    m.push(CoEntry::new(0x6040, 0, 16)).unwrap();
    m.push(CoEntry::new(0x607A, 0, 32)).unwrap();
    peer.add_rpdo(0x201, m).unwrap();
    let mut m = PdoMapping::new();
    m.push(CoEntry::new(0x6041, 0, 16)).unwrap();
    m.push(CoEntry::new(0x6064, 0, 32)).unwrap();
    peer.add_tpdo(0x181, m, TransmissionType::SynchronousCyclic(1))
        .unwrap();
    peer.boot();
    peer.on_frame(0x000, &[0x01, 0x00]);
    let mut target = 0i32;
    c.bench_function("canopen-rs Node: RPDO + SYNC + TPDO", |b| {
        b.iter(|| {
            target = target.wrapping_add(100);
            let f = rpdo(node, 0x0F, target);
            peer.on_frame(0x201, f.data());
            peer.on_frame(0x080, &[]);
            black_box(peer.sync_tpdos().len())
        })
    });

    // The whole simulated bus, shipped machine (4 drives at 1 Mbit/s), one 1 ms cycle.
    let mut bus: SimBus<SimDrive> = simulated_machine(&cfg);
    let nodes: Vec<NodeId> = bus.devices().iter().map(|d| d.node()).collect();
    let mut t = Instant::ZERO;
    let step = |bus: &mut SimBus<SimDrive>, t: &mut Instant, d: Duration| {
        *t += d;
        bus.advance(*t);
        while bus.recv().unwrap().is_some() {}
    };
    // Power on at t = 0; the drives send boot-up 1 ms later.
    step(&mut bus, &mut t, Duration::ZERO);
    step(&mut bus, &mut t, Duration::from_millis(5));
    for &n in &nodes {
        for f in csp_config(n) {
            bus.send(&f).unwrap();
            step(&mut bus, &mut t, Duration::from_micros(500));
        }
    }
    bus.send(&start_all()).unwrap();
    for cw in [0x06u16, 0x07, 0x0F] {
        for &n in &nodes {
            bus.send(&rpdo(n, cw, 0)).unwrap();
        }
        bus.send(&sync).unwrap();
        step(&mut bus, &mut t, Duration::from_millis(1));
    }
    assert!(
        bus.devices()
            .iter()
            .all(|d| d.state() == cia402::State::OperationEnabled)
    );
    let mut target = 0i32;
    c.bench_function("SimBus, 4 drives: one 1 ms cycle", |b| {
        b.iter(|| {
            target = target.wrapping_add(100);
            for &n in &nodes {
                bus.send(&rpdo(n, 0x0F, target)).unwrap();
            }
            bus.send(&sync).unwrap();
            step(&mut bus, &mut t, Duration::from_millis(1));
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
