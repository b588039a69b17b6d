#!/usr/bin/env bash
# Three robots and a basestation on four hosts joined by a simulated 1 Mbit/s radio (tests/linksim), every
# process on the radio link class. Each robot's camera alone would fill the link (20 frames/s at
# JPEG quality 95). Checks, in order:
#   1. each robot sees the other two on its link and takes a third of the radio's bulk shares;
#   2. the basestation hears each robot join, with what it offers (sensors, map resolution, link);
#   3. while the three drive (maps and cameras on the link), 30 commands spread over them are all accepted,
#      round trip p99 <= 100 ms (from 1 s after the goals start; the gotos' own round trips are a figure); what reached the basestation's radio and what its queue dropped are figures;
#   4. `links` shows each robot's probe round trip, lost state samples and sends per topic class, maps and
#      frames still flowing (slower), the three together within the link;
#   5. a robot that sends more than its stated budget is flagged over budget, in `links` and as an event.
# Run by ctest inside tests/netns_run.sh; enters a private mount namespace (the hosts' names vanish with it).
#   radio_fleet_test.sh BUILD_DIR
set -uo pipefail
# shellcheck source=linksim/test_harness.sh
source "$(dirname "${BASH_SOURCE[0]}")/linksim/test_harness.sh" radio_fleet_test rf "$@"
DOMAIN=84

RADIO=(--link radio --link-kbps 1000 --subnet 10.77.0.0/24)
linksim_up "$P" || exit 1
linksim_add_host "$P" base 10.77.0.2 1000 || exit 1
for i in 1 2 3; do linksim_add_host "$P" "r$i" "10.77.0.1$i" 1000 || exit 1; done
cat >"$LOGS/heavy.yaml" <<'YAML'
perception:
  camera_rate_hz: 20
  jpeg_quality: 95
  camera_budget_bits_per_s: 4000000
YAML

# Starts robot rN on its host at (X, 20) with the heavy camera (or the config ROBOT_CONFIG names), plus any
# extra flags.
declare -A PIDS
start_robot() {
  local n="$1" x="$2"
  shift 2
  [ -n "${PIDS[$n]:-}" ] && kill -TERM "${PIDS[$n]}" 2>/dev/null && wait "${PIDS[$n]}" 2>/dev/null
  linksim_start_agent "$LOGS/$n.log" "$n" --robot-id "$n" --domain "$DOMAIN" --start "$x,20,0" \
    --config "${ROBOT_CONFIG:-$LOGS/heavy.yaml}" "$@"
  PIDS[$n]=$AGENT_PID
}
wait_ready() { linksim_wait_ready "$LOGS/$1.log" "$1"; }
# The basestation on its host: `base ARGS` runs one command, `base_script ARGS <FILE` a script.
base_script() { linksim_exec "$P" base "$BASE" --base-id opA --domain "$DOMAIN" "${RADIO[@]}" "$@" 2>&1; }
base() { base_script "$@" </dev/null; }

start_robot r1 10 "${RADIO[@]}"
start_robot r2 16 "${RADIO[@]}"
start_robot r3 22 "${RADIO[@]}"
for n in r1 r2 r3; do wait_ready "$n"; done

# 1-4. One basestation process for the rest (a fresh one costs the link its discovery and map snapshots):
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

# 1. The bulk shares, split three ways once the basestation heard the three (robots never read one another:
# the basestation tells them how many it hears).
for n in r1 r2 r3; do
  if grep -q "3 robots share the 1000 kbit/s radio link: map telemetry 33333 bit/s, camera 50000 bit/s" "$LOGS/$n.log"; then
    pass "$n takes a third of the radio's bulk shares"
  else fail "$n did not split the link three ways: $(grep "radio link" "$LOGS/$n.log" | head -3)"; fi
done

# 2. Joined, with capabilities.
for n in r1 r2 r3; do
  if grep -q "\"event\":\"joined\".*\"message\":\"$n joined: wheeled, cairn [0-9.]*, modes [a-z_ ]*, sensors lidar camera, map 0.10 m, link radio 1000 kbit/s\"" "$LOGS/fleet.json"; then
    pass "the basestation heard $n join with its capabilities"
  else fail "no joined event for $n with its capabilities: $(grep joined "$LOGS/fleet.json" | head -3)"; fi
done

# 3. Commands while the three drive.
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

# 4. The links as the basestation saw them after the commands.
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

# 5. Over budget: r3 restarted with a budget its state alone exceeds (8 kbit/s, the least a radio takes; its
# state is ~10 kbit/s), without perception (whose map telemetry needs a larger budget).
linksim_light_robot_config "$LOGS/light.yaml"
ROBOT_CONFIG="$LOGS/light.yaml" start_robot r3 22 --link radio --link-kbps 8 --subnet 10.77.0.0/24
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

for n in r1 r2 r3; do kill -TERM "${PIDS[$n]}" 2>/dev/null; done
if [ "$failures" -ne 0 ]; then
  for n in r1 r2 r3; do echo "--- $n" >&2; tail -8 "$LOGS/$n.log" >&2; done
  echo "radio_fleet_test: $failures check(s) failed" >&2
  exit 1
fi
echo "radio_fleet_test: all checks passed"
