# Two separate processes exchange frames over the real vcan interface: candump (can-utils)
# logs what cansend puts on the bus; every frame must arrive intact and in order.
set -euo pipefail
iface="${HIL_IFACE:-vcan0}"
log="$HIL_OUT/candump.log"
frames=(123#DEADBEEF 7FF#R 000# 080# 12345678#0011223344556677 1ABC0001#01 601#4041600000000000)
expected=("${frames[@]}")

# -L: log format "(time) iface id#data"; -n: stop after that many frames; -T: give up (ms).
candump -L -n "${#frames[@]}" -T 20000 "$iface" >"$log" &
dump=$!
# candump must have bound its socket before the first frame is sent: wait until it holds one
# (a socket in /proc/PID/fd), at most 10 s.
for _ in $(seq 100); do
    if ls -l /proc/$dump/fd 2>/dev/null | grep -q 'socket:'; then break; fi
    sleep 0.1
done
sleep 0.2
for f in "${frames[@]}"; do cansend "$iface" "$f"; done
wait "$dump" || { echo "candump failed or timed out; it logged:"; cat "$log"; exit 1; }

mapfile -t got < <(awk '{ print $3 }' "$log")
echo "sent:     ${frames[*]}"
echo "received: ${got[*]}"
if [[ "${got[*]}" != "${expected[*]}" ]]; then
    echo "FAIL: candump saw something other than what cansend sent"
    exit 1
fi
echo "ok: ${#got[@]} frames from cansend to candump over $iface"
