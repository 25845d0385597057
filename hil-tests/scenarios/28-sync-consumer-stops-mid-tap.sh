#!/usr/bin/env bash
# A SYNC consumer that stops mid-tap: node 3 (Z) ignores SYNC from 1 s into the first hole's
# tap (no RPDO applied, no motion step, no TPDO; heartbeat and SDO go on). cnc402 run must stop
# with "feedback PDO missing" on node 3 and exit 1 with the G84 line (11); C then follows Z's
# last actual position, so at rest Z and C are on the thread within the dead-stop bound (62.5
# µm, as 26-drive-reboot-mid-tap). The HIL config waits bus.tpdo_timeout_cycles = 2000 cycles
# (2 s) before it calls a TPDO missing (TPDOs in the emulated guest come up to ~0.5 s late),
# and for those 2 s C goes on turning while Z stands: C's largest following error (its brake
# back onto Z) is reported. With the production limit (5 cycles) the in-process test bounds
# the whole stop (runtime/tests/faults.rs).
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" examples/m10x1.5-rigid-tap.nc --fault-clock tap \
    --fault 3:stop-sync@1
expect_rc "cnc402 run" "$RUN_RC" 1
rest_um=$(tap_rest_error_um 3 1.5)
awk -v e="${rest_um:-1e9}" 'BEGIN { exit !(e <= 62.5) }' ||
    sc_fail "Z and C at rest ${rest_um:-?} um off the thread (bound 62.5 um)"
scenario_check 'drives.3.position < 3' 'drives.3.faults_entered == 0' 'faults.0.applied_at_s >= 1' \
    -- 'ok == false' 'stop.node == 3' 'stop.axis == Z' 'stop.cause ~ feedback PDO missing' \
    'stop.location ~ m10x1.5-rigid-tap.nc:11' 'error ~ node 3' \
    'tapping.# >= 1' 'tapping.*.max_coupling_error_um_cmd <= @coupling_bound_um'
scenario_end "deaf from {faults.0.applied_at_s:.3} s, Z TPDOs {drives.3.tpdos_sent}, Z at {drives.3.position:.3} mm, C at {drives.4.position:.1} deg: at rest ${rest_um:-?} um off the thread (bound 62.5)" \
    "stop: {stop.cause}, node {stop.node}, at {stop.location}; coupling setpoints {max:tapping.*.max_coupling_error_um_cmd:.4} um (bound {coupling_bound_um:.4}); C max following error {axes.C.max_following_error:.1} deg; program {program_time_s:.2} s in {wall_time_s:.2} s"
