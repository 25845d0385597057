//! Dynamic matching of a rigid tap on the embedded simulator: a spindle drive slower than Z
//! (40 Hz / 2 cycles against 150 Hz / 1 cycle, the `sim` truth) cuts an M10×1.5 thread with
//! Z and C coupled at their actual positions once the master's models say so, and equal
//! models change nothing.

use cnc402_config::{DriveModel, MachineConfig, SimDynamics};
use cnc402_lang::SourceFile;
use cnc402_runtime::{RunOptions, run_program};

fn tap_program(rpm: u32) -> String {
    format!(
        "%\nG21 G90 G17 G94 G54\nG0 X20. Y20. Z10.\nM29 S{rpm}\n\
         G98 G84 X20. Y20. Z-16. R3. F{}\nX60.\nG80\nG0 Z50.\nM30\n%\n",
        rpm as f64 * 1.5
    )
}

/// Worst actual-position coupling error (µm) and the setpoint one over the run's taps.
fn run_taps(cfg: &MachineConfig, rpm: u32) -> (f64, f64) {
    let text = tap_program(rpm);
    let src = SourceFile::new("tap.nc", text.as_str());
    let ast = cnc402_lang::parse(&src).unwrap();
    let r = run_program(cfg, src, ast, RunOptions::default(), &mut |_| {})
        .unwrap_or_else(|e| panic!("{e:?}"));
    assert!(r.ok, "{:?}", r.error);
    assert_eq!(r.tapping.len(), 2);
    let act = r.tapping.iter().map(|t| t.max_coupling_error_um_act);
    let cmd = r.tapping.iter().map(|t| t.max_coupling_error_um_cmd);
    (act.fold(0.0, f64::max), cmd.fold(0.0, f64::max))
}

fn slow_spindle(model_it: bool) -> MachineConfig {
    let mut cfg = MachineConfig::default_machine();
    let sp = cfg.spindle_index().unwrap();
    let slow = (2, 40.0);
    cfg.axes[sp].sim = SimDynamics {
        delay_cycles: slow.0,
        bandwidth_hz: slow.1,
        ..SimDynamics::default()
    };
    if model_it {
        cfg.axes[sp].dynamics = Some(DriveModel {
            delay_cycles: slow.0,
            bandwidth_hz: slow.1,
        });
    }
    cfg
}

#[test]
fn a_slow_spindle_is_matched_to_within_5_um_at_the_actual_positions() {
    for rpm in [800, 2000] {
        let (unmatched, _) = run_taps(&slow_spindle(false), rpm);
        let (matched, cmd) = run_taps(&slow_spindle(true), rpm);
        eprintln!(
            "{rpm} rpm: actual coupling {unmatched:.3} µm unmatched, {matched:.3} µm matched"
        );
        assert!(
            unmatched > 50.0,
            "{rpm} rpm: the mismatch shows unmatched: {unmatched}"
        );
        assert!(matched <= 5.0, "{rpm} rpm: {matched} µm");
        // The path's setpoints stay coupled to a count.
        assert!(cmd <= 0.1, "{rpm} rpm: setpoints {cmd} µm");
    }
}

#[test]
fn equal_dynamics_couple_to_within_1_um_and_are_not_shaped() {
    let cfg = MachineConfig::default_machine();
    let sp = cfg.spindle_index().unwrap();
    assert_eq!(cfg.axes[sp].dynamics, cfg.axes[2].dynamics);
    for rpm in [800, 2000] {
        let (act, _) = run_taps(&cfg, rpm);
        let mut none = cfg.clone();
        for a in &mut none.axes {
            a.dynamics = None;
        }
        let (act_none, _) = run_taps(&none, rpm);
        assert!(act <= 1.0, "{rpm} rpm: {act} µm");
        assert_eq!(act, act_none, "equal models shape nothing");
    }
}
