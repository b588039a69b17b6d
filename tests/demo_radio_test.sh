#!/usr/bin/env bash
# End-to-end test of `./cairn demo --link radio` and `./cairn link`: two robots and the basestation
# each on a simulated host sharing a 1 Mbit/s radio (tools/demo.sh over tests/linksim). A headless mission
# drives r2 to the junction (r1 starts behind it at the west end: r2's way is clear, so the mission measures the
# radio, not passing a parked robot in a tunnel) and shows `links`; then this test cuts r2's link with
# `./cairn link r2 --loss 100` (the basestation must show r2 lost) and restores it (r2 back online). Run by ctest
# inside tests/netns_run.sh.
#   demo_radio_test.sh BUILD_DIR
set -uo pipefail
BUILD="$1"
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
[ "${CAIRN_IN_NETNS:-}" = 1 ] || { echo "demo_radio_test: run me inside tests/netns_run.sh" >&2; exit 2; }
LOGS="$(mktemp -d)"
export CAIRN_DEMO_LOGS="$LOGS" CAIRN_BUILD_DIR="$BUILD"
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
pass() { echo "ok: $*"; }
demo_pid=""
cleanup() {
  [ -n "$demo_pid" ] && kill -TERM "$demo_pid" 2>/dev/null && wait "$demo_pid" 2>/dev/null
  rm -rf "$LOGS"
}
trap cleanup EXIT

cat >"$LOGS/mission.cairn" <<'MISSION'
wait r1 online 20
wait r2 online 20
request-control r2
goto r2 junction --wait 180
links
wait r2 lost 30
wait r2 online 30
links r2
release r2
MISSION

# Bad options are refused before anything starts, naming the value.
out=$("$ROOT/tools/demo.sh" "$BUILD" --link wifi 2>&1)
if [ $? -eq 2 ] && grep -q "'wifi'" <<<"$out"; then pass "--link wifi refused: $out"; else fail "--link wifi: $out"; fi
out=$("$ROOT/tools/demo.sh" "$BUILD" --link radio --loss 150 2>&1)
if [ $? -eq 2 ] && grep -q "'150'" <<<"$out"; then pass "--loss 150 refused: $out"; else fail "--loss 150: $out"; fi

"$ROOT/tools/demo.sh" "$BUILD" --link radio --robots 2 --domain 87 --headless --script "$LOGS/mission.cairn" --json \
  >"$LOGS/demo.out" 2>"$LOGS/demo.err" &
demo_pid=$!
# Once the mission has shown `links`, cut r2's radio; once the basestation shows r2 lost, restore it.
for _ in $(seq 1 2400); do grep -q '"command":"links"' "$LOGS/demo.out" && break; sleep 0.1; done
if grep -q '"command":"links"' "$LOGS/demo.out"; then
  "$ROOT/cairn" link r2 --loss 100 || fail "./cairn link r2 --loss 100 failed"
  for _ in $(seq 1 300); do grep -q '"reason":"lost after' "$LOGS/demo.out" && break; sleep 0.1; done
  "$ROOT/cairn" link r2 --loss 0 || fail "./cairn link r2 --loss 0 failed"
else
  fail "the mission never showed links: $(tail -3 "$LOGS/demo.out") $(tail -3 "$LOGS/demo.err")"
fi
out=$("$ROOT/cairn" link r7 --loss 5 2>&1)
if [ $? -eq 2 ] && grep -q "no host 'r7'" <<<"$out"; then pass "./cairn link r7 refused: no such host"; else fail "./cairn link r7: $out"; fi
wait "$demo_pid"
status=$?
demo_pid=""
if [ "$status" -eq 0 ] && grep -q "mission succeeded" "$LOGS/demo.out"; then pass "the mission succeeded"
else fail "the mission: exit $status, $(grep -v '"ok":true' "$LOGS/demo.out" | head -5)"; fi
grep -q "on a simulated radio of 1000 kbit/s" "$LOGS/demo.out" && pass "the demo says it runs on a simulated radio" ||
  fail "no radio line: $(head -2 "$LOGS/demo.out")"
links=$(grep -m1 '"command":"links"' "$LOGS/demo.out")
for r in r1 r2; do
  if python3 - "$links" "$r" <<'PY'
import json, sys
j = json.loads(sys.argv[1]); r = sys.argv[2]
row = [x for x in j["robots"] if x["robot"] == r][0]
assert row["link"] == "radio" and row["budget_kbps"] == 1000, row
assert 0 < row["rtt_ms"] < 500, row
PY
  then pass "links shows $r on the radio with a probe round trip"; else fail "links for $r: $links"; fi
done
grep '"event":"lost"' "$LOGS/demo.out" | grep -q '"robot":"r2"' && pass "r2 shown lost while cut" ||
  fail "no lost event for r2: $(grep '"event"' "$LOGS/demo.out" | head -5)"
grep -q "2 robots share the 1000 kbit/s radio link" "$LOGS/r1.log" && pass "r1 shares the radio with r2" ||
  fail "r1 did not share the radio: $(grep -m2 radio "$LOGS/r1.log")"
if [ "$failures" -ne 0 ]; then
  echo "--- demo stderr" >&2; tail -5 "$LOGS/demo.err" >&2
  echo "demo_radio_test: $failures check(s) failed" >&2
  exit 1
fi
echo "demo_radio_test: all checks passed"
