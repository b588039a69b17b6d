#!/usr/bin/env bash
# Loss detection time against false loss, on simulated 1 Mbit/s radio links (docs/PERFORMANCE.md).
#
# Three robots (light simulation, no perception) on linksim hosts r1..r3 and four basestations on hosts b0..b3,
# each with its own `--lost-after` (0.3, 0.5, 0.8 and 1.5 s by default), all watching the same robots over the
# same robot links (each basestation on a host of its own: four on one 1 Mbit/s link would fill it). Then:
#   1. every link at each loss level (0, 5, 10, 20 % of packets dropped each way) for DURATION_S: the lost
#      events each basestation raised (all false: no robot went anywhere), per robot and minute;
#      and how often a robot lost the liveliness of op0, which holds every robot's control lock and never left;
#   2. each robot's link cut in turn: how long each basestation took to show it lost (`wait R lost`).
# Prints one FIGURE line per (lost-after, loss level) and per (lost-after, cut), then a table.
#   tests/netns_run.sh bench/loss_detection.sh BUILD_DIR
# Environment: CAIRN_LOSS_BENCH_AFTER="0.3 0.5 0.8 1.5", CAIRN_LOSS_BENCH_LEVELS="0 5 10 20",
# CAIRN_LOSS_BENCH_DURATION_S=30.
set -uo pipefail
# shellcheck source=../tests/linksim/test_harness.sh
source "$(dirname "${BASH_SOURCE[0]}")/../tests/linksim/test_harness.sh" loss_detection_bench ld "$@"
DOMAIN=89
read -r -a AFTER <<<"${CAIRN_LOSS_BENCH_AFTER:-0.3 0.5 0.8 1.5}"
read -r -a LEVELS <<<"${CAIRN_LOSS_BENCH_LEVELS:-0 5 10 20}"
DURATION_S="${CAIRN_LOSS_BENCH_DURATION_S:-30}"
ROBOTS=(r1 r2 r3)
RADIO=(--link radio --link-kbps 1000 --subnet 10.77.0.0/24)

linksim_up "$P" || exit 1
for k in "${!AFTER[@]}"; do linksim_add_host "$P" "b$k" "10.77.0.$((2 + k))" 1000 || exit 1; done
for i in "${!ROBOTS[@]}"; do linksim_add_host "$P" "${ROBOTS[$i]}" "10.77.0.$((11 + i))" 1000 || exit 1; done
linksim_light_robot_config "$LOGS/light.yaml"

# Basestation k (0-based) reads commands from fd 10+k and writes JSON lines to $LOGS/base$k.json.
BASE_PIDS=()
for k in "${!AFTER[@]}"; do
  mkfifo "$LOGS/base$k.in"
  ip netns exec "${P}b$k" "$BASE" --base-id "op$k" --domain "$DOMAIN" "${RADIO[@]}" --lost-after "${AFTER[$k]}" \
    --json --keep-going <"$LOGS/base$k.in" >"$LOGS/base$k.json" 2>"$LOGS/base$k.log" 10>&- 11>&- 12>&- 13>&- 14>&- 15>&- &
  BASE_PIDS+=($!)
  eval "exec $((10 + k))>\"\$LOGS/base$k.in\""
done
to_base() { echo "$2" >&"$((10 + $1))"; }
for i in "${!ROBOTS[@]}"; do
  n="${ROBOTS[$i]}"
  ip netns exec "${P}$n" "$AGENT" --robot-id "$n" --domain "$DOMAIN" --start "$((8 + 4 * i)),20,0" \
    --config "$LOGS/light.yaml" "${RADIO[@]}" >"$LOGS/$n.log" 2>&1 10>&- 11>&- 12>&- 13>&- 14>&- 15>&- &
done
answers() { grep '"command":"wait"' "$LOGS/base$1.json" | grep "\"robot\":\"$2\""; }
for k in "${!AFTER[@]}"; do for n in "${ROBOTS[@]}"; do to_base "$k" "wait $n online 30"; done; done
for k in "${!AFTER[@]}"; do
  for _ in $(seq 1 400); do [ "$(grep -c '"command":"wait"' "$LOGS/base$k.json")" -ge 3 ] && break; sleep 0.1; done
  [ "$(grep '"command":"wait"' "$LOGS/base$k.json" | grep -c '"ok":true')" = 3 ] ||
    { echo "loss_detection_bench: op$k did not see the 3 robots: $(cat "$LOGS/base$k.json"; tail -3 "$LOGS/base$k.log")" >&2; exit 1; }
done
# op0 takes every robot's control lock: each robot watches op0's liveliness (its dead-man check on the operator),
# and a lapse it sees while op0 is there is a false holder loss, counted from the robots' logs.
for n in "${ROBOTS[@]}"; do to_base 0 "request-control $n"; done
for _ in $(seq 1 100); do [ "$(grep -c '"command":"request-control".*"ok":true' "$LOGS/base0.json")" -ge 3 ] && break; sleep 0.1; done
[ "$(grep -c '"command":"request-control".*"ok":true' "$LOGS/base0.json")" = 3 ] ||
  { echo "loss_detection_bench: op0 did not get the 3 locks: $(grep request-control "$LOGS/base0.json")" >&2; exit 1; }
holder_losses() { for n in "${ROBOTS[@]}"; do cat "$LOGS/$n.log"; done | grep -c "control holder op0 lost"; }
# Seven processes start at once with multicast discovery on 1 Mbit/s links: their endpoint announcements take
# seconds to settle, and while they do the bursts overflow the links' queues and drop state samples. The loss
# levels start once that is over.
sleep 10

HOSTS=("${ROBOTS[@]}")
for k in "${!AFTER[@]}"; do HOSTS+=("b$k"); done
# A basestation prints the events it has gathered around each command: a short sleep flushes them.
flush_bases() {
  local k c
  declare -a before=()
  for k in "${!AFTER[@]}"; do before[$k]=$(grep -c '"command":"sleep"' "$LOGS/base$k.json"); to_base "$k" "sleep 0.1"; done
  for k in "${!AFTER[@]}"; do
    for _ in $(seq 1 100); do
      c=$(grep -c '"command":"sleep"' "$LOGS/base$k.json")
      [ "$c" -gt "${before[$k]}" ] && break
      sleep 0.1
    done
  done
}
lost_count() { grep -c '"event":"lost"' "$LOGS/base$1.json"; }
declare -A FALSE DETECT HOLDER
# 1. Loss levels.
for level in "${LEVELS[@]}"; do
  declare -a before=()
  flush_bases
  for k in "${!AFTER[@]}"; do before[$k]=$(lost_count "$k"); done
  holder_before=$(holder_losses)
  for n in "${HOSTS[@]}"; do linksim_set_loss "$P" "$n" "$level"; done
  sleep "$DURATION_S"
  for n in "${HOSTS[@]}"; do linksim_set_loss "$P" "$n" 0; done
  sleep 3  # lost robots come back; a loss raised in the last moment is counted
  flush_bases
  HOLDER["$level"]=$(( $(holder_losses) - holder_before ))
  echo "FIGURE false_holder_loss_loss_${level}_pct ${HOLDER[$level]} (robots that lost op0's liveliness while it ran, ${#ROBOTS[@]} robots, $DURATION_S s)"
  for k in "${!AFTER[@]}"; do
    events=$(( $(lost_count "$k") - before[k] ))
    rate=$(awk -v e="$events" -v s="$DURATION_S" -v r="${#ROBOTS[@]}" 'BEGIN{printf "%.2f", e / r / (s / 60)}')
    FALSE["$k,$level"]="$rate"
    echo "FIGURE false_loss_after_${AFTER[$k]}_s_loss_${level}_pct $events lost events ($rate per robot-minute, ${#ROBOTS[@]} robots, $DURATION_S s)"
    # Each false loss, as the basestation gave it (which robot, how long it had been silent).
    [ "$events" -gt 0 ] && grep '"event":"lost"' "$LOGS/base$k.json" | tail -n "$events" | sed "s/^/NOTE op$k: /"
  done
done

# 2. Cut links.
for n in "${ROBOTS[@]}"; do
  declare -a seen=()
  for k in "${!AFTER[@]}"; do seen[$k]=$(answers "$k" "$n" | wc -l); done
  linksim_set_loss "$P" "$n" 100
  for k in "${!AFTER[@]}"; do to_base "$k" "wait $n lost 5"; done
  for k in "${!AFTER[@]}"; do
    for _ in $(seq 1 80); do [ "$(answers "$k" "$n" | wc -l)" -gt "${seen[$k]}" ] && break; sleep 0.1; done
    detect=$(answers "$k" "$n" | tail -1 | sed -nE 's/.*"reason":"lost after ([0-9.]+) s".*/\1/p')
    DETECT["$k,$n"]="${detect:-none}"
    echo "FIGURE cut_detect_after_${AFTER[$k]}_s_${n}_s ${detect:-none}"
  done
  linksim_set_loss "$P" "$n" 0
  for k in "${!AFTER[@]}"; do to_base "$k" "wait $n online 10"; done
  sleep 3
done

for k in "${!AFTER[@]}"; do eval "exec $((10 + k))>&-"; done
for pid in "${BASE_PIDS[@]}"; do wait "$pid" 2>/dev/null; done

header="| --lost-after | cut detected after (r1, r2, r3) |"
rule="|---|---|"
for level in "${LEVELS[@]}"; do header+=" false loss at ${level} % (per robot-minute) |"; rule+="---|"; done
echo "$header"
echo "$rule"
for k in "${!AFTER[@]}"; do
  row="| ${AFTER[$k]} s | ${DETECT["$k,r1"]}, ${DETECT["$k,r2"]}, ${DETECT["$k,r3"]} s |"
  for level in "${LEVELS[@]}"; do row+=" ${FALSE["$k,$level"]} |"; done
  echo "$row"
done
row="| robots' false holder losses (op0's liveliness, 3 robots) | |"
for level in "${LEVELS[@]}"; do row+=" ${HOLDER[$level]} |"; done
echo "$row"
