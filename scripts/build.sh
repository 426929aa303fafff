#!/usr/bin/env bash
# Configures and builds LSNIF (Release) into build/ with Ninja, optimized for this machine
# (-DLSNIF_NATIVE=ON: -march=native). Packages (cmake --install, cpack) meant for other machines are
# built without it: LSNIF_NATIVE is off by default, so configure such a build folder yourself or pass
# -DLSNIF_NATIVE=OFF here. Extra arguments go to CMake's configure step (e.g. -DLSNIF_SANITIZE=ON).
# BUILD_DIR overrides the folder.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build="${BUILD_DIR:-$here/build}"
cmake -S "$here" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DLSNIF_NATIVE=ON "$@" >/dev/null
cmake --build "$build" -j "$(nproc)"
