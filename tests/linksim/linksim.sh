#!/usr/bin/env bash
# linksim: simulated radio links between "hosts" on this machine, for multi-host tests and demos.
#
# Every host is a network namespace of its own with one interface, `radio0`, joined by a veth pair to a bridge
# in a hub namespace. A link's budget is a token bucket (tc tbf) on both ends of the veth (host -> hub and
# hub -> host), its loss an iptables `statistic` drop rule in the host (netem is not in this kernel). Addresses
# exist only on those links (10.77.0.0/24 by default); no namespace has a route anywhere else, so nothing can
# leave the machine. Run it inside a private network and mount namespace (tests/netns_run.sh, then
# `unshare --mount`): the namespaces' names in /run/netns then vanish with the test.
#
# Source it, then:
#   linksim_up PREFIX                                   the hub (namespace ${PREFIX}hub, bridge br0)
#   linksim_add_host PREFIX NAME ADDRESS RATE_KBIT [LOSS_PCT]
#                                                       host ${PREFIX}NAME: radio0 = ADDRESS/24, RATE_KBIT each
#                                                       way, LOSS_PCT % of packets dropped each way (0..100)
#   linksim_set_loss PREFIX NAME LOSS_PCT               change a host's loss (100: the link is cut)
#   linksim_exec PREFIX NAME CMD...                     run CMD in that host
#   linksim_hub_bytes PREFIX                            bytes the hub has delivered to every host so far
#   linksim_host_queue PREFIX NAME                      "BYTES DROPPED": bytes the hub has delivered to NAME
#                                                       and packets its queue towards NAME dropped, so far
#   linksim_own_queue PREFIX NAME                       "BYTES DROPPED" of NAME's own queue (its sends), so far
#   linksim_down PREFIX                                 remove the hub and every host of PREFIX
# Or from a shell: tests/linksim/linksim.sh up|add-host|set-loss|exec|hub-bytes|host-queue|own-queue|down ARGS (same arguments).

linksim_fail() { echo "linksim: $*" >&2; return 1; }

linksim_up() {
  local prefix="$1"
  ip netns add "${prefix}hub" || linksim_fail "cannot create namespace ${prefix}hub (root, and a private mount namespace?)" || return 1
  ip -n "${prefix}hub" link set lo up
  ip -n "${prefix}hub" link add br0 type bridge
  ip -n "${prefix}hub" link set br0 up
}

# The drop rules of a host: one in each direction, replaced as a whole.
linksim_set_loss() {
  local prefix="$1" name="$2" loss_pct="$3"
  [[ "$loss_pct" =~ ^[0-9]+([.][0-9]+)?$ ]] && awk "BEGIN{exit !($loss_pct <= 100)}" ||
    linksim_fail "loss '$loss_pct' must be a percentage in [0, 100]" || return 1
  local ns="${prefix}${name}"
  ip netns exec "$ns" iptables -F INPUT
  ip netns exec "$ns" iptables -F OUTPUT
  if awk "BEGIN{exit !($loss_pct > 0)}"; then
    local p
    p=$(awk "BEGIN{printf \"%.6f\", $loss_pct / 100}")
    ip netns exec "$ns" iptables -A INPUT -i radio0 -m statistic --mode random --probability "$p" -j DROP
    ip netns exec "$ns" iptables -A OUTPUT -o radio0 -m statistic --mode random --probability "$p" -j DROP
  fi
}

linksim_add_host() {
  local prefix="$1" name="$2" address="$3" rate_kbit="$4" loss_pct="${5:-0}"
  [[ "$name" =~ ^[a-z0-9]{1,8}$ ]] || linksim_fail "host name '$name' must be 1-8 of [a-z0-9]" || return 1
  [[ "$rate_kbit" =~ ^[0-9]+$ ]] && [ "$rate_kbit" -ge 8 ] ||
    linksim_fail "rate '$rate_kbit' must be an integer number of kbit/s >= 8" || return 1
  local ns="${prefix}${name}" hub="${prefix}hub"
  ip netns add "$ns" || return 1
  ip -n "$ns" link set lo up
  ip -n "$hub" link add "p-$name" type veth peer name radio0 netns "$ns"
  ip -n "$hub" link set "p-$name" master br0 up
  ip -n "$ns" addr add "$address/24" dev radio0
  ip -n "$ns" link set radio0 up
  # Multicast discovery goes out on the radio (no default route exists: nothing else is reachable).
  ip -n "$ns" route add 224.0.0.0/4 dev radio0
  # The budget each way: a bucket of ~20 ms of the rate (at least one full frame), queueing at most 200 ms.
  local burst=$(( rate_kbit * 1000 / 8 / 50 ))
  [ "$burst" -ge 3000 ] || burst=3000
  ip netns exec "$ns" tc qdisc add dev radio0 root tbf rate "${rate_kbit}kbit" burst "$burst" latency 200ms
  ip netns exec "$hub" tc qdisc add dev "p-$name" root tbf rate "${rate_kbit}kbit" burst "$burst" latency 200ms
  linksim_set_loss "$prefix" "$name" "$loss_pct"
}

linksim_exec() {
  local prefix="$1" name="$2"
  shift 2
  ip netns exec "${prefix}${name}" "$@"
}

linksim_hub_bytes() {
  local prefix="$1" total=0 n port
  for port in $(ip -n "${prefix}hub" -o link show master br0 | awk -F': ' '{print $2}' | cut -d@ -f1); do
    n=$(ip netns exec "${prefix}hub" tc -s qdisc show dev "$port" | awk '/Sent/ {print $2; exit}')
    total=$((total + n))
  done
  echo "$total"
}

# "BYTES DROPPED" of the queue (qdisc) on DEV in namespace NS, from `tc -s qdisc show`'s
# "Sent B bytes P pkt (dropped D, overlimits O requeues R)".
linksim_queue_counts() {
  ip netns exec "$1" tc -s qdisc show dev "$2" |
    awk '/Sent/ {for (i = 1; i < NF; ++i) if ($i == "(dropped") d = $(i + 1); gsub(",", "", d); print $2, d; exit}'
}

linksim_host_queue() {
  local prefix="$1" name="$2"
  linksim_queue_counts "${prefix}hub" "p-$name"
}

linksim_own_queue() {
  local prefix="$1" name="$2"
  linksim_queue_counts "${prefix}${name}" radio0
}

linksim_down() {
  local prefix="$1" ns
  for ns in $(ip netns list | awk '{print $1}' | grep "^${prefix}"); do
    ip netns pids "$ns" 2>/dev/null | xargs -r kill -TERM 2>/dev/null
  done
  sleep 0.5
  for ns in $(ip netns list | awk '{print $1}' | grep "^${prefix}"); do
    ip netns pids "$ns" 2>/dev/null | xargs -r kill -KILL 2>/dev/null
    ip netns delete "$ns"
  done
}

if [ "${BASH_SOURCE[0]}" = "$0" ]; then
  set -uo pipefail
  verb="${1:-}"
  shift || true
  case "$verb" in
    up) linksim_up "$@" ;;
    add-host) linksim_add_host "$@" ;;
    set-loss) linksim_set_loss "$@" ;;
    exec) linksim_exec "$@" ;;
    down) linksim_down "$@" ;;
    hub-bytes) linksim_hub_bytes "$@" ;;
    host-queue) linksim_host_queue "$@" ;;
    own-queue) linksim_own_queue "$@" ;;
    *) echo "usage: linksim.sh up|add-host|set-loss|exec|hub-bytes|host-queue|own-queue|down ARGS (see the comment at the top)" >&2; exit 2 ;;
  esac
fi
