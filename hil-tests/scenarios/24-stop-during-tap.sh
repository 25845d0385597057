#!/usr/bin/env bash
# A stop during a rigid tap keeps Z and C coupled: node 1 (X, not part of the tap) faults with
# EMCY 0x5530 while the first hole of the M10x1.5 program is being tapped. cnc402 run stops
# (exit 1, node 1) and every window of Z+C setpoints that simdrive decoded, the deceleration
# included, stays within one count.
# simdrive injects faults at a time after the first SYNC (no program event), and the program
# runs slower than the wall clock on a loaded machine (program time = pace x wall time: 0.98
# on a quiet host, 0.5 measured with cargo test alongside). The first hole's tap spans program
# time 0.63-3.9 s (down to Z-16 until ~2.3 s, then out; the first SYNC comes a few cycles
# before program time 0), so a fault 3 s after the first SYNC lands in it for any pace from
# 1 down to 0.21. That the stop landed in the tap is checked, not assumed: Z stopped below
# the R plane Z3, where only the tap takes it (G98 returns to Z10 between holes).
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" examples/m10x1.5-rigid-tap.nc --fault 1:fault:0x5530@3
expect_rc "cnc402 run" "$RUN_RC" 1
scenario_check 'tap_windows >= 1' 'checks.?name~(setpoints).pass == true' \
    'drives.1.last_fault_code == 0x5530' 'drives.3.position < 3' \
    -- 'ok == false' 'stop.node == 1' 'stop.emcy == 0x5530' 'stop.location ~ m10x1.5-rigid-tap.nc:' \
    'axes.Z.final_position < 3'
scenario_end "fault at {faults.0.applied_at_s:.3} s, Z+C windows {tap_windows}, coupling setpoints {checks.?name~(setpoints).value_um:.4} um, actual {checks.?name~(actual).value_um:.1} um, Z at {drives.3.position:.3} mm" \
    "stop: {stop.cause}, node {stop.node}, EMCY {stop.emcy}, at {stop.location}; program {program_time_s:.2} s in {wall_time_s:.2} s"
