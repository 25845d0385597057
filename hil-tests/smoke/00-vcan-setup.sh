#!/bin/bash
# vcan-setup.sh on a kernel that has CAN (the guest, or a native run): creates and raises an
# interface, is idempotent, and rejects a bad name.
set -euo pipefail
iface=hilsmoke0
setup="$HIL_REPO/vcan-setup.sh"
trap 'ip link del dev "$iface" 2>/dev/null || true' EXIT
ip link del dev "$iface" 2>/dev/null || true

"$setup" "$iface"
"$setup" "$iface"   # a second call only checks that it is up
state=$(ip -br link show dev "$iface")
echo "$state"
[[ "$state" == *"UP"* ]] || { echo "FAIL: $iface is not up"; exit 1; }
ip link set down dev "$iface"
"$setup" "$iface"   # raises an existing interface that is down
[[ "$(ip -br link show dev "$iface")" == *"UP"* ]] || { echo "FAIL: $iface not raised again"; exit 1; }

rc=0
"$setup" "bad name" 2>/dev/null || rc=$?
[[ $rc == 1 ]] || { echo "FAIL: a bad interface name gave exit $rc, not 1"; exit 1; }
echo "ok: vcan-setup.sh creates, re-raises and validates"
