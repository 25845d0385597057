#!/bin/bash
# The Rust smoke binary (socketcan crate): frames between two sockets, then a 1 ms
# clock_nanosleep loop's wake-up latency and the mlockall / SCHED_FIFO grants, as JSON.
set -euo pipefail
bin="${HIL_BIN:?}/cansmoke"
[[ -x "$bin" ]] || { echo "FAIL: $bin not built (cargo build -p cnc402-hil)"; exit 1; }
"$bin" --iface "${HIL_IFACE:-vcan0}" --cycles "${HIL_CANSMOKE_CYCLES:-5000}" --report "$HIL_OUT/cansmoke.json"
echo "report: $HIL_OUT/cansmoke.json"
