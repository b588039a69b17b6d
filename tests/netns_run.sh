#!/usr/bin/env bash
# Runs a command inside a fresh private network namespace in which only loopback exists and is up.
# Used for every test (cmake/CairnTesting.cmake) so that no DDS packet can leave the machine.
set -euo pipefail
exec unshare --net -- bash -c 'ip link set lo up && CAIRN_IN_NETNS=1 exec "$@"' cairn-netns "$@"
