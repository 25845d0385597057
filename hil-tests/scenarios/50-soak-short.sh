#!/usr/bin/env bash
# The soak's short version for CI: hil-tests/soak.sh for 90 s (a sample every 10 s, RSS judged
# from 30 s): the M99 program runs in real time until SIGINT; passes when neither process's
# RSS grew past 10 % after the warm-up, no fd count grew, the run ended only by the SIGINT and
# simdrive's checks passed. Timing figures are reported, not judged.
set -uo pipefail
name="$(basename "$0" .sh)"
bash "$HIL_REPO/hil-tests/soak.sh" --minutes 1.5 --every 10 --warmup 30 --out "$HIL_OUT" \
    >"$HIL_OUT/soak.log" 2>&1
rc=$?
s="$HIL_OUT/summary.txt"
figs=$(grep -E '^(cnc402|simdrive): (RSS|[0-9]+ ticks|ok)' "$s" 2>/dev/null |
    sed -E 's/RSS [0-9]+ kB at the first sample \([0-9]+ s\), /RSS /; s/program time .* wall \(/(/' | paste -sd'|')
figs="${figs//|/ | }"
if [[ $rc == 0 ]]; then
    echo "PASS $name: $figs" | tee "$HIL_OUT/result.txt"
else
    { echo "FAIL $name: $figs"; grep -E '^  - ' "$s" 2>/dev/null || tail -n 15 "$HIL_OUT/soak.log"; } |
        tee "$HIL_OUT/result.txt"
fi
exit "$rc"
