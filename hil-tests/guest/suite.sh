#!/bin/bash
# suite.sh [SCRIPT...]: run HIL scenario scripts one after the other against $HIL_IFACE (already
# up), inside one guest boot or natively; default: smoke/*.sh then scenarios/*.sh.
# Each script runs with bash, cwd = the repo, a time limit of HIL_SCENARIO_TIMEOUT seconds
# (default 300) and HIL_OUT = a fresh directory for its reports. Exit 0 only if all passed;
# the last line is "N passed, N failed".
set -u
repo="${HIL_REPO:?run this through hil-tests/run.sh}"
limit="${HIL_SCENARIO_TIMEOUT:-300}"
out_root="${HIL_OUT_ROOT:-$repo/hil-tests/.cache/out}"

scripts=("$@")
if [[ ${#scripts[@]} == 0 ]]; then
    shopt -s nullglob
    scripts=("$repo"/hil-tests/smoke/*.sh "$repo"/hil-tests/scenarios/*.sh)
fi
passed=0
failed=0
failed_names=()
for s in "${scripts[@]}"; do
    name="$(basename "$s" .sh)"
    export HIL_OUT="$out_root/$name"
    rm -rf "$HIL_OUT" && mkdir -p "$HIL_OUT"
    echo "=== $name"
    t0=$(date +%s.%N)
    (cd "$repo" && timeout -k 5 "$limit" bash "$s")
    rc=$?
    took=$(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }')
    if [[ $rc == 0 ]]; then
        passed=$((passed + 1))
        echo "--- ok: $name (${took} s)"
    else
        failed=$((failed + 1))
        failed_names+=("$name")
        if [[ $rc == 124 || $rc == 137 ]]; then
            echo "--- FAILED: $name timed out after ${limit} s"
        else
            echo "--- FAILED: $name (exit $rc, ${took} s)"
        fi
    fi
done
[[ $failed == 0 ]] || echo "failed: ${failed_names[*]}"
echo "$passed passed, $failed failed"
[[ -n "${HIL_JOB:-}" ]] && echo "$passed passed, $failed failed" >"$HIL_JOB/summary"
[[ $failed == 0 && $passed -gt 0 ]]
