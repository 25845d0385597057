#!/usr/bin/env bash
# drivectl/hil.sh: drivectl against real kernel CAN sockets. Runs where $HIL_IFACE (vcan0) is
# up — inside the HIL guest or natively — with simulated drives hosted by a separate process
# on the same interface: hil-tests' `simdrive` (default; its JSON report must say ok), or
# drivectl's `simpeer` example with HIL_DRIVECTL_PEER=simpeer (or a path to either binary).
#
#   cargo build --release -p drivectl --bins --examples && cargo build --release -p cnc402-hil --bins
#   hil-tests/run.sh script --no-build drivectl/hil.sh
#   (or, as a suite scenario: hil-tests/run.sh suite --no-build drivectl/hil.sh)
#
# Checks: SocketCanBus (examples/sockcheck.rs: order, completeness, SDO during PDOs); scan finds the four drives of config/machine.toml; info; SDO read (expedited and
# segmented), write, abort (exit 6) and absent node (exit 7); enable/state/disable step by
# step; mode csp; a short CSP move; a drive faulted by the peer: EMCY seen by `emcy`, state
# FAULT, enable refused (exit 1), fault-reset; `monitor --log` in candump format (emcy and
# monitor listen from before the peer starts until SIGINT after these checks); with simdrive,
# its report (no protocol errors from all this traffic, frames for other nodes apart). Prints
# "drivectl HIL: N passed, M failed" and exits 1 if any failed.
set -u
repo="${HIL_REPO:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)}"
cd "$repo" || exit 125
iface="${HIL_IFACE:-vcan0}"
bin="${HIL_BIN:-$repo/target/release}"
out="${HIL_OUT:-$(mktemp -d)}"
mkdir -p "$out"
# Background processes, event waits and clean-up (hil-tests/guest/lib.sh); their output goes
# to $out/NAME.log.
export HIL_OUT="$out"
# shellcheck source=hil-tests/guest/lib.sh
source "$repo/hil-tests/guest/lib.sh"
dc="$bin/drivectl"
peer="${HIL_DRIVECTL_PEER:-${DRIVECTL_PEER:-simdrive}}"
case "$peer" in
simdrive) peer="$bin/simdrive" ;;
simpeer) peer="$bin/examples/simpeer" ;;
esac
sockcheck="$bin/examples/sockcheck"
for b in "$dc" "$peer" "$sockcheck"; do
    [[ -x "$b" ]] || { echo "FAIL: $b not built (cargo build --release -p drivectl --bins --examples; -p cnc402-hil --bins)"; exit 1; }
done
passed=0
failed=0
ok() { passed=$((passed + 1)); echo "ok   $*"; }
bad() { failed=$((failed + 1)); echo "FAIL $*"; }
# finish: the summary line, exit 1 if any check failed (lib.sh's trap then ends what runs).
finish() {
    echo "drivectl HIL: $passed passed, $failed failed (outputs in $out)"
    [[ $failed == 0 ]] || exit 1
    exit 0
}

# The master's timing monitors (TPDO missing for N cycles, heartbeat) and the SDO client's
# timeout (also scan's probe window) judge the emulated guest's loose timing, not the
# protocol: drivectl's own config gets wider margins here (the scenario configs' values;
# 100 ms for an SDO answer expired once in the guest). The check that wants a timeout
# (sdo-absent) sets its own with --timeout-ms.
sed -e 's/^tpdo_timeout_cycles = .*/tpdo_timeout_cycles = 200/' \
    -e 's/^heartbeat_timeout_ms = .*/heartbeat_timeout_ms = 2000/' \
    -e 's/^sdo_timeout_ms = .*/sdo_timeout_ms = 1000/' \
    config/machine.toml >"$out/machine-hil.toml"
for want in 'tpdo_timeout_cycles = 200' 'heartbeat_timeout_ms = 2000' 'sdo_timeout_ms = 1000'; do
    grep -qx "$want" "$out/machine-hil.toml" || { bad "config: '$want' not set (config/machine.toml changed?)"; finish; }
done
D=("$dc" --iface "$iface" --config "$out/machine-hil.toml")

# expect NAME EXIT PATTERN -- CMD...: run, check the exit status and that the combined output
# matches PATTERN (grep -E).
expect() {
    local name="$1" want="$2" pat="$3"
    shift 4
    local got=0
    "$@" >"$out/$name.out" 2>&1 || got=$?
    if [[ $got != "$want" ]]; then
        bad "$name: exit $got, expected $want"
        sed 's/^/     | /' "$out/$name.out" | head -20
    elif ! grep -Eq "$pat" "$out/$name.out"; then
        bad "$name: output does not match /$pat/"
        sed 's/^/     | /' "$out/$name.out" | head -20
    else
        ok "$name"
    fi
}

# Listeners in separate processes see everything the other commands put on the bus. They
# run until SIGINT after the checks (drivectl stops on Ctrl-C like at --duration: the candump
# log flushed, the summary printed, exit 0; SIGTERM would end them with the log unflushed).
# A background job may inherit SIGINT ignored, and then drivectl's handler is not installed:
# env gives them the default disposition. Each is bound before anything else starts, so
# neither can miss a frame of the peer or of the checks.
no_sigign=(env --default-signal=INT)
env --default-signal=INT true 2>/dev/null || no_sigign=()
hil_bg emcy "${no_sigign[@]}" "${D[@]}" --json emcy
hil_wait_socket emcy 30 || { bad "emcy listener did not bind its socket"; hil_log emcy; finish; }
# monitor prints "monitoring IFACE ..." once its socket is open.
hil_bg monitor "${no_sigign[@]}" "${D[@]}" monitor --quiet --log "$out/monitor-candump.log"
hil_wait_ready monitor '^monitoring ' 30 || { bad "monitor did not start"; hil_log monitor; finish; }

# The peer faults node 4 (EMCY 0x7300) 3 s after it starts (the listeners are up by then).
# It runs until SIGTERM at the end (600 s at most: the checks take 15-65 s in the guest, and a
# peer that ended by itself before them would leave the last checks without drives). The
# checks start when it says its socket is bound.
if [[ "$(basename "$peer")" == simdrive ]]; then
    # hil-tests' simdrive: same drive model, its own options and a JSON report.
    hil_bg peer "$peer" --iface "$iface" --config config/machine.toml --duration 600 --no-rt \
        --fault-clock start --fault 4:fault:0x7300@3 --report "$out/simdrive.json"
    peer_ready='^simdrive: nodes '
else
    hil_bg peer "$peer" --iface "$iface" --config config/machine.toml --for 600 \
        --fault 4:fault:0x7300@3
    peer_ready='^simpeer: [0-9]+ drive\(s\) on '
fi
hil_wait_ready peer "$peer_ready" 30 || { bad "peer did not start"; hil_log peer; finish; }

# emcy_seen: the listener has the EMCY 0x7300 (29440) of node 4.
emcy_seen() { grep '"code":29440' "$out/emcy.log" 2>/dev/null | grep -q '"node":4'; }

# The kernel has CAN here: a missing interface is named as such (exit 4), not errno 97.
expect no-such-iface 4 'cannot open CAN interface nosuch0: no such interface' -- "$dc" --iface nosuch0 scan
expect scan 0 'node 4 \(C\).*CiA 402' -- "${D[@]}" scan --listen-ms 100
expect scan-json 0 '"nodes":\[\{"axis":"X"' -- "${D[@]}" --json scan --listen-ms 50
expect info 0 'supported modes +0x000000a0: homing \(6\), cyclic synchronous position' -- "${D[@]}" info 3
expect sdo-read-segmented 0 '"cnc402 simdrive Z"' -- "${D[@]}" sdo read 3 1008
expect sdo-write 0 'expedited' -- "${D[@]}" sdo write 3 0x1017 u16 100
expect sdo-readback 0 '= 100 ' -- "${D[@]}" sdo read 3 0x1017
expect sdo-abort 6 '0x06020000' -- "${D[@]}" sdo read 3 0x2000
expect sdo-absent 7 'node 9: SDO read of 0x1000:00: no response' -- "${D[@]}" --timeout-ms 100 sdo read 9 0x1000
# Objects by name (the standard objects; python-canopen's "Parent.Sub" form) and store.
expect sdo-read-by-name 0 '0x6041:00 statusword = ' -- "${D[@]}" sdo read 3 STATUSWORD
expect sdo-read-dotted-name 0 '0x1018:01 vendor id = 12846082 ' -- "${D[@]}" sdo read 3 "Identity object.Vendor ID"
expect sdo-write-by-name 0 '0x1017:00 producer heartbeat time ← 100 \[UNSIGNED16\]' -- "${D[@]}" sdo write 3 "producer heartbeat time" 100
expect sdo-unknown-name 64 'nearest: "controlword" \(0x6040:00\)' -- "${D[@]}" sdo read 3 controlwrd
# stdin not a terminal (the guest's console could be one): refused, nothing asked.
expect store-needs-yes 64 'without --yes' -- sh -c '"$@" </dev/null' _ "${D[@]}" store 3
expect store 0 'parameters stored' -- "${D[@]}" store 3 --yes
expect mode 0 'confirmed by 0x6061' -- "${D[@]}" mode 3 csp
expect enable 0 'reached 0x[0-9a-f]{4} \(OPERATION ENABLED\)' -- "${D[@]}" enable 3
expect state 0 'OPERATION ENABLED' -- "${D[@]}" state 3
expect disable 0 'reached 0x0240 \(SWITCH ON DISABLED\)' -- "${D[@]}" disable 3
expect move 0 'done from' -- "${D[@]}" move 1 2
# The peer's fault on node 4 is due 3 s after its start: these checks begin once the EMCY
# listener has seen it.
hil_wait_until peer 60 emcy_seen || bad "no EMCY 0x7300 from node 4 within 60 s of the checks (the peer's fault)"
expect state-fault 0 'FAULT: error code 0x603F = 0x7300' -- "${D[@]}" state 4
expect enable-fault 1 'drive in 0x0208 \(FAULT\)' -- "${D[@]}" enable 4
expect fault-reset 0 'fault reset → 0x0240' -- "${D[@]}" fault-reset 4

# The listeners' part is over: Ctrl-C (SIGINT) to both, which end with exit 0.
kill -INT "${HIL_PIDS[emcy]}" "${HIL_PIDS[monitor]}" 2>/dev/null
emcy_rc=0
hil_wait emcy 30 || emcy_rc=$?
mon_rc=0
hil_wait monitor 30 || mon_rc=$?
if [[ $emcy_rc != 0 ]]; then
    bad "emcy: exit $emcy_rc after SIGINT"; sed 's/^/     | /' "$out/emcy.log" | tail -5
elif emcy_seen; then
    ok "emcy saw 0x7300 from node 4"
else
    bad "emcy: no EMCY 0x7300 from node 4"; sed 's/^/     | /' "$out/emcy.log" | head
fi
if [[ $mon_rc != 0 ]]; then
    bad "monitor: exit $mon_rc after SIGINT"; sed 's/^/     | /' "$out/monitor.log" | tail -5
elif grep -Eq "^\([0-9]+\.[0-9]{6}\) $iface 603#40081000" "$out/monitor-candump.log" \
    && grep -Eq "^\([0-9]+\.[0-9]{6}\) $iface 583#" "$out/monitor-candump.log"; then
    ok "monitor --log: $(wc -l <"$out/monitor-candump.log") frames in candump -l format"
else
    bad "monitor --log: SDO traffic of the other commands missing"; head -5 "$out/monitor-candump.log"
fi
tail -2 "$out/monitor.log" | sed 's/^/     monitor: /'
# The transport itself: a burst in order and complete; SDO during a PDO stream loses no PDO.
# sockcheck drains the bus until 200 ms pass without a frame: the drives' heartbeats (node 3's
# at 100 ms since sdo-write) would keep it there until the peer stops, so they go off first.
for n in 1 2 3 4; do "${D[@]}" sdo write "$n" 0x1017 u16 0 >>"$out/heartbeats-off.out" 2>&1; done
if "$sockcheck" --iface "$iface" >"$out/sockcheck.out" 2>&1; then
    ok "sockcheck"; sed 's/^/     /' "$out/sockcheck.out"
else
    bad "sockcheck"; sed 's/^/     | /' "$out/sockcheck.out"
fi
echo "     checks took ${SECONDS} s; stopping the peer (SIGTERM)"
kill -0 "${HIL_PIDS[peer]}" 2>/dev/null || bad "peer: ended before the checks did (see $out/peer.log)"
kill -TERM "${HIL_PIDS[peer]}" 2>/dev/null
peer_rc=0
hil_wait peer 30 || peer_rc=$?
sed 's/^/     peer: /' "$out/peer.log" | tail -3
echo "     peer stopped at ${SECONDS} s"
if [[ "$(basename "$peer")" == simdrive ]]; then
    # simdrive ends on SIGTERM with its report: exit 0 and "ok": true = no protocol errors.
    if [[ $peer_rc == 0 ]] && grep -q '"ok": true' "$out/simdrive.json" 2>/dev/null; then
        ok "simdrive report ok: $(python3 -c 'import json,sys; p=json.load(open(sys.argv[1]))["protocol_errors"]; print(", ".join(f"{k} {v}" for k, v in p.items()))' "$out/simdrive.json" 2>/dev/null)"
    else
        bad "simdrive report (exit $peer_rc): checks failed"
        grep -B1 -A3 '"pass": false' "$out/simdrive.json" 2>/dev/null | sed 's/^/     | /' | head -20
        python3 -c 'import json,sys; r=json.load(open(sys.argv[1])); print(r["protocol_errors"]); [print(k, {x: d[x] for x in ("nmt", "state", "unexpected_frames", "pdo_length_errors", "sdo_requests", "rpdos")}) for k, d in r["drives"].items()]' "$out/simdrive.json" 2>&1 | sed 's/^/     | /'
    fi
fi
finish
