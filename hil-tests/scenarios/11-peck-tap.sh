#!/usr/bin/env bash
# Peck tap (examples/peck-tap.nc): as the rigid tap, with the tap split into pecks (several
# Z+C windows per program line in simdrive, one entry per line in cnc402's report); the same
# actual-position bounds (simdrive ≤ 1 µm, cnc402 ≤ 250 µm).
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" examples/peck-tap.nc
expect_rc "cnc402 run" "$RUN_RC" 0
expect_rc simdrive "$DRIVE_RC" 0
scenario_check 'ok == true' 'tap_windows == 24' 'spindle_windows == 0' \
    'checks.*.pass == true' 'checks.?name~(actual).value_um <= 1' \
    'protocol_errors.unexpected_frames == 0' 'protocol_errors.unaddressed_frames == 0' 'protocol_errors.pdo_length_errors == 0' \
    'drives.*.faults_entered == 0' \
    -- 'ok == true' 'tapping.# == 2' 'tapping.*.pitch_mm > 1.2499' 'tapping.*.pitch_mm < 1.2501' \
    'tapping.*.max_coupling_error_um_cmd <= @coupling_bound_um' \
    'tapping.*.max_coupling_error_um_act <= 250'
scenario_end "taps {tap_windows}, coupling setpoints max {max:checks.?name~(setpoints).value_um:.4} um (limit {min:checks.?name~(setpoints).limit_um:.4}), actual max {max:checks.?name~(actual).value_um:.1} um; $COMMON_FIGURES_DRIVE" \
    "coupling setpoints max {max:tapping.*.max_coupling_error_um_cmd:.4} um (bound {coupling_bound_um:.4}), actual {tapping.*.max_coupling_error_um_act:.1} um; $COMMON_FIGURES_RUN"
