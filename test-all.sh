#!/usr/bin/env bash
# Every test: the cargo test suite (unit, integration, golden, property, doc tests), then the
# vcan hardware-in-the-loop suite (simdrive and cnc402 as separate processes on a real vcan0;
# in an emulated Debian kernel where this kernel has no CAN, see hil-tests/README.md).
set -euo pipefail
cd "$(dirname "$0")"
cargo test --workspace --locked
bash hil-tests/suite.sh
