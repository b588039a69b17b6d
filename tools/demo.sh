#!/usr/bin/env bash
# The Cairn demo: N simulated robots (cairn_agent) and one basestation (cairn_base), on loopback only.
# Called by `./cairn demo` inside a private network namespace. The robots run in their own session, so a
# Ctrl-C in the console cancels the console's wait and never reaches them; when the console ends, the demo
# asks before stopping them (a console attached with `./cairn console` meanwhile keeps working).
#   demo.sh BUILD_DIR [--world SPEC] [--robots N] [--domain D] [--gui [--gui-port P]] [--headless --script FILE] [--json]
set -euo pipefail
BUILD="$1"; shift
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
WORLD="builtin:tunnels"; ROBOTS=3; DOMAIN=7; HEADLESS=0; SCRIPT=""; JSON=""; PLATFORM="wheeled"; GUI=0; GUI_PORT=8080

usage() {
  cat <<USAGE
usage: ./cairn demo [--world builtin:NAME|FILE.bt|FILE.pcd] [--robots N] [--platform wheeled|legged]
                    [--domain D] [--gui [--gui-port P]] [--headless --script FILE] [--json]
  Starts N robots (r1..rN, default 3) at distinct free starts and a basestation 'op1'.
  --gui: op1 also serves the operator GUI; open http://127.0.0.1:P/ (default 8080) in a browser on this
  machine (./cairn forwards that one TCP port from 127.0.0.1 into the demo's private network namespace).
  Interactive by default; --headless --script FILE runs the command file, prints the outcome and exits
  non-zero if any command fails. Example: ./cairn demo --headless --script examples/geb079_mission.cairn
  A script may name the world and fleet size it was written for ('# world: PATH', '# robots: N' lines);
  --world and --robots given on the command line win.
USAGE
}

while [ $# -gt 0 ]; do
  case "$1" in
    --world) WORLD="${2:?--world needs a value}"; shift 2 ;;
    --robots) ROBOTS="${2:?--robots needs a value}"; ROBOTS_GIVEN=1; shift 2 ;;
    --platform) PLATFORM="${2:?--platform needs a value}"; shift 2 ;;
    --domain) DOMAIN="${2:?--domain needs a value}"; shift 2 ;;
    --headless) HEADLESS=1; shift ;;
    --script) SCRIPT="${2:?--script needs a file}"; shift 2 ;;
    --json) JSON="--json"; shift ;;
    --gui) GUI=1; shift ;;
    --gui-port) GUI_PORT="${2:?--gui-port needs a value}"; shift 2 ;;
    -h|--help) usage; exit 0 ;;
    *) echo "demo: unknown option '$1'" >&2; usage >&2; exit 2 ;;
  esac
done
# A mission script may name the fleet it was written for in a line '# robots: N' (--robots wins).
if [ -n "$SCRIPT" ] && [ -r "$SCRIPT" ] && [ -z "${ROBOTS_GIVEN:-}" ]; then
  wanted_robots=$(sed -n 's/^# robots: *//p' "$SCRIPT" | head -1)
  if [ -n "$wanted_robots" ]; then ROBOTS="$wanted_robots"; fi
fi
if ! [[ "$ROBOTS" =~ ^[0-9]+$ ]] || [ "$ROBOTS" -lt 1 ] || [ "$ROBOTS" -gt 20 ]; then
  echo "demo: --robots '$ROBOTS' must be an integer in 1..20" >&2; exit 2
fi
if ! [[ "$GUI_PORT" =~ ^[0-9]+$ ]] || [ "$GUI_PORT" -lt 1 ] || [ "$GUI_PORT" -gt 65535 ]; then
  echo "demo: --gui-port '$GUI_PORT' must be an integer in 1..65535" >&2; exit 2
fi
if [ "$HEADLESS" = 1 ] && [ -z "$SCRIPT" ]; then echo "demo: --headless needs --script FILE" >&2; exit 2; fi
if [ -n "$SCRIPT" ] && [ ! -r "$SCRIPT" ]; then echo "demo: --script '$SCRIPT' cannot be read" >&2; exit 2; fi
# A mission script may name the world it was written for in a line '# world: PATH' (relative to the repo).
if [ -n "$SCRIPT" ]; then
  wanted=$(sed -n 's/^# world: *//p' "$SCRIPT" | head -1)
  if [ -n "$wanted" ] && [ "$WORLD" = "builtin:tunnels" ]; then
    case "$wanted" in builtin:*|/*) WORLD="$wanted" ;; *) WORLD="$ROOT/$wanted" ;; esac
  fi
fi
case "$WORLD" in
  builtin:*) ;;
  *) [ -r "$WORLD" ] || { echo "demo: world file '$WORLD' cannot be read" >&2; exit 2; } ;;
esac

LOGS="${CAIRN_DEMO_LOGS:-$BUILD/demo-logs}"; mkdir -p "$LOGS"
ENV_FILE="$LOGS/demo.env"
PIDS=()
cleanup() {
  rm -f "$ENV_FILE"
  for pid in "${PIDS[@]}"; do kill -TERM "$pid" 2>/dev/null || true; done
  for pid in "${PIDS[@]}"; do wait "$pid" 2>/dev/null || true; done
}
trap cleanup EXIT
trap 'exit 130' INT TERM

echo "demo: world $WORLD, $ROBOTS robots, DDS domain $DOMAIN (loopback only); logs in $LOGS"
for i in $(seq 1 "$ROBOTS"); do
  setsid "$BUILD/robot_agent/cairn_agent" --robot-id "r$i" --world "$WORLD" --start "slot:$((i - 1))" \
    --platform "$PLATFORM" --domain "$DOMAIN" >"$LOGS/r$i.log" 2>&1 </dev/null &
  PIDS+=($!)
done
# Wait until every agent has loaded its world and is on DDS.
for i in $(seq 1 "$ROBOTS"); do
  for _ in $(seq 1 600); do
    grep -q "^READY" "$LOGS/r$i.log" 2>/dev/null && break
    if ! kill -0 "${PIDS[$((i - 1))]}" 2>/dev/null; then
      echo "demo: robot r$i failed to start:" >&2; tail -5 "$LOGS/r$i.log" >&2; exit 1
    fi
    sleep 0.1
  done
done
ROBOT_IDS="$(seq -s ' ' -f 'r%g' 1 "$ROBOTS")"
echo "demo: robots ready: $ROBOT_IDS"

# Named places, one file per world: the built-in world's landmarks on first use, then what operators add.
world_name="$(basename "${WORLD#builtin:}")"
PLACES="$LOGS/places-${world_name%.*}.yaml"
if [ ! -f "$PLACES" ] && [ -f "$ROOT/config/places/${WORLD#builtin:}.yaml" ]; then
  cp "$ROOT/config/places/${WORLD#builtin:}.yaml" "$PLACES"
fi
# What `./cairn console` needs to attach another operator to this demo (this shell is in the demo's netns).
printf 'CAIRN_DEMO_PID=%s\nCAIRN_DEMO_DOMAIN=%s\nCAIRN_DEMO_PLACES=%s\n' "$$" "$DOMAIN" "$PLACES" >"$ENV_FILE"

BASE="$BUILD/basestation/cairn_base"
GUI_ARGS=()
if [ "$GUI" = 1 ]; then
  GUI_ARGS=(--gui --listen "127.0.0.1:$GUI_PORT")
  echo "demo: operator GUI at http://127.0.0.1:$GUI_PORT/ (open it in a browser on this machine)"
fi
if [ -n "$SCRIPT" ]; then
  set +e
  "$BASE" --base-id op1 --domain "$DOMAIN" --places "$PLACES" $JSON "${GUI_ARGS[@]}" --script "$SCRIPT"
  status=$?
  set -e
  if [ $status -eq 0 ]; then echo "demo: mission succeeded"; else echo "demo: mission FAILED (exit $status)"; fi
  exit $status
fi
echo "demo: another operator can attach with: ./cairn console --base-id op2"
# Ctrl-C belongs to the console while it runs (it cancels a wait or clears the line): the demo only notes it.
trap 'true' INT
set +e
"$BASE" --base-id op1 --domain "$DOMAIN" --places "$PLACES" $JSON "${GUI_ARGS[@]}"
set -e
trap 'exit 130' INT TERM
if [ -t 0 ]; then
  read -r -p "demo: console closed. Stop robots $ROBOT_IDS and end the demo? [y/N] " answer || answer=y
  case "$answer" in
    y|Y|yes)
      ;;
    *)
      echo "demo: robots $ROBOT_IDS keep running, still locked to op1. Take them over with"
      echo "      ./cairn console --base-id op1 (another operator: ./cairn console --base-id op2); Ctrl-C here stops them."
      wait "${PIDS[@]}" 2>/dev/null || true ;;
  esac
fi
