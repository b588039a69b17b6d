# Every test process runs inside its own private network namespace (tests/netns_run.sh: unshare --net, lo up),
# so that no packet can leave the machine even when ctest is run by hand (network safety, DESIGN.md).
set(CAIRN_NETNS_RUN "${CMAKE_SOURCE_DIR}/tests/netns_run.sh")

# cairn_add_test(<name> SOURCES <files>... LIBS <libs>... [TIMEOUT <s>] [LABELS <labels>])
function(cairn_add_test name)
  cmake_parse_arguments(ARG "" "TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main Threads::Threads)
  target_compile_definitions(${name} PRIVATE CAIRN_SOURCE_DIR="${CMAKE_SOURCE_DIR}"
                                             CAIRN_BINARY_DIR="${CMAKE_BINARY_DIR}")
  cairn_target_warnings(${name})
  add_test(NAME ${name} COMMAND ${CAIRN_NETNS_RUN} $<TARGET_FILE:${name}>)
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  # Sanitized code runs slower (ASan about 2-3x, TSan 5-15x): the time limit grows with it.
  if(CAIRN_SANITIZER STREQUAL "address")
    math(EXPR ARG_TIMEOUT "${ARG_TIMEOUT} * 4")
  elseif(CAIRN_SANITIZER STREQUAL "thread")
    math(EXPR ARG_TIMEOUT "${ARG_TIMEOUT} * 10")
  endif()
  set_tests_properties(${name} PROPERTIES TIMEOUT ${ARG_TIMEOUT})
  if(ARG_LABELS)
    set_tests_properties(${name} PROPERTIES LABELS "${ARG_LABELS}")
  endif()
endfunction()
