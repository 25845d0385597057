//! Set-up shared by the runtime's integration tests: a started link and a program planned
//! by the feeder, ready for a `CycleController` driven tick by tick.

// Each test binary uses its own subset of these helpers.
#![allow(dead_code)]

use cnc402_config::{MAX_AXES, MachineConfig};
use cnc402_drives::Instant;
use cnc402_lang::SourceFile;
use cnc402_runtime::SimLink;
use cnc402_runtime::controller::{AxisTable, start_position};
use cnc402_runtime::feeder::Feeder;
use cnc402_runtime::link::{DriveLink, FaultPlan, Startup};
use cnc402_runtime::ring::{LoopInput, MoveConsumer, MoveProducer, move_ring};

/// The drives' positions once `link` reports ready at time zero (panics otherwise).
pub fn started<L: DriveLink>(link: &mut L) -> [f64; MAX_AXES] {
    match link.startup(Instant::ZERO) {
        Startup::Ready(p) => p,
        other => panic!("startup: {other:?}"),
    }
}

/// The feeder for program `text` (file `name`), planning from the positions `start`.
pub fn feeder(cfg: &MachineConfig, name: &str, text: &str, start: &[f64; MAX_AXES]) -> Feeder {
    let src = SourceFile::new(name, text);
    let ast = cnc402_lang::parse(&src).expect("parse");
    Feeder::new(cfg, src, ast, start_position(&AxisTable::new(cfg), start))
}

/// The whole program planned into a move ring of `capacity` (ending with `End`) before the
/// loop runs, so that the feeder runs outside what a test measures. The producer is handed
/// back too: the ring stays as the loop sees it in a run.
pub fn planned(
    cfg: &MachineConfig,
    name: &str,
    text: &str,
    start: &[f64; MAX_AXES],
    capacity: usize,
) -> (MoveProducer, MoveConsumer) {
    use cnc402_runtime::ring::Producer;
    let mut feeder = feeder(cfg, name, text, start);
    let (mut mp, mc) = move_ring(capacity);
    while let Some(mv) = feeder.next_move().expect("plan") {
        assert!(mp.try_push(LoopInput::Move(mv)).is_ok());
    }
    assert!(mp.try_push(LoopInput::End).is_ok());
    (mp, mc)
}

/// A drive fault injected on `node` at `at_ms` milliseconds, announced with EMCY `emcy`.
pub fn fault(node: u8, at_ms: u64, emcy: u16) -> FaultPlan {
    FaultPlan {
        node,
        at: core::time::Duration::from_millis(at_ms),
        emcy,
    }
}

/// The embedded simulated machine with `fault` planned.
pub fn faulty_sim(cfg: &MachineConfig, fault: FaultPlan) -> SimLink {
    SimLink::simulated(cfg, None)
        .expect("sim link")
        .with_fault(fault)
}

/// Runs `text` (file `t.nc`) on `link` tick by tick from start-up to the end of the cyclic
/// phase; returns the outcome, every status and the link.
pub fn run_on<L: DriveLink>(
    cfg: &MachineConfig,
    link: L,
    text: &str,
) -> (cnc402_runtime::Outcome, Vec<cnc402_runtime::Status>, L) {
    use cnc402_runtime::controller::{CycleController, Step};
    use cnc402_runtime::ring::{Consumer, status_ring};
    use std::sync::Arc;
    use std::sync::atomic::AtomicBool;
    let period = core::time::Duration::from_micros(cfg.bus.period_us as u64);
    let mut link = link;
    let start = started(&mut link);
    let mut feeder = feeder(cfg, "t.nc", text, &start);
    let (mut mp, mc) = move_ring(64);
    let (sp, mut sc) = status_ring(1024);
    let stop = Arc::new(AtomicBool::new(false));
    let mut ctrl = CycleController::new(cfg, start, link, mc, sp, stop);
    let mut out = Vec::new();
    let mut now = Instant::ZERO;
    let outcome = loop {
        feeder.fill(&mut mp).expect("program");
        now += period;
        let step = ctrl.step(now);
        while let Some(s) = sc.try_pop() {
            out.push(s);
        }
        if let Step::Done(o) = step {
            break o;
        }
        assert!(out.len() < 200_000, "runaway");
    };
    (outcome, out, ctrl.into_link())
}
