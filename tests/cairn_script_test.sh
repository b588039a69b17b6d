#!/usr/bin/env bash
# ./cairn's answers that must come before anything is installed or built: `demo --help` prints the usage and
# a bad option or world names itself and exits 2. The build folder given to ./cairn (CAIRN_BUILD_DIR) is a new
# empty one: had setup or the build run, it would hold a CMake cache.
#   cairn_script_test.sh SOURCE_DIR
set -euo pipefail
ROOT="$1"
export CAIRN_BUILD_DIR
CAIRN_BUILD_DIR="$(mktemp -d)"
trap 'rm -rf "$CAIRN_BUILD_DIR"' EXIT
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }

# expect STATUS PATTERN ARGS...: ./cairn ARGS exits STATUS within 20 s, prints PATTERN (stdout or stderr) and
# leaves the build folder empty.
expect() {
  local want_status="$1" pattern="$2" status=0 output
  shift 2
  output="$(timeout 20 "$ROOT/cairn" "$@" 2>&1)" || status=$?
  [ "$status" = "$want_status" ] || fail "./cairn $*: exit $status, expected $want_status; output: $output"
  grep -qF -- "$pattern" <<<"$output" || fail "./cairn $*: no '$pattern' in: $output"
  [ -z "$(ls -A "$CAIRN_BUILD_DIR")" ] || fail "./cairn $*: the build folder is not empty: $(ls -A "$CAIRN_BUILD_DIR")"
}

expect 0 "usage: ./cairn demo" demo --help
expect 0 "usage: ./cairn demo" demo --robots 2 -h
expect 2 "demo: unknown option '--robtos'" demo --robtos 2
expect 2 "demo: --robots '0' must be an integer in 1..20" demo --robots 0
expect 2 "demo: world file '/nonexistent.bt' cannot be read" demo --world /nonexistent.bt

[ "$failures" = 0 ] || exit 1
echo "ok: ./cairn demo answers --help and bad options without installing or building"
