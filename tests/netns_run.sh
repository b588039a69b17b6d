#!/usr/bin/env bash
# Runs a command inside a fresh private network namespace in which only loopback exists and is up.
# Used for every test (cmake/CairnTesting.cmake) so that no DDS packet can leave the machine.
# Each run also gets a temporary folder of its own (TEST_TMPDIR, which GoogleTest's TempDir() returns),
# removed when it ends: tests that run side by side (the same binary built with and without a sanitizer,
# too) never write each other's files.
set -euo pipefail
tmp="$(mktemp -d "${TMPDIR:-/tmp}/cairn-test.XXXXXX")"
trap 'rm -rf "$tmp"' EXIT
TEST_TMPDIR="$tmp/" unshare --net -- bash -c 'ip link set lo up && CAIRN_IN_NETNS=1 exec "$@"' cairn-netns "$@"
