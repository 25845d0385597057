#!/usr/bin/env bash
# A stop during a rigid tap keeps Z and C coupled: node 1 (X, not part of the tap) faults with
# EMCY 0x5530 while the first hole of the M10x1.5 program is being tapped. cnc402 run stops
# (exit 1, node 1) and every window of Z+C setpoints that simdrive decoded, the deceleration
# included, stays within one count.
# The fault runs on simdrive's tap clock (--fault-clock tap): 1 s after the first SYNC on
# which Z and C move together, i.e. 1 s into the first hole's tap (its in-stroke lasts ~1.7 s
# of program time), whatever the pace of the program against the wall clock. That the stop
# landed in the tap is checked, not assumed: Z stopped below the R plane Z3, where only the
# tap takes it (G98 returns to Z10 between holes).
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" examples/m10x1.5-rigid-tap.nc --fault-clock tap \
    --fault 1:fault:0x5530@1
expect_rc "cnc402 run" "$RUN_RC" 1
scenario_check 'tap_windows >= 1' 'checks.?name~(setpoints).pass == true' \
    'drives.1.last_fault_code == 0x5530' 'drives.3.position < 3' \
    -- 'ok == false' 'stop.node == 1' 'stop.emcy == 0x5530' 'stop.location ~ m10x1.5-rigid-tap.nc:' \
    'axes.Z.final_position < 3'
scenario_end "fault at {faults.0.applied_at_s:.3} s, Z+C windows {tap_windows}, coupling setpoints {checks.?name~(setpoints).value_um:.4} um, actual {checks.?name~(actual).value_um:.1} um, Z at {drives.3.position:.3} mm" \
    "stop: {stop.cause}, node {stop.node}, EMCY {stop.emcy}, at {stop.location}; program {program_time_s:.2} s in {wall_time_s:.2} s"
