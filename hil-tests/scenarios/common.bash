# shellcheck shell=bash
# Shared by the scenario scripts (sourced; not itself a scenario: the suite runs *.sh only).
# A scenario starts `simdrive` and `cnc402 run` as two processes on $HIL_IFACE, stops simdrive
# with SIGTERM when the run has ended, then asserts on both JSON reports with one `hilcheck`
# call and prints exactly one line `PASS NAME: figures` or `FAIL NAME: figures`, also kept in
# $HIL_OUT/result.txt for hil-tests/suite.sh's summary.
#
#   source "$HIL_REPO/hil-tests/scenarios/common.bash"
#   scenario_run CONFIG PROGRAM [SIMDRIVE_ARG...]   # sets RUN_RC, DRIVE_RC ($RUN_EXTRA: more
#                                                   # `cnc402 run` arguments)
#   scenario_check 'drive-assertion'... -- 'run-assertion'...
#   scenario_end "figures template"
set -uo pipefail
source "$HIL_REPO/hil-tests/guest/lib.sh"

SCENARIO="$(basename "${BASH_SOURCE[1]:-$0}" .sh)"
# shellcheck disable=SC2034 # used by the scenario scripts
SC_DIR="hil-tests/scenarios"
DRIVE_JSON="$HIL_OUT/simdrive.json"
RUN_JSON="$HIL_OUT/run.json"
SC_FAILS=()
RUN_RC=-1
DRIVE_RC=-1

# The scenario configs name vcan0 (cnc402 run takes the interface from the config).
if [[ "${HIL_IFACE:-}" != vcan0 ]]; then
    echo "FAIL $SCENARIO: the scenario configs use vcan0, HIL_IFACE is '${HIL_IFACE:-}'"
    exit 1
fi

sc_fail() { SC_FAILS+=("$*"); }

# simdrive's line once its CAN socket is bound (printed after the open; see simdrive.rs).
SIMDRIVE_READY='^simdrive: nodes '

# trace_row_matches FILE CONDITION: some complete row of cnc402's --trace CSV satisfies the
# awk CONDITION, which names columns by their header as $c["Z_cmd"] (t, line, <AXIS>_cmd,
# <AXIS>_act, <AXIS>_sw). A row still being written (fewer fields) is not judged.
trace_row_matches() {
    [[ -s "$1" ]] || return 1
    awk -F, "NR == 1 { for (i = 1; i <= NF; i++) c[\$i] = i; n = NF; next }
        NF == n && ($2) { found = 1; exit } END { exit !found }" "$1"
}

# scenario_run CONFIG PROGRAM [SIMDRIVE_ARG...]: simdrive (same config) in the background,
# then `cnc402 run PROGRAM` in the foreground (limit RUN_LIMIT s, default 150), then SIGTERM
# to simdrive. With SIGINT_WHEN='AWK-CONDITION' (see trace_row_matches), cnc402 run writes
# --trace $HIL_OUT/trace.csv and gets SIGINT (Ctrl-C) as soon as a row of it satisfies the
# condition: at a point of the program, however slowly the machine runs.
# RUN_RC / DRIVE_RC hold the exit statuses.
scenario_run() {
    local cfg="$1" prog="$2"
    shift 2
    SC_T0=$SECONDS
    # Leave the suite's per-script limit room for simdrive's start (20 s) and stop (20.5 s),
    # so a run that hits its own limit still ends in this script's FAIL line and figures.
    local run_limit="${RUN_LIMIT:-150}" cap=$(( ${HIL_SCENARIO_TIMEOUT:-300} - 50 ))
    if (( run_limit > cap )); then run_limit=$cap; fi
    hil_bg drive "$HIL_BIN/simdrive" --config "$cfg" --iface "$HIL_IFACE" \
        --report "$DRIVE_JSON" "$@"
    if ! hil_wait_ready drive "$SIMDRIVE_READY" 20; then
        hil_log drive
        sc_fail "simdrive did not report its socket bound"
        return 0
    fi
    RUN_RC=0
    if [[ -n "${SIGINT_WHEN:-}" ]]; then
        local trace="$HIL_OUT/trace.csv"
        hil_bg run "$HIL_BIN/cnc402" --config "$cfg" run "$prog" --report "$RUN_JSON" \
            --trace "$trace"
        # cnc402 writes the trace to .trace.csv.tmp<pid> and renames it at the end (crash-safe
        # writes, docs/faults.md): watch that file. The trace lags the loop by the recorder's
        # buffer (~80 rows); the condition must hold long enough in program time for that and
        # for the signal's delivery.
        local live="$HIL_OUT/.trace.csv.tmp${HIL_PIDS[run]}"
        if hil_wait_until run "$run_limit" trace_row_matches "$live" "$SIGINT_WHEN"; then
            # Program time of the last complete row when the signal went (for the figures).
            # shellcheck disable=SC2034 # used by the scenario scripts
            SIGINT_AT_S=$(awk -F, 'NR == 1 { n = NF } NR > 1 && NF == n { t = $1 } END { print t }' "$live")
            kill -INT "${HIL_PIDS[run]}" 2>/dev/null || sc_fail "cnc402 run had ended before SIGINT"
        else
            sc_fail "the trace never showed ${SIGINT_WHEN}: no SIGINT sent"
        fi
        hil_wait run "$run_limit" || RUN_RC=$?
    else
        # RUN_EXTRA: further `cnc402 run` arguments (e.g. `--channel 1=FILE`), word-split.
        # shellcheck disable=SC2086
        timeout -k 5 "$run_limit" "$HIL_BIN/cnc402" --config "$cfg" run "$prog" ${RUN_EXTRA:-} \
            --report "$RUN_JSON" >"$HIL_OUT/run.log" 2>&1 || RUN_RC=$?
    fi
    kill -TERM "${HIL_PIDS[drive]}" 2>/dev/null
    DRIVE_RC=0
    hil_wait drive 20 || DRIVE_RC=$?
    SC_SECONDS=$((SECONDS - SC_T0))
    if [[ ! -s "$RUN_JSON" ]]; then
        sc_fail "cnc402 run wrote no report (exit $RUN_RC): $(tail -n 3 "$HIL_OUT/run.log" | tr '\n' ' ')"
    fi
    if [[ ! -s "$DRIVE_JSON" ]]; then
        sc_fail "simdrive wrote no report (exit $DRIVE_RC): $(tail -n 3 "$HIL_OUT/drive.log" | tr '\n' ' ')"
    fi
}

# act_coupling_bound_um TOOL_SPEED_MM_S: a bound for cnc402's actual-level coupling figure
# (tapping.*.max_coupling_error_um_act) in this run, printed in µm (nothing without both
# reports). cnc402 compares Z and C feedback of the same SYNC cycle by each TPDO's inferred
# age; when a TPDO comes late (a process stalled), Z and C may be paired a few cycles apart,
# an error of the tool axis's speed times the mismatch (62.5 µm = 5 cycles at 12.5 mm/s was
# seen on a loaded host). A TPDO can be no later than the run's longest stall — simdrive's
# largest SYNC interval (its own stalls and the master's), cnc402's largest loop wake-up
# latency — plus a cycle for the answer and one for the master's read; plus 1 µm for what
# the drives' own tracking and the counts may add (simdrive's actual-level bound).
act_coupling_bound_um() {
    [[ -s "$DRIVE_JSON" && -s "$RUN_JSON" ]] || return 0
    local figs
    figs=$("$HIL_BIN/hilcheck" -f "$DRIVE_JSON" -p '{sync_period_us.max}' \
        -f "$RUN_JSON" -p '{wakeup_latency_us.max} {period_us}' 2>/dev/null | paste -sd' ') || return 0
    awk -v v="$1" -v f="$figs" 'BEGIN {
        split(f, x, " "); sync_max = x[1] + 0; wake_max = x[2] + 0; period = x[3] + 0
        if (period <= 0) exit 1
        stall = sync_max > wake_max ? sync_max : wake_max
        # mm/s * µs = nm; /1000 = µm
        printf "%.1f\n", v * (stall + 2 * period) / 1000 + 1
    }'
}

# tap_rest_error_um R PITCH: after a stop in the first hole's tap, how far (µm) Z's actual
# position at rest in simdrive's report is from the thread that C's actual angle cuts from the
# R plane (C starts that tap at 0°, turning PITCH mm per turn: Z = R - C * PITCH / 360), on
# the simulated drives' own positions; nothing without simdrive's report. The in-process
# fault tests (runtime/tests/faults.rs) make the same comparison.
tap_rest_error_um() {
    [[ -s "$DRIVE_JSON" ]] || return 0
    local zc
    zc=$("$HIL_BIN/hilcheck" -f "$DRIVE_JSON" -p '{drives.3.position} {drives.4.position}' 2>/dev/null) || return 0
    awk -v r="$1" -v p="$2" -v zc="$zc" 'BEGIN {
        split(zc, x, " "); e = (x[1] - (r - x[2] * p / 360)) * 1000
        printf "%.1f\n", e < 0 ? -e : e
    }'
}

# expect_rc WHAT GOT WANT
expect_rc() {
    [[ "$2" == "$3" ]] || sc_fail "$1 exited $2, expected $3"
}

# scenario_check DRIVE_ASSERTION... -- RUN_ASSERTION...: one hilcheck process for both files.
scenario_check() {
    local d=() r=() seen=0 a
    for a in "$@"; do
        if [[ $a == -- ]]; then seen=1; continue; fi
        if [[ $seen == 0 ]]; then d+=("$a"); else r+=("$a"); fi
    done
    local args=()
    [[ -s "$DRIVE_JSON" && ${#d[@]} -gt 0 ]] && args+=(-f "$DRIVE_JSON" "${d[@]}")
    [[ -s "$RUN_JSON" && ${#r[@]} -gt 0 ]] && args+=(-f "$RUN_JSON" "${r[@]}")
    [[ ${#args[@]} == 0 ]] && return 0
    local out line
    out=$("$HIL_BIN/hilcheck" "${args[@]}" 2>&1) && return 0
    while IFS= read -r line; do
        [[ -n "$line" ]] && sc_fail "${line/#FAIL $HIL_OUT\//}"
    done <<<"$out"
}

# Figures every scenario reports: SYNC period seen by simdrive, bus load, the loop's wake-up
# latency from cnc402's report.
COMMON_FIGURES_DRIVE='SYNC {sync_period_us.count} p50/p99/max {sync_period_us.p50:.0}/{sync_period_us.p99:.0}/{sync_period_us.max:.0} us, bus load {bus.load_percent:.1} %, protocol errors {protocol_errors.unexpected_frames}'
COMMON_FIGURES_RUN='wake-up p50/p99/max {wakeup_latency_us.p50:.0}/{wakeup_latency_us.p99:.0}/{wakeup_latency_us.max:.0} us, late {wakeup_latency_us.late}'

# scenario_end [DRIVE_TEMPLATE [RUN_TEMPLATE]]: prints the PASS/FAIL line with the figures and
# exits 0 / 1.
scenario_end() {
    local dt="${1:-$COMMON_FIGURES_DRIVE}" rt="${2:-$COMMON_FIGURES_RUN}" figs="" args=()
    [[ -s "$DRIVE_JSON" ]] && args+=(-f "$DRIVE_JSON" -p "simdrive: $dt")
    [[ -s "$RUN_JSON" ]] && args+=(-f "$RUN_JSON" -p "cnc402: $rt")
    [[ ${#args[@]} -gt 0 ]] && figs=$("$HIL_BIN/hilcheck" "${args[@]}" 2>/dev/null | paste -sd'|')
    figs="${figs//|/ | } (${SC_SECONDS:-?} s)"
    local line
    if [[ ${#SC_FAILS[@]} == 0 ]]; then
        line="PASS $SCENARIO: $figs"
    else
        line="FAIL $SCENARIO: $figs"
    fi
    echo "$line" | tee "$HIL_OUT/result.txt"
    if [[ ${#SC_FAILS[@]} != 0 ]]; then
        local m
        for m in "${SC_FAILS[@]}"; do echo "  - $m"; done | tee -a "$HIL_OUT/result.txt"
        for m in drive run; do
            [[ -s "$HIL_OUT/$m.log" ]] && tail -n 15 "$HIL_OUT/$m.log" | sed "s/^/  [$m] /"
        done
        exit 1
    fi
    exit 0
}
