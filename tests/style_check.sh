#!/usr/bin/env bash
# The repository's habits, checked: every tracked C++ file is formatted by .clang-format (clang-format 14, as
# Debian 12 ships), and the operator GUI's TypeScript type-checks (tsc --noEmit with its tsconfig.json).
#   style_check.sh SOURCE_DIR
# Fix formatting with: clang-format -i FILE... (the files are listed on failure).
set -uo pipefail
ROOT="$1"
cd "$ROOT" || exit 2
failures=0

if ! command -v clang-format >/dev/null; then
  echo "style_check: clang-format is not installed (./cairn setup installs it)" >&2
  exit 1
fi
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  mapfile -t files < <(git ls-files '*.cpp' '*.h' '*.hpp' '*.cc')
else
  mapfile -t files < <(find . -path ./build -prune -o -path '*/node_modules' -prune -o \
    \( -name '*.cpp' -o -name '*.h' -o -name '*.hpp' -o -name '*.cc' \) -type f -print | sed 's|^\./||')
fi
# One clang-format process for every file (its start-up, ~0.15 s, was most of the time with one per file); the
# files it would change are the ones its warnings name ("FILE:LINE:COL: error: code should be clang-formatted").
unformatted=()
if ! out=$(clang-format --dry-run -Werror "${files[@]}" 2>&1 >/dev/null); then
  mapfile -t unformatted < <(echo "$out" | sed -nE 's/^([^:]+):[0-9]+:[0-9]+: (error|warning): code should be clang-formatted.*/\1/p' | sort -u)
  if [ "${#unformatted[@]}" -eq 0 ]; then
    echo "FAIL: clang-format failed:" >&2
    echo "$out" | head -20 >&2
    exit 1
  fi
fi
if [ "${#unformatted[@]}" -eq 0 ]; then
  echo "ok: ${#files[@]} C++ files formatted by .clang-format ($(clang-format --version | grep -o 'version [0-9.]*'))"
else
  echo "FAIL: ${#unformatted[@]} of ${#files[@]} C++ files are not formatted by .clang-format: clang-format -i ${unformatted[*]}" >&2
  failures=$((failures + 1))
fi

web="$ROOT/basestation/web"
if [ -x "$web/node_modules/.bin/tsc" ]; then
  if out=$(cd "$web" && node_modules/.bin/tsc --noEmit 2>&1); then
    echo "ok: the GUI's TypeScript type-checks (tsc --noEmit)"
  else
    echo "FAIL: tsc --noEmit in basestation/web:" >&2
    echo "$out" | head -40 >&2
    failures=$((failures + 1))
  fi
else
  echo "FAIL: $web/node_modules/.bin/tsc is missing (the build's npm ci installs it)" >&2
  failures=$((failures + 1))
fi
exit $((failures != 0))
