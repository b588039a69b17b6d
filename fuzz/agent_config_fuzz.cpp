// Fuzz harness: the agent's YAML config file (cairn_agent --config) through AgentOptions::LoadConfigFile and
// IsValid. Every input must be taken or refused with an exception naming the key and the value.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>

#include "cairn/agent/agent_options.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  cairn::agent::AgentOptions options;
  options.robot_id = "r1";
  try {
    options.LoadConfigFile(cairn::fuzz::AsFile(data, size, ".yaml"));
    std::string why;
    (void)options.IsValid(&why);
  } catch (const std::exception&) {
  }
  return 0;
}
