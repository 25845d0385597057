#!/usr/bin/env bash
# A stop during a rigid tap keeps Z and C coupled: node 1 (X, not part of the tap) faults with
# EMCY 0x5530 1.5 s after the first SYNC, while the first hole of the M10x1.5 program is being
# tapped. cnc402 run stops (exit 1, node 1) and every window of Z+C setpoints that simdrive
# decoded, the deceleration included, stays within one count.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" examples/m10x1.5-rigid-tap.nc --fault 1:fault:0x5530@1.5
expect_rc "cnc402 run" "$RUN_RC" 1
scenario_check 'tap_windows >= 1' 'checks.?name~(setpoints).pass == true' \
    'drives.1.last_fault_code == 0x5530' \
    -- 'ok == false' 'stop.node == 1' 'stop.emcy == 0x5530' 'stop.location ~ m10x1.5-rigid-tap.nc:'
scenario_end "Z+C windows {tap_windows}, coupling setpoints {checks.?name~(setpoints).value_um:.4} um, actual {checks.?name~(actual).value_um:.1} um, Z at {drives.3.position:.3} mm" \
    "stop: {stop.cause}, node {stop.node}, EMCY {stop.emcy}, at {stop.location}"
