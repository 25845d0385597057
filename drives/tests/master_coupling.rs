//! A rigid tap through the master and the simulated drives, watched by the coupling checker:
//! the setpoints hold the pitch within a count; matched drive dynamics keep the actual
//! positions coupled too, and a slower spindle loop shows up as coupling error.

mod master_common;

use cnc402_config::{MachineConfig, SimDynamics};
use cnc402_drives::coupling::{CouplingChecker, CouplingSample};
use master_common::{Rig, smoothstep};

/// M10×1.5, 15 mm deep, 300 ms in and 300 ms out with 20 ms at the bottom; returns the
/// windows the checker found.
fn tap(config: MachineConfig) -> Vec<cnc402_drives::coupling::TapWindow> {
    let pitch = 1.5;
    let depth = 15.0;
    let mut rig = Rig::booted_for(config);
    let start = rig.master.positions();
    let z_cpu = rig.config.axes[2].counts_per_unit;
    let c_cpu = rig.config.axes[3].counts_per_unit;
    let mut checker = CouplingChecker::new(z_cpu, c_cpu);
    for k in 0..800u64 {
        let t = k as f64 * 1e-3;
        let d = if t < 0.3 {
            depth * smoothstep(t / 0.3)
        } else if t < 0.32 {
            depth
        } else {
            depth * (1.0 - smoothstep((t - 0.32) / 0.3))
        };
        let cmd = [
            start[0],
            start[1],
            start[2] - d,
            start[3] + d / pitch * 360.0,
        ];
        let fb = rig.cycle(&cmd).unwrap_or_else(|s| panic!("cycle {k}: {s}"));
        checker.feed(CouplingSample {
            z_cmd: fb.command[2],
            z_act: fb.actual[2],
            c_cmd: fb.command[3],
            c_act: fb.actual[3],
            line: 42,
            // Z and C actuals must answer the same SYNC to be compared.
            actual_stale: !(fb.fresh[2] && fb.fresh[3] && fb.age[2] == fb.age[3]),
        });
    }
    checker.finish();
    checker.windows().to_vec()
}

#[test]
fn tap_through_the_master_is_coupled_at_setpoint_and_actual_level() {
    let w = tap(MachineConfig::default_machine());
    assert_eq!(w.len(), 2, "{w:?}");
    for w in &w {
        assert_eq!(w.line, 42);
        assert!((w.pitch_mm - 1.5).abs() < 1e-6, "{}", w.pitch_mm);
        assert!(
            w.max_error_um_cmd < 0.1,
            "setpoints within a count of Z: {}",
            w.max_error_um_cmd
        );
        // Same dynamics on Z and C: only quantisation and the sampling of the actuals remain.
        assert!(w.max_error_um_act < 1.0, "{}", w.max_error_um_act);
    }
    eprintln!(
        "matched dynamics: coupling error cmd {:.3} µm, act {:.3} µm",
        w[0].max_error_um_cmd.max(w[1].max_error_um_cmd),
        w[0].max_error_um_act.max(w[1].max_error_um_act)
    );
}

#[test]
fn a_slower_spindle_loop_shows_as_coupling_error() {
    let mut config = MachineConfig::default_machine();
    config.axes[3].sim = SimDynamics {
        delay_cycles: 2,
        bandwidth_hz: 60.0,
        ..SimDynamics::default()
    };
    config.axes[3].feedback_delay_cycles = 2;
    let w = tap(config);
    assert_eq!(w.len(), 2);
    let act = w.iter().map(|w| w.max_error_um_act).fold(0.0, f64::max);
    let cmd = w.iter().map(|w| w.max_error_um_cmd).fold(0.0, f64::max);
    assert!(cmd < 0.1, "{cmd}");
    // Peak Z speed 75 mm/s; one extra cycle of delay alone is 75 µm of Z.
    assert!(act > 50.0 && act < 500.0, "{act}");
    eprintln!("C with 2 cycles delay, 60 Hz: coupling error act {act:.1} µm");
}
