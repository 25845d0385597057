#!/usr/bin/env bash
# hil-tests/soak.sh: a long real-time run on vcan. simdrive drives the bus, `cnc402 run` runs a
# main program that repeats itself (M99) for the whole duration and is stopped with SIGINT
# (Ctrl-C, exit 1 "operator stop") at the deadline. Every --every seconds it samples both
# processes' RSS (/proc/PID/status VmRSS) and open fds (/proc/PID/fd), and the periodic lines
# both print (`cnc402 run --stats-every`: wake-ups, late ones, the interval's worst wake-up and
# following error per axis; `simdrive --stats-every`: SYNCs, the interval's longest SYNC
# interval). Writes soak.csv (one row per sample) and summary.txt; see hil-tests/README.md.
#
#   hil-tests/soak.sh [--minutes N] [--every S] [--warmup S] [--rss-growth-pct P]
#                     [--program FILE] [--config FILE] [--out DIR] [--no-build]
#
# Defaults: 60 minutes, a sample every 60 s (10 s under 10 minutes), RSS judged against the
# first sample after 60 s of warm-up (3 samples under 5 minutes), bound 10 %,
# hil-tests/scenarios/programs/soak.nc on scenarios/machine-vcan.toml, out dir $HIL_OUT or
# hil-tests/.cache/soak. On the host it builds (release) and runs itself through
# hil-tests/run.sh script (the emulated guest where the kernel has no CAN).
#
# Exit status: 0 passed; 1 RSS grew past the bound, an fd count grew, the run stopped before
# the deadline or otherwise than by the SIGINT, or simdrive's checks failed; 2 usage; the
# runner's own codes (124, 125) on the host.
set -uo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/.." && pwd)"

minutes=60 every="" warmup="" rss_pct=10 no_build=0 out=""
program=hil-tests/scenarios/programs/soak.nc
config=hil-tests/scenarios/machine-vcan.toml
args=("$@")
usage() { sed -n '2,22p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
is_num() { [[ "$1" =~ ^[0-9]+(\.[0-9]+)?$ ]]; }
while [[ $# -gt 0 ]]; do
    case "$1" in
        --minutes) minutes="${2:-}"; shift 2 ;;
        --every) every="${2:-}"; shift 2 ;;
        --warmup) warmup="${2:-}"; shift 2 ;;
        --rss-growth-pct) rss_pct="${2:-}"; shift 2 ;;
        --program) program="${2:-}"; shift 2 ;;
        --config) config="${2:-}"; shift 2 ;;
        --out) out="${2:-}"; shift 2 ;;
        --no-build) no_build=1; shift ;;
        -h|--help) usage ;;
        *) echo "soak: unknown argument '$1'" >&2; usage ;;
    esac
done
is_num "$minutes" && is_num "$rss_pct" || usage
duration=$(awk -v m="$minutes" 'BEGIN { printf "%d", m * 60 }')
((duration >= 10)) || { echo "soak: --minutes must give at least 10 s" >&2; exit 2; }
if [[ -z "$every" ]]; then every=$((duration >= 600 ? 60 : 10)); fi
is_num "$every" || usage
every=${every%.*}
((every >= 1)) || usage
if [[ -z "$warmup" ]]; then warmup=$((duration >= 300 ? 60 : 3 * every)); fi
is_num "$warmup" || usage
warmup=${warmup%.*}

# On the host: build, then run this script where vcan0 is (run.sh: natively or in the guest).
if [[ -z "${HIL_RUNNING_IN:-}" ]]; then
    cd "$repo" || exit 2
    if [[ $no_build == 0 ]]; then
        echo "soak: cargo build --release (cnc402, cnc402-hil)"
        cargo build -q --release -p cnc402 -p cnc402-hil --bins || exit 1
    fi
    exec "$here/run.sh" script --no-build --timeout $((duration + 600)) "$0" "${args[@]}"
fi

cd "$HIL_REPO" || exit 2
out="${out:-${HIL_OUT:-$HIL_REPO/hil-tests/.cache/soak}}"
mkdir -p "$out" || exit 2
export HIL_OUT="$out"
# shellcheck source=guest/lib.sh
source "$HIL_REPO/hil-tests/guest/lib.sh"
csv="$out/soak.csv"
summary="$out/summary.txt"
rm -f "$csv" "$summary" "$out/run.json" "$out/simdrive.json"
fails=()

# rss_kb PID, fds PID: builtins only (starting a process takes up to 0.7 s in the guest).
# RSS from /proc/PID/statm (one short line, read whole: /proc/PID/status read line by line
# by `read` came back without VmRSS in 3 of 31 samples, its lines shifting between reads).
page_kb=$(($(getconf PAGESIZE 2>/dev/null || echo 4096) / 1024))
rss_kb() {
    local _size res
    read -r _size res _ <"/proc/$1/statm" 2>/dev/null && [[ $res =~ ^[0-9]+$ ]] &&
        echo $((res * page_kb))
}
fds() {
    local f=(/proc/"$1"/fd/*)
    [[ -e "${f[0]}" ]] && echo "${#f[@]}" || echo ""
}
# last_stats LOG PREFIX: the newest periodic line of a log, its key=value fields.
last_stats() { tail -n 400 "$1" 2>/dev/null | grep -E "^$2" | tail -n 1; }
field() { local re="(^| )$1=([^ ]*)"; [[ "$2" =~ $re ]] && echo "${BASH_REMATCH[2]}" || echo ""; }

echo "soak: ${duration} s of $program on $HIL_IFACE ($HIL_RUNNING_IN), a sample every ${every} s, RSS judged from ${warmup} s (bound ${rss_pct} %), out $out"
hil_bg drive "$HIL_BIN/simdrive" --config "$config" --iface "$HIL_IFACE" \
    --report "$out/simdrive.json" --stats-every "$every"
if ! hil_wait_ready drive '^simdrive: nodes ' 20; then
    hil_log drive
    echo "FAIL soak: simdrive did not start"
    exit 1
fi
hil_bg run "$HIL_BIN/cnc402" --config "$config" run "$program" --report "$out/run.json" \
    --stats-every "$every" --at-stop continue
run_pid=${HIL_PIDS[run]} drive_pid=${HIL_PIDS[drive]}
# Time runs from the cyclic start (the first stats line comes one interval after it).
if ! hil_wait_ready run '^stats: ' $((every + 60)); then
    hil_log run | tail -n 20
    echo "FAIL soak: cnc402 run printed no stats line"
    exit 1
fi
t0=$((SECONDS - every))
deadline=$((t0 + duration))

header=""
early=""
n=0
while :; do
    n=$((n + 1))
    # Half an interval after each periodic line is due, so a sample reads that line, not the
    # one before (on the grid itself a sample raced the line and repeated the last interval).
    next=$((t0 + n * every + every / 2))
    ((next > deadline)) && next=$deadline
    while ((SECONDS < next)); do
        kill -0 "$run_pid" 2>/dev/null || break
        sleep 1
    done
    if ! kill -0 "$run_pid" 2>/dev/null; then
        early="cnc402 run ended after $((SECONDS - t0)) s, before the deadline (${duration} s)"
        break
    fi
    rs=$(last_stats "$HIL_OUT/run.log" 'stats: ')
    ds=$(last_stats "$HIL_OUT/drive.log" 'simdrive: stats ')
    fe=$(field fe_max "$rs")
    if [[ -z "$header" ]]; then
        fe_cols=$(tr ',' '\n' <<<"$fe" | sed 's/:.*//; s/^/fe_max_/' | paste -sd,)
        header="t_s,run_rss_kb,run_fds,drive_rss_kb,drive_fds,tick,wakeups,late,skipped,wake_max_us,${fe_cols},syncs,sync_max_us,sync_long"
        echo "$header" >"$csv"
    fi
    fe_vals=$(tr ',' '\n' <<<"$fe" | sed 's/^[^:]*://' | paste -sd,)
    row="$((SECONDS - t0)),$(rss_kb "$run_pid"),$(fds "$run_pid"),$(rss_kb "$drive_pid"),$(fds "$drive_pid")"
    row+=",$(field tick "$rs"),$(field wakeups "$rs"),$(field late "$rs"),$(field skipped "$rs"),$(field wake_max_us "$rs"),$fe_vals"
    row+=",$(field syncs "$ds"),$(field sync_max_us "$ds"),$(field sync_long "$ds")"
    echo "$row" >>"$csv"
    echo "soak: $row"
    ((SECONDS >= deadline)) && break
done

run_rc=-1
if [[ -z "$early" ]]; then
    kill -INT "$run_pid"
    run_rc=0
    hil_wait run 120 || run_rc=$?
else
    run_rc=0
    hil_wait run 5 || run_rc=$?
fi
kill -TERM "$drive_pid" 2>/dev/null
drive_rc=0
hil_wait drive 30 || drive_rc=$?

[[ -n "$early" ]] && fails+=("$early (exit $run_rc): $(tail -n 3 "$HIL_OUT/run.log" | tr '\n' ' ')")
[[ -z "$early" && $run_rc != 1 ]] && fails+=("cnc402 run exited $run_rc after SIGINT, expected 1 (operator stop)")
[[ $drive_rc != 0 ]] && fails+=("simdrive exited $drive_rc (its checks: $out/simdrive.json)")
if [[ -s "$out/run.json" ]]; then
    "$HIL_BIN/hilcheck" -f "$out/run.json" 'stop.cause ~ operator stop' >/dev/null 2>&1 ||
        fails+=("cnc402's report gives another stop than the SIGINT: $("$HIL_BIN/hilcheck" -f "$out/run.json" -p '{error}' 2>/dev/null)")
else
    fails+=("cnc402 run wrote no report")
fi

# Growth of RSS and fds from the first sample at or after the warm-up to the last.
growth=$(awk -F, -v w="$warmup" -v pct="$rss_pct" '
    NR == 1 { next }
    # A sample without both RSS figures (a process gone) is not judged.
    $2 == "" || $4 == "" { next }
    { last = $0 }
    !b && $1 >= w { b = 1; bt = $1; br = $2; bf = $3; bdr = $4; bdf = $5 }
    !ft { ft = $1; fr = $2; fd = $4 }
    END {
        if (!b) { print "FAIL no sample after the warm-up"; exit }
        split(last, l, ",")
        h = (l[1] - bt) / 3600
        for (p = 0; p < 2; p++) {
            name = p ? "simdrive" : "cnc402"
            r0 = p ? bdr : br; r1 = p ? l[4] : l[2]; f0 = p ? bdf : bf; f1 = p ? l[5] : l[3]
            first = p ? fd : fr
            per_h = h > 0 ? (r1 - r0) / h : 0
            grew = r0 > 0 ? 100 * (r1 - r0) / r0 : 0
            printf("%s: RSS %d kB at the first sample (%d s), %d kB after warm-up (%d s), %d kB at the end (%+.1f %%, %+.0f kB/h); fds %d after warm-up, %d at the end\n", name, first, ft, r0, bt, r1, grew, per_h, f0, f1)
            if (grew > pct) printf("FAIL %s RSS grew %.1f %% after the warm-up (bound %s %%)\n", name, grew, pct)
            if (f1 > f0) printf("FAIL %s fds grew from %d to %d\n", name, f0, f1)
        }
    }' "$csv" 2>/dev/null)
while IFS= read -r l; do
    [[ $l == FAIL\ * ]] && fails+=("${l#FAIL }")
done <<<"$growth"
# Largest following error per axis and worst interval figures over the samples.
# Worst interval figures over the samples, by column name (wake-ups, following error, SYNC).
worst=$(awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) h[i] = $i; n = NF; next }
    { for (i = 1; i <= n; i++) if ($i + 0 > m[i]) m[i] = $i + 0; long += $n }
    END { for (i = 1; i <= n; i++) if (h[i] ~ /^(wake_max_us|fe_max_.*|sync_max_us)$/) printf "%s %s, ", h[i], m[i]
          printf "SYNC intervals over 1.5 periods %d\n", long }' "$csv" 2>/dev/null)
{
    echo "soak: ${duration} s of $program ($HIL_RUNNING_IN), samples every ${every} s: $out/soak.csv"
    echo "$growth" | grep -v '^FAIL'
    [[ -s "$out/run.json" ]] && "$HIL_BIN/hilcheck" -f "$out/run.json" \
        -p 'cnc402: {ticks} ticks, program time {program_time_s:.1} s in {wall_time_s:.1} s wall (real-time factor {realtime_factor:.2}); wake-up p50/p99/max {wakeup_latency_us.p50:.0}/{wakeup_latency_us.p99:.0}/{wakeup_latency_us.max:.0} us, late {wakeup_latency_us.late} of {wakeup_latency_us.samples}, deadlines let pass {wakeup_latency_us.skipped}; bus load {bus.load_percent:.1} %; taps {tapping.#}; stop: {stop.cause}' \
        -p 'cnc402: max following error per axis (mm or deg): X {axes.X.max_following_error:.4} Y {axes.Y.max_following_error:.4} Z {axes.Z.max_following_error:.4} C {axes.C.max_following_error:.4}' 2>/dev/null
    [[ -s "$out/simdrive.json" ]] && "$HIL_BIN/hilcheck" -f "$out/simdrive.json" \
        -p 'simdrive: ok {ok}; SYNC {sync_period_us.count} (percentiles over the first {sync_period_us.intervals}) period p50/p99/max {sync_period_us.p50:.0}/{sync_period_us.p99:.0}/{sync_period_us.max:.0} us; protocol errors {protocol_errors.unexpected_frames}; bus load {bus.load_percent:.1} %' 2>/dev/null
    echo "worst per interval: $worst"
    if [[ ${#fails[@]} == 0 ]]; then
        echo "PASS soak"
    else
        echo "FAIL soak"
        for f in "${fails[@]}"; do echo "  - $f"; done
    fi
} | tee "$summary"
[[ ${#fails[@]} == 0 ]]
