# Every test process runs inside its own private network namespace (tests/netns_run.sh: unshare --net, lo up),
# so that no packet can leave the machine even when ctest is run by hand (network safety, DESIGN.md).
set(CAIRN_NETNS_RUN "${CMAKE_SOURCE_DIR}/tests/netns_run.sh")

# cairn_add_test(<name> SOURCES <files>... LIBS <libs>... [TIMEOUT <s>] [LABELS <labels>]
#                [SHARDS <suffix>=<gtest filter>...] [CORES <n>])
# SHARDS: each pair becomes a ctest entry of its own, <name>_<suffix>, running the binary's tests that match the
# filter; the entry <name> runs the rest. Long scenario binaries are split so that ctest can run the pieces on
# both cores. CORES: the entries hold n of the machine's cores (ctest resource "cores", see
# tests/ctest_resources.json and cairn_real_time_tests below).
function(cairn_add_test name)
  cmake_parse_arguments(ARG "" "TIMEOUT;CORES" "SOURCES;LIBS;LABELS;SHARDS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main Threads::Threads)
  target_compile_definitions(${name} PRIVATE CAIRN_SOURCE_DIR="${CMAKE_SOURCE_DIR}"
                                             CAIRN_BINARY_DIR="${CMAKE_BINARY_DIR}")
  cairn_target_warnings(${name})
  set(tests ${name})
  set(rest_filter "")
  foreach(shard IN LISTS ARG_SHARDS)
    string(REPLACE "=" ";" parts "${shard}")
    list(GET parts 0 suffix)
    list(GET parts 1 filter)
    add_test(NAME ${name}_${suffix} COMMAND ${CAIRN_NETNS_RUN} $<TARGET_FILE:${name}> --gtest_filter=${filter})
    list(APPEND tests ${name}_${suffix})
    string(APPEND rest_filter ":${filter}")
  endforeach()
  if(rest_filter)
    string(SUBSTRING "${rest_filter}" 1 -1 rest_filter)
    add_test(NAME ${name} COMMAND ${CAIRN_NETNS_RUN} $<TARGET_FILE:${name}> --gtest_filter=-${rest_filter})
  else()
    add_test(NAME ${name} COMMAND ${CAIRN_NETNS_RUN} $<TARGET_FILE:${name}>)
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  # Sanitized code runs slower (ASan about 2-3x, TSan 5-15x): the time limit grows with it.
  if(CAIRN_SANITIZER STREQUAL "address")
    math(EXPR ARG_TIMEOUT "${ARG_TIMEOUT} * 4")
  elseif(CAIRN_SANITIZER STREQUAL "thread")
    math(EXPR ARG_TIMEOUT "${ARG_TIMEOUT} * 10")
  endif()
  set_tests_properties(${tests} PROPERTIES TIMEOUT ${ARG_TIMEOUT})
  if(ARG_LABELS)
    set_tests_properties(${tests} PROPERTIES LABELS "${ARG_LABELS}")
  endif()
  if(ARG_CORES)
    set_tests_properties(${tests} PROPERTIES RESOURCE_GROUPS "cores:${ARG_CORES}")
  endif()
endfunction()

# cairn_real_time_tests(<test>...): tests that run robots in real time (cairn_agent and cairn_base processes, or
# an agent's threads on the wall clock), each robot with a 50 Hz control loop and a perception thread. They must
# not overlap one another on a 2-core machine: starved control loops trip the robots' staleness guards (they
# stop, as they must) and the tests would measure the starvation instead of Cairn. They hold the lock
# cairn_robot_processes, and both cores when ctest is given tests/ctest_resources.json (./cairn test does) so
# that no scenario test on a simulated clock (CORES 1, CPU-bound) runs beside them; small unit tests still do.
function(cairn_real_time_tests)
  set_tests_properties(${ARGN} PROPERTIES RESOURCE_LOCK cairn_robot_processes RESOURCE_GROUPS "cores:2")
endfunction()
