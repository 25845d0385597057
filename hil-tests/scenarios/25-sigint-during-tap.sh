#!/usr/bin/env bash
# SIGINT (Ctrl-C) during the rigid tap: cnc402 run stops the machine the same way as a fault
# (cause "operator stop"), writes its report and exits non-zero without a drive fault; Z and C
# stay coupled at setpoint level through the stop (every simdrive episode within one count).
source "$HIL_REPO/hil-tests/scenarios/common.bash"
SIGINT_AFTER=4.5
scenario_run "$SC_DIR/machine-vcan.toml" examples/m10x1.5-rigid-tap.nc
[[ $RUN_RC != 0 && $RUN_RC != 124 ]] || sc_fail "cnc402 run exited $RUN_RC after SIGINT (expected a stop: non-zero)"
scenario_check 'tap_windows >= 1' 'checks.?name~(setpoints).pass == true' \
    'drives.*.faults_entered == 0' 'protocol_errors.unexpected_frames == 0' \
    -- 'ok == false' 'stop.cause ~ operator' 'stop.location ~ m10x1.5-rigid-tap.nc:'
scenario_end "exit ${RUN_RC}, Z+C episodes {tap_windows}, coupling setpoints {checks.?name~(setpoints).value_um:.4} um, actual {checks.?name~(actual).value_um:.1} um" \
    "stop: {stop.cause} at {stop.location}"
