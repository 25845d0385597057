#!/usr/bin/env bash
# Long spindle run across the INT32 wrap: M3 S6000 for 25 s with machine-vcan-wrap.toml, whose
# C has 2^20 counts/rev (machine.toml: 131072) so that the position passes 2^31 counts after
# 20.5 s instead of 164 s. The run ends ok, no fault; simdrive saw both the target and the
# actual position wrap and C turned past 2048 revolutions (737280 degrees) without a jump.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan-wrap.toml" "$SC_DIR/programs/spindle-wrap.nc"
expect_rc "cnc402 run" "$RUN_RC" 0
expect_rc simdrive "$DRIVE_RC" 0
scenario_check 'ok == true' 'drives.4.target_wraps >= 1' 'drives.4.position_wraps >= 1' \
    'drives.4.faults_entered == 0' 'drives.4.position > 737280' \
    'protocol_errors.unexpected_frames == 0' 'protocol_errors.unaddressed_frames == 0' \
    -- 'ok == true' 'axes.C.final_position > 737280'
scenario_end "C {drives.4.position:.0} deg, wraps target/actual {drives.4.target_wraps}/{drives.4.position_wraps}, C max following error {drives.4.max_following_error:.2} deg; $COMMON_FIGURES_DRIVE" \
    "C final {axes.C.final_position:.0} deg; $COMMON_FIGURES_RUN"
