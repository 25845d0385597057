#!/usr/bin/env bash
# SDO silence during boot: node 2 (Y) answers no SDO request from power-on (its boot-up and
# heartbeat go on). cnc402 run must refuse start-up after bus.sdo_timeout_ms (1000 ms in the HIL
# config) on the first object it reads, exit 1 naming node 2, the object 0x1000:00 and the
# time-out, and send the abort 0x05040000; no drive is enabled.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" "$SC_DIR/programs/short-moves.nc" --fault-clock start \
    --fault 2:sdo@0
expect_rc "cnc402 run" "$RUN_RC" 1
scenario_check 'drives.*.reached_operation_enabled == false' 'drives.2.boot_ups >= 1' \
    -- 'ok == false' 'error ~ start-up failed' 'error ~ node 2' 'error ~ 0x1000:00' \
    'error ~ no response' 'error ~ 0x05040000' 'ticks == 0'
scenario_end "Y boot-ups {drives.2.boot_ups}; $COMMON_FIGURES_DRIVE" "error: {error}"
