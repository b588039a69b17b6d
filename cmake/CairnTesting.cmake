# Every test process runs inside its own private network namespace (tests/netns_run.sh: unshare --net, lo up),
# so that no packet can leave the machine even when ctest is run by hand (network safety, DESIGN.md).
set(CAIRN_NETNS_RUN "${CMAKE_SOURCE_DIR}/tests/netns_run.sh")
# Tests that do not run robots on the wall clock (unit tests, scenario tests on a simulated clock, fuzz corpus
# replays, checks) run at the lowest CPU priority: ctest runs one beside a real-time test, where it takes only
# the CPU the robots leave idle (they use 0.5-1.2 of the 2 cores) and gives way the moment a control loop wakes.
set(CAIRN_BACKGROUND nice -n 19)
set(CAIRN_BACKGROUND_RUN ${CAIRN_BACKGROUND} ${CAIRN_NETNS_RUN})
# Real-time tests' launcher (cairn_real_time_tests below): one at a time through the lock file when ctest runs
# without ./cairn test's resource spec.
set(CAIRN_REAL_TIME_RUN "${CMAKE_SOURCE_DIR}/tests/real_time_run.sh" "${CMAKE_BINARY_DIR}/real-time-tests.lock")

# cairn_add_test(<name> SOURCES <files>... LIBS <libs>... [TIMEOUT <s>] [LABELS <labels>] [CPU_S <s>]
#                [SHARDS <suffix>=<gtest filter>[=<cpu s>]...] [REAL_TIME CPU_PERCENT <percent of a core>])
# SHARDS: each pair becomes a ctest entry of its own, <name>_<suffix>, running the binary's tests that match the
# filter; the entry <name> runs the rest. Long scenario binaries are split so that ctest can run the pieces on
# both cores. REAL_TIME: the test runs robots on the wall clock, using CPU_PERCENT of a core (cairn_real_time_tests
# below); any other test runs in the background (CAIRN_BACKGROUND_RUN above). CPU_S (and a shard's third part):
# the CPU seconds the entry takes (./cairn test's table of the most CPU, build/test-cpu.log), its ctest COST:
# a clean clone has no timings of its own, and without them ctest would start the longest scenario tests last,
# where they ran alone on a machine otherwise idle; longest first packs the cores.
function(cairn_add_test name)
  cmake_parse_arguments(ARG "REAL_TIME" "TIMEOUT;CPU_PERCENT;CPU_S" "SOURCES;LIBS;LABELS;SHARDS" ${ARGN})
  if(ARG_REAL_TIME)
    set(run ${CAIRN_REAL_TIME_RUN})
  else()
    set(run ${CAIRN_BACKGROUND_RUN})
  endif()
  add_executable(${name} ${ARG_SOURCES})
  # cairn_types: the build's folders (cairn/core/build_paths.h) for data, tools and the built programs.
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} cairn_types GTest::gtest GTest::gtest_main Threads::Threads)
  cairn_target_warnings(${name})
  set(tests ${name})
  set(rest_filter "")
  foreach(shard IN LISTS ARG_SHARDS)
    string(REPLACE "=" ";" parts "${shard}")
    list(GET parts 0 suffix)
    list(GET parts 1 filter)
    add_test(NAME ${name}_${suffix} COMMAND ${run} $<TARGET_FILE:${name}> --gtest_filter=${filter})
    list(APPEND tests ${name}_${suffix})
    list(LENGTH parts n)
    if(n GREATER 2)
      list(GET parts 2 cpu_s)
      set_tests_properties(${name}_${suffix} PROPERTIES COST ${cpu_s})
    endif()
    string(APPEND rest_filter ":${filter}")
  endforeach()
  if(rest_filter)
    string(SUBSTRING "${rest_filter}" 1 -1 rest_filter)
    add_test(NAME ${name} COMMAND ${run} $<TARGET_FILE:${name}> --gtest_filter=-${rest_filter})
  else()
    add_test(NAME ${name} COMMAND ${run} $<TARGET_FILE:${name}>)
  endif()
  if(ARG_CPU_S)
    set_tests_properties(${name} PROPERTIES COST ${ARG_CPU_S})
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  # A background test waits for the CPU that the real-time tests beside it leave (at nice 19 it may get a tenth
  # of a core for minutes): its time limit, meant to catch a hang, is three times its own.
  if(NOT ARG_REAL_TIME)
    math(EXPR ARG_TIMEOUT "${ARG_TIMEOUT} * 3")
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
  if(ARG_REAL_TIME)
    cairn_real_time_tests(CPU_PERCENT ${ARG_CPU_PERCENT} ${tests})
  endif()
endfunction()

# cairn_real_time_tests(CPU_PERCENT <percent> <test>...): tests that run robots in real time (cairn_agent and
# cairn_base processes, or an agent's threads on the wall clock), each robot with a 50 Hz control loop and a
# perception thread, launched through CAIRN_REAL_TIME_RUN. Starved, their control loops would trip the robots'
# staleness guards (they stop, as they must) and the tests would measure the starvation instead of Cairn. So
# each declares the CPU it uses, in percent of one core (its mean over a run alone, measured with
# /usr/bin/time, plus about a quarter for bursts; 100 * cores: it runs alone), as the ctest resource group
# "cpu:<percent>". ./cairn test gives ctest a resource spec of 100 * cores (build/ctest-resources.json), so
# real-time tests run side by side while their shares fit on the cores, at normal priority; background tests
# (niced above) take what they leave idle. Without that spec each takes the lock file in turn (one at a time).
# Their COST puts them at the head of ctest's queue (an explicit COST outranks the times ctest measured): the
# real-time chain is the suite's long pole, and the background tests fill the rest of the machine beside it.
function(cairn_real_time_tests)
  cmake_parse_arguments(ARG "" "CPU_PERCENT" "" ${ARGN})
  if(NOT ARG_CPU_PERCENT MATCHES "^[1-9][0-9]*$" OR ARG_CPU_PERCENT GREATER 200)
    message(FATAL_ERROR "cairn_real_time_tests(${ARG_UNPARSED_ARGUMENTS}): CPU_PERCENT '${ARG_CPU_PERCENT}' must be "
                        "an integer in [1, 200] (percent of one core, measured)")
  endif()
  set_tests_properties(${ARG_UNPARSED_ARGUMENTS} PROPERTIES RESOURCE_GROUPS "cpu:${ARG_CPU_PERCENT}" COST 1000)
  # The label lists them (ctest -N -L real_time; ./cairn test marks them in its table of the slowest tests).
  set_property(TEST ${ARG_UNPARSED_ARGUMENTS} APPEND PROPERTY LABELS real_time)
endfunction()
