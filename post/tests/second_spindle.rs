//! The post writes one spindle: a job that selects spindle 2 (`P2`) is refused at that
//! block for every target, and a job on spindle 1 of the two-spindle machine still posts.

// PostError carries lang's large NcError; the tests only unwrap it.
#![allow(clippy::result_large_err)]

use std::path::Path;

use cnc402_config::MachineConfig;
use cnc402_post::Target;

fn two_spindles() -> MachineConfig {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/two-spindles");
    MachineConfig::load(dir.join("machine.toml")).expect("config loads")
}

#[test]
fn a_job_on_spindle_2_is_refused_at_its_block_for_every_target() {
    let cfg = two_spindles();
    let job = "%\nO1\nN10 G21 G90 G94\nN20 M3 S1000\nN30 M4 S1500 P2\nN40 M30\n%\n";
    for target in Target::ALL {
        let e = cnc402_post::post(&cfg, "two.nc", job, target).unwrap_err();
        let text = e.to_string();
        assert!(text.contains("N30"), "{target:?}: {text}");
        assert!(text.contains("spindle 2"), "{target:?}: {text}");
    }
    let one = "%\nO1\nN10 G21 G90 G94\nN20 M3 S1000 P1\nN30 G0 X10.\nN40 M5\nN50 M30\n%\n";
    for target in Target::ALL {
        cnc402_post::post(&cfg, "one.nc", one, target)
            .unwrap_or_else(|e| panic!("{target:?}: {e}"));
    }
}
