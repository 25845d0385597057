mod common;
use std::time::Duration;

use cnc402_config::MachineConfig;
use cnc402_drives::bus::{Action, Direction, FaultRule, FrameFilter};
use cnc402_drives::sim::FaultKind;
use cnc402_runtime::{SimFault, SimFaultPlan, SimLink};

const TAP: &str = "%\nG21 G90 G17 G94 G54\nG0 X10. Y10. Z10.\nM29 S500\nG98 G84 X10. Y10. Z-16. R3. F750.\nG80\nG0 Z20.\nM30\n%\n";

fn at(ms: u64, fault: SimFault) -> SimFaultPlan {
    SimFaultPlan { at: Some(Duration::from_millis(ms)), fault }
}
fn drive(ms: u64, node: u8, kind: FaultKind) -> SimFaultPlan {
    at(ms, SimFault::Drive { node, kind })
}

#[test]
fn explore() {
    let cfg = MachineConfig::default_machine();
    for (name, f) in [
        ("none", vec![]),
        ("reboot z", vec![drive(2000, 3, FaultKind::Reboot)]),
        ("reboot c", vec![drive(2000, 4, FaultKind::Reboot)]),
        ("storm c", vec![drive(2000, 4, FaultKind::EmcyStorm(0x5530))]),
        ("storm z", vec![drive(2000, 3, FaultKind::EmcyStorm(0x5530))]),
        ("stopsync z", vec![drive(2000, 3, FaultKind::StopSync)]),
        ("stopsync c", vec![drive(2000, 4, FaultKind::StopSync)]),
        ("busoff 5ms", vec![at(2000, SimFault::BusOff(Duration::from_millis(5)))]),
        ("busoff 500ms", vec![at(2000, SimFault::BusOff(Duration::from_millis(500)))]),
        ("truncate some", vec![at(2000, SimFault::Frames(FaultRule::new(FrameFilter::class(0x180), Direction::Rx, Action::Truncate{len:3}).every(7).limit(20)))]),
        ("truncate all c", vec![at(2000, SimFault::Frames(FaultRule::new(FrameFilter::id(0x184), Direction::Rx, Action::Truncate{len:3})))]),
    ] {
        let mut link: SimLink = SimLink::simulated(&cfg, None).unwrap();
        for p in f { link = link.with_plan(p); }
        let (o, st, link) = common::run_on(&cfg, link, TAP);
        let d = link.sim_bus().devices();
        let z = d[2].position_actual() as f64 / cfg.axes[2].counts_per_unit;
        let c = d[3].position_actual() as f64 / cfg.axes[3].counts_per_unit;
        let want = 3.0 - c * 1.5 / 360.0;
        let follow = st.iter().any(|s| s.spindle_follow);
        eprintln!("== {name}: {o:?}\n   z {z} c {c} thread {want} err_um {} follow {follow} unexpected {} emcys {}", (z-want)*1000.0, link.master().unexpected_frames(), link.master().emcys_received(3));
    }
}
