//! `bus.pdo_layout = "compact"` end to end on the embedded simulated machine: a rigid tap runs
//! coupled within one count with the bus at ≤ 85 %, and a drive fault mid-tap still stops the
//! run naming the node and the EMCY (the statusword now arrives in an event-driven TPDO2).

use std::time::Duration;

use cnc402_config::MachineConfig;
use cnc402_config::busload::PdoLayout;
use cnc402_drives::sim::FaultKind;
use cnc402_lang::SourceFile;
use cnc402_runtime::link::StopCause;
use cnc402_runtime::{RunOptions, RunReport, SimFault, SimFaultPlan, run_program};

/// The G84 is line 5 (R3, Z-16, pitch 1.5 mm at S500: F750).
const TAP: &str = "%\nG21 G90 G17 G94 G54\nG0 X10. Y10. Z10.\nM29 S500\nG98 G84 X10. Y10. Z-16. R3. F750.\nG80\nG0 Z20.\nM30\n%\n";

fn compact() -> MachineConfig {
    let mut cfg = MachineConfig::default_machine();
    cfg.bus.pdo_layout = PdoLayout::Compact;
    cfg
}

fn run(cfg: &MachineConfig, faults: &[SimFaultPlan]) -> RunReport {
    let src = SourceFile::new("t.nc", TAP);
    let ast = cnc402_lang::parse(&src).unwrap();
    let opts = RunOptions {
        sim_faults: faults.to_vec(),
        ..RunOptions::default()
    };
    run_program(cfg, src, ast, opts, &mut |_| {}).unwrap_or_else(|e| panic!("{e:?}"))
}

#[test]
fn compact_rigid_tap_stays_coupled_within_one_count_at_most_85_percent_load() {
    let r = run(&compact(), &[]);
    assert!(r.ok, "{:?}", r.error);
    assert_eq!(r.tapping.len(), 1);
    let t = &r.tapping[0];
    assert!(
        t.max_coupling_error_um_cmd <= r.coupling_bound_um,
        "{} µm (bound {} µm)",
        t.max_coupling_error_um_cmd,
        r.coupling_bound_um
    );
    println!(
        "compact layout, 4 axes, 1 ms, 1 Mbit/s: measured {:.2} %, planned worst case {:.2} %",
        r.bus_load_percent, r.bus_planned_percent
    );
    assert!(r.bus_load_percent <= 85.0, "{}", r.bus_load_percent);
    assert!((r.bus_planned_percent - 88.69).abs() < 1e-9);
    // The same tap with the standard layout: the same coupling, more bus.
    let s = run(&MachineConfig::default_machine(), &[]);
    assert!(s.ok && s.bus_load_percent > r.bus_load_percent + 10.0);
}

#[test]
fn compact_drive_fault_mid_tap_stops_naming_node_and_emcy() {
    let fault = SimFaultPlan {
        at: Some(Duration::from_millis(1500)),
        fault: SimFault::Drive {
            node: 3,
            kind: FaultKind::Fault(0x8611),
        },
    };
    let r = run(&compact(), &[fault]);
    assert!(!r.ok);
    let stop = r.stop.as_ref().unwrap_or_else(|| panic!("{:?}", r.error));
    assert!(
        matches!(
            stop.stop.cause,
            StopCause::DriveFault | StopCause::Emergency
        ),
        "{stop:?}"
    );
    assert_eq!(stop.stop.node, 3, "{stop:?}");
    assert_eq!(stop.location, "t.nc:5");
    let msg = r.error.as_deref().unwrap();
    for part in ["on node 3", "0x8611", "t.nc:5"] {
        assert!(msg.contains(part), "{msg} lacks {part}");
    }
}
