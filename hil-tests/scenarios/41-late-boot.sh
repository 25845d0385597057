#!/usr/bin/env bash
# A drive that boots late: node 2 (Y) sends its boot-up 3 s after power-on, the others at once.
# cnc402 run must wait for it (within its boot time-out), configure and enable all four and run
# the program to the end.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" "$SC_DIR/programs/short-moves.nc" --boot-delay 2:3
expect_rc "cnc402 run" "$RUN_RC" 0
expect_rc simdrive "$DRIVE_RC" 0
scenario_check 'ok == true' 'drives.2.boot_ups >= 1' 'drives.*.reached_operation_enabled == true' \
    -- 'ok == true'
scenario_end "Y boot-ups {drives.2.boot_ups}; $COMMON_FIGURES_DRIVE" "$COMMON_FIGURES_RUN"
