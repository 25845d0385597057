#!/usr/bin/env bash
# simdrive against the drives crate's Master directly (hil-tests/examples/tapmaster.rs: boot,
# a synthetic rigid tap of 4 revolutions at 1.5 mm pitch down and back out, disable) — tests
# simdrive's own checks on a real socket independently of `cnc402 run`: two tap windows
# (down, out) within one count at setpoint level, actual figure reported, SYNC period measured
# over every SYNC tapmaster's cyclic phase sent, no protocol errors.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
SC_T0=$SECONDS
hil_bg drive "$HIL_BIN/simdrive" --config "$SC_DIR/machine-vcan.toml" --iface "$HIL_IFACE" \
    --report "$DRIVE_JSON"
hil_wait_ready drive "$SIMDRIVE_READY" 20 || sc_fail "simdrive did not report its socket bound"
RUN_RC=0
timeout -k 5 60 "$HIL_BIN/examples/tapmaster" --iface "$HIL_IFACE" \
    --config "$SC_DIR/machine-vcan.toml" >"$HIL_OUT/run.log" 2>&1 || RUN_RC=$?
kill -TERM "${HIL_PIDS[drive]}" 2>/dev/null
DRIVE_RC=0
hil_wait drive 20 || DRIVE_RC=$?
SC_SECONDS=$((SECONDS - SC_T0))
expect_rc tapmaster "$RUN_RC" 0
expect_rc simdrive "$DRIVE_RC" 0
RUN_JSON=/nonexistent
# SYNCs sent: tapmaster's cyclic phase ("N cycles") sends one per cycle, and a failed send
# stops it with exit 1; simdrive must have received every one of them (vcan loses nothing).
# Enable and disable cycles send SYNCs too (not counted here: their send errors do not stop).
syncs_sent=$(sed -n 's/^tapmaster: \([0-9][0-9]*\) cycles, .*/\1/p' "$HIL_OUT/run.log" | tail -n 1)
[[ -n "$syncs_sent" ]] || sc_fail "tapmaster's log names no number of cycles (SYNCs sent)"
scenario_check 'ok == true' 'tap_windows == 2' 'checks.*.pass == true' \
    'checks.?name~(setpoints).pitch_mm > 1.4999' 'checks.?name~(setpoints).pitch_mm < 1.5001' \
    'checks.?name~(actual).value_um > 0' "sync_period_us.count >= ${syncs_sent:-1}" \
    'protocol_errors.unexpected_frames == 0' 'protocol_errors.unaddressed_frames == 0' \
    'protocol_errors.sdo_aborts_sent == 0' 'drives.*.reached_operation_enabled == true'
scenario_end "taps {tap_windows}, SYNCs {sync_period_us.count} (cyclic phase sent ${syncs_sent:-?}), coupling setpoints max {max:checks.?name~(setpoints).value_um:.4} um (limit {min:checks.?name~(setpoints).limit_um:.4}), actual max {max:checks.?name~(actual).value_um:.1} um; $COMMON_FIGURES_DRIVE; tapmaster: $(grep -o 'wake-up.*' "$HIL_OUT/run.log" | head -1)"
