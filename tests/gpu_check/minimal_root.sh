#!/usr/bin/env bash
# tests/gpu_check/minimal_root.sh DIR OUT [check options]: runs the GPU check folder DIR (built by
# scripts/gpu-check.sh) inside a minimal root where none of the build's packages are installed:
# glibc, /bin/sh, and Mesa's lavapipe driver (its ICD file, libvulkan_lvp.so and the libraries it
# links). No Vulkan loader, no libstdc++ of the toolchain beyond what the driver links, no
# OpenImageIO, Embree, GLFW, GoogleTest or validation layer. Copies the check's report.json and
# images to OUT and exits non-zero unless the check passed. Needs root (chroot), else unprivileged
# user namespaces (unshare --map-root-user).
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: tests/gpu_check/minimal_root.sh DIR OUT [check options]" >&2; exit 2; }
dir=$(cd "$1" && pwd); out=$2; shift 2
[ -x "$dir/run" ] || { echo "minimal_root.sh: $dir is not a GPU check folder (no run)" >&2; exit 1; }
# The folder's programs and libraries look for libraries in the folder only: a RUNPATH of the build
# tree would load the build's libraries wherever that path exists (on the machine that built it).
for f in "$dir"/bin/* "$dir"/lib/*; do
  paths=$(readelf -d "$f" 2>/dev/null | sed -n 's/.*(R\(UN\)\{0,1\}PATH).*\[\(.*\)\]/\2/p')
  for p in ${paths//:/ }; do
    case "$p" in '$ORIGIN'|'$ORIGIN/'*) ;; *)
      echo "minimal_root.sh: $f has the library path $p outside the folder" >&2; exit 1 ;; esac
  done
done
root=$(mktemp -d "${TMPDIR:-/tmp}/lsnif-minimal-root.XXXXXX")
trap 'rm -rf "$root"' EXIT

# copy FILE...: each file (links followed) at its own path inside the root.
copy() {
  local f
  for f in "$@"; do
    mkdir -p "$root$(dirname "$f")"
    cp -L "$f" "$root$f"
  done
}
libs_of() { ldd "$1" | awk '$2 == "=>" && $3 ~ /^\// {print $3} $1 ~ /^\/lib64\// {print $1}'; }

# glibc's libraries and loader, and a shell.
for f in /lib/x86_64-linux-gnu/lib{c,m,dl,pthread,rt}.so.* /lib64/ld-linux-x86-64.so.2; do
  [ -e "$f" ] && copy "$f"
done
mkdir -p "$root/bin"
cp -L /bin/sh "$root/bin/sh"
for f in $(libs_of /bin/sh); do copy "$f"; done
# lavapipe: the ICD manifest, the driver and every library it links.
# (Filters that read their whole input: an early exit would end the writer with SIGPIPE, which
# pipefail turns into this script's failure; `ldconfig -p` writes more than a pipe holds.)
icd=$(ls /usr/share/vulkan/icd.d/lvp_icd*.json | sed -n 1p)
driver=$(sed -n 's/.*"library_path": *"\([^"]*\)".*/\1/p' "$icd")
case "$driver" in /*) ;; *) driver=$(ldconfig -p | awk -v n="$(basename "$driver")" '$1 == n && !found {print $NF; found = 1}') ;; esac
copy "$icd" "$driver"
for f in $(libs_of "$driver"); do copy "$f"; done
for f in libvulkan.so.1 libOpenImageIO.so.2.4 libembree3.so.3 libglfw.so.3 libtbb.so.12; do
  if [ -e "$root/lib/x86_64-linux-gnu/$f" ] || [ -e "$root/usr/lib/x86_64-linux-gnu/$f" ]; then
    echo "minimal_root.sh: $f came into the root with the driver; the root would not prove the folder self-contained" >&2
    exit 1
  fi
done
mkdir -p "$root/check" "$root/out" "$root/tmp"
cp -a "$dir/." "$root/check/"
echo "minimal root: $(du -sh "$root" | cut -f1) in $root ($(find "$root" -type f | wc -l) files)"

run=("$(command -v chroot)" "$root" /bin/sh /check/run /out "$@")
[ "$(id -u)" -eq 0 ] || run=("$(command -v unshare)" --map-root-user "${run[@]}")
status=0
env -i PATH=/bin TMPDIR=/tmp "${run[@]}" || status=$?
mkdir -p "$out"
cp "$root/out/"* "$out/" 2>/dev/null || true
[ -f "$out/report.json" ] || { echo "minimal_root.sh: the check wrote no report.json (exit $status)" >&2; exit 1; }
[ $status -eq 0 ] || { echo "minimal_root.sh: the check failed (exit $status); see $out/report.json" >&2; exit 1; }
echo "minimal_root.sh: the check passed inside the minimal root; report in $out/report.json"
