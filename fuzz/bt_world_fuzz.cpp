// Fuzz harness: an OctoMap file given as a world (cairn_agent --world FILE.bt|FILE.ot) through
// sim::LoadWorld, which checks it (core::ParseBtFile, ParseOtFile) and then reads it with OctoMap itself (not
// OccupancyMap::LoadBt) and builds the simulator's grid. An input whose first line is the full format's
// ("# Octomap OcTree file") is given as a .ot, any other as a .bt. Every input must load or be refused with
// an exception naming the file; no crash, no unbounded allocation (the grid has a limit).
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>

#include "cairn/sim/world.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const char kOtFirstLine[] = "# Octomap OcTree file\n";
  const bool full =
      size >= sizeof(kOtFirstLine) - 1 && std::memcmp(data, kOtFirstLine, sizeof(kOtFirstLine) - 1) == 0;
  try {
    const cairn::sim::World world =
        cairn::sim::LoadWorld(cairn::fuzz::AsFile(data, size, full ? ".ot" : ".bt"));
    (void)world;
  } catch (const std::exception&) {
  }
  return 0;
}
