#!/usr/bin/env bash
# long_functions.sh SRC_DIR DOC LIMIT: fails when a function in product code (SRC_DIR, without
# *_test.cpp and the test helpers of lsnif/testing/) is longer than LIMIT lines and DOC does not
# list it with a reason, as a table row naming `path` `function` (docs/architecture.md, "Function
# size"). Lengths come from universal-ctags (C++ for C/C++ sources, C for GLSL), first to last line.
set -euo pipefail
src=$1 doc=$2 limit=$3
if ! ctags --version 2>/dev/null | grep -q 'Universal Ctags'; then
  echo "long_functions.sh: universal-ctags is not installed (Debian package universal-ctags; scripts/setup.sh installs it)" >&2
  exit 1
fi
root=$(cd "$src/.." && pwd)
cd "$root"
mapfile -t cpp < <(find src -type f \( -name '*.cpp' -o -name '*.h' -o -name '*.hpp' -o -name '*.c' \) \
  ! -name '*_test.cpp' ! -path 'src/lsnif/testing/*' | sort)
mapfile -t glsl < <(find src -type f \( -name '*.glsl' -o -name '*.comp' -o -name '*.rgen' -o -name '*.rchit' \
  -o -name '*.rmiss' -o -name '*.rint' -o -name '*.frag' -o -name '*.vert' \) | sort)
[ ${#cpp[@]} -gt 100 ] || { echo "long_functions.sh: found only ${#cpp[@]} C++ files under $root/src" >&2; exit 1; }
{
  ctags --fields=+ne --kinds-C++=f --language-force=C++ -o - "${cpp[@]}"
  ctags --fields=+ne --kinds-C=f --language-force=C -o - "${glsl[@]}"
} | awk -F'\t' '{ ln = ""; en = "";
    for (i = 4; i <= NF; i++) { if ($i ~ /^line:/) ln = substr($i, 6); if ($i ~ /^end:/) en = substr($i, 5) }
    if (en != "") print en - ln + 1 "\t" $2 "\t" $1 }' > /tmp/lsnif_long_functions.$$
measured=$(wc -l < /tmp/lsnif_long_functions.$$)
fail=0 long=0
while IFS=$'\t' read -r n file name; do
  [ "$n" -gt "$limit" ] || continue
  long=$((long + 1))
  if grep -qF "\`$file\` \`$name\`" "$doc"; then
    echo "listed: $file $name ($n lines)"
  else
    echo "FAIL: $file: function $name has $n lines (limit $limit) and no stated reason in $doc" >&2
    fail=1
  fi
done < /tmp/lsnif_long_functions.$$
rm -f /tmp/lsnif_long_functions.$$
[ "$measured" -gt 1000 ] || { echo "long_functions.sh: ctags measured only $measured functions" >&2; exit 1; }
echo "$measured functions measured, $long over $limit lines"
exit $fail
