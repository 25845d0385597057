#!/usr/bin/env bash
# Peck tap (examples/peck-tap.nc): as the rigid tap, with the tap split into pecks (several
# Z+C windows per program line in simdrive, one entry per line in cnc402's report); the same
# actual-position bounds (simdrive ≤ 1 µm; cnc402 within what this run's longest stall
# allows, see 10-rigid-tap.sh and act_coupling_bound_um in common.bash).
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" examples/peck-tap.nc
expect_rc "cnc402 run" "$RUN_RC" 0
expect_rc simdrive "$DRIVE_RC" 0
# cnc402's actual-level bound from this run's stalls (common.bash): the tap feeds Z at
# 12.5 mm/s (pitch 1.25 mm (G95 F1.25) x S600 = 750 mm/min).
act_bound=$(act_coupling_bound_um 12.5)
scenario_check 'ok == true' 'tap_windows == 24' 'spindle_windows == 0' \
    'checks.*.pass == true' 'checks.?name~(actual).value_um <= 1' \
    'protocol_errors.unexpected_frames == 0' 'protocol_errors.unaddressed_frames == 0' 'protocol_errors.pdo_length_errors == 0' \
    'drives.*.faults_entered == 0' \
    -- 'ok == true' 'tapping.# == 2' 'tapping.*.pitch_mm > 1.2499' 'tapping.*.pitch_mm < 1.2501' \
    'tapping.*.max_coupling_error_um_cmd <= @coupling_bound_um' \
    "tapping.*.max_coupling_error_um_act <= ${act_bound:-0}"
scenario_end "taps {tap_windows}, coupling setpoints max {max:checks.?name~(setpoints).value_um:.4} um (limit {min:checks.?name~(setpoints).limit_um:.4}), actual max {max:checks.?name~(actual).value_um:.1} um; $COMMON_FIGURES_DRIVE" \
    "coupling setpoints max {max:tapping.*.max_coupling_error_um_cmd:.4} um (bound {coupling_bound_um:.4}), actual {tapping.*.max_coupling_error_um_act:.1} um (bound ${act_bound:-?}); $COMMON_FIGURES_RUN"
