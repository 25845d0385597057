//! Machine outputs on the drives' 0x60FE (issue 17) and the E-stop's stop category, against
//! simulated drives: boot writes the mask and the clamp and maps RPDO3, a change goes out in
//! RPDO3 and reads back from the drive; an open E-stop disables at once (category 0),
//! quick-stops and disables (1) or quick-stops and stays powered (2).

mod master_common;

use cia402::State;
use cia402::objects as obj;
use cnc402_config::{MachineConfig, MachineOutputs, OutputBit, StopCategory};
use cnc402_drives::master::{Output, StopReason};
use cnc402_drives::sim::FaultKind;
use master_common::Rig;

const Y: usize = 1;
const Z: usize = 2;

fn with_outputs() -> MachineConfig {
    let mut c = MachineConfig::default_machine();
    c.machine.outputs = MachineOutputs {
        coolant_flood: Some(OutputBit { axis: Z, bit: 16 }),
        coolant_mist: Some(OutputBit { axis: Z, bit: 17 }),
        spindle_enable: Some(OutputBit { axis: Y, bit: 20 }),
        tool_clamp: Some(OutputBit { axis: Z, bit: 31 }),
    };
    c
}

fn outputs_of(rig: &Rig, axis: usize) -> (u64, u64) {
    let od = rig.drive(axis).od();
    (
        od.get_u64(obj::DIGITAL_OUTPUTS, 1).unwrap(),
        od.get_u64(obj::DIGITAL_OUTPUTS, 2).unwrap(),
    )
}

/// Cycles holding position until the outputs are sent (at most 100 cycles), and 2 more
/// for the frames to arrive.
fn settle(rig: &mut Rig) {
    let hold = rig.master.positions();
    for _ in 0..100 {
        rig.cycle(&hold[..rig.axes()]).unwrap();
        if rig.master.outputs_settled() {
            for _ in 0..2 {
                rig.cycle(&hold[..rig.axes()]).unwrap();
            }
            return;
        }
    }
    panic!("outputs not sent in 100 cycles");
}

#[test]
fn outputs_are_masked_at_boot_and_switched_by_rpdo3() {
    let mut rig = Rig::booted_for(with_outputs());
    // Boot: Z's mask has its three bits, the clamp is on; Y has the spindle enable, off.
    assert_eq!(outputs_of(&rig, Z), (1 << 31, 1 << 16 | 1 << 17 | 1 << 31));
    assert_eq!(outputs_of(&rig, Y), (0, 1 << 20));
    assert_eq!(rig.master.output(Output::ToolClamp), Some(true));

    assert!(rig.master.set_output(Output::CoolantFlood, true));
    assert!(rig.master.set_output(Output::SpindleEnable, true));
    assert!(!rig.master.outputs_settled());
    settle(&mut rig);
    assert_eq!(outputs_of(&rig, Z).0, 1 << 16 | 1 << 31);
    assert_eq!(outputs_of(&rig, Y).0, 1 << 20);
    assert_eq!(rig.master.output(Output::CoolantFlood), Some(true));

    rig.master.set_output(Output::CoolantFlood, false);
    rig.master.set_output(Output::ToolClamp, false);
    rig.master.set_output(Output::CoolantMist, true);
    settle(&mut rig);
    assert_eq!(outputs_of(&rig, Z).0, 1 << 17);

    // After the run: all off but the clamp's last state (released here), by blocking SDO.
    rig.master.outputs_to_rest(&mut rig.bus).unwrap();
    assert_eq!(outputs_of(&rig, Z).0, 0);
    assert_eq!(outputs_of(&rig, Y).0, 0);
}

#[test]
fn an_output_the_config_does_not_name_is_refused_and_nothing_is_written() {
    let mut rig = Rig::booted();
    assert!(!rig.master.set_output(Output::CoolantFlood, true));
    assert_eq!(rig.master.output(Output::CoolantFlood), None);
    assert!(rig.master.outputs_settled());
    assert_eq!(outputs_of(&rig, Z), (0, 0));
}

fn estop_rig(category: StopCategory) -> Rig {
    let mut c = MachineConfig::default_machine();
    c.machine.estop_input = Some((Z, 16));
    c.machine.estop_category = category;
    c.axes[Z].inputs_pdo = true;
    c.axes[Z].sim.machine.inputs = 1 << 16;
    Rig::booted_for(c)
}

/// Opens the E-stop and returns every drive's state 200 cycles later (the stop seen).
fn open_estop(rig: &mut Rig) -> Vec<State> {
    let hold = rig.master.positions();
    for _ in 0..20 {
        rig.cycle(&hold[..rig.axes()]).unwrap();
    }
    rig.inject(Z, FaultKind::Inputs(0));
    let stop = (0..50)
        .find_map(|_| rig.cycle(&hold[..rig.axes()]).err())
        .expect("the E-stop stops the machine");
    assert_eq!(stop.reason, StopReason::EstopOpen { bit: 16 });
    for _ in 0..200 {
        let _ = rig.cycle(&hold[..rig.axes()]);
    }
    (0..rig.axes()).map(|i| rig.drive(i).state()).collect()
}

#[test]
fn estop_category_0_disables_voltage_at_once() {
    let mut rig = estop_rig(StopCategory::Zero);
    let states = open_estop(&mut rig);
    assert!(
        states.iter().all(|s| *s == State::SwitchOnDisabled),
        "{states:?}"
    );
    assert!(rig.master.is_disabled());
}

#[test]
fn estop_category_1_quick_stops_then_disables() {
    let mut rig = estop_rig(StopCategory::One);
    assert_eq!(
        rig.drive(Y).od().get_i64(obj::QUICK_STOP_OPTION, 0),
        Some(2)
    );
    let states = open_estop(&mut rig);
    assert!(
        states.iter().all(|s| *s == State::SwitchOnDisabled),
        "{states:?}"
    );
}

#[test]
fn estop_category_2_quick_stops_and_the_drives_stay_powered() {
    let mut rig = estop_rig(StopCategory::Two);
    assert_eq!(
        rig.drive(Y).od().get_i64(obj::QUICK_STOP_OPTION, 0),
        Some(6)
    );
    let states = open_estop(&mut rig);
    assert!(
        states.iter().all(|s| *s == State::QuickStopActive),
        "{states:?}"
    );
}
