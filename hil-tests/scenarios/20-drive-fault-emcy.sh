#!/usr/bin/env bash
# Drive fault + EMCY mid-program: simdrive puts node 3 (Z) into FAULT with EMCY 0x7300 1.5 s
# after the first SYNC of the bolt-circle program. cnc402 run must stop the machine and exit 1
# naming node 3, its statusword (fault bit 3 set), EMCY 0x7300 and the program line.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" examples/bolt-circle-drilling.nc --fault 3:fault:0x7300@1.5
expect_rc "cnc402 run" "$RUN_RC" 1
scenario_check 'faults.0.applied_at_s >= 1.5' 'drives.3.faults_entered == 1' \
    'drives.3.last_fault_code == 0x7300' 'emcys_sent >= 1' \
    'protocol_errors.unexpected_frames == 0' 'protocol_errors.unaddressed_frames == 0' \
    -- 'ok == false' 'stop.node == 3' 'stop.axis == Z' 'stop.emcy == 0x7300' \
    'stop.statusword ~ 0x' 'stop.location ~ bolt-circle-drilling.nc:' \
    'stop.cause ~ drive fault || stop.cause ~ emergency' 'error ~ 7300'
scenario_end "fault at {faults.0.applied_at_s:.3} s, Z state {drives.3.state}; $COMMON_FIGURES_DRIVE" \
    "stop: {stop.cause}, node {stop.node}, statusword {stop.statusword}, EMCY {stop.emcy}, at {stop.location}"
