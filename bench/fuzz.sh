#!/usr/bin/env bash
# Coverage-guided fuzzing of every decoder of peer data and files (fuzz/*_fuzz.cpp) with libFuzzer:
# builds the harnesses with clang (-fsanitize=fuzzer,address; Debian's clang and libclang-rt-dev) in
# BUILD_DIR (default build-fuzz), then runs each for RUNS executions (default 10^6) from a copy of its corpus
# (fuzz/corpus/<name>/, new inputs land in BUILD_DIR/corpus/<name>/), and prints executions, time and speed.
# A crash stops that harness and leaves crash-* in BUILD_DIR/artifacts/<name>/: add it to the corpus and a
# regression test. No network is used (run it in a private namespace anyway: tests/netns_run.sh).
# FUZZ_MAX_S (environment): also stop each harness after this many seconds (libFuzzer -max_total_time), for the
# slow decoders (a world file is loaded and cleaned up in milliseconds, not microseconds). FUZZ_MAX_LEN: the
# largest input libFuzzer makes (default 65536 bytes).
# Usage: bench/fuzz.sh [RUNS] [BUILD_DIR] [HARNESS...]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
RUNS="${1:-1000000}"
BUILD="${2:-$ROOT/build-fuzz}"
shift $(( $# > 2 ? 2 : $# )) || true
HARNESSES=("$@")
[ ${#HARNESSES[@]} -gt 0 ] || HARNESSES=(bt_file bt_world pcd_world agent_config mode_tree map_update peer_message cli_line)
[[ "$RUNS" =~ ^[0-9]+$ ]] || { echo "fuzz: RUNS '$RUNS' must be a number of executions" >&2; exit 2; }
command -v clang++ >/dev/null || { echo "fuzz: clang++ is not installed (apt-get install clang libclang-rt-dev)" >&2; exit 2; }
FLAGS="-fsanitize=fuzzer-no-link,address -fno-omit-frame-pointer"
if [ ! -f "$BUILD/CMakeCache.txt" ]; then
  CC=clang CXX=clang++ cmake -S "$ROOT" -B "$BUILD" -DCAIRN_FUZZ=ON -DCAIRN_WERROR=OFF \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_FLAGS="$FLAGS" -DCMAKE_CXX_FLAGS="$FLAGS" >/dev/null
fi
cmake "$BUILD" -DCAIRN_WERROR=OFF >/dev/null
targets=()
for h in "${HARNESSES[@]}"; do targets+=("cairn_fuzz_$h"); done
cmake --build "$BUILD" -j "$(nproc)" --target "${targets[@]}"
status=0
for h in "${HARNESSES[@]}"; do
  corpus="$BUILD/corpus/$h"
  artifacts="$BUILD/artifacts/$h"
  mkdir -p "$corpus" "$artifacts"
  cp -n "$ROOT/fuzz/corpus/$h/"* "$corpus/" 2>/dev/null || true
  start=$(date +%s.%N)
  asan="detect_leaks=0:allocator_may_return_null=1"
  # Fast DDS 2.9.1 (Debian's libfastrtps) deletes its statistics readers and writers with a size not theirs
  # when a participant is torn down: ASan's new-delete-type-mismatch, inside the library, at every exit of a
  # harness that has a participant (cli_line).
  [ "$h" = cli_line ] && asan="$asan:new_delete_type_mismatch=0"
  if ASAN_OPTIONS="$asan" "$BUILD/fuzz/cairn_fuzz_$h" -runs="$RUNS" \
      -max_total_time="${FUZZ_MAX_S:-0}" \
      -rss_limit_mb=4096 -malloc_limit_mb=2048 -max_len="${FUZZ_MAX_LEN:-65536}" -print_final_stats=1 \
      -artifact_prefix="$artifacts/" "$corpus" >"$BUILD/fuzz_$h.log" 2>&1; then
    result="no crash"
  else
    result="CRASH (see $BUILD/fuzz_$h.log and $artifacts/)"
    status=1
  fi
  end=$(date +%s.%N)
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$BUILD/fuzz_$h.log" | grep -o '[0-9]*$' || echo 0)
  awk -v h="$h" -v n="$execs" -v s="$start" -v e="$end" -v r="$result" -v c="$(ls "$corpus" | wc -l)" \
    'BEGIN { printf "FIGURE fuzz %s: %d executions in %.0f s (%.0f exec/s), corpus %d inputs: %s\n", h, n, e - s, n / (e - s), c, r }'
done
exit "$status"
