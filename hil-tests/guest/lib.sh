# shellcheck shell=bash
# Helpers for HIL scenario scripts (bash): start the processes of a scenario in the
# background, wait for them with a time limit, and never leave one running.
#   source "$HIL_REPO/hil-tests/guest/lib.sh"
#   hil_bg drive "$HIL_BIN/simdrive" --iface "$HIL_IFACE" --report "$HIL_OUT/drive.json"
#   hil_wait_socket drive          # it has opened its CAN socket
#   "$HIL_BIN/cnc402" run ... ; hil_wait drive 30
# Logs go to $HIL_OUT/NAME.log; every process still running when the script exits is killed.

declare -gA HIL_PIDS=()

# hil_bg NAME CMD [ARG...]: start CMD in the background, output to $HIL_OUT/NAME.log.
hil_bg() {
    local name="$1"
    shift
    "$@" >"${HIL_OUT:?}/$name.log" 2>&1 &
    HIL_PIDS[$name]=$!
}

# hil_wait NAME [SECONDS]: wait (default 60 s) for NAME to exit; returns its exit status, or
# 124 after killing it when it outlives the limit.
hil_wait() {
    local name="$1" limit="${2:-60}" pid="${HIL_PIDS[$1]:?hil_wait: no process named $1}"
    local deadline=$((SECONDS + limit)) rc=0
    while kill -0 "$pid" 2>/dev/null; do
        if ((SECONDS >= deadline)); then
            echo "hil_wait: $name (pid $pid) still running after ${limit} s: killed"
            kill -TERM "$pid" 2>/dev/null; sleep 0.5; kill -KILL "$pid" 2>/dev/null
            wait "$pid" 2>/dev/null
            unset "HIL_PIDS[$name]"
            return 124
        fi
        sleep 0.05
    done
    wait "$pid" || rc=$?
    unset "HIL_PIDS[$name]"
    return "$rc"
}

# hil_wait_socket NAME [SECONDS]: wait (default 10 s) until NAME holds an open socket (a CAN
# process has bound its socket, so frames sent from now on reach it). 1 if not in time.
hil_wait_socket() {
    local name="$1" limit="${2:-10}" pid="${HIL_PIDS[$1]:?hil_wait_socket: no process named $1}"
    local deadline=$((SECONDS + limit))
    while ((SECONDS < deadline)); do
        kill -0 "$pid" 2>/dev/null || { echo "hil_wait_socket: $name exited early"; return 1; }
        # One ls rather than a readlink per fd: starting a process is slow in the guest.
        # shellcheck disable=SC2010
        if ls -l "/proc/$pid/fd" 2>/dev/null | grep -q 'socket:'; then
            sleep 0.1  # from socket() to bind()
            return 0
        fi
        sleep 0.05
    done
    echo "hil_wait_socket: $name opened no socket within ${limit} s"
    return 1
}

# hil_log NAME: print NAME's log, each line prefixed with its name.
hil_log() { sed "s/^/[$1] /" "${HIL_OUT:?}/$1.log"; }

hil_cleanup() {
    local name
    [[ ${#HIL_PIDS[@]} == 0 ]] && return 0
    for name in "${!HIL_PIDS[@]}"; do kill -TERM "${HIL_PIDS[$name]}"; done
    sleep 0.2
    for name in "${!HIL_PIDS[@]}"; do kill -KILL "${HIL_PIDS[$name]}"; done
    wait
} 2>/dev/null
trap hil_cleanup EXIT
