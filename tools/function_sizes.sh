#!/usr/bin/env bash
# Functions longer than N lines (default 80) in the tracked C++ sources, longest first, with a count:
#   tools/function_sizes.sh [N] [--all]   (--all: tests, benches and fuzz harnesses too)
# Functions whose first lines say why they are "kept whole" are listed apart, not counted.
# Uses Universal Ctags (Debian package universal-ctags) for each function's first and last line.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
limit="${1:-80}"
command -v ctags >/dev/null && ctags --version | grep -q Universal ||
  { echo "function_sizes: needs Universal Ctags (apt-get install universal-ctags)" >&2; exit 2; }
files=$(git ls-files '*.cpp' '*.h')
[ "${2:-}" = --all ] || files=$(grep -v -E '(^|/)(test|tests|bench|fuzz)/|_test\.cpp$' <<<"$files")
# shellcheck disable=SC2086
ctags --fields=+ne --c++-kinds=f -o - $files 2>/dev/null |
  awk -F'\t' -v limit="$limit" '{
    line = ""; end = ""
    for (i = 4; i <= NF; ++i) { if ($i ~ /^line:/) line = substr($i, 6); if ($i ~ /^end:/) end = substr($i, 5) }
    if (line != "" && end != "" && end - line + 1 > limit) printf "%5d  %s:%s  %s\n", end - line + 1, $2, line, $1
  }' | sort -rn | while read -r size where name; do
    # A function whose first lines say why it is "kept whole" (a data table, one state machine) is listed
    # apart and not counted.
    file="${where%%:*}" first="${where##*:}"
    if sed -n "${first},$((first + 4))p" "$file" | grep -q "kept whole"; then
      printf "%5d  %s  %s (kept whole, says why)\n" "$size" "$where" "$name" >&2
    else
      printf "%5d  %s  %s\n" "$size" "$where" "$name"
    fi
  done | tee /dev/stderr | wc -l | xargs printf "%s functions over $limit lines\n"
