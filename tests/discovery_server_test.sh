#!/usr/bin/env bash
# Discovery on a simulated 1 Mbit/s radio (tests/linksim), three robots and a basestation on four hosts,
# first with simple discovery (multicast announcements), then with a Fast DDS discovery server on the
# basestation's host (tools/discovery_server.sh; every process its client, no multicast). Checks:
#   1. a discovery server address outside the named subnet is refused, naming it;
#   2. with either kind of discovery the basestation sees the three and commands one; the time it takes from
#      the basestation's start, and the bytes the hub delivers over 10 s with the three robots idle and no
#      basestation (discovery and liveliness only), are figures;
#   3. with the server, no UDP datagram is sent to a multicast group;
#   4. robots that exit cleanly are told as "left" at a basestation watching (either kind of discovery).
# Run by ctest inside tests/netns_run.sh; enters a private mount namespace (the hosts' names vanish with it).
#   discovery_server_test.sh BUILD_DIR
set -uo pipefail
# shellcheck source=linksim/test_harness.sh
source "$(dirname "${BASH_SOURCE[0]}")/linksim/test_harness.sh" discovery_server_test ds "$@"
DOMAIN=85

linksim_up "$P" || exit 1
linksim_add_host "$P" base 10.77.0.2 1000 || exit 1
for i in 1 2 3; do linksim_add_host "$P" "r$i" "10.77.0.1$i" 1000 || exit 1; done
SERVER=10.77.0.2:11811

# 1. A server outside the named network.
out=$(ip netns exec "${P}r1" "$AGENT" --robot-id r9 --domain "$DOMAIN" --link lan --subnet 10.77.0.0/24 \
  --discovery-server 10.99.0.1:11811 2>&1 </dev/null)
code=$?
if [ "$code" -ne 0 ] && grep -q "10.99.0.1" <<<"$out"; then pass "a discovery server outside 10.77.0.0/24 refused: $(grep -m1 10.99.0.1 <<<"$out" | cut -c1-160)"
else fail "a discovery server outside the subnet: exit $code, $(tail -2 <<<"$out")"; fi
expect_bad_flag() {
  out=$(ip netns exec "${P}r1" "$AGENT" --robot-id r9 --domain "$DOMAIN" "$@" 2>&1 </dev/null)
  if [ $? -eq 2 ] && grep -qF -- "$NEEDLE" <<<"$out"; then pass "refused: $NEEDLE"; else fail "expected '$NEEDLE': $out"; fi
}
NEEDLE="--discovery-server '10.77.0.2' must be IPV4_ADDRESS:PORT" expect_bad_flag --link lan --subnet 10.77.0.0/24 --discovery-server 10.77.0.2
NEEDLE="--discovery-server names a server on a lan or radio link" expect_bad_flag --discovery-server "$SERVER"

# One round: three robots and a basestation with the given extra link flags ("simple" or "server").
round() {
  local label="$1"
  shift
  local flags=(--link lan --subnet 10.77.0.0/24 "$@") pids=() x=10 n
  for n in r1 r2 r3; do
    linksim_start_agent "$LOGS/$n.log" "$n" --robot-id "$n" --domain "$DOMAIN" --start "$x,20,0" "${flags[@]}"
    pids+=("$AGENT_PID")
    x=$((x + 6))
  done
  for n in r1 r2 r3; do linksim_wait_ready "$LOGS/$n.log" "$label: $n"; done
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
  for pid in "${pids[@]}"; do
    kill -TERM "$pid" 2>/dev/null
    wait "$pid" 2>/dev/null
  done
  wait "$watcher"
  if [ "$(grep -c '"event":"left".*its process exited' "$LOGS/leave.json")" = 3 ]; then
    pass "$label: the three robots that exited are told as left"
  else fail "$label: left events: $(grep -a '"event"' "$LOGS/leave.json" | grep -v joined | head -4)"; fi
}

# 2. Simple discovery.
round simple

# 2-3. A discovery server on the basestation's host; every process its client.
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

if [ "$failures" -ne 0 ]; then
  for n in r1 r2 r3; do echo "--- $n" >&2; tail -5 "$LOGS/$n.log" >&2; done
  echo "discovery_server_test: $failures check(s) failed" >&2
  exit 1
fi
echo "discovery_server_test: all checks passed"
