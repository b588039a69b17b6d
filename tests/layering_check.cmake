# Test (cmake -P): no source of the robot's autonomy includes a simulator header. Run by ctest as
# cairn_layering_test with -DSOURCE_DIR=<repo>. Directories checked: nav/ and perception/ (libraries, not their
# tests), and the autonomy sources of robot_agent/ (everything but the simulated-platform driver choice in
# main.cpp). Fails naming each file and line.
if(NOT SOURCE_DIR)
  message(FATAL_ERROR "layering_check.cmake: pass -DSOURCE_DIR=<repository root>")
endif()
file(GLOB_RECURSE sources
     "${SOURCE_DIR}/nav/include/*.h" "${SOURCE_DIR}/nav/src/*.cpp" "${SOURCE_DIR}/nav/src/*.h"
     "${SOURCE_DIR}/perception/include/*.h" "${SOURCE_DIR}/perception/src/*.cpp" "${SOURCE_DIR}/perception/src/*.h"
     "${SOURCE_DIR}/robot_agent/include/*.h" "${SOURCE_DIR}/robot_agent/src/*.cpp" "${SOURCE_DIR}/robot_agent/src/*.h")
list(FILTER sources EXCLUDE REGEX "/robot_agent/src/main\\.cpp$")
if(NOT sources)
  message(FATAL_ERROR "layering_check.cmake: no sources found under ${SOURCE_DIR}")
endif()
set(violations "")
foreach(file IN LISTS sources)
  file(STRINGS "${file}" lines REGEX "^[ \t]*#[ \t]*include[ \t]*[\"<]cairn/sim/")
  foreach(line IN LISTS lines)
    file(RELATIVE_PATH rel "${SOURCE_DIR}" "${file}")
    string(APPEND violations "\n  ${rel}: ${line}")
  endforeach()
endforeach()
list(LENGTH sources n)
if(violations)
  message(FATAL_ERROR "the autonomy includes simulator headers (use cairn/core types and core::PlatformIO):"
                      "${violations}")
endif()
message(STATUS "layering: ${n} autonomy sources include no cairn/sim header")

# The judge apart: the simulator's library sources include no navigation header, so that its ground truth
# never shares navigation's classifier. platform_profile.h (header-only, numbers from a profile) is the one
# exception.
file(GLOB_RECURSE sim_sources "${SOURCE_DIR}/sim/include/*.h" "${SOURCE_DIR}/sim/src/*.cpp" "${SOURCE_DIR}/sim/src/*.h")
list(FILTER sim_sources EXCLUDE REGEX "/sim/include/cairn/sim/platform_profile\\.h$")
foreach(file IN LISTS sim_sources)
  file(STRINGS "${file}" lines REGEX "^[ \t]*#[ \t]*include[ \t]*[\"<]cairn/nav/")
  foreach(line IN LISTS lines)
    file(RELATIVE_PATH rel "${SOURCE_DIR}" "${file}")
    string(APPEND violations "\n  ${rel}: ${line}")
  endforeach()
endforeach()
list(LENGTH sim_sources n_sim)
if(violations)
  message(FATAL_ERROR "the simulator includes navigation headers (its ground truth is its own):${violations}")
endif()
message(STATUS "layering: ${n_sim} simulator sources include no cairn/nav header")
