#!/usr/bin/env bash
# Three robots explore a large sparse survey scan on a busy machine: the field report this reproduces is a
# low-resolution lidar survey of an industrial building (about 270 k points, `--world FILE.pcd`), one legged
# robot at the foot of a staircase and two wheeled ones in a 3 m office corridor, exploring, while other work
# keeps one core busy. Each agent runs under its supervisor (--supervise --journal), as in the field.
#
# It reports how long the robots ran, whether any agent process died or asked for a restart (a part that did
# not stop), the health events the basestation saw, and what each robot explored (m², sampled every 30 s, and
# its exploration state). FIGURE lines on stdout; logs and samples in OUT_DIR.
#
# Must run in a private network namespace:
#   tests/netns_run.sh bench/real_scan_fleet.sh BUILD_DIR [DURATION_S] [OUT_DIR] [FILE.pcd]
# Without FILE.pcd it writes one: cairn_survey_pcd --world builtin:plant (270 k points, seed 1).
set -euo pipefail
BUILD="${1:?usage: real_scan_fleet.sh BUILD_DIR [DURATION_S] [OUT_DIR] [FILE.pcd]}"
DURATION_S="${2:-600}"
OUT="${3:-$(mktemp -d)}"
PCD="${4:-}"
source "$(dirname "$0")/fleet_bench_lib.sh"
fleet_bench_duration real_scan_fleet "$DURATION_S"
[ "${CAIRN_IN_NETNS:-}" = 1 ] || { echo "real_scan_fleet: run it inside tests/netns_run.sh" >&2; exit 2; }
DOMAIN=71
mkdir -p "$OUT"
export XDG_CACHE_HOME="${XDG_CACHE_HOME:-$BUILD/cache}"

if [ -z "$PCD" ]; then
  PCD="$OUT/plant.pcd"
  "$BUILD/sim/cairn_survey_pcd" --world builtin:plant --out "$PCD" --seed 1 | tee "$OUT/survey.txt"
fi

# Other work on the machine: one core kept busy for the whole run.
(while :; do :; done) &
pids+=($!)

# r1 legged, before the staircase up to the mezzanine (its foot at (12.6, 45), climbing west); r2 and r3 wheeled
# in the office corridor (y 43.5..46.5), facing each other.
declare -a IDS=(r1 r2 r3)
declare -a PLATFORMS=(legged wheeled wheeled)
declare -a STARTS=("13.8,45,3.1416" "56,45,0" "78,45,3.1416")
started=$(date +%s)
for k in 0 1 2; do
  "$BUILD/robot_agent/cairn_agent" --robot-id "${IDS[$k]}" --world "$PCD" --platform "${PLATFORMS[$k]}" \
    --start "${STARTS[$k]}" --domain "$DOMAIN" --journal "$OUT/${IDS[$k]}.journal" --supervise \
    >"$OUT/${IDS[$k]}.out" 2>"$OUT/${IDS[$k]}.log" &
  pids+=($!)
done
fleet_bench_wait_ready real_scan_fleet "$OUT" "${IDS[@]}"
echo "FIGURE real_scan_fleet start_to_ready_s $(($(date +%s) - started))"

fleet_bench_start_base "$BUILD" "$OUT" "$DOMAIN"
for id in "${IDS[@]}"; do echo "wait $id online 60" >&3; done
echo "request-control r1 r2 r3" >&3
for id in "${IDS[@]}"; do echo "explore $id" >&3; done
start=$(date +%s)
while :; do
  now=$(($(date +%s) - start))
  [ "$now" -ge "$DURATION_S" ] && break
  sleep 30
  for id in "${IDS[@]}"; do echo "status $id" >&3; done
done
echo "stop all" >&3
sleep 2
exec 3>&-

PYTHONPATH="$(dirname "$0")" python3 - "$OUT" "$DURATION_S" <<'EOF'
import re, sys
from base_answers import read_answers, explorations, event_counts
out, duration = sys.argv[1], int(sys.argv[2])
answers = read_answers(f"{out}/base.out")
explored, states = explorations(answers)
print(f"FIGURE real_scan_fleet ran_s {duration}")
for r in sorted(explored):
    print(f"FIGURE real_scan_fleet {r}_explored_m2 {explored[r][-1]:.0f} (samples every 30 s: "
          + " ".join(f"{v:.0f}" for v in explored[r]) + f"); exploration {states[r][0]}: {states[r][1]}")
kinds = event_counts(answers)
print("FIGURE real_scan_fleet events " + (", ".join(f"{k} {n}" for k, n in sorted(kinds.items())) or "none"))
for e in answers:
    if e.get("event", "").startswith("component_") or e.get("event") in ("exploration_stopped", "lost"):
        print(f"  {e.get('robot', '')}: {e['event']}: {e.get('message', '')}")
for r in ("r1", "r2", "r3"):
    log = open(f"{out}/{r}.log", errors="replace").read()
    died = len(re.findall(r"supervisor of \w+: the agent died", log))
    asked = len(re.findall(r"supervisor of \w+: the agent asked for a restart", log))
    segv = len(re.findall(r"signal 11", log))
    print(f"FIGURE real_scan_fleet {r}_process_deaths {died} (SIGSEGV {segv}), restarts_asked {asked}")
EOF
