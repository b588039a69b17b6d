#!/usr/bin/env bash
# Runs a real-time test (robots on the wall clock) in its own network namespace (tests/netns_run.sh).
#   real_time_run.sh LOCK_FILE COMMAND [ARGS...]
# Under ./cairn test, ctest gives each real-time test the share of the cores it declared (its resource group
# "cpu", in percent of a core; cmake/CairnTesting.cmake) and runs as many side by side as the cores hold.
# Run by ctest without a resource spec (ctest by hand), no share is given (CTEST_RESOURCE_GROUP_COUNT is
# unset): the test then holds LOCK_FILE, so real-time tests run one at a time, as they must to keep their
# control loops fed.
set -euo pipefail
lock="${1:?lock file}"
shift
netns_run="$(dirname "${BASH_SOURCE[0]}")/netns_run.sh"
if [ -n "${CTEST_RESOURCE_GROUP_COUNT:-}" ]; then
  exec "$netns_run" "$@"
fi
exec flock "$lock" "$netns_run" "$@"
