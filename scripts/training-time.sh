#!/usr/bin/env bash
# scripts/training-time.sh [--ref REV] [--rounds N] [--steps N] [--meshes LIST] [OUT]
# Training time of the default model against an earlier build's default, measured side by side in
# one run on this machine (OUT, default out/training-time):
#   1. builds `lsnif` of revision REV (default 691a56d, the last commit whose default was the
#      paper's 16-bit hashed grid) from `git archive` into OUT/ref-build (Release, native, as
#      scripts/build.sh; kept for the next run of the same revision);
#   2. per mesh (bunny, armadillo, dragon by default: data/meshes/bunny00.off, armadillo.off,
#      ChineseDragon-10kv.off) and round, `lsnif train MESH` without options with REV's build and
#      with build/bin/lsnif, and this build with the former default grid (--grid-bits 16
#      --indexed 0); the order turns round every other round so that a drifting host favours none;
#   3. `lsnif eval` (this build, the same held-out rays) of each model of the first round.
# Writes OUT/training-time.md (per mesh and build: the training loop's seconds per round, their
# mean, the ratio to REV's default, the held-out metrics) and OUT/log.txt. Measure on a quiet host.
set -euo pipefail
cd "$(dirname "$0")/.."
here=$(pwd)

ref=691a56d
rounds=2
steps=
meshes=bunny,armadillo,dragon
out=out/training-time
usage() { sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'; }
die() { echo "training-time.sh: $*" >&2; exit 2; }
in_range() { [[ $1 =~ ^[0-9]+$ ]] && (( 10#$1 >= $2 && 10#$1 <= $3 )); }
while (($#)); do
  case "$1" in
    --ref) (($# >= 2)) || die "--ref needs a revision"; ref=$2; shift 2 ;;
    --rounds) (($# >= 2)) && in_range "$2" 1 5 || die "--rounds takes a whole number in [1, 5]"; rounds=$2; shift 2 ;;
    --steps) (($# >= 2)) && in_range "$2" 1 100000 || die "--steps takes a whole number in [1, 100000]"; steps=$2; shift 2 ;;
    --meshes) (($# >= 2)) || die "--meshes needs a list"; meshes=$2; shift 2 ;;
    -h|--help) usage; exit 0 ;;
    -*) die "unknown option '$1' (--help lists them)" ;;
    *) out=$1; shift ;;
  esac
done

declare -A mesh_file=([bunny]=bunny00.off [armadillo]=armadillo.off [dragon]=ChineseDragon-10kv.off)
IFS=, read -r -a mesh_list <<< "$meshes"
((${#mesh_list[@]})) || die "--meshes is empty"
for m in "${mesh_list[@]}"; do
  [[ -n $m ]] || die "--meshes '$meshes' has an empty name"
  [[ -n ${mesh_file[$m]+x} ]] || die "unknown mesh '$m' (bunny, armadillo, dragon)"
  [[ -f data/meshes/${mesh_file[$m]} ]] || { echo "training-time.sh: data/meshes/${mesh_file[$m]} missing: run scripts/setup.sh first" >&2; exit 1; }
done
lsnif=build/bin/lsnif
[[ -x $lsnif ]] || { echo "training-time.sh: $lsnif missing: run scripts/build.sh first" >&2; exit 1; }
rev=$(git rev-parse --verify --quiet "$ref^{commit}") || die "'$ref' is not a commit of this repository"

mkdir -p "$out"
log=$out/log.txt
: > "$log"

# 1. The reference build (rebuilt when OUT holds another revision's).
ref_build=$out/ref-build
if [[ ! -x $ref_build/bin/lsnif || $(cat "$ref_build/revision" 2>/dev/null) != "$rev" ]]; then
  echo "== building lsnif at ${rev:0:12} into $ref_build (a few minutes)" | tee -a "$log" >&2
  rm -rf "$out/ref-src" "$ref_build"
  mkdir -p "$out/ref-src"
  git archive "$rev" | tar -x -C "$out/ref-src"
  { cmake -S "$out/ref-src" -B "$ref_build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DLSNIF_NATIVE=ON &&
    cmake --build "$ref_build" -j "$(nproc)" --target lsnif; } >> "$log" 2>&1 ||
    { tail -20 "$log" >&2; echo "training-time.sh: building revision ${rev:0:12} failed (log: $log)" >&2; exit 1; }
  echo "$rev" > "$ref_build/revision"
fi

# 2. The trainings. One training: its command and output into the log; prints the loop's seconds.
train() {
  local name=$1 bin=$2 mesh=$3; shift 3
  local model=$out/$name.lsnif text=$out/$name.txt
  echo "== $name: $bin train $mesh -o $model ${steps:+--steps $steps} $*" | tee -a "$log" >&2
  "$bin" train "$mesh" -o "$model" ${steps:+--steps "$steps"} "$@" > "$text" 2>&1 ||
    { cat "$text" >&2; echo "training-time.sh: training $name failed" >&2; exit 1; }
  cat "$text" >> "$log"
  local s
  s=$(sed -n 's/^trained .* in \([0-9.]*\) s .*/\1/p' "$text")
  [[ -n $s ]] || { echo "training-time.sh: no training time in $text" >&2; exit 1; }
  echo "$s"
}
declare -A seconds
builds=(ref default former)
for ((r = 1; r <= rounds; ++r)); do
  order=("${builds[@]}")
  ((r % 2)) || order=(former default ref)
  for m in "${mesh_list[@]}"; do
    mesh=data/meshes/${mesh_file[$m]}
    for b in "${order[@]}"; do
      case $b in
        ref) s=$(train "$m.ref.r$r" "$ref_build/bin/lsnif" "$mesh") ;;
        default) s=$(train "$m.default.r$r" "$lsnif" "$mesh") ;;
        former) s=$(train "$m.former.r$r" "$lsnif" "$mesh" --grid-bits 16 --indexed 0) ;;
      esac
      seconds[$m.$b]+="$s "
    done
  done
done

# 3. Held-out metrics of the first round's models, and the table.
metric() {  # metric FILE PATTERN: the first capture of PATTERN on the 'model' line
  sed -n "s/^model .*$2.*/\\1/p" "$1" | head -1
}
md=$out/training-time.md
{
  echo "Training time, \`scripts/training-time.sh --ref ${rev:0:12} --rounds $rounds${steps:+ --steps $steps} --meshes $meshes\`"
  echo "($(date -u +%Y-%m-%d\ %H:%M) UTC, $(nproc) threads; the training loop's seconds, \`trained ... in\`):"
  echo
  echo "| mesh | build and model | seconds per round | mean | / ${rev:0:7}'s default | size (MiB) | occlusion acc | t err median | normal err median |"
  echo "|---|---|---|---:|---:|---:|---:|---:|---:|"
  for m in "${mesh_list[@]}"; do
    ref_mean=$(echo "${seconds[$m.ref]}" | awk '{for (i = 1; i <= NF; ++i) s += $i; printf "%.3f", s / NF}')
    for b in "${builds[@]}"; do
      label=$(case $b in ref) echo "${rev:0:7}, its default (16-bit, hashed)" ;;
                         default) echo "this build, the default" ;;
                         former) echo "this build, --grid-bits 16 --indexed 0" ;; esac)
      eval_text=$out/$m.$b.eval.txt
      "$lsnif" eval "$out/$m.$b.r1.lsnif" "data/meshes/${mesh_file[$m]}" > "$eval_text" 2>&1 ||
        { cat "$eval_text" >&2; echo "training-time.sh: lsnif eval of $m.$b.r1.lsnif failed" >&2; exit 1; }
      cat "$eval_text" >> "$log"
      mean=$(echo "${seconds[$m.$b]}" | awk '{for (i = 1; i <= NF; ++i) s += $i; printf "%.3f", s / NF}')
      ratio=$(awk -v a="$mean" -v b="$ref_mean" 'BEGIN { printf "%.2f", a / b }')
      mean=$(awk -v a="$mean" 'BEGIN { printf "%.1f", a }')
      size=$(stat -c %s "$out/$m.$b.r1.lsnif" | awk '{printf "%.3f", $1 / 1048576}')
      echo "| $m | $label | ${seconds[$m.$b]% } | $mean | ${ratio}x | $size | $(metric "$eval_text" 'occlusion acc *\([0-9.]*%\)') |" \
           "$(metric "$eval_text" 't err median \([0-9.]*%\)') | $(metric "$eval_text" 'normal err median *\([0-9.]*\) deg') deg |"
    done
  done
} > "$md.tmp"
mv "$md.tmp" "$md"
cat "$md"
echo "training-time.sh: wrote $md" >&2
