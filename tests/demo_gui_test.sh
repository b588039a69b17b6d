#!/usr/bin/env bash
# End-to-end test of `./cairn demo --gui`'s network setup, run by ctest inside a private network namespace (the
# "host" here): the demo (tools/demo.sh, 1 robot, GUI on) runs in a namespace of its own, and only its GUI port
# is forwarded to 127.0.0.1 here by tools/gui_forward.sh. A client here loads the page and sees the robot on
# /fleet; no DDS participant runs here (the host namespace has no robot and no basestation).
#   demo_gui_test.sh BUILD_DIR
set -euo pipefail
BUILD="$1"
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
[ "${CAIRN_IN_NETNS:-}" = 1 ] || { echo "demo_gui_test: run me inside tests/netns_run.sh" >&2; exit 2; }
LOGS="$(mktemp -d)"
PORT=18080
export CAIRN_DEMO_LOGS="$LOGS"
pids=()
cleanup() {
  for p in "${pids[@]}"; do pkill -TERM -P "$p" 2>/dev/null || true; kill -TERM "$p" 2>/dev/null || true; done
  sleep 1
  for p in "${pids[@]}"; do pkill -KILL -P "$p" 2>/dev/null || true; kill -KILL "$p" 2>/dev/null || true; done
  rm -rf "$LOGS"
}
trap cleanup EXIT

"$ROOT/tools/gui_forward.sh" "$PORT" "$LOGS/demo.env" "$LOGS/gui-forward.log" &
pids+=($!)
unshare --net -- bash -c 'ip link set lo up && exec "$@"' demo-netns \
  "$ROOT/tools/demo.sh" "$BUILD" --robots 1 --domain 79 --gui --gui-port "$PORT" </dev/null >"$LOGS/demo.out" 2>&1 &
pids+=($!)

status=0
(cd "$ROOT/basestation/web" && node test/gui_probe.mjs "http://127.0.0.1:$PORT/" r1 120) || status=$?
grep -q "operator GUI at http://127.0.0.1:$PORT/" "$LOGS/demo.out" || { echo "the demo did not print the URL" >&2; status=1; }
# Nothing listens on the GUI port here but the forward (the demo's own sockets are in its namespace).
if ss -Htlnp "sport = :$PORT" | grep -qv socat; then echo "something other than socat listens on $PORT here" >&2; status=1; fi
if [ "$status" -ne 0 ]; then
  echo "--- demo output" >&2; tail -20 "$LOGS/demo.out" >&2
  echo "--- forward" >&2; cat "$LOGS/gui-forward.log" >&2 || true
fi
exit "$status"
