#!/usr/bin/env bash
# Runs the whole CTest suite of a build folder (default build/). Fails on any failure or on no test.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build="${BUILD_DIR:-$here/build}"
ctest --test-dir "$build" --output-on-failure --no-tests=error -j "$(nproc)" "$@"
