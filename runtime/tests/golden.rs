//! Golden output: the setpoint stream (INT32 counts on the wire, every 20th tick and the last)
//! of a known program through the whole loop — feeder, planner, interpolator, controller —
//! on the bus-less model machine. A change anywhere in that chain shows up here as a diff to
//! review. Regenerate deliberately with `CNC402_BLESS=1 cargo test -p cnc402-runtime --test
//! golden` and say why in the commit.

mod common;

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use cnc402_config::{MAX_AXES, MachineConfig};
use cnc402_drives::Instant;
use cnc402_runtime::controller::{CycleController, Step};
use cnc402_runtime::ring::{Consumer, move_ring, status_ring};
use cnc402_runtime::testing::ModelLink;
use cnc402_runtime::{Outcome, Status};

const PROGRAM: &str = "%
O9 (GOLDEN: RAPID, RIGID TAP, ARC)
G21 G90 G17 G94 G54
G0 X5. Y5. Z5.
M29 S600
G98 G84 X5. Y5. Z-3. R2. F600.
G80
G2 X15. Y5. I5. J0 F1200.
M30
%
";

fn stream() -> Vec<Status> {
    let cfg = MachineConfig::default_machine();
    let start = [0.0; MAX_AXES];
    let link = ModelLink::new(&cfg, start, 1);
    let mut feeder = common::feeder(&cfg, "golden.nc", PROGRAM, &start);
    let (mut mp, mc) = move_ring(64);
    let (sp, mut sc) = status_ring(256);
    let mut ctrl =
        CycleController::new(&cfg, start, link, mc, sp, Arc::new(AtomicBool::new(false)));
    let period = Duration::from_micros(cfg.bus.period_us as u64);
    let mut now = Instant::ZERO;
    let mut out = Vec::new();
    loop {
        feeder.fill(&mut mp).unwrap();
        now += period;
        let step = ctrl.step(now);
        while let Some(s) = sc.try_pop() {
            out.push(s);
        }
        match step {
            Step::Continue => {}
            Step::Done(o) => {
                assert_eq!(o, Outcome::Finished);
                return out;
            }
        }
    }
}

#[test]
fn setpoint_stream_of_a_known_program() {
    let st = stream();
    let mut text = String::from("tick,line,X,Y,Z,C\n");
    for (k, s) in st.iter().enumerate() {
        if k % 20 == 0 || k + 1 == st.len() {
            let c = &s.cmd_counts;
            text.push_str(&format!(
                "{},{},{},{},{},{}\n",
                s.tick, s.line, c[0], c[1], c[2], c[3]
            ));
        }
    }
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden/setpoints.csv");
    if std::env::var_os("CNC402_BLESS").is_some() {
        std::fs::write(path, &text).unwrap();
    }
    let want = std::fs::read_to_string(path).expect("fixture (CNC402_BLESS=1 writes it)");
    if want != text {
        let first = want
            .lines()
            .zip(text.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(want.lines().count().min(text.lines().count()));
        panic!(
            "setpoint stream differs from the fixture at row {first}: want {:?}, got {:?} ({} vs {} rows)",
            want.lines().nth(first),
            text.lines().nth(first),
            want.lines().count(),
            text.lines().count()
        );
    }
}
