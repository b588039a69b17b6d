# Shared by the fleet benches (bench/soak.sh, bench/real_scan_fleet.sh, bench/team_explore_load.sh); sourced,
# not run. After sourcing: `pids` (processes ended on exit, with TERM) and the functions below.
pids=()
fleet_bench_cleanup() {
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
}
trap fleet_bench_cleanup EXIT

# fleet_bench_duration NAME VALUE: VALUE must be an integer >= 60 (seconds), else exit 2 naming it.
fleet_bench_duration() {
  [[ "$2" =~ ^[0-9]+$ ]] && [ "$2" -ge 60 ] || { echo "$1: DURATION_S '$2' must be an integer >= 60" >&2; exit 2; }
}

# fleet_bench_wait_ready NAME OUT_DIR ID...: each agent's OUT_DIR/ID.out says READY within 3 min, else exit 1.
fleet_bench_wait_ready() {
  local name="$1" out="$2" id
  shift 2
  for id in "$@"; do
    for _ in $(seq 1800); do grep -qs READY "$out/$id.out" && break; sleep 0.1; done
    grep -qs READY "$out/$id.out" || { echo "$name: $id did not start" >&2; tail -3 "$out/$id.log" >&2; exit 1; }
  done
}

# fleet_bench_start_base BUILD_DIR OUT_DIR DOMAIN: an operator console (op1, --json) reading commands from
# file descriptor 3 (a fifo), answers and events in OUT_DIR/base.out.
fleet_bench_start_base() {
  local fifo="$2/base.in"
  rm -f "$fifo"
  mkfifo "$fifo"
  "$1/basestation/cairn_base" --base-id op1 --domain "$3" --keep-going --json <"$fifo" >"$2/base.out" \
    2>"$2/base.log" &
  pids+=($!)
  exec 3>"$fifo"
}
