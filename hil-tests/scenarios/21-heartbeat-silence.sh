#!/usr/bin/env bash
# Heartbeat silence: node 2 (Y) stops its heartbeat 1.5 s after the first SYNC (PDOs go on).
# cnc402 run must stop with "heartbeat lost" for node 2 after heartbeat_timeout_ms (2000 ms in
# the HIL config) and exit 1 with the program line.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" examples/bolt-circle-drilling.nc --fault 2:heartbeat@1.5
expect_rc "cnc402 run" "$RUN_RC" 1
scenario_check 'faults.0.applied_at_s >= 1.5' 'drives.2.faults_entered == 0' \
    'protocol_errors.unexpected_frames == 0' 'protocol_errors.unaddressed_frames == 0' \
    -- 'ok == false' 'stop.node == 2' 'stop.axis == Y' 'stop.cause ~ heartbeat' \
    'stop.statusword ~ 0x' 'stop.location ~ bolt-circle-drilling.nc:'
scenario_end "silenced at {faults.0.applied_at_s:.3} s, heartbeats sent {drives.2.heartbeats_sent}; $COMMON_FIGURES_DRIVE" \
    "stop: {stop.cause}, node {stop.node}, statusword {stop.statusword}, at {stop.location}, after {wall_time_s:.2} s"
