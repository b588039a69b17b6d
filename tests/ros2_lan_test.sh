#!/usr/bin/env bash
# cairn_agent --driver ros2 when the robot's ROS 2 nodes run on another computer of the robot (a lidar
# driver's or a SLAM's), joined by ethernet: config `ros2.interface` names the interface, and the ROS 2
# participant binds to it only and finds the nodes by multicast discovery there. The ROS 2 robot emulator on
# Cyclone DDS (--interface) is the other computer; two linksim hosts joined by a 100 Mbit/s link are the two
# computers. Checks, in order:
#   1. a bad ros2.interface is refused naming the field and the value; an interface the host lacks is
#      refused naming it and the interfaces seen (exit 2, before the robot moves);
#   2. without ros2.interface (loopback) the agent never hears the other computer: not localized, naming
#      the odometry topic, and a goal is refused;
#   3. with ros2.interface radio0 the agent is localized from the other computer's odometry, and cairn_base
#      (on the agent's computer, the fleet on loopback) drives the robot to a goal 3 m ahead; the emulator's
#      ground truth says it got there.
# Run by ctest inside tests/netns_run.sh; it enters a private mount namespace too.
#   ros2_lan_test.sh BUILD_DIR
set -uo pipefail
# shellcheck source=linksim/test_harness.sh
source "$(dirname "${BASH_SOURCE[0]}")/linksim/test_harness.sh" ros2_lan_test rl "$@"
EMULATOR="$BUILD/tools/ros2_robot_emulator/cairn_ros2_robot_emulator"
DOMAIN=84
ROS2_DOMAIN=17

linksim_up "$P" || exit 1
linksim_add_host "$P" sensors 10.77.0.2 100000 || exit 1
linksim_add_host "$P" robot 10.77.0.3 100000 || exit 1

# The emulator: the corner world, the robot at (1, 0) facing +x, its odometry's origin.
linksim_exec "$P" sensors "$EMULATOR" --world corner --domain "$ROS2_DOMAIN" --interface radio0 \
  --truth-out "$LOGS/truth.txt" >"$LOGS/emulator.out" 2>"$LOGS/emulator.log" &
for _ in $(seq 1 100); do grep -q READY "$LOGS/emulator.out" && break; sleep 0.1; done
grep -q READY "$LOGS/emulator.out" || { fail "the emulator did not start: $(tail -3 "$LOGS/emulator.log")"; exit 1; }

# Writes an agent config with ros2.interface = $2 (and a short start wait) to $1.
write_config() {
  printf 'ros2:\n  interface: "%s"\n  start_wait_s: %s\n' "$2" "$3" >"$1"
}
# Runs the given console lines, one after the other, in one cairn_base on the robot's computer.
base() { printf '%s\n' "$@" | linksim_exec "$P" robot "$BASE" --base-id op1 --domain "$DOMAIN" 2>&1; }

# Starts r1 on the robot's computer with config $1, waits for READY; R1_PID is the agent.
start_r1() {
  [ -n "${R1_PID:-}" ] && kill -TERM "$R1_PID" 2>/dev/null && wait "$R1_PID" 2>/dev/null
  linksim_start_agent "$LOGS/r1.log" robot --robot-id r1 --domain "$DOMAIN" --driver ros2 \
    --ros2-domain "$ROS2_DOMAIN" --config "$1"
  R1_PID=$AGENT_PID
  linksim_wait_ready "$LOGS/r1.log" "r1 with $(tr '\n' ' ' <"$1")"
}

# 1. Bad interfaces.
expect_refused() {
  local needle="$1" config="$2" out code
  out=$(linksim_exec "$P" robot "$AGENT" --robot-id r9 --domain "$DOMAIN" --driver ros2 --ros2-domain "$ROS2_DOMAIN" \
    --config "$config" 2>&1 </dev/null)
  code=$?
  if [ "$code" -eq 2 ] && grep -qF -- "$needle" <<<"$out"; then pass "refused: $needle"
  else fail "expected exit 2 and '$needle', got exit $code: $(tail -2 <<<"$out")"; fi
}
write_config "$LOGS/bad_name.yaml" "eth 1" 1
expect_refused "ros2.interface 'eth 1' is not a network interface name" "$LOGS/bad_name.yaml"
write_config "$LOGS/absent.yaml" eth7 1
expect_refused "--interface 'eth7': no interface of this host has an IPv4 address there (seen: lo 127.0.0.1, radio0 10.77.0.3)" \
  "$LOGS/absent.yaml"

# 2. Loopback only: the other computer's odometry never arrives.
write_config "$LOGS/loopback.yaml" "" 1
start_r1 "$LOGS/loopback.yaml"
out=$(base "wait r1 online 20" "request-control r1" "goto r1 4 0")
if grep -q "goto r1: refused: .*not localized: .*no odometry on /odom" <<<"$out"; then
  pass "loopback only: $(grep -o "goto r1: refused: [^;]*" <<<"$out")"
else fail "loopback only: expected goto and manual refused for no odometry on /odom: $out"; fi

# 3. On the robot's ethernet.
write_config "$LOGS/lan.yaml" radio0 10
start_r1 "$LOGS/lan.yaml"
out=$(base "wait r1 online 20" "request-control r1" "goto r1 4 0 --wait 60")
if grep -q "arrived" <<<"$out"; then pass "goto over the robot's ethernet: $(grep arrived <<<"$out" | tail -1)"
else fail "goto over the robot's ethernet: $(tail -4 <<<"$out")"; fi
# The truth (t_s x_m y_m yaw_rad in_contact, world frame; the odometry's origin, the robot's map frame, is
# the start (1, 0) facing +x): within 0.5 m of (5, 0), never in contact.
tail -1 "$LOGS/truth.txt" | awk '{ d = sqrt(($2 - 5)^2 + $3^2); exit !(d < 0.5) }' &&
  pass "the emulator's truth ends at $(tail -1 "$LOGS/truth.txt" | awk '{print $2, $3}') in the world" ||
  fail "the emulator's truth ends at $(tail -1 "$LOGS/truth.txt" | awk '{print $2, $3}'), not within 0.5 m of (5, 0)"
awk '$5 != 0 { hit = 1 } END { exit hit }' "$LOGS/truth.txt" || fail "the robot touched a wall (truth in_contact)"
grep -q "on radio0" "$LOGS/emulator.log" || fail "the emulator's log does not say radio0: $(head -2 "$LOGS/emulator.log")"

kill -TERM "$R1_PID" 2>/dev/null
wait "$R1_PID" 2>/dev/null
if [ "$failures" -ne 0 ]; then
  echo "logs:"; tail -n 40 "$LOGS"/*.log
  exit 1
fi
echo "ros2_lan_test: all checks passed"
