#!/usr/bin/env bash
# Following error beyond the window: machine-vcan-tight-fe.toml gives X a 0.01 mm window
# (machine.toml: 0.5 mm), which the first rapid of the bolt circle exceeds. cnc402 run must stop
# naming node 1 and exit 1. The master writes the same window to the drive (0x6065), so either
# the master's monitor (from 0x6064 feedback) or the drive's own (FAULT + EMCY 0x8611) may trip
# first: both are accepted, and which one did is reported.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan-tight-fe.toml" examples/bolt-circle-drilling.nc
expect_rc "cnc402 run" "$RUN_RC" 1
scenario_check 'protocol_errors.unexpected_frames == 0' 'protocol_errors.unaddressed_frames == 0' \
    -- 'ok == false' 'stop.node == 1' 'stop.axis == X' \
    'stop.cause ~ following error || stop.emcy == 0x8611' \
    'stop.statusword ~ 0x' 'stop.location ~ bolt-circle-drilling.nc:'
scenario_end "X max following error {drives.1.max_following_error:.4} mm, faults {drives.1.faults_entered}; $COMMON_FIGURES_DRIVE" \
    "stop: {stop.cause}, node {stop.node}, statusword {stop.statusword}, EMCY {stop.emcy}, at {stop.location}"
