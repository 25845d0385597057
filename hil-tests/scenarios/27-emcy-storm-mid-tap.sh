#!/usr/bin/env bash
# An EMCY storm mid-tap: node 4 (C, the spindle) sends EMCY 0x5530 after every SYNC from 1 s
# into the first hole's tap, staying enabled. cnc402 run must stop once, with the first code,
# exit 1 naming node 4, the EMCY and the G84 line (11); the drive keeps following, so the stop
# runs along the path and Z and C stay coupled as in 10-rigid-tap: setpoints within one count
# (simdrive's check), actual positions within 1 µm (simdrive) and within this run's stall
# bound (cnc402's per-line figure). The storm goes on until simdrive ends: the master only
# counts it.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" examples/m10x1.5-rigid-tap.nc --fault-clock tap \
    --fault 4:emcy-storm:0x5530@1
expect_rc "cnc402 run" "$RUN_RC" 1
act_bound=$(act_coupling_bound_um 12.5)
scenario_check 'tap_windows >= 1' 'checks.?name~(setpoints).pass == true' \
    'checks.?name~(actual).value_um <= 1' 'drives.4.emcys_sent >= 10' 'drives.3.position < 3' \
    -- 'ok == false' 'stop.node == 4' 'stop.axis == C' 'stop.emcy == 0x5530' \
    'stop.cause ~ emergency' 'stop.location ~ m10x1.5-rigid-tap.nc:11' 'error ~ EMCY 0x5530' \
    'tapping.*.max_coupling_error_um_cmd <= @coupling_bound_um' \
    "tapping.*.max_coupling_error_um_act <= ${act_bound:-0}"
scenario_end "storm from {faults.0.applied_at_s:.3} s, EMCYs sent {drives.4.emcys_sent}, Z+C windows {tap_windows}, coupling setpoints {max:checks.?name~(setpoints).value_um:.4} um, actual {max:checks.?name~(actual).value_um:.2} um" \
    "stop: {stop.cause}, node {stop.node}, EMCY {stop.emcy}, at {stop.location}; coupling setpoints {max:tapping.*.max_coupling_error_um_cmd:.4} um (bound {coupling_bound_um:.4}), actual {max:tapping.*.max_coupling_error_um_act:.1} um (bound ${act_bound:-?})"
