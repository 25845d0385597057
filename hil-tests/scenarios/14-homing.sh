#!/usr/bin/env bash
# Homing over vcan0 (issue 17): machine-vcan.toml with [machine] require_homing = true, so
# cnc402 run homes X (method 19, home switch), Y (34, index pulse) and Z (18, positive limit
# switch) on simdrive's simulated machine before the program; the run ends ok, its report says
# each was homed, and Z ends where the program puts it in machine coordinates (Z5 above the
# G54 zero, Z homed to 50).
source "$HIL_REPO/hil-tests/scenarios/common.bash"
cfg="$HIL_OUT/machine-vcan-homing.toml"
# The variant lives in $HIL_OUT: its relative paths are made absolute.
sed -e 's#^\[bus\]#[machine]\nrequire_homing = true\n\n[bus]#' \
    -e "s#\"\\.\\./\\.\\./examples#\"$HIL_REPO/examples#g" "$SC_DIR/machine-vcan.toml" >"$cfg"
grep -q '^require_homing = true' "$cfg" || sc_fail "the homing config was not written"
scenario_run "$cfg" "$SC_DIR/programs/short-moves.nc"
expect_rc "cnc402 run" "$RUN_RC" 0
expect_rc simdrive "$DRIVE_RC" 0
scenario_check 'ok == true' 'drives.*.faults_entered == 0' \
    'drives.*.reached_operation_enabled == true' \
    -- 'ok == true' 'axes.X.homed == true' 'axes.Y.homed == true' 'axes.Z.homed == true' \
    'axes.Z.final_position > 4.999' 'axes.Z.final_position < 5.001'
scenario_end "$COMMON_FIGURES_DRIVE" "program {program_time_s:.1} s; $COMMON_FIGURES_RUN"
