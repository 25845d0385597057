//! CPU time of one `Master::cycle` for the shipped 4-drive machine: on the simulated bus with
//! the drives (compare with `sim_cycle`'s "SimBus, 4 drives: one 1 ms cycle", the same frames
//! sent by hand without a master), and alone on a loopback that replays the drives' TPDOs
//! (the master's own cost: decoding, monitors, encoding).

use std::collections::VecDeque;
use std::hint::black_box;

use cnc402_config::MachineConfig;
use cnc402_drives::bus::{BusCounters, BusError, CanBus, SimBus};
use cnc402_drives::master::Master;
use cnc402_drives::sim::{SimDrive, simulated_machine};
use cnc402_drives::wire::CanFrame;
use criterion::{Criterion, criterion_group, criterion_main};

/// Answers every SYNC with the four TPDOs of drives standing enabled at their targets.
struct Loopback {
    rx: VecDeque<CanFrame>,
    targets: [i32; 4],
    syncs: u64,
}

impl CanBus for Loopback {
    fn send(&mut self, f: &CanFrame) -> Result<(), BusError> {
        match f.id() {
            0x201..=0x204 => {
                let d = f.data();
                self.targets[(f.id() - 0x201) as usize] =
                    i32::from_le_bytes([d[2], d[3], d[4], d[5]]);
            }
            0x080 => {
                self.syncs += 1;
                if self.syncs.is_multiple_of(50) {
                    for n in 1..=4u16 {
                        self.rx
                            .push_back(CanFrame::new(0x700 + n, &[0x05]).unwrap());
                    }
                }
                for (i, t) in self.targets.iter().enumerate() {
                    let mut d = [0u8; 6];
                    d[..2].copy_from_slice(&0x1237u16.to_le_bytes());
                    d[2..].copy_from_slice(&t.to_le_bytes());
                    self.rx
                        .push_back(CanFrame::new(0x181 + i as u16, &d).unwrap());
                }
            }
            _ => {}
        }
        Ok(())
    }
    fn recv(&mut self) -> Result<Option<CanFrame>, BusError> {
        Ok(self.rx.pop_front())
    }
    fn counters(&self) -> BusCounters {
        BusCounters::default()
    }
}

fn bench(c: &mut Criterion) {
    let cfg = MachineConfig::default_machine();
    let mut bus: SimBus<SimDrive> = simulated_machine(&cfg);
    let mut master = Master::new(&cfg).unwrap();
    let report = master.boot(&mut bus).unwrap();
    let period = master.period();
    let mut t = report.enabled_at + period;
    let start = master.positions();
    let mut k = 0u64;
    c.bench_function("Master::cycle + SimBus, 4 drives: one 1 ms cycle", |b| {
        b.iter(|| {
            k += 1;
            let x = (k % 2000) as f64 * 1e-4;
            let cmd = [
                start[0] + x,
                start[1] - x,
                start[2] + x,
                start[3] + k as f64 * 0.36,
            ];
            bus.advance(t);
            let fb = master.cycle(&mut bus, t, &cmd).unwrap();
            t += period;
            black_box(fb.actual[0])
        })
    });

    // The master alone: a second master put in Running by booting against the simulator,
    // then cycled against the loopback.
    let mut bus2: SimBus<SimDrive> = simulated_machine(&cfg);
    let mut alone = Master::new(&cfg).unwrap();
    let r2 = alone.boot(&mut bus2).unwrap();
    let mut lb = Loopback {
        rx: VecDeque::with_capacity(64),
        targets: core::array::from_fn(|i| r2.drives[i].position_counts),
        syncs: 0,
    };
    let mut t2 = bus2.now() + period;
    let start = alone.positions();
    let mut k = 0u64;
    c.bench_function("Master::cycle alone (loopback), 4 drives", |b| {
        b.iter(|| {
            k += 1;
            let cmd = [
                start[0],
                start[1],
                start[2],
                start[3] + (k % 1000) as f64 * 0.01,
            ];
            let fb = alone.cycle(&mut lb, t2, &cmd).unwrap();
            t2 += period;
            black_box(fb.actual[3])
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(2));
    targets = bench
}
criterion_main!(benches);
