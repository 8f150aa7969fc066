#!/usr/bin/env bash
# Every test: the Rust workspace, the Blender add-on with the command it built
# (tools/test-blender.sh), then the Python package (tools/test-python.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --workspace --release
tools/test-blender.sh
tools/test-python.sh
