//! The E-stop's stop category end to end on the embedded simulated machine (issue 17): the
//! chain opens in the middle of a feed move; whatever the category, the run stops with
//! `EstopOpen` naming the node and line, the drives come to rest and the run ends (category
//! 0 disables voltage at once, 1 quick-stops and disables, 2 quick-stops and holds; the
//! drive states themselves are checked in drives/tests/master_outputs.rs).

use std::time::Duration;

use cnc402_config::{MachineConfig, StopCategory};
use cnc402_drives::sim::FaultKind;
use cnc402_lang::SourceFile;
use cnc402_runtime::link::StopCause;
use cnc402_runtime::{RunOptions, SimFault, SimFaultPlan, run_program};

const Z: usize = 2;
const PROGRAM: &str = "G1 X20 F1200\nG1 X0\nM30\n";

fn run(category: StopCategory) -> cnc402_runtime::RunReport {
    let mut cfg = MachineConfig::default_machine();
    cfg.machine.estop_input = Some((Z, 16));
    cfg.machine.estop_category = category;
    cfg.axes[Z].inputs_pdo = true;
    cfg.axes[Z].sim.machine.inputs = 1 << 16;
    let src = SourceFile::new("t.nc", PROGRAM);
    let ast = cnc402_lang::parse(&src).unwrap();
    let opts = RunOptions {
        sim_faults: vec![SimFaultPlan {
            at: Some(Duration::from_millis(300)),
            fault: SimFault::Drive {
                node: 3,
                kind: FaultKind::Inputs(0),
            },
        }],
        ..RunOptions::default()
    };
    run_program(&cfg, src, ast, opts, &mut |_| {}).unwrap_or_else(|e| panic!("{e:?}"))
}

#[test]
fn every_estop_category_stops_the_run_naming_node_and_line() {
    for category in [StopCategory::Zero, StopCategory::One, StopCategory::Two] {
        let r = run(category);
        assert!(!r.ok, "{category:?}");
        let stop = r.stop.as_ref().expect("a stop");
        assert_eq!(
            (stop.stop.cause, stop.stop.node),
            (StopCause::EstopOpen, 3),
            "{category:?}"
        );
        assert_eq!(stop.location, "t.nc:1", "{category:?}");
        // X was stopped well before the end of its 20 mm move (at 20 mm/s, 0.3 s in).
        let x = r.axes[0].final_position;
        assert!(x > 3.0 && x < 12.0, "{category:?}: X at {x}");
    }
}
