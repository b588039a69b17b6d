// Fuzz harness: a .pcd point cloud given as a world (cairn_agent --world FILE.pcd) through sim::LoadWorld.
// Every input must load or be refused with an exception naming the file; the header is checked field by field
// against the file size before PCL allocates anything.
// The world's grid is capped at 2*10^5 voxels (WorldLoadOptions::max_voxels; the default, 5*10^8, lets a few
// far-apart points make each execution spend its time allocating and clearing a grid instead of decoding): a
// larger grid is refused by the same check, and every other step runs as in the agent.
#include <cstddef>
#include <cstdint>
#include <exception>

#include "cairn/sim/world.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    cairn::sim::WorldLoadOptions options;
    options.max_voxels = 200'000;
    const cairn::sim::World world = cairn::sim::LoadWorld(cairn::fuzz::AsFile(data, size, ".pcd"), options);
    (void)world;
  } catch (const std::exception&) {
  }
  return 0;
}
