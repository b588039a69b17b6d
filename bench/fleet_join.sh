#!/usr/bin/env bash
# Bench: robots joining one basestation over a simulated 1 Mbit/s radio (tests/linksim: a host each), every
# process on the radio link class, first with simple discovery (multicast announcements), then as clients of a
# Fast DDS discovery server on the basestation's host. In each round:
#   1. the robots start one after the other; with the server each is visible at the basestation (its
#      announcement arrived) within 1 s (p95) of announcing itself, which it does once ready to take commands
#      (its DDS participant starts first, so discovery overlaps its own start); with simple discovery a figure
#      (see below). Its own start (process start to ready) and the time from its process start are figures:
#      on this machine eleven processes share two cores, so a robot's start is slower than on its own computer;
#   2. the traffic the hub delivers with 1, 5 and N robots and the basestation up is a figure;
#   3. three robots' links are cut in turn: each is shown lost within 1 s, and back once restored;
#   4. 5 % random loss on every link for 20 s: no robot is shown lost (no false loss);
#   5. the basestation quits; the idle traffic of N, 5 and 1 robots alone (discovery and liveliness) is a
#      figure.
# By default it runs 5 robots with simple discovery (CAIRN_FLEET_JOIN_SIMPLE_ROBOTS: with 10, the 7th and later
# robots are not seen at all within 15 s on 1 Mbit/s links, and the test fails: docs/PERFORMANCE.md), then 10
# with the server (CAIRN_FLEET_JOIN_ROBOTS). CAIRN_FLEET_JOIN_ROUNDS="server" runs one round;
# CAIRN_FLEET_JOIN_KBIT the links' rate (default 1000). Run by hand with CAIRN_FLEET_JOIN_LINK=lan for the lan
# link's figures (250 ms announcements).
# The robots run a light simulation (no perception, a sparse lidar at 5 Hz) so that a dozen processes fit two
# cores: discovery, state and liveliness do not depend on it.
# Its checks fail it (exit 1) like a test's. Run it inside tests/netns_run.sh (./cairn bench does); it enters a
# private mount namespace (the hosts' names vanish with it).
#   tests/netns_run.sh bench/fleet_join.sh BUILD_DIR
set -uo pipefail
# shellcheck source=../tests/linksim/test_harness.sh
source "$(dirname "${BASH_SOURCE[0]}")/../tests/linksim/test_harness.sh" fleet_join fj "$@"
DOMAIN=88
N_SERVER="${CAIRN_FLEET_JOIN_ROBOTS:-10}"
N_SIMPLE="${CAIRN_FLEET_JOIN_SIMPLE_ROBOTS:-5}"
N_HOSTS=$((N_SERVER > N_SIMPLE ? N_SERVER : N_SIMPLE))
KBIT="${CAIRN_FLEET_JOIN_KBIT:-1000}"
RADIO=(--link radio --link-kbps 1000 --subnet 10.77.0.0/24)
# By hand, for a comparison: CAIRN_FLEET_JOIN_LINK=lan (the lan link keeps 250 ms participant announcements).
if [ "${CAIRN_FLEET_JOIN_LINK:-radio}" = lan ]; then RADIO=(--link lan --subnet 10.77.0.0/24); fi
SERVER=10.77.0.2:11811

linksim_up "$P" || exit 1
linksim_add_host "$P" base 10.77.0.2 "$KBIT" || exit 1
for i in $(seq 1 "$N_HOSTS"); do linksim_add_host "$P" "r$i" "10.77.0.$((10 + i))" "$KBIT" || exit 1; done
linksim_light_robot_config "$LOGS/light.yaml"

# kbit/s the hub delivers over SECONDS.
hub_kbps() {
  local b0 b1
  b0=$(linksim_hub_bytes "$P")
  sleep "$1"
  b1=$(linksim_hub_bytes "$P")
  awk -v a="$b0" -v b="$b1" -v s="$1" 'BEGIN{printf "%.1f", (b - a) * 8 / 1000 / s}'
}
epoch_of_log_line() {  # "[2026-11-23 22:19:23.536] ..." -> seconds since the epoch
  date -d "$(sed -E 's/^\[([^]]+)\].*/\1/' <<<"$1")" +%s.%N
}
percentile() {  # percentile P of the numbers on stdin
  sort -g | awk -v p="$1" '{v[NR] = $1} END {i = int(p / 100 * NR + 0.999999); if (i < 1) i = 1; print v[i]}'
}

# The basestation's answers to `wait` commands about robot R in round LABEL (JSON keys come sorted).
wait_answers() { grep '"command":"wait"' "$LOGS/$1.json" | grep "\"robot\":\"$2\""; }

declare -A PIDS
round() {
  local label="$1" N="$2"
  shift 2
  local flags=("${RADIO[@]}" "$@") i n line
  # The basestation reads commands from a pipe this test writes to; its answers and events are JSON lines.
  rm -f "$LOGS/base.in"
  mkfifo "$LOGS/base.in"
  ip netns exec "${P}base" "$BASE" --base-id opA --domain "$DOMAIN" "${flags[@]}" --json --keep-going \
    <"$LOGS/base.in" >"$LOGS/$label.json" 2>"$LOGS/$label-base.log" &
  local base_pid=$!
  exec 3>"$LOGS/base.in"
  sleep 1

  # 1-2. Robots join one after the other.
  : >"$LOGS/$label-visible.txt"
  : >"$LOGS/$label-from-start.txt"
  : >"$LOGS/$label-own-start.txt"
  for i in $(seq 1 "$N"); do
    n="r$i"
    local started
    started=$(date +%s.%N)
    linksim_start_agent "$LOGS/$label-$n.log" "$n" --robot-id "$n" --domain "$DOMAIN" --start "$((4 + 4 * i)),20,0" \
      --config "$LOGS/light.yaml" "${flags[@]}"
    PIDS[$n]=$AGENT_PID
    line=""
    for _ in $(seq 1 150); do
      line=$(grep -m1 "opA: $n announced itself" "$LOGS/$label-base.log") && break
      sleep 0.1
    done
    if [ -z "$line" ]; then
      fail "$label: $n not visible at the basestation 15 s after its start: $(tail -2 "$LOGS/$label-$n.log")"
      continue
    fi
    sed -E 's/.*\(([0-9.-]+) s ago by its clock\).*/\1/' <<<"$line" >>"$LOGS/$label-visible.txt"
    awk -v a="$started" -v b="$(epoch_of_log_line "$line")" 'BEGIN{printf "%.3f\n", b - a}' >>"$LOGS/$label-from-start.txt"
    local ready
    ready=$(grep -m1 "$n ([a-z]*) ready on platform" "$LOGS/$label-$n.log") &&
      awk -v a="$started" -v b="$(epoch_of_log_line "$ready")" 'BEGIN{printf "%.3f\n", b - a}' >>"$LOGS/$label-own-start.txt"
    if [ "$i" = 1 ] || [ "$i" = 5 ] || [ "$i" = "$N" ]; then
      sleep 1
      echo "FIGURE join_${label}_${i}_robots_and_base_kbps $(hub_kbps 5) (bytes the hub delivered to all hosts, 5 s)"
    else
      sleep 0.5
    fi
  done
  local p95 worst p95_start
  p95=$(percentile 95 <"$LOGS/$label-visible.txt")
  worst=$(sort -g "$LOGS/$label-visible.txt" | tail -1)
  p95_start=$(percentile 95 <"$LOGS/$label-from-start.txt")
  echo "FIGURE join_${label}_visible_after_announce_p95_s $p95 (worst $worst, $(wc -l <"$LOGS/$label-visible.txt") robots: $(tr '\n' ' ' <"$LOGS/$label-visible.txt"))"
  echo "FIGURE join_${label}_visible_after_process_start_p95_s $p95_start (worst $(sort -g "$LOGS/$label-from-start.txt" | tail -1): $(tr '\n' ' ' <"$LOGS/$label-from-start.txt"))"
  echo "FIGURE join_${label}_robot_start_p95_s $(percentile 95 <"$LOGS/$label-own-start.txt") (process start to ready: $(tr '\n' ' ' <"$LOGS/$label-own-start.txt"))"
  if [ "$(wc -l <"$LOGS/$label-visible.txt")" = "$N" ] && awk -v v="$p95" 'BEGIN{exit !(v <= 1.0)}'; then
    pass "$label: the $N robots visible at the basestation within 1 s of announcing themselves (p95 $p95 s)"
  elif [ "$label" = simple ]; then
    # Known (docs/PERFORMANCE.md): with simple discovery every participant sends its endpoint announcements
    # to a newcomer at once; on a 1 Mbit/s link that burst overflows the newcomer's queue as the fleet grows,
    # and Fast DDS 2.9 repairs it only at its 1 s endpoint heartbeat. A figure here; the server round asserts.
    echo "NOTE simple: visibility p95 $p95 s over the 1 s bound: $(tr '\n' ' ' <"$LOGS/$label-visible.txt")"
  else fail "$label: visibility p95 $p95 s: $(tr '\n' ' ' <"$LOGS/$label-visible.txt")"; fi

  # 3. Cut links: each robot shown lost within 1 s, back once restored.
  local k detect
  for k in $((N - 2)) $((N - 1)) "$N"; do
    n="r$k"
    linksim_set_loss "$P" "$n" 100
    echo "wait $n lost 5" >&3
    line=""
    for _ in $(seq 1 80); do
      line=$(wait_answers "$label" "$n" | tail -1) && [ -n "$line" ] && break
      sleep 0.1
    done
    detect=$(sed -nE 's/.*"reason":"lost after ([0-9.]+) s".*/\1/p' <<<"$line")
    linksim_set_loss "$P" "$n" 0
    if [ -n "$detect" ] && awk -v v="$detect" 'BEGIN{exit !(v <= 1.0)}'; then
      pass "$label: $n's cut link detected in $detect s"
    else fail "$label: $n's cut link: ${line:-no answer}"; fi
    echo "FIGURE loss_detect_${label}_${n}_s ${detect:-none}"
    echo "wait $n online 10" >&3
    for _ in $(seq 1 120); do
      [ "$(wait_answers "$label" "$n" | wc -l)" -ge 2 ] && break
      sleep 0.1
    done
    wait_answers "$label" "$n" | tail -1 | grep -q '"ok":true' &&
      pass "$label: $n back once its link returned" || fail "$label: $n not back after its link returned"
  done

  # 4. 5 % loss on every link: no false loss.
  local before after
  sleep 2
  before=$(grep -c '"event":"lost"' "$LOGS/$label.json")
  local q0 q1 t0 t1
  q0=$(linksim_host_queue "$P" base)
  t0=$(date +%s.%N)
  for i in $(seq 1 "$N"); do linksim_set_loss "$P" "r$i" 5; done
  linksim_set_loss "$P" base 5
  echo "sleep 20" >&3
  echo "events 1" >&3
  for _ in $(seq 1 300); do grep -q '"command":"events"' "$LOGS/$label.json" && break; sleep 0.1; done
  q1=$(linksim_host_queue "$P" base)
  t1=$(date +%s.%N)
  awk -v q0="$q0" -v q1="$q1" -v a="$t0" -v b="$t1" -v n="$N" -v k="$KBIT" 'BEGIN{split(q0, x, " "); split(q1, y, " ");
    printf "FIGURE to_base_kbps_%d_robots %.1f of %d (during the 5 %% loss, %d packets dropped by its queue)\n",
      n, (y[1] - x[1]) * 8 / 1000 / (b - a), k, y[2] - x[2]}'
  for i in $(seq 1 "$N"); do linksim_set_loss "$P" "r$i" 0; done
  linksim_set_loss "$P" base 0
  after=$(grep -c '"event":"lost"' "$LOGS/$label.json")
  if [ "$after" = "$before" ]; then pass "$label: 5 % loss for 20 s on every link: no robot shown lost"
  else fail "$label: 5 % loss: $((after - before)) false lost events: $(grep '"event":"lost"' "$LOGS/$label.json" | tail -3)"; fi
  echo "FIGURE false_loss_${label}_5pct_20s $((after - before)) (lost events, $N robots)"

  # 5. The basestation quits: idle traffic of the robots alone.
  exec 3>&-  # end of its input: it exits
  wait "$base_pid"
  sleep 2
  echo "FIGURE idle_${label}_${N}_robots_kbps $(hub_kbps 5) (no basestation: discovery and liveliness)"
  if [ "$N" -gt 5 ]; then
    for i in $(seq 6 "$N"); do kill -TERM "${PIDS[r$i]}" 2>/dev/null; done
    for i in $(seq 6 "$N"); do wait "${PIDS[r$i]}" 2>/dev/null; done
    sleep 2
    echo "FIGURE idle_${label}_5_robots_kbps $(hub_kbps 5)"
  fi
  for i in $(seq 2 5); do kill -TERM "${PIDS[r$i]}" 2>/dev/null; done
  for i in $(seq 2 5); do wait "${PIDS[r$i]}" 2>/dev/null; done
  sleep 2
  echo "FIGURE idle_${label}_1_robot_kbps $(hub_kbps 5)"
  kill -TERM "${PIDS[r1]}" 2>/dev/null
  wait "${PIDS[r1]}" 2>/dev/null
}

ROUNDS="${CAIRN_FLEET_JOIN_ROUNDS:-simple server}"
if [[ " $ROUNDS " == *" simple "* ]]; then round simple "$N_SIMPLE"; fi
if [[ " $ROUNDS " != *" server "* ]]; then ROUNDS=""; fi
[ -z "$ROUNDS" ] || {
ip netns exec "${P}base" "$ROOT/tools/discovery_server.sh" --subnet 10.77.0.0/24 >"$LOGS/server.log" 2>&1 &
server_pid=$!
for _ in $(seq 1 50); do grep -q "Server is running" "$LOGS/server.log" && break; sleep 0.1; done
grep -q "discovery server on $SERVER" "$LOGS/server.log" || fail "the discovery server did not start: $(cat "$LOGS/server.log")"
round server "$N_SERVER" --discovery-server "$SERVER"
kill -TERM "$server_pid" 2>/dev/null
wait "$server_pid" 2>/dev/null
}

if [ "$failures" -ne 0 ]; then
  echo "--- basestation (server round)" >&2; tail -5 "$LOGS/server-base.log" >&2
  echo "fleet_join: $failures check(s) failed" >&2
  exit 1
fi
echo "fleet_join: all checks passed"
