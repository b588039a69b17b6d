#!/usr/bin/env bash
# Networks, end to end: cairn_agent and cairn_base processes on simulated hosts joined by a 1 Mbit/s radio
# (tests/linksim: a host each, a hub between; base 10.77.0.2, r1-r3 10.77.0.11-13), talking DDS on the lan or
# radio link class bound to the test subnet. Checks, in order:
#   1. the link simulator: a 1 Mbit/s link carries about 1 Mbit/s, and 20 % loss drops about 20 %;
#   2. bad link and discovery flags are refused naming the flag and the value, before any participant starts;
#      a lan participant in a subnet its host has no address in is refused, naming the interfaces seen;
#   3. one robot, r1, on the lan link:
#      3.1 the shipped loopback link stays on loopback: a basestation on another host never sees r1;
#      3.2 over the lan link the basestation sees r1, takes control and drives it to a goal 3 m away;
#      3.3 command round trips while it drives, then with a camera that saturates the link (lan, then radio);
#      3.4 at 5 % loss each way, commands are applied once and the basestation's map converges;
#      3.5 a 10 s link cut while driving by teleop: the robot stops, keeps its lock, is lost then back, and its
#          map resyncs;
#   4. three robots sharing the radio link, each camera alone enough to fill it: the bulk shares split three
#      ways, joins with capabilities, 30 commands while they drive (p99 <= 100 ms), `links`, over budget;
#   5. a Fast DDS discovery server on the basestation's host, every process its client: the basestation sees
#      and commands the three, no datagram goes to a multicast group, robots that exit are told as "left";
#   6. cairn_agent --driver ros2 with the robot's ROS 2 nodes on its second computer (ros2.interface).
# Sections 1-4 use simple discovery (multicast announcements). Robots joining one after the other, how soon a
# cut link shows and false loss are measured by bench/fleet_join.sh.
# Run by ctest inside tests/netns_run.sh (a private network namespace); it enters a private mount namespace
# too, so that the hosts' names in /run/netns vanish with it.
#   networks_test.sh BUILD_DIR
set -uo pipefail
# shellcheck source=linksim/test_harness.sh
source "$(dirname "${BASH_SOURCE[0]}")/linksim/test_harness.sh" networks_test nw "$@"
DOMAIN=83

linksim_up "$P" || exit 1
linksim_add_host "$P" base 10.77.0.2 1000 || exit 1
for i in 1 2 3; do linksim_add_host "$P" "r$i" "10.77.0.1$i" 1000 || exit 1; done
LAN=(--link lan --subnet 10.77.0.0/24)
RADIO=(--link radio --link-kbps 1000 --subnet 10.77.0.0/24)
SERVER=10.77.0.2:11811
# A camera that alone fills a 1 Mbit/s link: 20 frames/s at JPEG quality 95, budget 4 Mbit/s.
cat >"$LOGS/heavy.yaml" <<'YAML'
perception:
  camera_rate_hz: 20
  jpeg_quality: 95
  camera_budget_bits_per_s: 4000000
YAML

# start_robot N X AGENT_FLAGS...: (re)starts robot N on its host at (X, 20), its output in $LOGS/N.log;
# wait_ready N waits for its READY; stop_robot N stops it (SIGTERM) and waits for it to exit.
declare -A PIDS
stop_robot() {
  [ -n "${PIDS[$1]:-}" ] && kill -TERM "${PIDS[$1]}" 2>/dev/null && wait "${PIDS[$1]}" 2>/dev/null
  PIDS[$1]=""
}
start_robot() {
  local n="$1" x="$2"
  shift 2
  stop_robot "$n"
  linksim_start_agent "$LOGS/$n.log" "$n" --robot-id "$n" --domain "$DOMAIN" --start "$x,20,0" "$@"
  PIDS[$n]=$AGENT_PID
}
wait_ready() { linksim_wait_ready "$LOGS/$1.log" "$1"; }

# 1. The link simulator.
linksim_exec "$P" base node "$ROOT/tests/linksim/udp_probe.mjs" recv 9000 4 >"$LOGS/recv" &
sleep 0.5
linksim_exec "$P" r1 node "$ROOT/tests/linksim/udp_probe.mjs" send 10.77.0.2 9000 3 3000 >"$LOGS/send"
wait
read -r _ received _ _ _ kbps <"$LOGS/recv"
if [ "$kbps" -ge 700 ] && [ "$kbps" -le 1150 ]; then pass "1 Mbit/s link carried $kbps kbit/s of 3000 offered"
else fail "1 Mbit/s link carried $kbps kbit/s ($(cat "$LOGS/recv"))"; fi
linksim_set_loss "$P" base 20
linksim_exec "$P" base node "$ROOT/tests/linksim/udp_probe.mjs" recv 9001 7 >"$LOGS/recv" &
sleep 0.5
linksim_exec "$P" r1 node "$ROOT/tests/linksim/udp_probe.mjs" send 10.77.0.2 9001 6 400 >"$LOGS/send"
wait
read -r _ sent <"$LOGS/send"
read -r _ received _ _ _ _ <"$LOGS/recv"
lost_pct=$(( (sent - received) * 100 / sent ))
if [ "$lost_pct" -ge 10 ] && [ "$lost_pct" -le 30 ]; then pass "20 % loss: $received of $sent arrived ($lost_pct % lost)"
else fail "20 % loss: $received of $sent arrived ($lost_pct % lost)"; fi
linksim_set_loss "$P" base 0

# 2. Bad flags, refused before anything starts (exit 2, the flag and the value named).
expect_refused() {
  local needle="$1"
  shift
  local out code
  out=$("$@" 2>&1 </dev/null)
  code=$?
  if [ "$code" -eq 2 ] && grep -qF -- "$needle" <<<"$out"; then pass "refused: $needle"
  else fail "expected exit 2 and '$needle', got exit $code: $(tail -2 <<<"$out")"; fi
}
expect_refused "--link 'wifi' must be loopback, lan or radio" "$AGENT" --robot-id r9 --domain "$DOMAIN" --link wifi
expect_refused "a radio link needs its budget" "$AGENT" --robot-id r9 --domain "$DOMAIN" --link radio --subnet 10.77.0.0/24
expect_refused "--link lan needs --subnet CIDR or --interface NAME" "$BASE" --base-id opX --domain "$DOMAIN" --link lan -- robots
expect_refused "add --link lan" "$BASE" --base-id opX --domain "$DOMAIN" --subnet 10.77.0.0/24 -- robots
expect_refused "subnet '10.77.0.0/33' must be an IPv4 CIDR" "$BASE" --base-id opX --domain "$DOMAIN" --link lan --subnet 10.77.0.0/33 -- robots

# A subnet this host has no address in.
expect_refused "--subnet 10.99.0.0/24: no interface of this host has an IPv4 address there (seen: lo 127.0.0.1, radio0 10.77.0.11)" \
  linksim_exec "$P" r1 "$AGENT" --robot-id r9 --domain "$DOMAIN" --link lan --subnet 10.99.0.0/24

# A discovery server outside the named network.
out=$(ip netns exec "${P}r1" "$AGENT" --robot-id r9 --domain "$DOMAIN" --link lan --subnet 10.77.0.0/24 \
  --discovery-server 10.99.0.1:11811 2>&1 </dev/null)
code=$?
if [ "$code" -ne 0 ] && grep -q "10.99.0.1" <<<"$out"; then pass "a discovery server outside 10.77.0.0/24 refused: $(grep -m1 10.99.0.1 <<<"$out" | cut -c1-160)"
else fail "a discovery server outside the subnet: exit $code, $(tail -2 <<<"$out")"; fi
expect_refused "--discovery-server '10.77.0.2' must be IPV4_ADDRESS:PORT" \
  linksim_exec "$P" r1 "$AGENT" --robot-id r9 --domain "$DOMAIN" --link lan --subnet 10.77.0.0/24 --discovery-server 10.77.0.2
expect_refused "--discovery-server names a server on a lan or radio link" \
  linksim_exec "$P" r1 "$AGENT" --robot-id r9 --domain "$DOMAIN" --discovery-server "$SERVER"

# 3. One robot, r1, on its host.
# Starts r1 at (10, 20) with the given agent flags (after stopping the one running) and waits for READY.
start_r1() {
  start_robot r1 10 "$@"
  wait_ready r1
}

# 3.1 The loopback link on the other host: never sees r1.
start_r1 "${LAN[@]}"
out=$(linksim_exec "$P" base "$BASE" --base-id opB --domain "$DOMAIN" -- wait r1 online 5 2>&1 </dev/null)
code=$?
if [ "$code" -ne 0 ]; then pass "a loopback basestation on another host does not see r1 (exit $code)"
else fail "a loopback basestation on another host saw r1: $out"; fi

# 3.2 Over the lan link: seen, commanded, arrives.
base_lan() { linksim_exec "$P" base "$BASE" --base-id opA --domain "$DOMAIN" "${LAN[@]}" -- "$@" 2>&1 </dev/null; }
start_s=$(date +%s.%N)
out=$(base_lan wait r1 online 30)
code=$?
seen_s=$(awk -v a="$start_s" -v b="$(date +%s.%N)" 'BEGIN{printf "%.1f", b - a}')
if [ "$code" -eq 0 ]; then pass "a lan basestation on another host sees r1 ($seen_s s, its process start included)"
else fail "a lan basestation did not see r1: $out"; fi
out=$(base_lan request-control r1)
if grep -q "accepted" <<<"$out"; then pass "request-control over the link: $(head -1 <<<"$out")"
else fail "request-control over the link: $out"; fi
out=$(base_lan goto r1 13 20 --wait 60)
code=$?
if [ "$code" -eq 0 ] && grep -q "arrived" <<<"$out"; then pass "goto over the link: $(tail -1 <<<"$out")"
else fail "goto over the link (exit $code): $(tail -3 <<<"$out")"; fi

# 30 request-control round trips from one basestation process, 5 per second, while r1 drives to a goal 27 m
# away (its map, camera and state on the link). Sets ACCEPTED, P50, P99, WORST; none may be lost, unless the
# second argument is "baseline" (a link left saturated on purpose: what is lost there is a figure).
command_round_trips() {
  local label="$1" mode="${2:-}" summary drove answered
  {
    echo "request-control r1"  # a restarted robot has forgotten its holder
    echo "goto r1 40 20"
    for _ in $(seq 1 30); do echo "request-control r1"; echo "sleep 0.2"; done
    echo "stop r1"
  } | linksim_exec "$P" base "$BASE" --base-id opA --domain "$DOMAIN" "${LAN[@]}" --json >"$LOGS/rtt.json" 2>"$LOGS/rtt.err"
  summary=$(node "$ROOT/tests/linksim/round_trips.mjs" "$LOGS/rtt.json" 1)
  read -r ACCEPTED answered P50 P99 WORST drove _ <<<"$summary"
  echo "FIGURE ${label}_command_round_trip_ms median $P50 p99 $P99 max $WORST ($ACCEPTED of 30 accepted)"
  if [ "$mode" = baseline ]; then
    echo "FIGURE ${label}_commands_lost $((30 - ACCEPTED)) of 30 (r1 drove: $drove)"
    return
  fi
  [ "$drove" = true ] || fail "$label: the goto that was to keep r1 driving was not accepted: $(head -c 400 "$LOGS/rtt.json")"
  if [ "$ACCEPTED" = 30 ]; then pass "$label: 30 commands over the link while r1 drove, all accepted"
  else fail "$label: $ACCEPTED of 30 commands accepted ($answered answered): $(tail -3 "$LOGS/rtt.err")"; fi
}

# 3.3 Commands while r1 drives, its traffic as shipped (the round trip is a figure, not a limit).
command_round_trips lan_1mbit

#     A camera that saturates the link (20 frames/s at JPEG quality 95, budget 4 Mbit/s: about 2-3 Mbit/s
#    offered to a 1 Mbit/s link). As configured (lan), commands queue behind the frames; on the radio link the
#    robot holds its camera and map to shares of the stated budget, and commands keep their round trip
#    (p99 <= 100 ms, none lost).
start_r1 --config "$LOGS/heavy.yaml" "${LAN[@]}"
command_round_trips saturated_lan baseline
lan_p99="$P99"
start_r1 --config "$LOGS/heavy.yaml" --link radio --link-kbps 1000 --subnet 10.77.0.0/24
grep -q "radio link of 1000 kbit/s: camera 4000000 -> 150000 bit/s" "$LOGS/r1.log" ||
  fail "r1 did not hold its camera to the radio share: $(grep -m1 radio "$LOGS/r1.log")"
command_round_trips saturated_radio
if awk -v p="$P99" 'BEGIN{exit !(p >= 0 && p <= 100)}'; then pass "radio link: command round trip p99 $P99 ms <= 100 ms"
else fail "radio link: command round trip p99 $P99 ms > 100 ms"; fi
if awk -v a="$lan_p99" -v b="$P99" 'BEGIN{exit !(a > 0 && b > 0)}'; then
  echo "FIGURE saturated_command_round_trip_p99_ratio_lan_over_radio $(awk -v a="$lan_p99" -v b="$P99" 'BEGIN{printf "%.1f", a / b}')"
else
  echo "FIGURE saturated_command_round_trip_p99_ratio_lan_over_radio none (no lan command answered: every one lost in the saturated link)"
fi

# 3.4 5 % random loss each way on both hosts (~10 % of round trips hit): every command answered once and applied
#    once (retries are de-duplicated: the goals the robot numbers are consecutive, each arrives under its own
#    id), and the basestation's map of the robot, kept by deltas over the lossy link, ends equal to a snapshot
#    a second basestation asks for once the robot has stopped.
start_r1 "${LAN[@]}"
linksim_set_loss "$P" r1 5
linksim_set_loss "$P" base 5
{
  echo "request-control r1"
  echo "goto r1 16 20 --wait 60"
  echo "goto r1 22 20 --wait 60"
  for _ in $(seq 1 20); do echo "request-control r1"; done
  echo "goto r1 28 20 --wait 60"
  echo "sleep 3"
  echo "map r1 --save $LOGS/deltas.bt"
} | linksim_exec "$P" base "$BASE" --base-id opA --domain "$DOMAIN" "${LAN[@]}" --json >"$LOGS/loss.json" 2>"$LOGS/loss.err"
out=$(printf 'wait r1 online 20\nmap r1 --save %s\n' "$LOGS/snapshot.bt" |
  linksim_exec "$P" base "$BASE" --base-id opC --domain "$DOMAIN" "${LAN[@]}" --json 2>&1)
verdict=$(node -e '
  const fs = require("fs");
  const all = fs.readFileSync(process.argv[1], "utf8").split("\n").filter((l) => l.startsWith("{")).map((l) => JSON.parse(l));
  const snap = fs.readFileSync(process.argv[2], "utf8").split("\n").filter((l) => l.startsWith("{")).map((l) => JSON.parse(l)).find((o) => o.command === "map");
  const bad = [];
  const controls = all.filter((o) => o.command === "request-control");
  if (controls.length !== 21 || !controls.every((o) => o.ok)) bad.push(`${controls.filter((o) => o.ok).length} of ${controls.length} request-control accepted (not: ${JSON.stringify(controls.filter((o) => !o.ok))})`);
  const gotos = all.filter((o) => o.command === "goto" && !o.progress);
  if (gotos.length !== 3 || !gotos.every((o) => o.ok && /^arrived/.test(o.reason))) bad.push(`gotos: ${JSON.stringify(gotos.map((o) => o.reason))}`);
  const ids = gotos.map((o) => o.goal_id);
  if (ids.length !== 3 || ids[1] !== ids[0] + 1 || ids[2] !== ids[1] + 1) bad.push(`goal ids ${JSON.stringify(ids)} (3 consecutive expected)`);
  const map = all.find((o) => o.command === "map");
  if (!map || !map.ok) bad.push(`map over the lossy link: ${JSON.stringify(map)}`);
  if (!snap || !snap.ok) bad.push(`snapshot map: ${JSON.stringify(snap)}`);
  if (map && snap && map.ok && snap.ok && (map.voxels !== snap.voxels || map.occupied !== snap.occupied)) {
    bad.push(`maps differ: deltas ${map.voxels} voxels (${map.occupied} occupied), snapshot ${snap.voxels} (${snap.occupied})`);
  }
  console.log(bad.length ? "BAD " + bad.join("; ") : `GOOD goals ${ids.join(", ")}; map ${map.voxels} voxels (${map.occupied} occupied) both ways`);
' "$LOGS/loss.json" <(echo "$out"))
if [[ "$verdict" == GOOD* ]]; then pass "5 % loss: 21 commands and 3 goals each applied once, ${verdict#GOOD }"
else fail "5 % loss: ${verdict#BAD } ($(tail -15 "$LOGS/loss.err"))"; fi
linksim_set_loss "$P" r1 0
linksim_set_loss "$P" base 0

# 3.5 The link cut for 10 s while the operator drives r1 by teleop (0.4 m/s for 16 s), then restored: the robot
#    stops when teleop goes stale (it drives ~2.5 m, not 6.4), keeps the operator's lock, is shown lost then
#    back, and the basestation's map of it resyncs (equal to a fresh snapshot).
start_r1 "${LAN[@]}"
{
  echo "request-control r1"
  echo "mode r1 manual"
  echo "teleop r1 0.4 0 16"
  echo "wait r1 online 30"
  echo "sleep 4"
  echo "status r1"
  echo "map r1 --save $LOGS/after_cut.bt"
} | linksim_exec "$P" base "$BASE" --base-id opA --domain "$DOMAIN" "${LAN[@]}" --json >"$LOGS/cut.json" 2>"$LOGS/cut.err" &
cut_base=$!
for _ in $(seq 1 200); do grep -q '"command":"mode".*"ok":true' "$LOGS/cut.json" 2>/dev/null && break; sleep 0.1; done
sleep 3
linksim_set_loss "$P" r1 100
sleep 10
linksim_set_loss "$P" r1 0
wait "$cut_base"
out=$(printf 'wait r1 online 20\nmap r1 --save %s\n' "$LOGS/fresh.bt" |
  linksim_exec "$P" base "$BASE" --base-id opC --domain "$DOMAIN" "${LAN[@]}" --json 2>&1)
verdict=$(node -e '
  const fs = require("fs");
  const lines = (t) => t.split("\n").filter((l) => l.startsWith("{")).map((l) => JSON.parse(l));
  const all = lines(fs.readFileSync(process.argv[1], "utf8"));
  const fresh = lines(fs.readFileSync(process.argv[2], "utf8")).find((o) => o.command === "map");
  const bad = [];
  const kinds = all.filter((o) => o.event && o.robot === "r1").map((o) => o.event);
  const lost = kinds.indexOf("lost"), back = kinds.lastIndexOf("back");
  if (lost < 0 || back < lost) bad.push(`events ${JSON.stringify(kinds)} (lost then back expected)`);
  const status = all.find((o) => o.command === "status");
  if (!status || status.holder !== "opA") bad.push(`holder after the cut: ${status && status.holder}`);
  const dx = status ? status.x_m - 10 : NaN;
  if (!(dx > 0.5 && dx < 4.0)) bad.push(`drove ${dx.toFixed(2)} m (0.5-4 expected: it must stop while the link is cut)`);
  const map = all.find((o) => o.command === "map");
  if (!map || !map.ok || !fresh || !fresh.ok || map.voxels !== fresh.voxels || map.occupied !== fresh.occupied) {
    bad.push(`map after the cut ${map && map.voxels}/${map && map.occupied}, fresh snapshot ${fresh && fresh.voxels}/${fresh && fresh.occupied}`);
  }
  console.log(bad.length ? "BAD " + bad.join("; ") : `GOOD drove ${dx.toFixed(2)} m, events ${kinds.join(" ")}, lock kept, map ${map.voxels} voxels both ways`);
' "$LOGS/cut.json" <(echo "$out"))
if [[ "$verdict" == GOOD* ]]; then pass "10 s link cut: ${verdict#GOOD }"
else fail "10 s link cut: ${verdict#BAD } ($(tail -2 "$LOGS/cut.err"))"; fi

# 4. Three robots sharing the radio link, each with the heavy camera.
# The basestation on its host: `base ARGS` runs one command, `base_script ARGS <FILE` a script.
base_script() { linksim_exec "$P" base "$BASE" --base-id opA --domain "$DOMAIN" "${RADIO[@]}" "$@" 2>&1; }
base() { base_script "$@" </dev/null; }

start_robot r1 10 --config "$LOGS/heavy.yaml" "${RADIO[@]}"
start_robot r2 16 --config "$LOGS/heavy.yaml" "${RADIO[@]}"
start_robot r3 22 --config "$LOGS/heavy.yaml" "${RADIO[@]}"
for n in r1 r2 r3; do wait_ready "$n"; done

# 4.1-4 One basestation process for the rest (a fresh one costs the link its discovery and map snapshots):
# it waits for the three, drives them, sends 30 commands spread over them while they drive, lists the links.
{
  for n in r1 r2 r3; do echo "wait $n online 20"; done
  echo "sleep 3"  # discovery, transient-local state and the map snapshots a new basestation asks for
  for n in r1 r2 r3; do echo "request-control $n"; done
  echo "goto r1 28 20"
  echo "goto r2 34 20"
  echo "goto r3 40 20"
  # The second after three goals start is their burst to the basestation (each robot's new state, tree, path
  # and plan at once): the gotos' own answers wait in it (a figure below); the commands measure the driving.
  echo "sleep 1"
  for _ in $(seq 1 10); do
    for n in r1 r2 r3; do echo "request-control $n"; echo "sleep 0.2"; done
  done
  # The loss `links` shows is over its last 10 s: from 11 s after the join, the driving alone. The join's own
  # burst (each robot's map snapshot and bulk to the new basestation at once) drops packets on the base's
  # downlink: a figure above (radio_fleet_join_drops), and the cumulative counts below.
  echo "sleep 2"
  echo "links"
  echo "stop all"
} >"$LOGS/script"
read_base_queue() { linksim_host_queue "$P" base; }
# Packets each robot's own radio queue dropped so far (its sends beyond the link's 200 ms of queue).
read_robot_drops() { for n in r1 r2 r3; do echo -n "$n $(linksim_own_queue "$P" "$n" | cut -d' ' -f2) "; done; }
# UDP datagrams the base's host dropped because a socket's receive buffer was full (a process too slow to read).
read_base_rcvbuf_errors() { linksim_exec "$P" base awk '/^Udp:/ {n++; if (n == 1) for (i = 1; i <= NF; ++i) if ($i == "RcvbufErrors") k = i; if (n == 2) print $k}' /proc/net/snmp; }
# The base's queue counters (bytes sent, packets dropped) are read around the driving part, by its output.
base_script --json <"$LOGS/script" >"$LOGS/fleet.json" &
base_pid=$!
for _ in $(seq 1 300); do grep -q '"command":"goto"' "$LOGS/fleet.json" 2>/dev/null && break; sleep 0.1; done
read -r bytes0 drops0 <<<"$(read_base_queue)"
robot_drops0=$(read_robot_drops)
rcvbuf0=$(read_base_rcvbuf_errors)
t0=$(date +%s.%N)
for _ in $(seq 1 300); do grep -q '"command":"links"' "$LOGS/fleet.json" 2>/dev/null && break; sleep 0.1; done
read -r bytes1 drops1 <<<"$(read_base_queue)"
robot_drops1=$(read_robot_drops)
rcvbuf1=$(read_base_rcvbuf_errors)
t1=$(date +%s.%N)
wait "$base_pid"

# 4.1 The bulk shares, split three ways once the basestation heard the three (robots never read one another:
# the basestation tells them how many it hears).
for n in r1 r2 r3; do
  if grep -q "3 robots share the 1000 kbit/s radio link: map telemetry 33333 bit/s, camera 50000 bit/s" "$LOGS/$n.log"; then
    pass "$n takes a third of the radio's bulk shares"
  else fail "$n did not split the link three ways: $(grep "radio link" "$LOGS/$n.log" | head -3)"; fi
done

# 4.2 Joined, with capabilities.
for n in r1 r2 r3; do
  if grep -q "\"event\":\"joined\".*\"message\":\"$n joined: wheeled, cairn [0-9.]*, modes [a-z_ ]*, sensors lidar camera, map 0.10 m, link radio 1000 kbit/s\"" "$LOGS/fleet.json"; then
    pass "the basestation heard $n join with its capabilities"
  else fail "no joined event for $n with its capabilities: $(grep joined "$LOGS/fleet.json" | head -3)"; fi
done

# 4.3 Commands while the three drive.
read -r ACCEPTED answered P50 P99 WORST drove GOTO_WORST <<<"$(node "$ROOT/tests/linksim/round_trips.mjs" "$LOGS/fleet.json" 3)"
echo "FIGURE radio_fleet_3_robots_command_round_trip_ms median $P50 p99 $P99 max $WORST ($ACCEPTED of 30 accepted)"
echo "FIGURE radio_fleet_goal_start_round_trip_ms the slowest of the three gotos sent back to back: $GOTO_WORST"
awk -v b0="$bytes0" -v b1="$bytes1" -v a="$t0" -v b="$t1" -v d0="$drops0" -v d1="$drops1" \
  'BEGIN{printf "FIGURE radio_fleet_link_to_base_kbps %.0f over %.1f s of driving, %d packets dropped by its queue\n", (b1 - b0) * 8 / 1000 / (b - a), b - a, d1 - d0}'
echo "FIGURE radio_fleet_join_drops the base's queue dropped $drops0 packets before the robots drove (its join: snapshots and bulk from the three at once)"
echo "FIGURE radio_fleet_robot_queue_drops before driving: $robot_drops0; after: $robot_drops1"
echo "FIGURE radio_fleet_base_udp_rcvbuf_errors before driving: $rcvbuf0; after: $rcvbuf1"
[ "$drove" = true ] || fail "the gotos that were to keep the robots driving were not all accepted: $(grep '"goto"' "$LOGS/fleet.json" | head -3)"
if [ "$ACCEPTED" = 30 ]; then pass "30 commands to 3 robots over the shared link while they drove, all accepted"
else fail "$ACCEPTED of 30 commands accepted ($answered answered): $(grep -v '"ok":true' "$LOGS/fleet.json" | head -3)"; fi
if awk -v p="$P99" 'BEGIN{exit !(p >= 0 && p <= 100)}'; then pass "command round trip p99 $P99 ms <= 100 ms"
else fail "command round trip p99 $P99 ms > 100 ms"; fi

# 4.4 The links as the basestation saw them after the commands.
summary=$(node -e '
  const j = JSON.parse(require("fs").readFileSync(process.argv[1], "utf8").split("\n").find((l) => l.includes("\"command\":\"links\"")));
  const bad = [];
  let total = 0;
  for (const r of j.robots) {
    const by = Object.fromEntries(r.usage.map((u) => [u.topic_class, u]));
    total += r.sent_kbps;
    if (r.link !== "radio" || r.budget_kbps !== 1000) bad.push(`${r.robot}: link ${r.link} ${r.budget_kbps}`);
    if (!(r.rtt_ms >= 0 && r.rtt_ms < 100)) bad.push(`${r.robot}: probe round trip ${r.rtt_ms} ms`);
    if (!(r.state_received > 50)) bad.push(`${r.robot}: ${r.state_received} states`);
    if (!(r.loss_pct < 5)) bad.push(`${r.robot}: ${r.loss_pct} % of states lost over the last 10 s`);
    for (const c of ["command", "state", "tree", "map", "camera"]) if (!by[c]) bad.push(`${r.robot}: no ${c} class`);
    if (!(by.camera && by.camera.sent_bytes > 0 && by.map && by.map.sent_bytes > 0)) bad.push(`${r.robot}: no map or camera sent`);
    if (r.over_budget) bad.push(`${r.robot}: over budget`);
    console.log(`FIGURE radio_fleet_${r.robot}_sends_kbps ${r.sent_kbps.toFixed(1)} (${r.usage.map((u) => `${u.topic_class} ${u.sent_kbps.toFixed(1)}`).join(", ")}) probe rtt ${r.rtt_ms.toFixed(1)} ms (max ${r.rtt_max_ms.toFixed(1)}), ${r.state_lost} of ${r.state_received + r.state_lost} states lost`);
  }
  if (j.robots.length !== 3) bad.push(`${j.robots.length} robots listed`);
  if (!(total < 1000)) bad.push(`the three send ${total} kbit/s together, more than the link`);
  console.log(bad.length ? "BAD " + bad.join("; ") : `GOOD ${total.toFixed(1)}`);
' "$LOGS/fleet.json")
echo "$summary" | grep FIGURE
verdict=$(echo "$summary" | grep -v FIGURE)
if [[ "$verdict" == GOOD* ]]; then pass "links: every robot on radio 1000 kbit/s, probed, maps and frames flowing, ${verdict#GOOD } kbit/s together"
else fail "links: ${verdict#BAD }"; fi

# 4.5 Over budget: r3 restarted with a budget its state alone exceeds (8 kbit/s, the least a radio takes; its
# state is ~10 kbit/s), without perception (whose map telemetry needs a larger budget).
linksim_light_robot_config "$LOGS/light.yaml"
start_robot r3 22 --config "$LOGS/light.yaml" --link radio --link-kbps 8 --subnet 10.77.0.0/24
wait_ready r3
sleep 3  # a usage report (once a second) over a full window
# A fresh one-shot basestation may not have r3's first usage report yet: r3's whole output, the report too,
# is squeezed into 8 kbit/s (seen once in CI: r3 joined, SENDS still "-"). Asked again, up to 4 times.
flagged=false
for attempt in 1 2 3 4; do
  out=$(base -- links r3)
  if grep -aq "warning: r3 sends [0-9.]* kbit/s, over its link budget of 8 kbit/s" <<<"$out" &&
     grep -aq "r3 sends [0-9.]* kbit/s, over its link budget of 8.0 kbit/s" <<<"$out"; then
    flagged=true
    break
  fi
  sleep 2
done
if $flagged; then pass "r3 over its 8 kbit/s budget: a warning in links and an event (asked $attempt times)"
else fail "r3 over budget not flagged: $out"; fi

for n in r1 r2 r3; do stop_robot "$n"; done

# A round of three robots and a basestation, every process with the given extra link flags: the robots idle
# (a figure), are seen and commanded, then told as "left" when they exit.
round() {
  local label="$1"
  shift
  local flags=(--link lan --subnet 10.77.0.0/24 "$@") x=10 n
  for n in r1 r2 r3; do
    start_robot "$n" "$x" "${flags[@]}"
    x=$((x + 6))
  done
  for n in r1 r2 r3; do wait_ready "$n"; done
  sleep 2
  local b0 b1
  b0=$(linksim_hub_bytes "$P")
  sleep 10
  b1=$(linksim_hub_bytes "$P")
  echo "FIGURE discovery_${label}_3_idle_robots_kbps $(awk -v a="$b0" -v b="$b1" 'BEGIN{printf "%.1f", (b - a) * 8 / 1000 / 10}') (bytes the hub delivered to the 4 hosts over 10 s, no basestation)"
  local start_s seen_s out
  start_s=$(date +%s.%N)
  out=$(printf 'wait r1 online 20\nwait r2 online 20\nwait r3 online 20\n' |
    ip netns exec "${P}base" "$BASE" --base-id opA --domain "$DOMAIN" "${flags[@]}" --json 2>&1)
  seen_s=$(awk -v a="$start_s" -v b="$(date +%s.%N)" 'BEGIN{printf "%.2f", b - a}')
  if [ "$(grep -c '"command":"wait".*"ok":true' <<<"$out")" = 3 ]; then
    pass "$label: a basestation sees the three robots"
    echo "FIGURE discovery_${label}_base_sees_3_robots_s $seen_s (from the basestation process's start)"
  else fail "$label: the basestation did not see the three: $(grep -v '"ok":true' <<<"$out" | head -3)"; fi
  out=$(ip netns exec "${P}base" "$BASE" --base-id opA --domain "$DOMAIN" "${flags[@]}" -- request-control r2 2>&1 </dev/null)
  if grep -q "accepted" <<<"$out"; then pass "$label: request-control r2 accepted"
  else fail "$label: request-control r2: $out"; fi
  # The three exit cleanly, one after the other, while a basestation watches: each is told as "left", not lost.
  printf 'wait r1 online 20\nwait r2 online 20\nwait r3 online 20\nsleep 1\nevents 1\nsleep 14\n' |
    ip netns exec "${P}base" "$BASE" --base-id opW --domain "$DOMAIN" "${flags[@]}" --json >"$LOGS/leave.json" 2>&1 &
  local watcher=$!
  for _ in $(seq 1 200); do grep -q '"command":"events"' "$LOGS/leave.json" 2>/dev/null && break; sleep 0.1; done
  # A participant's removal goes to the participants it has discovered: give the robots one lease (2 s) to have
  # discovered the watcher before the first goes. Twice in CI r1, the first to go, was shown lost instead of
  # left (its lease expired at the watcher), most likely because its removal went out before that.
  sleep 2
  for n in r1 r2 r3; do stop_robot "$n"; done
  wait "$watcher"
  if [ "$(grep -c '"event":"left".*its process exited' "$LOGS/leave.json")" = 3 ]; then
    pass "$label: the three robots that exited are told as left"
  else fail "$label: left events: $(grep -a '"event"' "$LOGS/leave.json" | grep -v joined | head -4)"; fi
}

# 5. A discovery server on the basestation's host; every process its client.
ip netns exec "${P}base" "$ROOT/tools/discovery_server.sh" --subnet 10.77.0.0/24 >"$LOGS/server.log" 2>&1 &
server_pid=$!
for _ in $(seq 1 50); do grep -q "Server is running" "$LOGS/server.log" && break; sleep 0.1; done
grep -q "discovery server on $SERVER" "$LOGS/server.log" || fail "the discovery server did not start: $(cat "$LOGS/server.log")"
ip netns exec "${P}r1" iptables -A OUTPUT -p udp -d 224.0.0.0/4 -j ACCEPT  # counts UDP to any multicast group
round server --discovery-server "$SERVER"
multicast=$(ip netns exec "${P}r1" iptables -L OUTPUT -v -x -n | awk '$0 ~ /224.0.0.0\/4/ {print $1; exit}')
if [ "${multicast:-x}" = 0 ]; then pass "server: r1 sent nothing to a multicast group"
else fail "server: r1 sent $multicast packets to multicast groups"; fi
kill -TERM "$server_pid" 2>/dev/null
wait "$server_pid" 2>/dev/null

# 6. The robot's ROS 2 nodes (a lidar driver's, a SLAM's) on its second computer, joined by ethernet: two hosts
#    on a 100 Mbit/s link, the ROS 2 robot emulator on Cyclone DDS (--interface radio0) on one, cairn_agent
#    --driver ros2 and a basestation (its fleet on loopback) on the other. Config ros2.interface names the
#    interface; the ROS 2 participant binds to it only and finds the nodes by multicast discovery there.
#    6.1 a bad ros2.interface is refused naming the field and the value; an interface the host lacks is refused
#        naming it and the interfaces seen (exit 2, before the robot moves);
#    6.2 without ros2.interface (loopback) the agent never hears the other computer: not localized, naming the
#        odometry topic, and a goal is refused;
#    6.3 with ros2.interface radio0 the agent is localized from the other computer's odometry and drives to a
#        goal 3 m ahead; the emulator's ground truth says it got there, never in contact.
EMULATOR="$BUILD/tools/ros2_robot_emulator/cairn_ros2_robot_emulator"
ROS2_DOMAIN=17
linksim_add_host "$P" sensors 10.77.0.21 100000 || exit 1
linksim_add_host "$P" robot 10.77.0.22 100000 || exit 1
# The emulator: the corner world, the robot at (1, 0) facing +x, its odometry's origin.
linksim_exec "$P" sensors "$EMULATOR" --world corner --domain "$ROS2_DOMAIN" --interface radio0 \
  --truth-out "$LOGS/truth.txt" >"$LOGS/emulator.out" 2>"$LOGS/emulator.log" &
emulator_pid=$!
for _ in $(seq 1 100); do grep -q READY "$LOGS/emulator.out" && break; sleep 0.1; done
grep -q READY "$LOGS/emulator.out" || fail "the emulator did not start: $(tail -3 "$LOGS/emulator.log")"
# Writes an agent config with ros2.interface = $2 and start_wait_s = $3 to $1.
write_ros2_config() { printf 'ros2:\n  interface: "%s"\n  start_wait_s: %s\n' "$2" "$3" >"$1"; }
# The agent on the robot's computer with config $1: its flags, and (re)starting it until READY.
ros2_agent_flags() { echo --robot-id r1 --domain "$DOMAIN" --driver ros2 --ros2-domain "$ROS2_DOMAIN" --config "$1"; }
start_ros2_r1() {
  [ -n "${ROS2_R1_PID:-}" ] && kill -TERM "$ROS2_R1_PID" 2>/dev/null && wait "$ROS2_R1_PID" 2>/dev/null
  # shellcheck disable=SC2046  # the flags are words without spaces
  linksim_start_agent "$LOGS/ros2_r1.log" robot $(ros2_agent_flags "$1")
  ROS2_R1_PID=$AGENT_PID
  linksim_wait_ready "$LOGS/ros2_r1.log" "r1 (ROS 2) with $(tr '\n' ' ' <"$1")"
}
# Runs the given console lines, one after the other, in one cairn_base on the robot's computer.
robot_base() { printf '%s\n' "$@" | linksim_exec "$P" robot "$BASE" --base-id op1 --domain "$DOMAIN" 2>&1; }

write_ros2_config "$LOGS/bad_name.yaml" "eth 1" 1
# shellcheck disable=SC2046
expect_refused "ros2.interface 'eth 1' is not a network interface name" \
  linksim_exec "$P" robot "$AGENT" $(ros2_agent_flags "$LOGS/bad_name.yaml")
write_ros2_config "$LOGS/absent.yaml" eth7 1
# shellcheck disable=SC2046
expect_refused "--interface 'eth7': no interface of this host has an IPv4 address there (seen: lo 127.0.0.1, radio0 10.77.0.22)" \
  linksim_exec "$P" robot "$AGENT" $(ros2_agent_flags "$LOGS/absent.yaml")

write_ros2_config "$LOGS/loopback.yaml" "" 1
start_ros2_r1 "$LOGS/loopback.yaml"
out=$(robot_base "wait r1 online 20" "request-control r1" "goto r1 4 0")
if grep -q "goto r1: refused: .*not localized: .*no odometry on /odom" <<<"$out"; then
  pass "ROS 2 on loopback only: $(grep -o "goto r1: refused: [^;]*" <<<"$out")"
else fail "ROS 2 on loopback only: expected goto refused for no odometry on /odom: $out"; fi

write_ros2_config "$LOGS/lan.yaml" radio0 10
start_ros2_r1 "$LOGS/lan.yaml"
out=$(robot_base "wait r1 online 20" "request-control r1" "goto r1 4 0 --wait 60")
if grep -q "arrived" <<<"$out"; then pass "goto over the robot's ethernet: $(grep arrived <<<"$out" | tail -1)"
else fail "goto over the robot's ethernet: $(tail -4 <<<"$out")"; fi
# The truth (t_s x_m y_m yaw_rad in_contact, world frame; the odometry's origin, the robot's map frame, is
# the start (1, 0) facing +x): within 0.5 m of (5, 0), never in contact.
tail -1 "$LOGS/truth.txt" | awk '{ d = sqrt(($2 - 5)^2 + $3^2); exit !(d < 0.5) }' &&
  pass "the emulator's truth ends at $(tail -1 "$LOGS/truth.txt" | awk '{print $2, $3}') in the world" ||
  fail "the emulator's truth ends at $(tail -1 "$LOGS/truth.txt" | awk '{print $2, $3}'), not within 0.5 m of (5, 0)"
awk '$5 != 0 { hit = 1 } END { exit hit }' "$LOGS/truth.txt" || fail "the robot touched a wall (truth in_contact)"
grep -q "on radio0" "$LOGS/emulator.log" || fail "the emulator's log does not say radio0: $(head -2 "$LOGS/emulator.log")"
kill -TERM "$ROS2_R1_PID" "$emulator_pid" 2>/dev/null
wait "$ROS2_R1_PID" "$emulator_pid" 2>/dev/null

if [ "$failures" -ne 0 ]; then
  for n in r1 r2 r3 ros2_r1 emulator; do echo "--- $n" >&2; tail -10 "$LOGS/$n.log" >&2; done
  echo "networks_test: $failures check(s) failed" >&2
  exit 1
fi
echo "networks_test: all checks passed"
