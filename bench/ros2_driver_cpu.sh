#!/usr/bin/env bash
# CPU of one agent driving through its ROS 2 driver against the ROS 2 robot emulator on Cyclone DDS (lidar
# 16 x 900 at 10 Hz as sensor_msgs/PointCloud2, odometry at 50 Hz), beside the same agent on the simulated
# platform (whose own lidar rendering, 16 x 1800 at 10 Hz, is in its process), over a 20 s window while each
# robot drives a goal; the emulator's own CPU is shown apart (a real robot's drivers). Also each agent's
# scan-to-map latency (a scan's stamp to its insertion into the map finished; its shutdown summary). Prints
# FIGURE lines.
# Must run in a private network namespace:
#   tests/netns_run.sh bench/ros2_driver_cpu.sh BUILD_DIR
set -euo pipefail
BUILD="${1:?usage: ros2_driver_cpu.sh BUILD_DIR}"
[ "${CAIRN_IN_NETNS:-}" = 1 ] || { echo "ros2_driver_cpu: run it inside tests/netns_run.sh" >&2; exit 2; }
OUT="$(mktemp -d)"
export XDG_CACHE_HOME="${XDG_CACHE_HOME:-$BUILD/cache}"
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; rm -rf "$OUT"; }
trap cleanup EXIT
ticks() { awk '{print $14 + $15}' "/proc/$1/stat"; }
hz=$(getconf CLK_TCK)
window=20

# measure NAME GOAL AGENT_PID [OTHER_PID]: drives r1 to GOAL from a console and samples the processes' CPU over
# the window (agent_pct, other_pct: per cent of one core).
measure() {
  local name="$1" goal="$2" agent="$3" other="${4:-}"
  for _ in $(seq 600); do grep -qs READY "$OUT/$name.out" && break; sleep 0.1; done
  printf 'wait r1 online 20\nrequest-control r1\ngoto r1 %s\nsleep %s\nstop r1\n' "$goal" "$((window + 4))" |
    "$BUILD/basestation/cairn_base" --base-id cpu --domain 71 >"$OUT/$name.base" 2>&1 &
  local base=$!
  sleep 3
  local a0 o0=0 a1 o1=0
  a0=$(ticks "$agent"); [ -n "$other" ] && o0=$(ticks "$other")
  sleep "$window"
  a1=$(ticks "$agent"); [ -n "$other" ] && o1=$(ticks "$other")
  wait "$base" || true
  agent_pct=$(awk -v d=$((a1 - a0)) -v hz="$hz" -v w="$window" 'BEGIN{printf "%.1f", 100 * d / hz / w}')
  other_pct=$(awk -v d=$((o1 - o0)) -v hz="$hz" -v w="$window" 'BEGIN{printf "%.1f", 100 * d / hz / w}')
}

# The ROS 2 driver against the emulator (corner world: 8 m up the second leg).
"$BUILD/tools/ros2_robot_emulator/cairn_ros2_robot_emulator" --world corner --domain 43 >"$OUT/emu.out" 2>"$OUT/emu.log" &
emu=$!; pids+=($emu)
for _ in $(seq 300); do grep -qs READY "$OUT/emu.out" && break; sleep 0.1; done
"$BUILD/robot_agent/cairn_agent" --robot-id r1 --driver ros2 --ros2-domain 43 --domain 71 >"$OUT/ros2.out" 2>"$OUT/ros2.log" &
agent=$!; pids+=($agent)
measure ros2 "9.75 8" "$agent" "$emu"
ros2_pct=$agent_pct; emu_pct=$other_pct
kill "$agent" "$emu"; wait "$agent" "$emu" 2>/dev/null || true
ros2_latency=$(grep -o 'scan to map [0-9.]* ms mean, [0-9.]* ms max' "$OUT/ros2.log" || echo "scan to map ?")

# The same agent on the simulated platform (builtin:tunnels, a far goal).
"$BUILD/robot_agent/cairn_agent" --robot-id r1 --start slot:0 --domain 71 >"$OUT/sim.out" 2>"$OUT/sim.log" &
agent=$!; pids+=($agent)
measure sim "40 20" "$agent"
sim_pct=$agent_pct
kill "$agent"; wait "$agent" 2>/dev/null || true
sim_latency=$(grep -o 'scan to map [0-9.]* ms mean, [0-9.]* ms max' "$OUT/sim.log" || echo "scan to map ?")

echo "FIGURE ros2_driver_cpu agent_ros2_driver_pct_of_core $ros2_pct (emulated robot's drivers apart: $emu_pct)"
echo "FIGURE ros2_driver_cpu agent_sim_platform_pct_of_core $sim_pct (simulated lidar rendering included)"
awk -v a="$ros2_pct" -v b="$sim_pct" 'BEGIN{printf "FIGURE ros2_driver_cpu ratio_ros2_over_sim %.2f\n", a / b}'
echo "FIGURE ros2_driver_cpu ros2_driver $ros2_latency"
echo "FIGURE ros2_driver_cpu sim_platform $sim_latency"
