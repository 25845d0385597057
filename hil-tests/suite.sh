#!/usr/bin/env bash
# hil-tests/suite.sh: the whole HIL suite, as `.ci/run` calls it. Builds the binaries (release),
# then runs, in ONE boot of the emulated guest (or natively where the kernel has CAN):
# smoke/*.sh, scenarios/*.sh and drivectl/hil.sh — each scenario starts `simdrive` and
# `cnc402 run` as separate processes on vcan0 and asserts on both JSON reports (hilcheck).
# Prints each scenario's PASS/FAIL line with its figures, then a figures table, and ends with
# the line "N passed, M failed"; exits non-zero if any failed.
#
#   hil-tests/suite.sh [--no-build] [SCRIPT...]     (default: all of the above)
#
# Environment: HIL_SUITE_TIMEOUT (whole guest run, s, default 1500), HIL_SCENARIO_TIMEOUT (per
# script, default 300), and everything hil-tests/run.sh takes (HIL_MODE, HIL_CACHE, ...).
set -uo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/.." && pwd)"
cd "$repo" || exit 2
t0=$(date +%s)
no_build=0
if [[ "${1:-}" == --no-build ]]; then
    no_build=1
    shift
fi
scripts=("$@")
if [[ ${#scripts[@]} == 0 ]]; then
    scripts=(hil-tests/smoke/*.sh hil-tests/scenarios/*.sh)
    [[ -f drivectl/hil.sh ]] && scripts+=(drivectl/hil.sh)
fi

if [[ $no_build == 0 ]]; then
    echo "suite: cargo build --release (cnc402, cnc402-hil, drivectl + its examples)"
    if ! cargo build -q --release -p cnc402 -p cnc402-hil -p drivectl --bins ||
        ! cargo build -q --release -p cnc402-hil --examples; then
        echo "suite: build failed"; echo "0 passed, ${#scripts[@]} failed"; exit 1
    fi
    if [[ " ${scripts[*]} " == *drivectl/hil.sh* ]]; then
        cargo build -q --release -p drivectl --examples || {
            echo "suite: build of drivectl's examples failed"; echo "0 passed, ${#scripts[@]} failed"; exit 1; }
    fi
fi

# The scenario configs are generated from config/machine.toml: warn when they drift.
if command -v python3 >/dev/null && ! python3 hil-tests/scenarios/gen_configs.py --check; then
    echo "suite: WARNING: hil-tests/scenarios/machine-vcan*.toml differ from what config/machine.toml gives;"
    echo "suite:   regenerate with python3 hil-tests/scenarios/gen_configs.py"
fi

cache="${HIL_CACHE:-$here/.cache}"
log="$cache/suite.log"
mkdir -p "$cache"
HIL_SCENARIO_TIMEOUT="${HIL_SCENARIO_TIMEOUT:-300}" \
    "$here/run.sh" suite --no-build --timeout "${HIL_SUITE_TIMEOUT:-1500}" "${scripts[@]}" 2>&1 | tee "$log"
rc=${PIPESTATUS[0]}

# Figures table: each scenario's PASS/FAIL line (also kept in its out dir).
out_root="${HIL_OUT_ROOT:-$cache/out}"
echo
echo "=== HIL figures ($(date -u '+%Y-%m-%d %H:%M UTC'), mode $("$here/run.sh" mode 2>/dev/null))"
for s in "${scripts[@]}"; do
    name="$(basename "$s" .sh)"
    if [[ -s "$out_root/$name/result.txt" ]]; then
        head -n 1 "$out_root/$name/result.txt"
    elif [[ -s "$out_root/$name/cansmoke.json" ]]; then
        "$repo/target/release/hilcheck" -f "$out_root/$name/cansmoke.json" -p "smoke $name: socket-to-socket p50/p99/max {exchange.round_trip.p50_ns}/{exchange.round_trip.p99_ns}/{exchange.round_trip.max_ns} ns; 1 ms loop (mlockall {periodic_loop.mlockall}, SCHED_FIFO {periodic_loop.sched_fifo}) wake-up p50/p99/max {periodic_loop.wakeup_latency.p50_ns}/{periodic_loop.wakeup_latency.p99_ns}/{periodic_loop.wakeup_latency.max_ns} ns, {periodic_loop.wakeup_latency.late_by_a_period} of {periodic_loop.wakeup_latency.samples} late by a period; SYNC sent/received {periodic_loop.sync_frames_sent}/{periodic_loop.sync_frames_received}" 2>/dev/null
    elif [[ "$name" == hil && -d "$out_root/hil" ]]; then
        echo "drivectl/hil.sh: $(grep -hE '^drivectl HIL:' "$log" | tail -n 1)"
    fi
done
took=$(($(date +%s) - t0))
echo "suite: total ${took} s (build, guest boot, all scripts)"

summary=$(grep -E '^[0-9]+ passed, [0-9]+ failed$' "$log" | tail -n 1)
if [[ -z "$summary" ]]; then
    echo "suite: the guest produced no result (run.sh exit $rc); see $log"
    summary="0 passed, ${#scripts[@]} failed"
fi
echo "$summary"
failed=${summary#* passed, }
failed=${failed% failed}
[[ $rc == 0 && $failed == 0 ]]
