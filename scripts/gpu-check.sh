#!/usr/bin/env bash
# scripts/gpu-check.sh DIR [--quick] [--test-models FROM]: builds the GPU check folder DIR (docs/gpu-check.md), at most
# 40 MiB, that runs on a bare x86-64 Linux with glibc and a Vulkan driver only:
#   DIR/run OUT [lsnif-gpu check options]   runs the check, writes OUT/report.json and <= 6 images
#   DIR/bin/     lsnif-gpu and the portable GPU conformance tests (no OpenImageIO, Embree or GLFW)
#   DIR/lib/     the plugin, libstdc++, libgcc_s, libgomp and the Vulkan loader
#   DIR/data/    the meshes, the foliage scene's sprites, and the bench scenes' environments as .hdr
#                (the portable image reader's)
#   DIR/models/  tests/ (the conformance tests' models), trace/ (bench-trace's bunny), bench/ (the
#                bench scenes' models: default and low)
# Needs the Release build of scripts/build.sh (BUILD_DIR overrides build/); trains what it carries
# here, reusing the bench models of an earlier run in BUILD/gpu-check-models (lsnif bench reuses a
# model whose mesh and settings are unchanged). --quick: tiny models of the bunny scene only, for the
# smoke run CI makes (tests/gpu_check/minimal_root.sh). --test-models FROM: the conformance tests'
# models from a folder a test run filled (LSNIF_TEST_MODELS=FROM scripts/test.sh, as .ci/run does)
# instead of running the training tests again; a portable test refuses a model whose key differs.
# DIR must not exist or be empty.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build="${BUILD_DIR:-$here/build}"
max_bytes=$((40 * 1024 * 1024))

usage() { echo "usage: scripts/gpu-check.sh DIR [--quick] [--test-models FROM]" >&2; exit 2; }
[ $# -ge 1 ] || usage
dir=$1; shift
quick=0
test_models_from=""
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=1 ;;
    --test-models) [ $# -ge 2 ] || usage; test_models_from=$2; shift ;;
    *) echo "gpu-check.sh: unknown option '$1'" >&2; usage ;;
  esac
  shift
done
if [ -n "$test_models_from" ] && ! ls "$test_models_from"/*.key >/dev/null 2>&1; then
  echo "gpu-check.sh: --test-models $test_models_from holds no models (NAME.lsnif and NAME.key)" >&2; exit 1
fi
if [ -e "$dir" ] && [ -n "$(ls -A "$dir" 2>/dev/null)" ]; then
  echo "gpu-check.sh: $dir exists and is not empty; give a new folder" >&2; exit 1
fi
[ -f "$build/build.ninja" ] || { echo "gpu-check.sh: no build in $build: run scripts/build.sh first" >&2; exit 1; }

tests=(gpu_reference_test rt_conformance_test plugin_test render_test)
echo "== building lsnif, lsnif-gpu and the GPU tests (both variants)"
targets=(lsnif lsnif-gpu lsnif_vk)
for t in "${tests[@]}"; do targets+=("$t" "${t}_portable"); done
cmake --build "$build" -j "$(nproc)" --target "${targets[@]}"

mkdir -p "$dir"/{bin,lib,data/meshes,data/hdr,data/textures,models/tests,models/trace,models/bench}
dir=$(cd "$dir" && pwd)
# A failure leaves no half-built folder behind.
trap 'status=$?; if [ $status -ne 0 ]; then rm -rf "$dir"; echo "gpu-check.sh: failed; removed $dir" >&2; fi' EXIT

if [ -n "$test_models_from" ]; then
  echo "== the conformance tests' models, from $test_models_from"
  cp "$test_models_from"/*.lsnif "$test_models_from"/*.key "$dir/models/tests/"
else
  echo "== the conformance tests' models (the training build of each test saves them)"
  pids=()
  for t in "${tests[@]}"; do
    LSNIF_TEST_MODELS="$dir/models/tests" LSNIF_TEST_VALIDATION=0 MESA_SHADER_CACHE_DIR="$build/tests/gpu/mesa_shader_cache" \
      "$build/bin/$t" > "$build/gpu-check-$t.log" 2>&1 &
    pids+=($!)
  done
  for i in "${!pids[@]}"; do
    wait "${pids[$i]}" || { echo "gpu-check.sh: ${tests[$i]} failed (log: $build/gpu-check-${tests[$i]}.log)" >&2; exit 1; }
  done
fi

echo "== bench-trace's bunny model"
if [ $quick -eq 1 ]; then train_preset=(--tiny); else train_preset=(); fi
"$build/bin/lsnif" train "$here/data/meshes/bunny00.off" -o "$dir/models/trace/bunny.lsnif" --quiet \
  "${train_preset[@]}" --csv "$build/gpu-check-trace-bunny.csv"

echo "== the bench scenes' models"
if [ $quick -eq 1 ]; then scenes=(bunny); bench_opts=(--quick); models="$build/gpu-check-models-quick"
else scenes=(bunny dragons heavy foliage grid); bench_opts=(); models="$build/gpu-check-models"; fi
"$build/bin/lsnif" bench "${scenes[@]}" --quality default,low --no-render --out "$models" "${bench_opts[@]}"
for s in "${scenes[@]}"; do
  mkdir -p "$dir/models/bench/$s"
  cp "$models/$s/"*.lsnif "$models/$s/"*.lsnif.key "$dir/models/bench/$s/"
done

echo "== programs, libraries, meshes, environments"
for t in "${tests[@]}"; do strip --strip-unneeded -o "$dir/bin/$t" "$build/bin/portable/$t"; done
strip --strip-unneeded -o "$dir/bin/lsnif-gpu" "$build/bin/lsnif-gpu"
# Every shared library the programs need beyond glibc, and the Vulkan loader (volk opens it at run time).
libs=$(for f in "$dir"/bin/*; do ldd "$f"; done | awk '$2 == "=>" && $3 ~ /^\// {print $3}' | sort -u)
for lib in $libs /lib/x86_64-linux-gnu/libvulkan.so.1; do
  case "$(basename "$lib")" in
    libc.so.*|libm.so.*|libdl.so.*|libpthread.so.*|librt.so.*|ld-linux*) continue ;;
  esac
  strip --strip-unneeded -o "$dir/lib/$(basename "$lib")" "$(readlink -f "$lib")"
done
# The build tree's RUNPATH would load the build's libraries wherever that path exists: the folder's
# programs and libraries look in the folder's own lib/ only (after ldd above, which needed the build's).
for f in "$dir"/bin/*; do patchelf --set-rpath '$ORIGIN/../lib' "$f"; done
for f in "$dir"/lib/*; do
  if [ -n "$(patchelf --print-rpath "$f")" ]; then patchelf --set-rpath '$ORIGIN' "$f"; fi
done
for m in elephant.off bunny00.off armadillo.off ChineseDragon-10kv.off; do cp "$here/data/meshes/$m" "$dir/data/meshes/"; done
cp "$here"/data/textures/*.png "$dir/data/textures/"  # the foliage scene's alpha-tested sprites
# As Radiance HDR at 512x256 (0.5 MiB each instead of 1.9 at full size: the folder must stay within
# 40 MiB with ten 1.6 MiB bench models); both renders of a row see the same environment.
for e in forest sunset city courtyard; do oiiotool "$here/data/hdr/$e.exr" --resize 512x256 -o "$dir/data/hdr/$e.hdr"; done

cat > "$dir/run" <<'EOF'
#!/bin/sh
# DIR/run OUT [options]: the LSNIF GPU check (lsnif-gpu check --help lists the options; the device:
# --device or LSNIF_DEVICE). Needs glibc and a Vulkan driver; carries everything else.
here=$(cd "${0%/*}" && pwd) || exit 1
LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export LD_LIBRARY_PATH
exec "$here/bin/lsnif-gpu" check "$@" --folder "$here"
EOF
chmod +x "$dir/run"
git -C "$here" rev-parse HEAD > "$dir/COMMIT" 2>/dev/null || echo unknown > "$dir/COMMIT"

bytes=$(du -sb "$dir" | cut -f1)
echo "== $dir: $(awk -v b="$bytes" 'BEGIN { printf "%.1f MiB", b / 1048576 }') (at most 40 MiB)"
if [ "$bytes" -gt "$max_bytes" ]; then
  echo "gpu-check.sh: the folder holds $bytes bytes, more than 40 MiB" >&2; du -sh "$dir"/* >&2; exit 1
fi
echo "run it with: $dir/run OUT"
