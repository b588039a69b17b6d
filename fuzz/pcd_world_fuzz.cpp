// Fuzz harness: a .pcd point cloud given as a world (cairn_agent --world FILE.pcd) through sim::LoadWorld.
// Every input must load or be refused with an exception naming the file; the header is checked field by field
// against the file size before PCL allocates anything.
#include <cstddef>
#include <cstdint>
#include <exception>

#include "cairn/sim/world.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const cairn::sim::World world = cairn::sim::LoadWorld(cairn::fuzz::AsFile(data, size, ".pcd"));
    (void)world;
  } catch (const std::exception&) {
  }
  return 0;
}
