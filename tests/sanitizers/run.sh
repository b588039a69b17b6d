#!/usr/bin/env bash
# Builds the in-process tests of core, nav, perception and robot_agent with a sanitizer, each kind in a build
# folder of its own (ccache shared with the main build), and runs them (each in its own network namespace).
#   tests/sanitizers/run.sh address|thread BUILD_DIR [--build-only | --tests-only] [ctest args...]
# address: AddressSanitizer + UndefinedBehaviorSanitizer (any report fails the test); thread: ThreadSanitizer.
# --build-only builds the tests and runs none (./cairn test builds in the background while ctest runs the main
# build's tests); --tests-only runs them without building.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
kind="${1:?address|thread}"
build="${2:?build folder}"
shift 2
step=all
case "${1:-}" in --build-only) step=build; shift ;; --tests-only) step=tests; shift ;; esac
case "$kind" in address | thread) ;; *) echo "sanitizers: kind '$kind' is neither address nor thread" >&2; exit 2 ;; esac

# The tests that run in one process (no cairn_agent or cairn_base child processes). The scenario tests of
# robot_agent (navigation, team, explore, perception: minutes each, 3-10x that sanitized) run with
# CAIRN_SANITIZE_SCENARIOS=1.
TESTS=(
  cairn_core_test cairn_bt_test
  cairn_nav_traversability_test cairn_nav_astar_test cairn_nav_global_planner_test cairn_nav_local_planner_test
  cairn_nav_ilqr_test cairn_nav_sampling_test cairn_nav_scan_obstacles_test cairn_nav_multilevel_test
  cairn_nav_frontier_test cairn_nav_geb079_test
  cairn_perception_map_test cairn_perception_telemetry_test cairn_perception_staircase_test cairn_perception_jpeg_test
  cairn_agent_unit_test cairn_agent_perception_test_watchdog cairn_ros2_test cairn_fuzz_ros2_message_replay
)
# ThreadSanitizer finds races only between threads that run: it gets the tests that start threads (the
# component loops and health monitor, the map and telemetry readers, the agent's services, the perception
# watchdog). The single-threaded ones (behaviour tree, planners, detector, codecs: minutes under TSan) run
# under ASan + UBSan only.
if [ "$kind" = thread ]; then
  TESTS=(cairn_core_test cairn_perception_map_test cairn_perception_telemetry_test cairn_agent_unit_test
         cairn_agent_perception_test_watchdog)
fi
if [ "${CAIRN_SANITIZE_SCENARIOS:-0}" = 1 ]; then
  TESTS+=(cairn_agent_navigation_test cairn_agent_team_test cairn_agent_team_test_convoy cairn_agent_explore_test
          cairn_agent_explore_test_team cairn_agent_explore_test_gone cairn_agent_explore_test_legged
          cairn_agent_perception_test)
fi

if [ "$step" != tests ]; then
  export CCACHE_BASEDIR="$ROOT" CCACHE_NOHASHDIR=true
  # Configured every time (seconds): a build folder from before a new test target was added then has it too.
  cmake -S "$ROOT" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCAIRN_SANITIZER="$kind" >/dev/null
  # A shard's ctest entry (<binary>_<suffix>, cmake/CairnTesting.cmake) runs its binary.
  targets=($(printf '%s\n' "${TESTS[@]}" | sed -E 's/^(cairn_agent_(perception|team|explore)_test)_[a-z]+$/\1/' | sort -u))
  cmake --build "$build" -j "${CAIRN_JOBS:-$(nproc)}" --target "${targets[@]}"
  [ "$step" = build ] && exit 0
fi

supp="$ROOT/tests/sanitizers"
# halt_on_error: the first report fails the test (its output names the race or the fault).
# new_delete_type_mismatch=0: Fast DDS 2.9.1 deletes its statistics readers through the wrong type when a participant
# goes (RTPSReader::~RTPSReader from StatisticsReaderImpl; inside libfastrtps, not built with ASan).
export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:strict_string_checks=1:detect_stack_use_after_return=1:new_delete_type_mismatch=0"
export LSAN_OPTIONS="suppressions=$supp/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:suppressions=$supp/ubsan.supp"
export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$supp/tsan.supp:print_suppressions=0"
export XDG_CACHE_HOME="$build/cache"
# Accuracy and rejection sweeps of the detector and the local planner (7-50 s each under ASan, two thirds of
# its run) repeat on more data code paths that the other cases of their binaries cover (the tunnels' stairs
# from several approaches, a rotated flight, ramps and podiums, the registry): they run unsanitized only.
# Under TSan, the map's single-threaded comparisons with OctoMap's own insertion and its file round trips
# (5-14 s each there) leave out no race: the map's threads meet in its concurrent-query case, which runs.
# (GTEST_FILTER is read by every test binary; a shard's own --gtest_filter would take precedence.)
if [ "$kind" = address ]; then
  sweeps=(
    StaircaseSparseScanTest.OnePlatformBeforeACabinetIsNotAStaircase
    StaircaseSparseScanTest.ThreeRisersBeforeACabinetAreAStaircase
    StaircaseSparseScanTest.TwoStepsBeforeACabinetAreNotAStaircase
    StaircaseDetectorTest.QuarterMetreRunsWithinTwoCentimetres
    StaircaseDetectorTest.AWallDownTheMiddleOfAFlightDoesNotBendTheFit
    StaircaseRejectionTest.FlightSeenSideOnIsNeverAStaircaseAlongTheRay
    StaircaseRejectionTest.CratesAreNotAStaircase
    StaircaseRejectionTest.WallIsNotAStaircase
    StaircaseFalsePositiveTest.Geb079CorridorWithoutStairs
    LocalPlannerPropertyTest.DefaultLibraryNeverCrossesAnObstacleAndMatchesBruteForce
  )
else
  sweeps=(
    OccupancyMapTest.OneRayPerEndpointVoxelIsCloseAndConservative
    OccupancyMapTest.MatchesInsertPointCloudExactlyWithOneRayPerPoint
    OccupancyMapTest.WideScansMatchInsertPointCloudToo
    OccupancyMapCoarseTest.SnapshotEqualsAccumulatedChanges
    OccupancyMapFileTest.LoadsOctomapsOwnFile
    OccupancyMapFileTest.SaveLoadRoundTrip
  )
fi
export GTEST_FILTER="-$(IFS=':'; echo "${sweeps[*]}")"
regex="^($(IFS='|'; echo "${TESTS[*]}"))\$"
cd "$build"
# Sanitized code runs 2-15x slower: the tests' time limits are scaled (cmake/CairnTesting.cmake).
ctest --output-on-failure -j "${CAIRN_JOBS:-$(nproc)}" -R "$regex" "$@"
