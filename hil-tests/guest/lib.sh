# shellcheck shell=bash
# Helpers for HIL scenario scripts (bash): start the processes of a scenario in the
# background, wait for them with a time limit, and never leave one running.
#   source "$HIL_REPO/hil-tests/guest/lib.sh"
#   hil_bg drive "$HIL_BIN/simdrive" --iface "$HIL_IFACE" --report "$HIL_OUT/drive.json"
#   hil_wait_ready drive '^simdrive: nodes '   # its line printed after its socket is bound
#   "$HIL_BIN/cnc402" run ... ; kill -TERM "${HIL_PIDS[drive]}"; hil_wait drive 20
# Logs go to $HIL_OUT/NAME.log; every process still running when the script exits is killed.
# Waits are for events (a line in a log, a receiver registered with the kernel, a condition
# on a file), each with a time limit, never a fixed sleep standing in for one.

declare -gA HIL_PIDS=()
declare -gA HIL_RECEIVERS0=()

# hil_can_receivers: how many CAN receive filters the kernel has registered (every bound
# CAN_RAW socket registers its filters in /proc/net/can/rcvlist_*, one line each); empty
# when the kernel has no /proc/net/can.
hil_can_receivers() {
    [[ -r /proc/net/can/rcvlist_all ]] || return 0
    # grep -c prints 0 and fails when there is none (a failure set -e must not see).
    { cat /proc/net/can/rcvlist_* 2>/dev/null | grep -cE '^ +[^ (]+ +[0-9A-Fa-f]+ +[0-9A-Fa-f]+ +[0-9A-Fa-f]+ '; } || true
}

# hil_bg NAME CMD [ARG...]: start CMD in the background, output to $HIL_OUT/NAME.log.
hil_bg() {
    local name="$1"
    shift
    # Before the start: hil_wait_socket waits for the count to grow past this.
    HIL_RECEIVERS0[$name]=$(hil_can_receivers)
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

# hil_wait_socket NAME [SECONDS]: wait (default 10 s) until NAME has bound a CAN socket, so
# that frames sent from now on reach it: NAME holds a socket and the kernel's count of CAN
# receivers has grown past the count before NAME started (scripts start their listeners one
# at a time). For a process that prints a line once bound, hil_wait_ready is the direct way.
# Where the kernel has no /proc/net/can, NAME holding a socket is all that can be seen.
# 1 if not in time.
hil_wait_socket() {
    local name="$1" limit="${2:-10}" pid="${HIL_PIDS[$1]:?hil_wait_socket: no process named $1}"
    local base="${HIL_RECEIVERS0[$1]:-}" deadline=$((SECONDS + limit)) have_socket=0 n
    while ((SECONDS < deadline)); do
        kill -0 "$pid" 2>/dev/null || { echo "hil_wait_socket: $name exited early"; return 1; }
        if [[ $have_socket == 0 ]]; then
            # One ls rather than a readlink per fd: starting a process is slow in the guest.
            # shellcheck disable=SC2010
            ls -l "/proc/$pid/fd" 2>/dev/null | grep -q 'socket:' && have_socket=1
        fi
        if [[ $have_socket == 1 ]]; then
            [[ -z "$base" ]] && return 0
            n=$(hil_can_receivers)
            [[ -n "$n" ]] && ((n > base)) && return 0
        fi
        sleep 0.05
    done
    if [[ $have_socket == 0 ]]; then
        echo "hil_wait_socket: $name opened no socket within ${limit} s"
    else
        echo "hil_wait_socket: $name holds a socket but no new CAN receiver within ${limit} s (receivers: $base before, $(hil_can_receivers) now)"
    fi
    return 1
}

# hil_wait_ready NAME PATTERN [SECONDS]: wait (default 20 s) until NAME's log has a line
# matching PATTERN (grep -E), e.g. the line a process prints once its socket is bound. 1 if
# NAME exits first or the line does not come in time.
hil_wait_ready() {
    local name="$1" pat="$2" limit="${3:-20}"
    local pid="${HIL_PIDS[$1]:?hil_wait_ready: no process named $1}" deadline=$((SECONDS + limit))
    local log="${HIL_OUT:?}/$name.log"
    while ((SECONDS < deadline)); do
        grep -Eq -- "$pat" "$log" 2>/dev/null && return 0
        if ! kill -0 "$pid" 2>/dev/null; then
            grep -Eq -- "$pat" "$log" 2>/dev/null && return 0
            echo "hil_wait_ready: $name exited before printing /$pat/"
            return 1
        fi
        sleep 0.05
    done
    echo "hil_wait_ready: $name printed no line /$pat/ within ${limit} s"
    return 1
}

# hil_wait_until NAME SECONDS CMD [ARG...]: wait until CMD succeeds (polled every 50 ms)
# while NAME runs. 0 when it did; 1 if NAME exited first (CMD is tried once more then) or
# SECONDS passed.
hil_wait_until() {
    local name="$1" limit="$2"
    local pid="${HIL_PIDS[$1]:?hil_wait_until: no process named $1}" deadline=$((SECONDS + $2))
    shift 2
    while ((SECONDS < deadline)); do
        "$@" && return 0
        if ! kill -0 "$pid" 2>/dev/null; then
            "$@" && return 0
            echo "hil_wait_until: $name exited before: $*"
            return 1
        fi
        sleep 0.05
    done
    echo "hil_wait_until: not within ${limit} s: $*"
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
