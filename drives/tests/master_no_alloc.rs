//! The master's per-cycle path (`Master::cycle`: taking in TPDOs/EMCY/heartbeats/SDO
//! responses, the monitors, RPDOs + SYNC, an in-cycle SDO transfer, a machine output's RPDO3, the tripping cycle of a
//! safety stop and the stop reaction) allocates nothing: a counting global allocator counts
//! allocations made on this thread while `cycle` runs.

mod master_common;

use cnc402_drives::sim::FaultKind;
use master_common::Rig;

use cnc402_testkit::{CountingAlloc, count_allocs};

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

/// Runs one master cycle (the bus advance before it is not counted).
fn counted_cycle(rig: &mut Rig, cmd: &[f64]) -> (u64, bool) {
    rig.bus.advance(rig.next);
    let (r, n) = count_allocs(|| rig.master.cycle(&mut rig.bus, rig.next, cmd));
    rig.next += rig.master.period();
    (n, r.is_err())
}

#[test]
fn the_cycle_allocates_nothing_in_any_phase() {
    // 2 ms so that an SDO transfer fits next to the PDOs.
    let mut config = master_common::machine_at_period_us(2000);
    config.machine.outputs.coolant_flood = Some(cnc402_config::OutputBit { axis: 2, bit: 16 });
    let mut rig = Rig::booted_for(config);
    let start = rig.master.positions();
    let mut allocs = 0;
    let mut cmd = [0.0; 4];
    let mut k = 0u64;
    let mut step = |rig: &mut Rig, k: &mut u64| {
        let t = *k as f64 * 2e-3;
        for i in 0..3 {
            cmd[i] = start[i] + 10.0 * (t * 3.0).sin();
        }
        cmd[3] = start[3] + 1800.0 * t;
        *k += 1;
        counted_cycle(rig, &cmd)
    };
    for _ in 0..500 {
        let (n, stopped) = step(&mut rig, &mut k);
        assert!(!stopped);
        allocs += n;
    }
    // An in-cycle SDO upload (segmented, 17 bytes) and a download.
    let now = rig.next;
    rig.master.start_sdo_upload(3, 0x1008, 0, now).unwrap();
    for _ in 0..20 {
        allocs += step(&mut rig, &mut k).0;
    }
    assert_eq!(rig.master.take_sdo_outcome(3), Some(Ok(())));
    assert_eq!(rig.master.sdo_data(3), b"cnc402 simdrive C");
    // A machine output switched: its RPDO3 goes out from a cycle.
    rig.master
        .set_output(cnc402_drives::master::Output::CoolantFlood, true);
    for _ in 0..20 {
        allocs += step(&mut rig, &mut k).0;
    }
    assert!(rig.master.outputs_settled());
    // A fault: the tripping cycle and the stop reaction.
    rig.inject(1, FaultKind::Fault(0x8611));
    let mut tripped = false;
    for _ in 0..200 {
        let (n, stopped) = step(&mut rig, &mut k);
        allocs += n;
        tripped |= stopped;
    }
    assert!(tripped);
    assert_eq!(allocs, 0, "allocations inside Master::cycle");
}
