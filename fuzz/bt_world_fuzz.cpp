// Fuzz harness: an OctoMap .bt file given as a world (cairn_agent --world FILE.bt) through sim::LoadWorld, which
// reads it with OctoMap itself (not OccupancyMap::LoadBt) and builds the simulator's grid. Every input must load
// or be refused with an exception naming the file; no crash, no unbounded allocation (the grid has a limit).
#include <cstddef>
#include <cstdint>
#include <exception>

#include "cairn/sim/world.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const cairn::sim::World world = cairn::sim::LoadWorld(cairn::fuzz::AsFile(data, size, ".bt"));
    (void)world;
  } catch (const std::exception&) {
  }
  return 0;
}
