#!/usr/bin/env bash
# Every test: the cargo test suite, then the vcan hardware-in-the-loop suite.
set -euo pipefail
cd "$(dirname "$0")"
cargo test --workspace --locked
