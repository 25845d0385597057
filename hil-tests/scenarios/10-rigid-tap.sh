#!/usr/bin/env bash
# M10x1.5 rigid tap (examples/m10x1.5-rigid-tap.nc, G84 four holes): the run ends ok; Z and C
# coupled within one count at setpoint level in BOTH reports (cnc402: per program line against
# its coupling bound; simdrive: every window of Z+C motion it decoded from the RPDOs); at
# actual-position level simdrive's figure (the simulated drives' positions at each SYNC,
# measured ≤ 0.09 µm) within 1 µm; cnc402's (feedback off the bus, Z and C paired by SYNC
# cycle: 0.1 µm quiet, 62.5 µm seen on a loaded host = a pairing 5 cycles off at the tap's
# 12.5 mm/s) within the bound this run's longest stall allows (act_coupling_bound_um in
# common.bash: speed x (stall + 2 cycles) + 1 µm); no protocol errors on the bus.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" examples/m10x1.5-rigid-tap.nc
expect_rc "cnc402 run" "$RUN_RC" 0
expect_rc simdrive "$DRIVE_RC" 0
# cnc402's actual-level bound from this run's stalls (common.bash): the tap feeds Z at
# 12.5 mm/s (F750 mm/min = pitch 1.5 mm x S500).
act_bound=$(act_coupling_bound_um 12.5)
scenario_check 'ok == true' 'tap_windows == 8' 'spindle_windows == 0' \
    'checks.*.pass == true' 'checks.?name~(actual).value_um <= 1' \
    'protocol_errors.unexpected_frames == 0' 'protocol_errors.unaddressed_frames == 0' 'protocol_errors.pdo_length_errors == 0' \
    'drives.*.reached_operation_enabled == true' 'drives.*.faults_entered == 0' \
    -- 'ok == true' 'tapping.# == 4' 'tapping.*.pitch_mm > 1.4999' 'tapping.*.pitch_mm < 1.5001' \
    'tapping.*.max_coupling_error_um_cmd <= @coupling_bound_um' \
    "tapping.*.max_coupling_error_um_act <= ${act_bound:-0}"
scenario_end "taps {tap_windows}, coupling setpoints max {max:checks.?name~(setpoints).value_um:.4} um (limit {min:checks.?name~(setpoints).limit_um:.4}), actual max {max:checks.?name~(actual).value_um:.1} um; $COMMON_FIGURES_DRIVE" \
    "coupling setpoints max {max:tapping.*.max_coupling_error_um_cmd:.4} um (bound {coupling_bound_um:.4}), actual {tapping.*.max_coupling_error_um_act:.1} um (bound ${act_bound:-?}); $COMMON_FIGURES_RUN"
