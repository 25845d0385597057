#!/usr/bin/env bash
# A wrong device type at start-up: node 2 (Y) reads 0x1000 = 0x00020191 (a CiA 401 I/O module,
# not a CiA 402 drive) from power-on. cnc402 run must refuse start-up before any motion, exit 1
# naming node 2, the object 0x1000 and the value; no drive is enabled and no program line ran.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" "$SC_DIR/programs/short-moves.nc" --fault-clock start \
    --fault 2:device-type:0x20191@0
expect_rc "cnc402 run" "$RUN_RC" 1
scenario_check 'drives.*.reached_operation_enabled == false' \
    -- 'ok == false' 'error ~ start-up failed' 'error ~ node 2' 'error ~ 0x1000' \
    'error ~ 0x00020191' 'ticks == 0'
scenario_end "$COMMON_FIGURES_DRIVE" "error: {error}"
