#!/usr/bin/env bash
# Configures and builds LSNIF (Release) into build/ with Ninja. Extra arguments go to CMake's
# configure step (e.g. -DLSNIF_SANITIZE=ON). BUILD_DIR overrides the folder.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build="${BUILD_DIR:-$here/build}"
cmake -S "$here" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build "$build" -j "$(nproc)"
