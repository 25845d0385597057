#!/usr/bin/env bash
# M10x1.5 rigid taps at 800 and 2000 rpm (programs/tap-800-2000.nc, two holes each) with the
# spindle's simulated drive slower than Z's (machine-vcan-mismatched.toml: spindle 2 cycles /
# 40 Hz, Z 1 cycle / 150 Hz; the master's `dynamics` state the same): the run ends ok, and
# simdrive's own checker (--actual-limit-um 5), on the simulated drives' positions at each
# SYNC, finds Z and C coupled within 5 µm at actual-position level in every tap episode
# (without matching the lag difference gives 77 µm at 800 and 192 µm at 2000 rpm). The
# setpoints are shaped apart on purpose (each for its own drive): simdrive reports their
# episodes, it does not judge them; cnc402 still checks its path's setpoints (pitch and
# coupling bound). No protocol errors, no drive fault.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan-mismatched.toml" "$SC_DIR/programs/tap-800-2000.nc" \
    --actual-limit-um 5
expect_rc "cnc402 run" "$RUN_RC" 0
expect_rc simdrive "$DRIVE_RC" 0
scenario_check 'ok == true' 'tap_windows == 8' 'spindle_windows == 0' \
    'checks.*.pass == true' 'checks.?name~(actual).value_um <= 5' 'checks.?name~(actual).limit_um == 5' \
    'protocol_errors.unexpected_frames == 0' 'protocol_errors.unaddressed_frames == 0' 'protocol_errors.pdo_length_errors == 0' \
    'drives.*.reached_operation_enabled == true' 'drives.*.faults_entered == 0' \
    -- 'ok == true' 'tapping.# == 4' 'tapping.*.pitch_mm > 1.4999' 'tapping.*.pitch_mm < 1.5001' \
    'tapping.*.max_coupling_error_um_cmd <= @coupling_bound_um'
scenario_end "taps {tap_windows}, actual coupling max {max:checks.?name~(actual).value_um:.2} um (limit 5), setpoints max {max:checks.?name~(setpoints).value_um:.4} um; $COMMON_FIGURES_DRIVE" \
    "actual coupling per tap {tapping.*.max_coupling_error_um_act:.2} um (feedback paired by SYNC, informational); $COMMON_FIGURES_RUN"
