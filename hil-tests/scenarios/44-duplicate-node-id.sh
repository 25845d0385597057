#!/usr/bin/env bash
# A duplicate node id: a second simdrive process hosts node 2 (Y) of the same config, so two
# devices answer on node id 2 (both send a boot-up after the master's reset communication,
# both answer its SDO requests). cnc402 run must refuse start-up naming node 2 as two devices
# on one node id, exit 1, before any motion.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
hil_bg twin "$HIL_BIN/simdrive" --config "$SC_DIR/machine-vcan.toml" --iface "$HIL_IFACE" \
    --nodes 2 --report "$HIL_OUT/twin.json"
if ! hil_wait_ready twin "$SIMDRIVE_READY" 20; then
    hil_log twin
    sc_fail "the second simdrive (node 2) did not report its socket bound"
fi
scenario_run "$SC_DIR/machine-vcan.toml" "$SC_DIR/programs/short-moves.nc"
expect_rc "cnc402 run" "$RUN_RC" 1
kill -TERM "${HIL_PIDS[twin]}" 2>/dev/null
hil_wait twin 20 || true
"$HIL_BIN/hilcheck" -f "$HIL_OUT/twin.json" 'drives.# == 1' 'drives.2.boot_ups >= 2' \
    >/dev/null 2>&1 || sc_fail "twin report: $("$HIL_BIN/hilcheck" -f "$HIL_OUT/twin.json" 'drives.2.boot_ups >= 2' 2>&1 | head -n 2 | tr '\n' ' ')"
scenario_check 'drives.2.boot_ups >= 2' 'drives.*.reached_operation_enabled == false' \
    -- 'ok == false' 'error ~ start-up failed' 'error ~ node 2' 'error ~ two devices on node id 2' \
    'ticks == 0'
scenario_end "Y boot-ups {drives.2.boot_ups}, SDO requests {drives.2.sdo_requests}; $COMMON_FIGURES_DRIVE" "error: {error}"
