#!/usr/bin/env bash
# Every test: the Rust workspace, then the Python package (tools/test-python.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --workspace --release
tools/test-python.sh
