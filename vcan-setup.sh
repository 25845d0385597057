#!/usr/bin/env bash
# vcan-setup.sh [IFACE]: create and raise a virtual CAN interface (default vcan0).
#
# Idempotent: an interface that already exists is only raised. Where the running kernel has no
# CAN support, says what is missing and exits 2; hil-tests/run.sh then falls back to an
# emulated Debian kernel (see hil-tests/README.md).
#
# Exit codes: 0 interface up; 1 usage or other error (e.g. not allowed to create links);
# 2 the kernel has no (v)CAN support.
set -uo pipefail

iface="${1:-vcan0}"
if [[ $# -gt 1 || "$iface" == -* || ! "$iface" =~ ^[A-Za-z0-9_.-]{1,15}$ ]]; then
    echo "usage: $0 [IFACE]   (IFACE: 1-15 characters, default vcan0)" >&2
    exit 1
fi

no_can() {
    echo "vcan-setup: this kernel ($(uname -r)) has no usable CAN support: $1" >&2
    echo "vcan-setup: hil-tests/run.sh will fall back to an emulated Debian kernel (qemu) that has vcan." >&2
    exit 2
}

if ! command -v ip >/dev/null 2>&1; then
    echo "vcan-setup: 'ip' (iproute2) is not installed: apt-get install iproute2" >&2
    exit 1
fi

# Already there (vcan, or a real CAN interface of that name): just make sure it is up.
if ip link show dev "$iface" >/dev/null 2>&1; then
    if ! ip link set up dev "$iface"; then
        echo "vcan-setup: $iface exists but could not be raised (are you root?)" >&2
        exit 1
    fi
    echo "vcan-setup: $iface is up"
    exit 0
fi

# Load vcan unless it is already loaded or built in. modprobe needs /lib/modules, which an
# emulated guest running the host's root (hil-tests/guest) does not have; there the guest's
# init has already insmod-ed the modules, so /sys/module/vcan exists and this is skipped.
if [[ ! -d /sys/module/vcan ]]; then
    if ! modprobe vcan 2>/dev/null; then
        if [[ ! -d /proc/net/can ]]; then
            if [[ ! -d "/lib/modules/$(uname -r)" ]]; then
                no_can "CONFIG_CAN is not enabled (no /proc/net/can) and there is no /lib/modules/$(uname -r) to load can/vcan from"
            fi
            no_can "modprobe vcan failed and /proc/net/can does not exist (CONFIG_CAN / CONFIG_CAN_VCAN missing?)"
        fi
        # CAN is there; vcan may still be built in, so go on and let 'ip link add' decide.
    fi
fi

if ! err=$(ip link add dev "$iface" type vcan 2>&1); then
    # Another caller may have created it between our check and now: that is fine.
    if ! ip link show dev "$iface" >/dev/null 2>&1; then
        if [[ "$err" == *"Unknown device type"* || "$err" == *"not supported"* ]]; then
            no_can "'ip link add dev $iface type vcan' says: $err (CONFIG_CAN_VCAN missing)"
        fi
        echo "vcan-setup: 'ip link add dev $iface type vcan' failed: $err" >&2
        exit 1
    fi
fi
if ! ip link set up dev "$iface"; then
    echo "vcan-setup: could not raise $iface" >&2
    exit 1
fi
echo "vcan-setup: $iface is up"
