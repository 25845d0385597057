#!/bin/bash
# job.sh JOBDIR: run one HIL job prepared by hil-tests/run.sh, with a real vcan interface up.
# Runs inside the emulated guest (chrooted into the host's root) or natively, the same way:
# load DIR/env, bring up $HIL_IFACE with vcan-setup.sh, cd to the caller's directory, run
# DIR/cmd and write its exit status to DIR/status (125 when the job could not start).
set -u
jobdir="$1"

# Inside the guest the environment is the kernel's (HOME=/ TERM=linux): start from the
# host's exported variables instead.
# shellcheck source=/dev/null
. "$jobdir/env"

finish() {
    echo "$1" >"$jobdir/status.tmp" && mv -f "$jobdir/status.tmp" "$jobdir/status"
    sync 2>/dev/null
    exit "$1"
}

if ! out=$("$HIL_REPO/vcan-setup.sh" "$HIL_IFACE" 2>&1); then
    echo "HIL: could not bring up $HIL_IFACE: $out"
    finish 125
fi
if [[ "$HIL_RUNNING_IN" == qemu ]]; then
    read -r up _ </proc/uptime
    echo "HIL: guest kernel $(uname -r) ready after ${up} s of guest uptime; $HIL_IFACE up"
fi
if ! cd "$HIL_CWD"; then
    echo "HIL: cannot cd to $HIL_CWD"
    finish 125
fi
bash "$jobdir/cmd"
finish $?
