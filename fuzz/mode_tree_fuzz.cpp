// Fuzz harness: a mode tree file (cairn_agent --mode-tree, BehaviorTree.CPP v4 XML) through ModeManager's
// loader and its checks against the mux's channels. Every input must load or be refused with an exception
// naming the file, line and element.
#include <cstddef>
#include <cstdint>
#include <exception>

#include "cairn/agent/modes/mode_manager.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    cairn::agent::ModeManager modes(cairn::fuzz::AsFile(data, size, ".xml"),
                                    {"none", "teleop", "smart_joystick", "waypoint", "explore"});
    (void)modes;
  } catch (const std::exception&) {
  }
  return 0;
}
