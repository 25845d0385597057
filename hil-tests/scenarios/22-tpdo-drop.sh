#!/usr/bin/env bash
# TPDO drop: node 1 (X) stops sending its TPDOs 1.5 s after the first SYNC. cnc402 run must
# stop with "feedback PDO missing" for node 1 after tpdo_timeout_cycles (2000 in the HIL config)
# and exit 1 with the program line.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" examples/bolt-circle-drilling.nc --fault 1:tpdo@1.5
expect_rc "cnc402 run" "$RUN_RC" 1
scenario_check 'faults.0.applied_at_s >= 1.5' 'drives.1.tpdos_dropped >= 2000' \
    'drives.1.faults_entered == 0' 'protocol_errors.unexpected_frames == 0' 'protocol_errors.unaddressed_frames == 0' \
    -- 'ok == false' 'stop.node == 1' 'stop.axis == X' 'stop.cause ~ PDO missing' \
    'stop.statusword ~ 0x' 'stop.location ~ bolt-circle-drilling.nc:'
scenario_end "dropped from {faults.0.applied_at_s:.3} s: {drives.1.tpdos_dropped} TPDOs; $COMMON_FIGURES_DRIVE" \
    "stop: {stop.cause}, node {stop.node}, statusword {stop.statusword}, at {stop.location}"
