#!/bin/bash
# Two separate processes exchange frames over the real vcan interface: candump (can-utils)
# logs what cansend puts on the bus; every frame must arrive intact and in order.
set -euo pipefail
source "$HIL_REPO/hil-tests/guest/lib.sh"
iface="${HIL_IFACE:-vcan0}"
frames=(123#DEADBEEF 7FF#R 000# 080# 12345678#0011223344556677 1ABC0001#01 601#4041600000000000)

# -L: log format "(time) iface id#data"; -n: stop after that many frames; -T: give up (ms).
hil_bg candump candump -L -n "${#frames[@]}" -T 20000 "$iface"
hil_wait_socket candump
for f in "${frames[@]}"; do cansend "$iface" "$f"; done
if ! hil_wait candump 30; then
    echo "FAIL: candump failed or timed out; it logged:"
    hil_log candump
    exit 1
fi

mapfile -t got < <(awk '{ print $3 }' "$HIL_OUT/candump.log")
echo "sent:     ${frames[*]}"
echo "received: ${got[*]}"
if [[ "${got[*]}" != "${frames[*]}" ]]; then
    echo "FAIL: candump saw something other than what cansend sent"
    exit 1
fi
echo "ok: ${#got[@]} frames from cansend to candump over $iface"
