#!/usr/bin/env bash
# Soak: 5 robots in builtin:tunnels patrol between two places each (a new goal every 40 s, the
# other end of their patrol) with the full perception pipeline, and one basestation commands and watches them,
# for DURATION_S (default 3600) on this machine. Every 10 s it samples each process's resident memory (RSS,
# /proc/PID/status VmRSS), its CPU use over the last 10 s (per cent of one core) and the robot's missed control
# deadlines so far (the agent's "control loop woke N ms late" and "control cycle took" warnings: a 50 Hz cycle
# that ran over 100 ms). RSS growth compares the 4 minutes from the baseline (5 minutes in) with the last 4
# (bench/soak_report.py: floor and peak of each window). Samples go to OUT_DIR/soak.csv, figures to stdout
# (FIGURE lines). Every minute the
# basestation also asks each robot's health (`health R`): the memory of its maps as the robot counts it
# (perception: the OctoMap; planning: the navigation map's grids, which the planner shares) and its
# agent's RSS, to tell maps that grow (the navigation map is re-allocated over a larger area in steps) from
# memory that leaks: OUT_DIR/health.csv, and the RSS growth net of the maps' (FIGURE ... net of its maps).
# Must run in a private network namespace: tests/netns_run.sh bench/soak.sh BUILD_DIR [DURATION_S] [OUT_DIR]
set -euo pipefail
BUILD="${1:?usage: soak.sh BUILD_DIR [DURATION_S] [OUT_DIR]}"
DURATION_S="${2:-3600}"
OUT="${3:-$(mktemp -d)}"
[[ "$DURATION_S" =~ ^[0-9]+$ ]] && [ "$DURATION_S" -ge 60 ] || { echo "soak: DURATION_S '$DURATION_S' must be >= 60" >&2; exit 2; }
BASELINE_S=$(( DURATION_S >= 600 ? 300 : DURATION_S / 2 ))
DOMAIN=69
ROBOTS=5
mkdir -p "$OUT"
source "$(dirname "$0")/fleet_bench_lib.sh"
export XDG_CACHE_HOME="${XDG_CACHE_HOME:-$BUILD/cache}"
for k in $(seq 0 $((ROBOTS - 1))); do
  "$BUILD/robot_agent/cairn_agent" --robot-id "r$k" --start "slot:$k" --domain "$DOMAIN" \
    >"$OUT/r$k.out" 2>"$OUT/r$k.log" &
  pids+=($!)
done
for k in $(seq 0 $((ROBOTS - 1))); do
  for _ in $(seq 900); do grep -q READY "$OUT/r$k.out" && break; sleep 0.1; done
  grep -q READY "$OUT/r$k.out" || { echo "soak: r$k did not start" >&2; tail -3 "$OUT/r$k.log" >&2; exit 1; }
done

# Patrols (frame map, metres; builtin:tunnels' landmarks): each robot alternates between its two ends.
# Each on its own stretch of tunnel: robots keep clear of one another (peers), so patrols that met head-on in
# a 3 m tunnel would measure waiting, not driving.
declare -a FROM=("4,20" "30,5" "30,35" "48.8,20" "20,20")
declare -a TO=("14,20" "50,5" "14,35" "38,20" "30,28")
fifo="$OUT/base.in"
rm -f "$fifo"
mkfifo "$fifo"
"$BUILD/basestation/cairn_base" --base-id soak --domain "$DOMAIN" --keep-going --json <"$fifo" >"$OUT/base.out" 2>"$OUT/base.log" &
base_pid=$!
pids+=("$base_pid")
exec 3>"$fifo"
for k in $(seq 0 $((ROBOTS - 1))); do echo "wait r$k online 30" >&3; done
for k in $(seq 0 $((ROBOTS - 1))); do echo "request-control r$k" >&3; done

ticks() { awk '{print $14 + $15}' "/proc/$1/stat" 2>/dev/null || echo 0; }
rss_kb() { awk '/^VmRSS/ {print $2}' "/proc/$1/status" 2>/dev/null || echo 0; }
late() { grep -c "control loop woke\|control cycle took" "$OUT/r$1.log" || true; }
hz=$(getconf CLK_TCK)
names=()
for k in $(seq 0 $((ROBOTS - 1))); do names+=("r$k"); done
names+=("base")
procs=("${pids[@]:0:$ROBOTS}" "$base_pid")
declare -A last_ticks
for i in "${!procs[@]}"; do last_ticks[$i]=$(ticks "${procs[$i]}"); done
echo "t_s,process,rss_kb,cpu_pct,missed_deadlines" >"$OUT/soak.csv"
start=$(date +%s)
: >"$OUT/health_times.txt"
next_health=60
leg=0
next_goal=0
while :; do
  now=$(( $(date +%s) - start ))
  [ "$now" -ge "$DURATION_S" ] && break
  if [ "$now" -ge "$next_goal" ]; then
    for k in $(seq 0 $((ROBOTS - 1))); do
      if (( leg % 2 == 0 )); then p="${TO[$k]}"; else p="${FROM[$k]}"; fi
      echo "goto r$k ${p/,/ }" >&3
    done
    leg=$((leg + 1))
    next_goal=$((now + 40))
  fi
  sleep 10
  now=$(( $(date +%s) - start ))
  if [ "$now" -ge "$next_health" ]; then
    echo "$now" >>"$OUT/health_times.txt"
    for k in $(seq 0 $((ROBOTS - 1))); do echo "health r$k" >&3; done
    next_health=$((next_health + 60))
  fi
  for i in "${!procs[@]}"; do
    pid="${procs[$i]}"
    kill -0 "$pid" 2>/dev/null || { echo "soak: ${names[$i]} (pid $pid) died at ${now} s" >&2; exit 1; }
    t=$(ticks "$pid")
    cpu=$(awk -v d="$((t - ${last_ticks[$i]}))" -v hz="$hz" 'BEGIN { printf "%.1f", 100 * d / hz / 10 }')
    last_ticks[$i]=$t
    missed=0
    [ "${names[$i]}" != base ] && missed=$(late "${names[$i]#r}")
    rss=$(rss_kb "$pid")
    echo "$now,${names[$i]},$rss,$cpu,$missed" >>"$OUT/soak.csv"
  done
done
echo "quit" >&3 || true

echo "soak: $ROBOTS robots and a basestation for $DURATION_S s; samples in $OUT/soak.csv"
grep -h "arrived" "$OUT"/r*.log | wc -l | xargs -I{} echo "FIGURE soak goals arrived: {}"
sleep 2  # the last health answers
python3 "$(dirname "${BASH_SOURCE[0]}")/soak_report.py" "$OUT" "$BASELINE_S"
