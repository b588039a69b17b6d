#!/usr/bin/env bash
# CPU budget of the perception stack: 3 robots in builtin:tunnels drive to far goals while their agents run
# the full perception pipeline (lidar 16 x 1800 at 10 Hz, mapping, staircase detection, map telemetry, camera)
# on this machine; prints each agent's CPU use (per cent of one core) over a 20 s window and the sum against
# the machine's cores. Must run in a private network namespace: ./cairn bench does that (tests/netns_run.sh).
# Usage: bench/fleet_cpu.sh BUILD_DIR
set -euo pipefail
BUILD="${1:?usage: fleet_cpu.sh BUILD_DIR}"
DOMAIN=70
LOGS="$(mktemp -d)"
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; rm -rf "$LOGS"; }
trap cleanup EXIT
for k in 0 1 2; do
  "$BUILD/robot_agent/cairn_agent" --robot-id "r$k" --start "slot:$k" --domain "$DOMAIN" >"$LOGS/r$k.out" 2>"$LOGS/r$k.log" &
  pids+=($!)
done
for k in 0 1 2; do
  for _ in $(seq 600); do grep -q READY "$LOGS/r$k.out" && break; sleep 0.1; done
done
# Far goals along the tunnels for each robot, so that all three keep moving (and mapping) during the window.
"$BUILD/basestation/cairn_base" --base-id cpu --domain "$DOMAIN" --keep-going >"$LOGS/base.out" 2>"$LOGS/base.log" <<'SCRIPT' &
wait r0 online 10
wait r1 online 10
wait r2 online 10
request-control r0
request-control r1
request-control r2
goto r0 40 20
goto r1 30 34
goto r2 30 6
sleep 40
SCRIPT
pids+=($!)
sleep 6  # discovery, control and goals
ticks() { awk '{print $14 + $15}' "/proc/$1/stat"; }
hz=$(getconf CLK_TCK)
declare -A start
for k in 0 1 2; do start[$k]=$(ticks "${pids[$k]}"); done
window=20
sleep "$window"
total=0
for k in 0 1 2; do
  used=$(( $(ticks "${pids[$k]}") - ${start[$k]} ))
  pct=$(awk -v u="$used" -v hz="$hz" -v w="$window" 'BEGIN { printf "%.1f", 100 * u / hz / w }')
  echo "FIGURE fleet_cpu r$k = $pct % of one core"
  total=$(awk -v t="$total" -v p="$pct" 'BEGIN { print t + p }')
done
echo "FIGURE fleet_cpu three_robots = $total % of one core (machine: $(nproc) cores = $(( $(nproc) * 100 )) %)"
grep -h "arrived\|failed" "$LOGS"/r*.log | tail -3 || true
