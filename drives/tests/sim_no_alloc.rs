//! The in-process simulator runs inside the 1 ms loop, so its steady-state path (SimBus
//! delivery, SimDrive SYNC/RPDO/TPDO handling, heartbeats) must not allocate. A counting
//! global allocator proves it; the same run measures the bus load of 4 CSP axes.

use std::time::Duration;

use cnc402_config::MachineConfig;
use cnc402_drives::Instant;
use cnc402_drives::bus::CanBus;
use cnc402_drives::sim::simulated_machine;
use cnc402_drives::wire::{
    CanFrame, ExpeditedData, InitiateKind, NmtCommand, NmtRepr, NmtTarget, NodeId, SdoRequest,
    SyncRepr,
};

use cnc402_testkit::{CountingAlloc, allocs, arm};

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

fn expedited(node: NodeId, index: u16, sub: u8, data: &[u8]) -> CanFrame {
    let kind = InitiateKind::Expedited(ExpeditedData::new(data).unwrap());
    SdoRequest::InitiateDownload { index, sub, kind }.emit(node)
}

#[test]
fn steady_state_cycles_allocate_nothing_and_load_matches_the_arithmetic() {
    let cfg = MachineConfig::default_machine();
    let mut bus = simulated_machine(&cfg);
    let nodes: Vec<NodeId> = bus.devices().iter().map(|d| d.node()).collect();
    assert_eq!(nodes.len(), 4);
    let mut now = Instant::ZERO;
    let tick = |bus: &mut cnc402_drives::bus::SimBus<_>, now: &mut Instant| {
        *now += Duration::from_micros(100);
        bus.advance(*now);
        while bus.recv().unwrap().is_some() {}
    };
    for _ in 0..50 {
        tick(&mut bus, &mut now);
    }
    // Configure over SDO: CSP PDOs (type 1), mode 8, heartbeat 50 ms.
    for &n in &nodes {
        let id = n.get() as u32;
        let writes: [(u16, u8, Vec<u8>); 15] = [
            (0x1400, 1, (0x8000_0200 + id).to_le_bytes().to_vec()),
            (0x1600, 0, vec![0]),
            (0x1600, 1, 0x6040_0010u32.to_le_bytes().to_vec()),
            (0x1600, 2, 0x607A_0020u32.to_le_bytes().to_vec()),
            (0x1600, 0, vec![2]),
            (0x1400, 2, vec![1]),
            (0x1400, 1, (0x200 + id).to_le_bytes().to_vec()),
            (0x1800, 1, (0x8000_0180 + id).to_le_bytes().to_vec()),
            (0x1A00, 0, vec![0]),
            (0x1A00, 1, 0x6041_0010u32.to_le_bytes().to_vec()),
            (0x1A00, 2, 0x6064_0020u32.to_le_bytes().to_vec()),
            (0x1A00, 0, vec![2]),
            (0x1800, 2, vec![1]),
            (0x1800, 1, (0x180 + id).to_le_bytes().to_vec()),
            (0x6060, 0, vec![8]),
        ];
        for (i, s, d) in writes
            .iter()
            .chain([(0x1017u16, 0u8, 50u16.to_le_bytes().to_vec())].iter())
        {
            bus.send(&expedited(n, *i, *s, d)).unwrap();
            for _ in 0..5 {
                tick(&mut bus, &mut now);
            }
        }
    }
    assert_eq!(
        bus.devices()
            .iter()
            .map(|d| d.stats().sdo_aborts)
            .sum::<u64>(),
        0
    );
    bus.send(
        &NmtRepr {
            command: NmtCommand::Start,
            target: NmtTarget::All,
        }
        .emit(),
    )
    .unwrap();
    tick(&mut bus, &mut now);

    let sync = SyncRepr { counter: None }.emit();
    let mut targets = [0i32; 4];
    let mut cycle = |bus: &mut cnc402_drives::bus::SimBus<_>, now: &mut Instant, k: u32| {
        for (i, &n) in nodes.iter().enumerate() {
            let cw: u16 = match k {
                0 => 0x06,
                1 => 0x07,
                _ => 0x0F,
            };
            if k > 3 {
                targets[i] = targets[i].wrapping_add(100);
            }
            let mut d = [0u8; 6];
            d[..2].copy_from_slice(&cw.to_le_bytes());
            d[2..].copy_from_slice(&targets[i].to_le_bytes());
            bus.send(&CanFrame::new(0x200 + n.get() as u16, &d).unwrap())
                .unwrap();
        }
        bus.send(&sync).unwrap();
        for _ in 0..10 {
            tick(bus, now);
        }
    };
    for k in 0..20 {
        cycle(&mut bus, &mut now, k);
    }
    assert!(
        bus.devices()
            .iter()
            .all(|d| d.state() == cia402::State::OperationEnabled)
    );

    let before = bus.counters();
    let t0 = now;
    let before_allocs = allocs();
    arm(true);
    for k in 20..2020 {
        cycle(&mut bus, &mut now, k);
    }
    arm(false);
    let allocs = allocs() - before_allocs;
    assert_eq!(allocs, 0, "allocations in 2000 steady-state cycles");
    assert!(
        bus.devices()
            .iter()
            .all(|d| d.state() == cia402::State::OperationEnabled)
    );
    // X follows with one cycle of delay and 150 Hz: lag = 100 + 100 (1 - α) / α ≈ 164 counts.
    let lag = targets[0].wrapping_sub(bus.devices()[0].position_actual());
    assert!((160..=168).contains(&lag), "{lag}");

    // Bus load: SYNC + 4 × (RPDO 6 B + TPDO 6 B) = 55 + 4 × 230 = 975 bits per ms, plus
    // 4 heartbeats (65 bits) every 50 ms.
    let after = bus.counters();
    let load = cnc402_drives::bus::BusCounters {
        bus_bits: after.bus_bits - before.bus_bits,
        ..after
    }
    .load_percent(cfg.bus.bitrate, now - t0);
    let expected = (975.0 + 4.0 * 65.0 / 50.0) / 1000.0 * 100.0;
    println!("bus load, 4 CSP axes at 1 Mbit/s and 1 ms: {load:.2} % (arithmetic {expected:.2} %)");
    assert!((load - expected).abs() < 0.3, "{load} vs {expected}");
}
