#!/usr/bin/env bash
# simdrive's fault injection on vcan, against the drives crate's Master (tapmaster), without
# cnc402 run: node 3 (Z) goes to FAULT with EMCY 0x7300 0.5 s after the first SYNC, then
# node 2 stops its heartbeat in a second run. The master must stop naming the node (and the
# EMCY / heartbeat); simdrive's report shows the injected fault applied.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
SC_T0=$SECONDS
RUN_JSON=/nonexistent
# run_pair NAME SIMDRIVE_ARG...: simdrive + tapmaster; sets RUN_RC; report in $HIL_OUT/NAME.json
run_pair() {
    local name="$1"
    shift
    hil_bg "drive-$name" "$HIL_BIN/simdrive" --config "$SC_DIR/machine-vcan.toml" \
        --iface "$HIL_IFACE" --report "$HIL_OUT/$name.json" "$@"
    hil_wait_ready "drive-$name" "$SIMDRIVE_READY" 20 || sc_fail "$name: simdrive did not report its socket bound"
    RUN_RC=0
    timeout -k 5 60 "$HIL_BIN/examples/tapmaster" --iface "$HIL_IFACE" --seconds 3 \
        --config "$SC_DIR/machine-vcan.toml" >"$HIL_OUT/$name-master.log" 2>&1 || RUN_RC=$?
    kill -TERM "${HIL_PIDS[drive-$name]}" 2>/dev/null
    hil_wait "drive-$name" 20
}
run_pair fault --fault 3:fault:0x7300@0.5
expect_rc "tapmaster (fault)" "$RUN_RC" 1
grep -q 'STOP: axis Z (node 3).*7300' "$HIL_OUT/fault-master.log" ||
    sc_fail "fault: master's stop does not name node 3 and 0x7300: $(grep STOP "$HIL_OUT/fault-master.log")"
run_pair heartbeat --fault 2:heartbeat@0.5
expect_rc "tapmaster (heartbeat)" "$RUN_RC" 1
grep -qi 'STOP: axis Y (node 2).*heartbeat' "$HIL_OUT/heartbeat-master.log" ||
    sc_fail "heartbeat: master's stop does not name node 2 and the heartbeat: $(grep STOP "$HIL_OUT/heartbeat-master.log")"
SC_SECONDS=$((SECONDS - SC_T0))
DRIVE_JSON="$HIL_OUT/fault.json"
scenario_check 'faults.0.applied_at_s >= 0.5' 'drives.3.last_fault_code == 0x7300' \
    'drives.3.faults_entered == 1' 'emcys_sent >= 1' 'protocol_errors.unexpected_frames == 0'
DRIVE_JSON="$HIL_OUT/heartbeat.json"
scenario_check 'faults.0.applied_at_s >= 0.5' 'drives.2.faults_entered == 0' \
    'protocol_errors.unexpected_frames == 0'
scenario_end "heartbeat silenced at {faults.0.applied_at_s:.3} s; $COMMON_FIGURES_DRIVE | master: $(sed -n 's/.*STOP: //; s/ (t = .*//p' "$HIL_OUT"/*-master.log | paste -sd'|' | sed 's/|/ | /')"
