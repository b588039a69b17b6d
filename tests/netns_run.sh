#!/usr/bin/env bash
# Runs a command inside a fresh private network namespace in which only loopback exists and is up.
# Used for every test (cmake/CairnTesting.cmake) so that no DDS packet can leave the machine.
# Each run also gets a temporary folder of its own (TEST_TMPDIR, which GoogleTest's TempDir() returns),
# removed when it ends: tests that run side by side (the same binary built with and without a sanitizer,
# too) never write each other's files.
set -euo pipefail
tmp="$(mktemp -d "${TMPDIR:-/tmp}/cairn-test.XXXXXX")"
trap 'rm -rf "$tmp"' EXIT
status=0
TEST_TMPDIR="$tmp/" unshare --net -- bash -c 'ip link set lo up && CAIRN_IN_NETNS=1 exec "$@"' cairn-netns "$@" ||
  status=$?
# With CAIRN_TEST_CPU_LOG set (./cairn test sets it), one line per run: the CPU seconds (user + system) of the
# command and every process it waited for (`times`' second line), then the command. Where the suite's CPU goes.
if [ -n "${CAIRN_TEST_CPU_LOG:-}" ]; then
  times >"$tmp/times"  # in this shell: `times` in $(...) would count the subshell only
  cpu="$(awk 'END { for (i = 1; i <= NF; ++i) { split($i, t, /[ms]/); total += t[1] * 60 + t[2] }
                    printf "%.1f", total }' "$tmp/times")"
  echo "$cpu $*" >>"$CAIRN_TEST_CPU_LOG"
fi
exit "$status"
