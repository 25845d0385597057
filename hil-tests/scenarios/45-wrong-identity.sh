#!/usr/bin/env bash
# Another drive than the one commissioned: the config expects node 2 (Y) to be vendor
# 0x00C40402, product 0x00000001, revision at least 0x00010000 (simdrive's identity; the
# other axes expect nothing), and simdrive's node 2 reports product 0x00000002 in 0x1018:2
# from power-on. cnc402 run must refuse start-up before anything is written to the drive,
# exit 1 naming node 2, 0x1018:2 and both values. A second run against an unchanged simdrive
# with the same config (the identity right) must start and end ok: the check refuses only what
# differs.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
cfg="$HIL_OUT/machine-vcan-identity.toml"
awk '{ print } /^name = "Y"$/ {
    print "identity = { vendor = 0x00C40402, product = 0x00000001, revision_min = 0x00010000 }" }' \
    "$SC_DIR/machine-vcan.toml" >"$cfg"
grep -q '^identity = ' "$cfg" || sc_fail "no identity line in $cfg"
scenario_run "$cfg" "$SC_DIR/programs/short-moves.nc" --fault-clock start \
    --fault 2:identity:0x00C40402:0x00000002@0
expect_rc "cnc402 run" "$RUN_RC" 1
scenario_check 'drives.*.reached_operation_enabled == false' \
    -- 'ok == false' 'error ~ start-up failed' 'error ~ node 2' 'error ~ 0x1018:2' \
    'error ~ 0x00000002' 'error ~ expects 0x00000001' 'ticks == 0'
refused="$("$HIL_BIN/hilcheck" -f "$RUN_JSON" -p '{error}' 2>/dev/null)"
# The same config against the right drive starts.
mkdir -p "$HIL_OUT/right"
DRIVE_JSON="$HIL_OUT/right/simdrive.json" RUN_JSON="$HIL_OUT/right/run.json"
scenario_run "$cfg" "$SC_DIR/programs/short-moves.nc"
expect_rc "cnc402 run (right identity)" "$RUN_RC" 0
scenario_check 'drives.*.reached_operation_enabled == true' -- 'ok == true'
scenario_end "$COMMON_FIGURES_DRIVE" "refused: $refused; right identity: ok {ok}"
