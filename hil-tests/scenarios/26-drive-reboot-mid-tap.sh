#!/usr/bin/env bash
# A drive that reboots mid-tap (boot-up during cyclic operation): node 3 (Z) resets itself 1 s
# into the first hole's tap (simdrive's tap clock; the in-stroke lasts ~1.7 s of program time).
# cnc402 run must stop at once on the boot-up message, exit 1 naming node 3, "drive rebooted"
# and the G84 line (11), and keep the thread coupled: C follows Z's last actual position.
# Coupling as in 10-rigid-tap on cnc402's side (setpoints per line within one count, actual
# within this run's stall bound), and at rest on the simulated drives' own positions: Z stands
# dead from the reboot (the simulated drive halts at once) and C brakes onto it with its own
# dynamics, within the in-process bound for a dead stop (5 cycles of tap travel, 62.5 µm at
# F750: runtime/tests/faults.rs). simdrive's own windows need Z and C both moving to the end
# of the stroke, which a dead Z does not give: not judged.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
scenario_run "$SC_DIR/machine-vcan.toml" examples/m10x1.5-rigid-tap.nc --fault-clock tap \
    --fault 3:reboot@1
expect_rc "cnc402 run" "$RUN_RC" 1
act_bound=$(act_coupling_bound_um 12.5)
rest_um=$(tap_rest_error_um 3 1.5)
awk -v e="${rest_um:-1e9}" 'BEGIN { exit !(e <= 62.5) }' ||
    sc_fail "Z and C at rest ${rest_um:-?} um off the thread (bound 62.5 um)"
scenario_check 'drives.3.boot_ups >= 3' 'drives.3.position < 3' 'faults.0.applied_at_s >= 1' \
    -- 'ok == false' 'stop.node == 3' 'stop.axis == Z' 'stop.cause ~ drive rebooted' \
    'stop.location ~ m10x1.5-rigid-tap.nc:11' 'error ~ node 3' 'axes.Z.final_position < 3' \
    'tapping.# >= 1' 'tapping.*.max_coupling_error_um_cmd <= @coupling_bound_um' \
    "tapping.*.max_coupling_error_um_act <= ${act_bound:-0}"
scenario_end "reboot at {faults.0.applied_at_s:.3} s, Z boot-ups {drives.3.boot_ups}, Z at {drives.3.position:.3} mm, C at {drives.4.position:.1} deg: at rest ${rest_um:-?} um off the thread (bound 62.5)" \
    "stop: {stop.cause}, node {stop.node}, at {stop.location}; coupling setpoints {max:tapping.*.max_coupling_error_um_cmd:.4} um (bound {coupling_bound_um:.4}), actual {max:tapping.*.max_coupling_error_um_act:.1} um (bound ${act_bound:-?}); program {program_time_s:.2} s in {wall_time_s:.2} s"
