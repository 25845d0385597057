#!/usr/bin/env bash
# Start-up against a drive in FAULT at power-on: node 1 (X) boots in FAULT with EMCY 0x5530.
# cnc402 run must reset the fault, enable it with the others and run the program to the end.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" "$SC_DIR/programs/short-moves.nc" --start-in-fault 1:0x5530
expect_rc "cnc402 run" "$RUN_RC" 0
expect_rc simdrive "$DRIVE_RC" 0
scenario_check 'ok == true' 'drives.1.faults_entered == 1' 'drives.1.fault_resets >= 1' \
    'drives.1.last_fault_code == 0x5530' 'drives.*.reached_operation_enabled == true' \
    -- 'ok == true'
scenario_end "X states {drives.1.state_history}; $COMMON_FIGURES_DRIVE" "$COMMON_FIGURES_RUN"
