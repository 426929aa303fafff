#!/usr/bin/env bash
# scripts/where-it-stands.sh [--update-readme] [OUT]: the numbers of the README's "Where it stands"
# from one run on this machine (OUT, default out/where-it-stands):
#   1. `lsnif train` of the bunny with the defaults, then with the former default grid (fp16, both
#      levels hashed: --grid-bits 16 --indexed 0), one after another: training times and their ratio;
#   2. `lsnif demo --reuse` on the default model: the held-out evaluation and the render summary
#      (reference on the fastest triangle path, LSNIF with the pipeline chosen for the device, and
#      the inline path);
#   3. `lsnif eval` of the former default model;
#   4. the host's GEMM speed (`lsnif bench-trace`'s CPU GEMM of the same network), to scale by.
# Writes OUT/where-it-stands.md; with --update-readme also replaces the block between the README's
# "where-it-stands" markers with it. Measure on a quiet host: the times are this machine's.
set -euo pipefail
cd "$(dirname "$0")/.."

update=0
out=out/where-it-stands
for arg in "$@"; do
  case "$arg" in
    --update-readme) update=1 ;;
    -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "where-it-stands.sh: unknown option '$arg'" >&2; exit 2 ;;
    *) out=$arg ;;
  esac
done
lsnif=build/bin/lsnif
mesh=data/meshes/bunny00.off
for f in "$lsnif" "$mesh"; do
  [[ -e $f ]] || { echo "where-it-stands.sh: $f missing: run scripts/setup.sh && scripts/build.sh first" >&2; exit 1; }
done
if ((update)) && ! grep -q '^<!-- where-it-stands: begin' README.md; then
  echo "where-it-stands.sh: README.md has no '<!-- where-it-stands: begin' marker" >&2
  exit 1
fi
mkdir -p "$out"
log=$out/log.txt
: > "$log"

# One step: its command into the log, its output into the log and $out/STEP.txt.
step() {
  local name=$1; shift
  echo "== $name: $*" | tee -a "$log" >&2
  "$@" > "$out/$name.txt" 2>&1 || { cat "$out/$name.txt" >&2; echo "where-it-stands.sh: step $name failed" >&2; exit 1; }
  cat "$out/$name.txt" >> "$log"
}
seconds() { sed -n 's/^trained .* in \([0-9.]*\) s .*/\1/p' "$1"; }

step train-default "$lsnif" train "$mesh" -o "$out/bunny.lsnif"
step train-former "$lsnif" train "$mesh" -o "$out/bunny.former.lsnif" --grid-bits 16 --indexed 0
step demo "$lsnif" demo --reuse -o "$out/bunny.lsnif" --picture "$out/bunny_compare.png"
step eval-former "$lsnif" eval "$out/bunny.former.lsnif" "$mesh"
step gemm "$lsnif" bench-trace "$mesh" "$out/bunny.lsnif" --rays 4096 --repeat 1

t_new=$(seconds "$out/train-default.txt")
t_old=$(seconds "$out/train-former.txt")
[[ -n $t_new && -n $t_old ]] || { echo "where-it-stands.sh: no training time in the train output" >&2; exit 1; }
bytes_new=$(stat -c %s "$out/bunny.lsnif")
bytes_old=$(stat -c %s "$out/bunny.former.lsnif")
gemm=$(grep -o '[0-9.e+]* GFLOP/s in the GEMMs' "$out/gemm.txt" | head -1 | sed 's/ in the GEMMs//')
[[ -n $gemm ]] || { echo "where-it-stands.sh: no GEMM speed in the bench-trace output" >&2; exit 1; }
cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)

md=$out/where-it-stands.md
{
  echo "<!-- where-it-stands: begin (scripts/where-it-stands.sh --update-readme writes this block) -->"
  echo "Measured by \`scripts/where-it-stands.sh\` on $(date -u +%Y-%m-%d) ($(nproc) threads of ${cpu:-an unknown CPU}; the"
  echo "CPU GEMM of the same network, \`lsnif bench-trace\`'s, runs at $gemm here: scale by it)."
  echo
  echo "| model (bunny) | file | training | occlusion acc | median t error | median normal error |"
  echo "|---|---:|---:|---:|---:|---:|"
  row() {  # label, bytes, seconds, the output with `lsnif eval`'s "model" line
    local acc t n
    acc=$(sed -n 's/^model *occlusion acc *\([0-9.]*%\).*/\1/p' "$4" | head -1)
    t=$(sed -n 's/^model .*t err median \([0-9.]*%\).*/\1/p' "$4" | head -1)
    n=$(sed -n 's/^model .*normal err median *\([0-9.]*\) deg.*/\1 deg/p' "$4" | head -1)
    [[ -n $acc && -n $t && -n $n ]] || { echo "where-it-stands.sh: no eval metrics in $4" >&2; exit 1; }
    echo "| $1 | $(awk -v b="$2" 'BEGIN{printf "%.3f MiB", b/1048576}') | $3 s | $acc | $t | $n |"
  }
  row "default (8-bit grid, coarse level indexed)" "$bytes_new" "$t_new" "$out/demo.txt"
  row "former default (fp16, both levels hashed)" "$bytes_old" "$t_old" "$out/eval-former.txt"
  echo
  echo "Training time of the default: $(awk -v a="$t_new" -v b="$t_old" 'BEGIN{printf "%.2f", a/b}')x the former default's (one run, one after the other)."
  echo "The demo's renders (\`lsnif demo\`, its summary as printed):"
  echo
  echo '```text'
  sed -n '/^summary:/,/^  (time:/p' "$out/demo.txt" | sed "s|$PWD/||g"
  echo '```'
  echo "<!-- where-it-stands: end -->"
} > "$md.tmp"
mv "$md.tmp" "$md"
echo "wrote $md" >&2
if ((update)); then
  awk -v block="$md" '
    /^<!-- where-it-stands: begin/ { while ((getline line < block) > 0) print line; skip = 1; next }
    /^<!-- where-it-stands: end/ { skip = 0; next }
    !skip { print }' README.md > README.md.tmp
  mv README.md.tmp README.md
  echo "updated README.md" >&2
fi
