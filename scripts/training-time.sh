#!/usr/bin/env bash
# scripts/training-time.sh [--ref REV] [--seeds LIST] [--steps N] [--meshes LIST] [--repeat N] [--report-only] [OUT]
# Training time and quality of the default model against an earlier build's default, measured side
# by side in one run on this machine (OUT, default out/training-time):
#   1. builds `lsnif` of revision REV (default 6b426c3, the default before the training-time work of
#      docs/results.md "Training time") from `git archive` into OUT/ref-build (Release, native, as
#      scripts/build.sh; kept for the next run of the same revision);
#   2. per seed (1,2 by default), `lsnif bench-size MESHES --settings default --seed S` with REV's
#      build and with build/bin/lsnif (the order turns round every other seed so that a drifting
#      host favours neither): each trains the default model of bunny, armadillo and dragon
#      (data/meshes/bunny00.off, armadillo.off, ChineseDragon-10kv.off), times its training loop,
#      evaluates it on 100,000 held-out rays (the same seed in both builds) and renders it against
#      its triangles (FLIP; the same renderer in both builds).
#   3. with --repeat N (0-10, default 0), N more trainings of each mesh per build (`lsnif train`,
#      the first seed, timed only), the builds alternating, so that the ratio of the medians of
#      the N + seeds timings holds against a host whose pace drifts (2-3x between hosts of this
#      kind, 10-20% within minutes on one).
# Writes OUT/training-time.md (per mesh, build and seed: the training loop's seconds, the ratio to
# REV's, model size, held-out metrics, FLIP; then the means over the seeds; with --repeat, the
# medians of all timings) and OUT/log.txt.
# --report-only rewrites OUT/training-time.md from an earlier run's outputs. Measure on a quiet
# host: nothing else running.
set -euo pipefail
cd "$(dirname "$0")/.."

ref=6b426c3
seeds=1,2
steps=
meshes=bunny,armadillo,dragon
out=out/training-time
report_only=
repeat=0
usage() { sed -n '2,22p' "$0" | sed 's/^# \{0,1\}//'; }
die() { echo "training-time.sh: $*" >&2; exit 2; }
in_range() { [[ $1 =~ ^[0-9]+$ ]] && (( 10#$1 >= $2 && 10#$1 <= $3 )); }
while (($#)); do
  case "$1" in
    --ref) (($# >= 2)) || die "--ref needs a revision"; ref=$2; shift 2 ;;
    --seeds) (($# >= 2)) || die "--seeds needs a list"; seeds=$2; shift 2 ;;
    --steps) (($# >= 2)) && in_range "$2" 1 100000 || die "--steps takes a whole number in [1, 100000]"; steps=$2; shift 2 ;;
    --meshes) (($# >= 2)) || die "--meshes needs a list"; meshes=$2; shift 2 ;;
    --repeat) (($# >= 2)) && in_range "$2" 0 10 || die "--repeat takes a whole number in [0, 10]"; repeat=$2; shift 2 ;;
    --report-only) report_only=1; shift ;;
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
IFS=, read -r -a seed_list <<< "$seeds"
((${#seed_list[@]} >= 1 && ${#seed_list[@]} <= 5)) || die "--seeds takes 1 to 5 seeds"
for s in "${seed_list[@]}"; do
  in_range "$s" 0 1000000 || die "--seeds '$seeds': '$s' is not a whole number in [0, 1000000]"
done
lsnif=build/bin/lsnif
[[ -x $lsnif ]] || { echo "training-time.sh: $lsnif missing: run scripts/build.sh first" >&2; exit 1; }
rev=$(git rev-parse --verify --quiet "$ref^{commit}") || die "'$ref' is not a commit of this repository"

mkdir -p "$out"
log=$out/log.txt
[[ -n $report_only ]] || : > "$log"

# 1. The reference build (rebuilt when OUT holds another revision's).
ref_build=$out/ref-build
if [[ -z $report_only && ( ! -x $ref_build/bin/lsnif || $(cat "$ref_build/revision" 2>/dev/null) != "$rev" ) ]]; then
  echo "== building lsnif at ${rev:0:12} into $ref_build (several minutes)" | tee -a "$log" >&2
  rm -rf "$out/ref-src" "$ref_build"
  mkdir -p "$out/ref-src"
  git archive "$rev" | tar -x -C "$out/ref-src"
  { cmake -S "$out/ref-src" -B "$ref_build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DLSNIF_NATIVE=ON &&
    cmake --build "$ref_build" -j "$(nproc)" --target lsnif lsnif_image_oiio; } >> "$log" 2>&1 ||
    { tail -20 "$log" >&2; echo "training-time.sh: building revision ${rev:0:12} failed (log: $log)" >&2; exit 1; }
  echo "$rev" > "$ref_build/revision"
fi

# 2. One bench-size run per build and seed: its output into OUT/BUILD-sSEED.txt and the log.
bench() {
  local name=$1 bin=$2 seed=$3
  local dir=$out/$name-s$seed text=$out/$name-s$seed.txt
  echo "== $name, seed $seed: $bin bench-size $meshes --settings default --seed $seed ${steps:+--steps $steps}" |
    tee -a "$log" >&2
  "$bin" bench-size "${mesh_list[@]}" --settings default --seed "$seed" ${steps:+--steps "$steps"} --retrain \
    --data "$PWD/data" --out "$dir" > "$text" 2>&1 || { tail -20 "$text" >&2; echo "training-time.sh: bench-size of $name failed" >&2; exit 1; }
  cat "$text" >> "$log"
}
builds=(ref this)
for ((i = 0; i < ${#seed_list[@]} && !report_only; ++i)); do
  order=(ref this)
  ((i % 2)) && order=(this ref)
  for b in "${order[@]}"; do
    case $b in
      ref) bench ref "$ref_build/bin/lsnif" "${seed_list[i]}" ;;
      this) bench this "$lsnif" "${seed_list[i]}" ;;
    esac
  done
done

# 2b. --repeat: timing-only trainings, the builds alternating (and which goes first turning round).
timing=$out/timing
[[ -n $report_only ]] || rm -rf "$timing"  # no earlier run's timings in this run's report
if ((repeat && !report_only)); then
  mkdir -p "$timing"
  for ((r = 0; r < repeat; ++r)); do
    for m in "${mesh_list[@]}"; do
      order=(ref this)
      ((r % 2)) && order=(this ref)
      for b in "${order[@]}"; do
        bin=$lsnif
        [[ $b == ref ]] && bin=$ref_build/bin/lsnif
        echo "== timing $r: $b, $m" | tee -a "$log" >&2
        "$bin" train "data/meshes/${mesh_file[$m]}" -o "$timing/$m-$b-$r.lsnif" --seed "${seed_list[0]}" \
          ${steps:+--steps "$steps"} > "$timing/$m-$b-$r.txt" 2>&1 ||
          { tail -20 "$timing/$m-$b-$r.txt" >&2; echo "training-time.sh: timing training of $m by $b failed" >&2; exit 1; }
        grep '^trained ' "$timing/$m-$b-$r.txt" >> "$log"
      done
    done
  done
fi

# 3. The table: per mesh, build and seed, from bench-size's output.
section() {  # section TEXT MESH: the lines of MESH's '-- MESH, setting default' block
  awk -v m="-- $2, setting default" '$0 == m { on = 1; next } /^(-- |== )/ { on = 0 } on' "$1"
}
mean() { awk '{ for (i = 1; i <= NF; ++i) s += $i; printf "%.4f", s / NF }' <<< "$1"; }
md=$out/training-time.md
declare -A sum
{
  echo "Training time, \`scripts/training-time.sh --ref ${rev:0:12} --seeds $seeds${steps:+ --steps $steps} --meshes $meshes\`"
  echo "($(date -u +%Y-%m-%d\ %H:%M) UTC, $(nproc) threads; seconds: the training loop's, \`trained ... in\`; eval and"
  echo "FLIP: bench-size's, 100,000 held-out rays and its render against the triangles):"
  echo
  echo "| mesh | build | seed | seconds | / ${rev:0:7} | size (MiB) | occlusion acc | t err median | normal err median | FLIP |"
  echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"
  for m in "${mesh_list[@]}"; do
    for s in "${seed_list[@]}"; do
      ref_s=$(section "$out/ref-s$s.txt" "$m" | sed -n 's/^trained .* in \([0-9.]*\) s .*/\1/p')
      for b in "${builds[@]}"; do
        text=$out/$b-s$s.txt
        sec=$(section "$text" "$m" | sed -n 's/^trained .* in \([0-9.]*\) s .*/\1/p')
        flip=$(section "$text" "$m" | sed -n 's/.*LDR-FLIP of LSNIF vs reference: mean \([0-9.]*\).*/\1/p')
        [[ -n $sec && -n $ref_s && -n $flip ]] || { echo "training-time.sh: no time or FLIP for $m in $text" >&2; exit 1; }
        model=$out/$b-s$s/$m/default.lsnif
        # bench-size's eval line: "eval      occlusion A%, t error median B%, normal error median C deg (N rays)"
        read -r occ terr nerr < <(section "$text" "$m" |
          sed -n 's/^eval *occlusion \([0-9.]*\)%, t error median \([0-9.]*\)%, normal error median \([0-9.]*\) deg.*/\1 \2 \3/p') || true
        [[ -n $occ && -n $terr && -n $nerr ]] || { echo "training-time.sh: no eval line for $m in $text" >&2; exit 1; }
        size=$(stat -c %s "$model" | awk '{printf "%.3f", $1 / 1048576}')
        ratio=$(awk -v a="$sec" -v b="$ref_s" 'BEGIN { printf "%.2f", a / b }')
        label=$([[ $b == ref ]] && echo "${rev:0:7}'s default" || echo "this build's default")
        echo "| $m | $label | $s | $sec | ${ratio}x | $size | $occ% | $terr% | $nerr deg | $flip |"
        sum[$m.$b.sec]+="$sec "; sum[$m.$b.occ]+="$occ "; sum[$m.$b.terr]+="$terr "
        sum[$m.$b.nerr]+="$nerr "; sum[$m.$b.flip]+="$flip "
      done
    done
  done
  echo
  echo "Means over the seeds:"
  echo
  echo "| mesh | build | seconds | / ${rev:0:7} | occlusion acc | t err median | normal err median | FLIP |"
  echo "|---|---|---:|---:|---:|---:|---:|---:|"
  for m in "${mesh_list[@]}"; do
    ref_mean=$(mean "${sum[$m.ref.sec]}")
    for b in "${builds[@]}"; do
      sec=$(mean "${sum[$m.$b.sec]}")
      label=$([[ $b == ref ]] && echo "${rev:0:7}'s default" || echo "this build's default")
      printf '| %s | %s | %.1f | %.2fx | %.2f%% | %.3f%% | %.2f deg | %.4f |\n' "$m" "$label" "$sec" \
        "$(awk -v a="$sec" -v b="$ref_mean" 'BEGIN { print a / b }')" "$(mean "${sum[$m.$b.occ]}")" \
        "$(mean "${sum[$m.$b.terr]}")" "$(mean "${sum[$m.$b.nerr]}")" "$(mean "${sum[$m.$b.flip]}")"
    done
  done
  # The medians of every timing of a mesh (the seeds' and the repeated ones), when there are repeats.
  median() { tr ' ' '\n' <<< "$1" | sed '/^$/d' | sort -g | awk '{ v[NR] = $1 } END { printf "%.1f", NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
  if compgen -G "$timing/*-ref-*.txt" > /dev/null; then
    echo
    echo "All timings (the seeds' above and \`$timing\`'s repeats, the builds alternating), medians:"
    echo
    echo "| mesh | ${rev:0:7}'s default (s) | this build's default (s) | timings each | / ${rev:0:7}, medians |"
    echo "|---|---:|---:|---:|---:|"
    for m in "${mesh_list[@]}"; do
      all_ref=${sum[$m.ref.sec]} all_this=${sum[$m.this.sec]}
      for f in "$timing/$m"-ref-*.txt; do all_ref+="$(sed -n 's/^trained .* in \([0-9.]*\) s .*/\1/p' "$f") "; done
      for f in "$timing/$m"-this-*.txt; do all_this+="$(sed -n 's/^trained .* in \([0-9.]*\) s .*/\1/p' "$f") "; done
      n=$(wc -w <<< "$all_ref")
      mr=$(median "$all_ref") mt=$(median "$all_this")
      printf '| %s | %s (%s) | %s (%s) | %s | %.2fx |\n' "$m" "$mr" "$(xargs <<< "$all_ref")" "$mt" "$(xargs <<< "$all_this")" \
        "$n" "$(awk -v a="$mt" -v b="$mr" 'BEGIN { print a / b }')"
    done
  fi
} > "$md.tmp"
mv "$md.tmp" "$md"
cat "$md"
echo "training-time.sh: wrote $md" >&2
