#!/usr/bin/env bash
# N robots (default 5) explore builtin:tunnels together on this machine, with nothing else running: on a
# 2-core machine that is more than it has (about 0.5 of a core per robot), as robot computers in the field are
# overloaded. It reports what a field team would want to know afterwards: explorations completed, component
# restarts, missions paused and resumed, time degraded (a component beating under half its rate), late control
# cycles, what each robot explored, and how long until every exploration had ended (the bench stops then, or
# after DURATION_S, default 600). FIGURE lines on stdout; logs and samples in OUT_DIR.
#
# Must run in a private network namespace:
#   tests/netns_run.sh bench/team_explore_load.sh BUILD_DIR [ROBOTS] [DURATION_S] [OUT_DIR]
set -euo pipefail
BUILD="${1:?usage: team_explore_load.sh BUILD_DIR [ROBOTS] [DURATION_S] [OUT_DIR]}"
ROBOTS="${2:-5}"
DURATION_S="${3:-600}"
OUT="${4:-$(mktemp -d)}"
[[ "$ROBOTS" =~ ^[0-9]+$ ]] && [ "$ROBOTS" -ge 1 ] && [ "$ROBOTS" -le 8 ] ||
  { echo "team_explore_load: ROBOTS '$ROBOTS' must be an integer in 1..8" >&2; exit 2; }
source "$(dirname "$0")/fleet_bench_lib.sh"
fleet_bench_duration team_explore_load "$DURATION_S"
[ "${CAIRN_IN_NETNS:-}" = 1 ] || { echo "team_explore_load: run it inside tests/netns_run.sh" >&2; exit 2; }
DOMAIN=73
mkdir -p "$OUT"
export XDG_CACHE_HOME="${XDG_CACHE_HOME:-$BUILD/cache}"

IDS=()
for k in $(seq 1 "$ROBOTS"); do
  id="r$k"
  IDS+=("$id")
  "$BUILD/robot_agent/cairn_agent" --robot-id "$id" --world builtin:tunnels --start "slot:$((k - 1))" \
    --domain "$DOMAIN" >"$OUT/$id.out" 2>"$OUT/$id.log" &
  pids+=($!)
done
fleet_bench_wait_ready team_explore_load "$OUT" "${IDS[@]}"
fleet_bench_start_base "$BUILD" "$OUT" "$DOMAIN"
for id in "${IDS[@]}"; do echo "wait $id online 60" >&3; done
echo "request-control ${IDS[*]}" >&3
for id in "${IDS[@]}"; do echo "explore $id" >&3; done
start=$(date +%s)
start_clock=$(date +%H:%M:%S)
# Until every exploration has ended (its event) or DURATION_S: a status of each robot every 30 s.
while :; do
  [ "$(($(date +%s) - start))" -ge "$DURATION_S" ] && break
  ended=$(grep -cE '"event":"exploration_(complete|stopped)"' "$OUT/base.out" || true)
  [ "$ended" -ge "$ROBOTS" ] && break
  sleep 5
  [ $(((($(date +%s) - start) / 5) % 6)) -eq 0 ] && for id in "${IDS[@]}"; do echo "status $id" >&3; done
done
for id in "${IDS[@]}"; do echo "status $id" >&3; done
for id in "${IDS[@]}"; do echo "health $id" >&3; done
echo "sleep 1" >&3
echo "stop all" >&3
sleep 2
exec 3>&-

ran_s=$(($(date +%s) - start))
PYTHONPATH="$(dirname "$0")" python3 - "$OUT" "$ran_s" "$start_clock" "${IDS[@]}" <<'EOF'
import sys
from base_answers import read_answers, explorations, event_counts
out, duration, start_clock, ids = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4:]
answers = read_answers(f"{out}/base.out")
explored, states = explorations(answers)
complete = sum(1 for r in ids if states.get(r, ("",))[0] == "complete")
def seconds(t):
    """Seconds of the day of an event's HH:MM:SS."""
    h, m, s = (int(v) for v in t.split(":"))
    return h * 3600 + m * 60 + s
# When each exploration ended, after the bench's start (seconds): the robot's exploration_complete event.
ended_after_s = {e["robot"]: (seconds(e["time"]) - seconds(start_clock)) % 86400 for e in answers
                 if e.get("event") == "exploration_complete" and "time" in e}
print(f"FIGURE team_explore_load robots {len(ids)} ran_s {duration} explorations_complete {complete} of {len(ids)}"
      + (f", the last after {max(ended_after_s.values())} s" if complete == len(ids) and ended_after_s else ""))
for r in ids:
    samples = explored.get(r, [0.0])
    st = states.get(r, ("?", ""))
    after = f" after {ended_after_s[r]} s" if r in ended_after_s else ""
    print(f"FIGURE team_explore_load {r}_explored_m2 {samples[-1]:.0f} (every 30 s: "
          + " ".join(f"{v:.0f}" for v in samples) + f"); exploration {st[0]}{after}: {st[1]}")
kinds = event_counts(answers)
print("FIGURE team_explore_load events " + (", ".join(f"{k} {n}" for k, n in sorted(kinds.items())) or "none"))
# Degraded time: from each component_degraded to its component_recovered (or the end), per robot and component.
open_since, degraded_s, last_t = {}, {}, 0
for e in answers:
    if not e.get("event") or "time" not in e:
        continue
    last_t = seconds(e["time"])
    key = (e.get("robot", ""), e.get("other", ""))
    if e["event"] == "component_degraded":
        open_since[key] = last_t
    elif e["event"] == "component_recovered" and key in open_since:
        degraded_s[key] = degraded_s.get(key, 0) + last_t - open_since.pop(key)
for key, t0 in open_since.items():
    degraded_s[key] = degraded_s.get(key, 0) + max(0, last_t - t0)
print("FIGURE team_explore_load degraded_s " +
      (", ".join(f"{r}/{c} {s}" for (r, c), s in sorted(degraded_s.items())) or "none"))
late = {a.get("robot"): a.get("late_control_cycles") for a in answers
        if isinstance(a, dict) and "late_control_cycles" in a}
print("FIGURE team_explore_load late_control_cycles " + ", ".join(f"{r} {late.get(r, '?')}" for r in ids))
restarts = kinds.get("component_restarted", 0)
print(f"FIGURE team_explore_load component_restarts {restarts} missions_paused {kinds.get('mission_paused', 0)} "
      f"resumed {kinds.get('mission_resumed', 0)} exploration_stopped {kinds.get('exploration_stopped', 0)}")
EOF
