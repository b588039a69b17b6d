#!/usr/bin/env bash
# The Cairn demo: N simulated robots (cairn_agent) and one basestation (cairn_base), on loopback only, or each
# on a simulated host of its own joined by a simulated radio (--link lan|radio: tests/linksim, 10.77.0.0/24).
# Called by `./cairn demo` inside a private network namespace. The robots run in their own session, so a
# Ctrl-C in the console cancels the console's wait and never reaches them; when the console ends, the demo
# asks before stopping them (a console attached with `./cairn console` meanwhile keeps working).
#   demo.sh BUILD_DIR [--world SPEC] [--robots N] [--domain D] [--link loopback|lan|radio [--link-kbps K] [--loss PCT]]
#           [--gui [--gui-port P]] [--headless --script FILE] [--json]
set -euo pipefail
BUILD="$1"; shift
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
WORLD="builtin:tunnels"; ROBOTS=3; DOMAIN=7; HEADLESS=0; SCRIPT=""; JSON=""; PLATFORM="wheeled"; GUI=0; GUI_PORT=8080
LINK="loopback"; LINK_KBPS=1000; LOSS_PCT=0

usage() {
  cat <<USAGE
usage: ./cairn demo [--world builtin:NAME|FILE.bt|FILE.pcd] [--robots N] [--platform wheeled|legged]
                    [--domain D] [--link loopback|lan|radio [--link-kbps K] [--loss PCT]]
                    [--gui [--gui-port P]] [--headless --script FILE] [--json]
  Starts N robots (r1..rN, default 3) at distinct free starts and a basestation 'op1'.
  --link lan|radio: every robot and the basestation on a simulated host of its own (a network namespace, r1 at
  10.77.0.11, op1 at 10.77.0.2), joined by a simulated radio of K kbit/s each way (default 1000) losing PCT %
  of the packets (default 0); DDS on that link (radio: the robots share K). Cut or restore a host's link
  while it runs: ./cairn link r1 --loss 100 | --loss 0. Default: loopback (one namespace, no radio).
  --gui: op1 also serves the operator GUI; open http://127.0.0.1:P/ (default 8080) in a browser on this
  machine (./cairn forwards that one TCP port from 127.0.0.1 into the demo's private network namespace).
  Interactive by default; --headless --script FILE runs the command file, prints the outcome and exits
  non-zero if any command fails. Example: ./cairn demo --headless --script examples/geb079_mission.cairn
  A script may name the world and fleet size it was written for ('# world: PATH', '# robots: N' lines);
  --world and --robots given on the command line win.
USAGE
}

ORIGINAL_ARGS=("$@")
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
    --link) LINK="${2:?--link needs a value}"; shift 2 ;;
    --link-kbps) LINK_KBPS="${2:?--link-kbps needs a value}"; shift 2 ;;
    --loss) LOSS_PCT="${2:?--loss needs a value}"; shift 2 ;;
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
# What N robots need: an agent with full perception and navigation on the simulated platform took 0.38-0.53 of
# a core on this kind of machine (docs/PERFORMANCE.md, fleet_cpu). Past the cores here their loops run slow:
# perception defers map insertions and staircase runs, and health shows the parts "degraded".
CORES="$(nproc)"
NEED_CENTI=$((ROBOTS * 50))
if [ "$NEED_CENTI" -gt $((CORES * 80)) ] && [ "${CAIRN_DEMO_CHECK_ONLY:-}" != 1 ]; then
  echo "demo: warning: $ROBOTS robots need about $((NEED_CENTI / 100)).$(((NEED_CENTI % 100) / 10)) cores" \
       "(0.5 each, simulator included); this machine has $CORES: expect degraded rates (health R shows them)" >&2
fi
if ! [[ "$GUI_PORT" =~ ^[0-9]+$ ]] || [ "$GUI_PORT" -lt 1 ] || [ "$GUI_PORT" -gt 65535 ]; then
  echo "demo: --gui-port '$GUI_PORT' must be an integer in 1..65535" >&2; exit 2
fi
case "$LINK" in
  loopback|lan|radio) ;;
  *) echo "demo: --link '$LINK' must be loopback, lan or radio" >&2; exit 2 ;;
esac
if ! [[ "$LINK_KBPS" =~ ^[0-9]+$ ]] || [ "$LINK_KBPS" -lt 64 ] || [ "$LINK_KBPS" -gt 1000000 ]; then
  echo "demo: --link-kbps '$LINK_KBPS' must be an integer number of kbit/s in 64..1000000" >&2; exit 2
fi
if ! [[ "$LOSS_PCT" =~ ^[0-9]+([.][0-9]+)?$ ]] || ! awk "BEGIN{exit !($LOSS_PCT <= 100)}"; then
  echo "demo: --loss '$LOSS_PCT' must be a percentage in 0..100" >&2; exit 2
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
# ./cairn demo checks its options this way before it installs or builds anything.
[ "${CAIRN_DEMO_CHECK_ONLY:-}" = 1 ] && exit 0

# A radio link needs hosts (network namespaces) named in /run/netns: in a private mount namespace, so the
# names vanish with the demo.
if [ "$LINK" != loopback ] && [ "${CAIRN_IN_MOUNTNS:-}" != 1 ]; then
  exec env CAIRN_IN_MOUNTNS=1 unshare --mount --propagation private -- "$0" "$BUILD" "${ORIGINAL_ARGS[@]}"
fi

LOGS="${CAIRN_DEMO_LOGS:-$BUILD/demo-logs}"; mkdir -p "$LOGS"
ENV_FILE="$LOGS/demo.env"
PIDS=()
SUBNET="10.77.0.0/24"
HOSTS="cd$$"  # linksim's prefix of the hosts' namespaces
LINK_ARGS=()
cleanup() {
  rm -f "$ENV_FILE"
  for pid in "${PIDS[@]}"; do kill -TERM "$pid" 2>/dev/null || true; done
  for pid in "${PIDS[@]}"; do wait "$pid" 2>/dev/null || true; done
  if [ "$LINK" != loopback ]; then linksim_down "$HOSTS"; fi
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# on_host NAME: ON_HOST becomes the command prefix that runs a command on simulated host NAME (radio), or
# nothing (loopback). A prefix, not a function: `"${ON_HOST[@]}" CMD &` leaves CMD's own pid in $!.
ON_HOST=()
on_host() {
  if [ "$LINK" = loopback ]; then ON_HOST=(); else ON_HOST=(ip netns exec "${HOSTS}$1"); fi
}

if [ "$LINK" = loopback ]; then
  echo "demo: world $WORLD, $ROBOTS robots, DDS domain $DOMAIN (loopback only); logs in $LOGS"
else
  # shellcheck source=../tests/linksim/linksim.sh
  source "$ROOT/tests/linksim/linksim.sh"
  linksim_up "$HOSTS" || exit 1
  linksim_add_host "$HOSTS" op1 10.77.0.2 "$LINK_KBPS" "$LOSS_PCT" || exit 1
  for i in $(seq 1 "$ROBOTS"); do
    linksim_add_host "$HOSTS" "r$i" "10.77.0.$((10 + i))" "$LINK_KBPS" "$LOSS_PCT" || exit 1
  done
  LINK_ARGS=(--link "$LINK" --subnet "$SUBNET")
  if [ "$LINK" = radio ]; then LINK_ARGS+=(--link-kbps "$LINK_KBPS"); fi
  echo "demo: world $WORLD, $ROBOTS robots, DDS domain $DOMAIN on a simulated $LINK of $LINK_KBPS kbit/s each way" \
    "($LOSS_PCT % loss), $SUBNET: op1 at 10.77.0.2, r1.. at 10.77.0.11..; logs in $LOGS"
fi
for i in $(seq 1 "$ROBOTS"); do
  on_host "r$i"
  "${ON_HOST[@]}" setsid "$BUILD/robot_agent/cairn_agent" --robot-id "r$i" --world "$WORLD" --start "slot:$((i - 1))" \
    --platform "$PLATFORM" --domain "$DOMAIN" "${LINK_ARGS[@]}" --journal "$LOGS/r$i.journal" --supervise \
    >"$LOGS/r$i.log" 2>&1 </dev/null &
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
# What `./cairn console` (and the GUI forward) need to attach to this demo: a process in the basestation's
# network namespace (this shell on loopback; a placeholder on op1's host on a radio), the DDS domain, link
# flags and places file; `./cairn link` needs this shell (its mount namespace names the hosts) and their prefix.
ANCHOR=$$
if [ "$LINK" != loopback ]; then
  on_host op1
  "${ON_HOST[@]}" sleep infinity &
  ANCHOR=$!
  PIDS+=("$ANCHOR")
fi
{
  printf 'CAIRN_DEMO_PID=%s\nCAIRN_DEMO_DOMAIN=%s\nCAIRN_DEMO_PLACES=%s\n' "$ANCHOR" "$DOMAIN" "$PLACES"
  printf 'CAIRN_DEMO_LINK_ARGS="%s"\nCAIRN_DEMO_SHELL_PID=%s\nCAIRN_DEMO_HOSTS=%s\n' "${LINK_ARGS[*]}" "$$" "$HOSTS"
} >"$ENV_FILE"

BASE="$BUILD/basestation/cairn_base"
on_host op1
GUI_ARGS=()
if [ "$GUI" = 1 ]; then
  GUI_ARGS=(--gui --listen "127.0.0.1:$GUI_PORT")
  echo "demo: operator GUI at http://127.0.0.1:$GUI_PORT/ (open it in a browser on this machine)"
fi
if [ -n "$SCRIPT" ]; then
  set +e
  "${ON_HOST[@]}" "$BASE" --base-id op1 --domain "$DOMAIN" "${LINK_ARGS[@]}" --places "$PLACES" $JSON "${GUI_ARGS[@]}" \
    --script "$SCRIPT"
  status=$?
  set -e
  if [ $status -eq 0 ]; then echo "demo: mission succeeded"; else echo "demo: mission FAILED (exit $status)"; fi
  exit $status
fi
echo "demo: another operator can attach with: ./cairn console --base-id op2"
if [ "$LINK" != loopback ]; then
  echo "demo: cut r1's radio link with ./cairn link r1 --loss 100 (and restore it with --loss 0); 'links' shows it"
fi
# Ctrl-C belongs to the console while it runs (it cancels a wait or clears the line): the demo only notes it.
trap 'true' INT
set +e
"${ON_HOST[@]}" "$BASE" --base-id op1 --domain "$DOMAIN" "${LINK_ARGS[@]}" --places "$PLACES" $JSON "${GUI_ARGS[@]}"
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
