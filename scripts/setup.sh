#!/usr/bin/env bash
# One-time, idempotent setup for a fresh Debian 12 (bookworm): installs every Debian package the
# project uses (toolchain, CPU training/reference stack, Vulkan stack with Mesa 25 lavapipe from
# bookworm-backports) and fetches the real test meshes and the Khronos glTF validator (npm) into data/
# (ignored by git).
# Run as root, or as a user with sudo. Safe to run again: it only does what is missing.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
data_dir="${LSNIF_DATA_DIR:-$here/data}"

if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then exec sudo -E LSNIF_DATA_DIR="$data_dir" bash "$0" "$@"; fi
  echo "setup.sh: must run as root (or with sudo available)" >&2; exit 1
fi
export DEBIAN_FRONTEND=noninteractive

. /etc/os-release
if [ "${VERSION_CODENAME:-}" != "bookworm" ]; then
  echo "setup.sh: expected Debian 12 (bookworm), found '${PRETTY_NAME:-unknown}'" >&2; exit 1
fi

# --- 1. bookworm-backports, copied from the machine's own Debian entry (no host name written here).
bp_file=/etc/apt/sources.list.d/lsnif-bookworm-backports.sources
if ! grep -rqs 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
  uris="" signed=""
  for f in /etc/apt/sources.list.d/*.sources; do
    [ -f "$f" ] || continue
    # Walk deb822 stanzas; take the first one whose Suites has plain 'bookworm' and whose URIs is not a security mirror.
    read -r uris signed < <(awk '
      BEGIN { RS=""; FS="\n" }
      {
        u=""; s=""; su=""; t="";
        for (i=1;i<=NF;i++) {
          if ($i ~ /^URIs:/)      { u=$i; sub(/^URIs:[ \t]*/,"",u) }
          if ($i ~ /^Signed-By:/) { s=$i; sub(/^Signed-By:[ \t]*/,"",s) }
          if ($i ~ /^Suites:/)    { su=" " $i " " }
          if ($i ~ /^Types:/)     { t=$i }
        }
        if (t ~ /deb( |$)/ && su ~ / bookworm / && u !~ /security/ && u != "") { print u, s; exit }
      }' "$f") || true
    [ -n "$uris" ] && break
  done
  if [ -z "$uris" ] && [ -f /etc/apt/sources.list ]; then
    # One-line format: deb [signed-by=...] URI bookworm main
    line=$(grep -E '^deb(\s|\s\[)[^#]*\sbookworm\s' /etc/apt/sources.list | grep -v security | head -n1 || true)
    if [ -n "$line" ]; then
      signed=$(sed -n 's/.*signed-by=\([^] ]*\).*/\1/p' <<<"$line")
      uris=$(sed -E 's/^deb\s+(\[[^]]*\]\s+)?//' <<<"$line" | awk '{print $1}')
    fi
  fi
  if [ -z "$uris" ]; then
    echo "setup.sh: found no Debian 'bookworm' apt entry to copy for bookworm-backports" >&2; exit 1
  fi
  [ -n "$signed" ] || signed=/usr/share/keyrings/debian-archive-keyring.gpg
  printf 'Types: deb\nURIs: %s\nSuites: bookworm-backports\nComponents: main\nSigned-By: %s\n' \
    "$uris" "$signed" > "$bp_file"
  echo "setup.sh: enabled bookworm-backports from $uris"
fi

# --- 2. packages
packages=(
  build-essential cmake ninja-build pkg-config git ca-certificates xz-utils
  file binutils  # cpack -G DEB (file, dpkg-shlibdeps) and the package test (nm, readelf, strings)
  patchelf  # scripts/gpu-check.sh: the folder's programs find its lib/ ($ORIGIN/../lib), not the build's
  universal-ctags  # tests/lint/long_functions.sh measures function lengths
  libgtest-dev libgmock-dev
  libembree-dev libeigen3-dev
  libtinygltf-dev nlohmann-json3-dev libstb-dev libglm-dev libre2-dev
  glslang-tools glslang-dev spirv-tools
  libvulkan-dev libvulkan-volk-dev vulkan-validationlayers vulkan-tools
  libglfw3-dev libopenimageio-dev openimageio-tools
  xvfb xauth
  nodejs curl  # the Khronos glTF validator (npm's gltf-validator, fetched below) checks the glTF we write
  slurm-wlm munge  # the cluster test: a single-node Slurm job array (tests/cluster/slurm_local.sh)
  python3-dev pybind11-dev python3-numpy  # the Python module (src/lsnif/python, docs/python.md)
  python3-pytest python3-matplotlib     # its tests (tests/python) and its example (samples/python)
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
mesa_ok=0
v=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || true)
if [ -n "$v" ] && dpkg --compare-versions "$v" ge 25; then mesa_ok=1; fi
if [ ${#missing[@]} -gt 0 ] || [ $mesa_ok -eq 0 ]; then
  apt-get update -q
  [ ${#missing[@]} -gt 0 ] && apt-get install -y -q --no-install-recommends "${missing[@]}"
  if [ $mesa_ok -eq 0 ]; then
    apt-get install -y -q --no-install-recommends -t bookworm-backports mesa-vulkan-drivers
  fi
fi

# --- 3. test data from Debian packages (extracted, not installed)
fetch_deb() {  # fetch_deb PACKAGE WORKDIR -> extracts the package's files into WORKDIR/root
  local pkg=$1 work=$2
  mkdir -p "$work/root"
  (cd "$work" && apt-get download -q "$pkg" >/dev/null)
  dpkg-deb -x "$work"/"$pkg"_*.deb "$work/root"
}
mkdir -p "$data_dir/meshes" "$data_dir/gltf" "$data_dir/hdr"
if [ ! -f "$data_dir/meshes/bunny00.off" ] || [ ! -f "$data_dir/meshes/armadillo.off" ] \
   || [ ! -f "$data_dir/meshes/ChineseDragon-10kv.off" ]; then
  tmp=$(mktemp -d); chmod 755 "$tmp"; chown _apt "$tmp" 2>/dev/null || true; trap 'rm -rf "$tmp"' EXIT
  fetch_deb libcgal-demo "$tmp"
  tarball=$(find "$tmp/root" -name data.tar.gz | head -n1)
  [ -n "$tarball" ] || { echo "setup.sh: libcgal-demo has no data.tar.gz" >&2; exit 1; }
  mkdir -p "$tmp/cgal" && tar -xzf "$tarball" -C "$tmp/cgal"
  for m in bunny00.off armadillo.off ChineseDragon-10kv.off elephant.off; do
    src=$(find "$tmp/cgal" -name "$m" | head -n1)
    [ -n "$src" ] || { echo "setup.sh: $m not found in libcgal-demo data" >&2; exit 1; }
    cp "$src" "$data_dir/meshes/$m"
  done
  rm -rf "$tmp"; trap - EXIT
fi
if [ ! -f "$data_dir/gltf/.fetched" ]; then
  tmp=$(mktemp -d); chmod 755 "$tmp"; chown _apt "$tmp" 2>/dev/null || true; trap 'rm -rf "$tmp"' EXIT
  fetch_deb assimp-testmodels "$tmp"
  gl=$(find "$tmp/root" -type d -name glTF2 | head -n1)
  [ -n "$gl" ] || { echo "setup.sh: assimp-testmodels has no glTF2 folder" >&2; exit 1; }
  cp -r "$gl"/. "$data_dir/gltf/"
  touch "$data_dir/gltf/.fetched"
  rm -rf "$tmp"; trap - EXIT
fi
if [ ! -f "$data_dir/hdr/.fetched" ]; then  # CC0 HDR environments of Blender's studio lights
  tmp=$(mktemp -d); chmod 755 "$tmp"; chown _apt "$tmp" 2>/dev/null || true; trap 'rm -rf "$tmp"' EXIT
  fetch_deb blender-data "$tmp"
  world=$(find "$tmp/root" -type d -path '*studiolights/world' | head -n1)
  [ -n "$world" ] || { echo "setup.sh: blender-data has no studiolights/world folder" >&2; exit 1; }
  cp "$world"/*.exr "$data_dir/hdr/"
  ls "$data_dir/hdr/"*.exr >/dev/null 2>&1 || { echo "setup.sh: no .exr in blender-data's studiolights/world" >&2; exit 1; }
  touch "$data_dir/hdr/.fetched"
  rm -rf "$tmp"; trap - EXIT
fi
if [ ! -f "$data_dir/textures/.fetched" ]; then  # alpha-tested plant sprites (Minetest Game, CC BY-SA 3.0)
  tmp=$(mktemp -d); chmod 755 "$tmp"; chown _apt "$tmp" 2>/dev/null || true; trap 'rm -rf "$tmp"' EXIT
  fetch_deb minetest-data "$tmp"
  mkdir -p "$data_dir/textures"
  for t in default_aspen_leaves.png default_fern_3.png; do
    src=$(find "$tmp/root" -path '*minetest_game/mods/default/textures/*' -name "$t" | head -n1)
    [ -n "$src" ] || { echo "setup.sh: $t not found in minetest-data" >&2; exit 1; }
    cp "$src" "$data_dir/textures/$t"
  done
  touch "$data_dir/textures/.fetched"
  rm -rf "$tmp"; trap - EXIT
fi
# --- 4. the Khronos glTF validator from npm's registry (the tests run it on every glTF the tools
# write, tests/gltf_validator/validate_gltf.js); a pinned version, checked against its sha512.
gv_version=2.0.0-dev.3.10
gv_sha512=a1d278934b519065e20c69fbf320c183e7c16c022f0675f187747002d6b47a64b11adc9a80513c078c442c1d6861edd2e510fc0a2dee640b1969ab1c1f62c011
gv_dir="$data_dir/npm/gltf-validator"
if [ "$(cat "$gv_dir/.fetched" 2>/dev/null)" != "$gv_version" ]; then
  tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
  curl -fsSL --retry 3 -o "$tmp/gv.tgz" "https://registry.npmjs.org/gltf-validator/-/gltf-validator-$gv_version.tgz" \
    || { echo "setup.sh: cannot download gltf-validator $gv_version from registry.npmjs.org" >&2; exit 1; }
  echo "$gv_sha512  $tmp/gv.tgz" | sha512sum -c --quiet - \
    || { echo "setup.sh: gltf-validator $gv_version does not match its pinned sha512" >&2; exit 1; }
  tar xzf "$tmp/gv.tgz" -C "$tmp"
  rm -rf "$gv_dir" && mkdir -p "$(dirname "$gv_dir")" && mv "$tmp/package" "$gv_dir"
  echo "$gv_version" > "$gv_dir/.fetched"
  rm -rf "$tmp"; trap - EXIT
fi

chmod -R a+rX "$data_dir" 2>/dev/null || true
echo "setup.sh: ready (packages installed, data in $data_dir)"
