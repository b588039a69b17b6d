# The common start of a multi-host test on linksim hosts. Source it first thing, with the test's name, a
# namespace prefix and the script's own arguments (BUILD_DIR):
#   source "$(dirname "${BASH_SOURCE[0]}")/linksim/test_harness.sh" my_test xy "$@"
# It refuses to run outside tests/netns_run.sh, re-runs the script in a private mount namespace (the hosts'
# names in /run/netns vanish with it), sources linksim.sh and sets BUILD, ROOT, AGENT, BASE, P (the hosts'
# prefix), LOGS (removed at exit, with every host), failures and fail/pass, and linksim_light_robot_config.
linksim_test_name="$1"
P="$2$$"
shift 2
BUILD="$1"
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
[ "${CAIRN_IN_NETNS:-}" = 1 ] || { echo "$linksim_test_name: run me inside tests/netns_run.sh" >&2; exit 2; }
if [ "${CAIRN_IN_MOUNTNS:-}" != 1 ]; then
  exec env CAIRN_IN_MOUNTNS=1 unshare --mount --propagation private -- "$0" "$@"
fi
# shellcheck source=linksim.sh
source "$ROOT/tests/linksim/linksim.sh"
AGENT="$BUILD/robot_agent/cairn_agent"
BASE="$BUILD/basestation/cairn_base"
LOGS="$(mktemp -d)"
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
pass() { echo "ok: $*"; }
# Writes the agent config of a light simulated robot to FILE: no perception, a sparse lidar (4 beams of 180
# points) at 5 Hz, so that a dozen idle processes fit two cores (~5 % of a core each; discovery, state and
# liveliness do not depend on perception).
linksim_light_robot_config() {
  cat >"$1" <<'YAML'
perception:
  enabled: false
simulation:
  lidar_rate_hz: 5.0
  lidar_beams: 4
  lidar_points_per_beam: 180
YAML
}
# Starts the agent on linksim host HOST with the given arguments, its output in LOG; AGENT_PID is the agent's
# pid (ip netns exec execs it). LOG is emptied here, before the start: the started process opens it on its own
# time, so a READY an earlier process left in it would otherwise pass for this one's. The agent does not
# inherit descriptor 3 (a test's pipe to its basestation stays the test's own).
#   linksim_start_agent LOG HOST AGENT_ARGS...
linksim_start_agent() {
  local log="$1" host="$2"
  shift 2
  : >"$log"
  ip netns exec "${P}$host" "$AGENT" "$@" >>"$log" 2>&1 3>&- &
  AGENT_PID=$!
}
# Waits up to 60 s for READY in LOG (written by linksim_start_agent); if it never comes, fails naming WHO
# with the log's last lines and returns 1.
linksim_wait_ready() {
  local log="$1" who="$2"
  for _ in $(seq 1 600); do grep -q READY "$log" && return 0; sleep 0.1; done
  fail "$who did not start: $(tail -3 "$log")"
  return 1
}
linksim_test_cleanup() {
  linksim_down "$P"
  rm -rf "$LOGS"
}
trap linksim_test_cleanup EXIT
