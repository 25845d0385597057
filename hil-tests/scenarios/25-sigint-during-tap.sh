#!/usr/bin/env bash
# SIGINT (Ctrl-C) during the rigid tap: cnc402 run stops the machine the same way as a fault
# (cause "operator stop"), writes its report and exits non-zero without a drive fault; Z and C
# stay coupled at setpoint level through the stop (every simdrive episode within one count).
# The signal goes when cnc402's trace shows the first hole's tap under way (C turned, Z below
# the R plane Z3), not after a fixed time: boot, enable and the loop's pace in the emulated
# guest vary by seconds, and the tap of a hole lasts ~3.3 s of program time (down and out).
# That the stop landed in the tap is checked, not assumed: Z stopped below R, where only the
# tap takes it (G98 returns to Z10 between holes).
source "$HIL_REPO/hil-tests/scenarios/common.bash"
# shellcheck disable=SC2016 # awk code
SIGINT_WHEN='$c["C_cmd"] > 1 && $c["Z_cmd"] < 2.9'
scenario_run "$SC_DIR/machine-vcan.toml" examples/m10x1.5-rigid-tap.nc
[[ $RUN_RC != 0 && $RUN_RC != 124 ]] || sc_fail "cnc402 run exited $RUN_RC after SIGINT (expected a stop: non-zero)"
scenario_check 'tap_windows >= 1' 'checks.?name~(setpoints).pass == true' \
    'drives.*.faults_entered == 0' 'protocol_errors.unexpected_frames == 0' \
    'drives.3.position < 3' \
    -- 'ok == false' 'stop.cause ~ operator' 'stop.location ~ m10x1.5-rigid-tap.nc:' \
    'axes.Z.final_position < 3'
scenario_end "exit ${RUN_RC}, Z+C episodes {tap_windows}, coupling setpoints {checks.?name~(setpoints).value_um:.4} um, actual {checks.?name~(actual).value_um:.1} um, Z at {drives.3.position:.3} mm" \
    "SIGINT when the trace was at ${SIGINT_AT_S:-?} s; stop: {stop.cause} at {stop.location}"
