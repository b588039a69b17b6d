// Fuzz harness: an OctoMap file given as a world (cairn_agent --world FILE.bt|FILE.ot) through
// sim::LoadWorld, which checks it (core::ParseBtFile, ParseOtFile) and then reads it with OctoMap itself (not
// OccupancyMap::LoadBt) and builds the simulator's grid. An input whose first line is the full format's
// ("# Octomap OcTree file") is given as a .ot, any other as a .bt. Every input must load or be refused with
// an exception naming the file; no crash, no unbounded allocation.
// The grid is capped at 2*10^5 voxels (WorldLoadOptions::max_voxels; the agent's default is 5*10^8), as in
// the pcd_world harness, so that an execution decodes instead of filling a large grid. The clean-up after
// loading (support filter, floor-hole filling) is off: it reads the grid, not the file, and its
// neighbourhoods are sized in metres, so on a fuzzed map of 5 mm voxels one execution took up to 17 s.
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
  cairn::sim::WorldLoadOptions options;
  options.max_voxels = 200'000;
  options.support_radius_m = 0.0;
  options.fill_hole_max_m = 0.0;
  try {
    const cairn::sim::World world =
        cairn::sim::LoadWorld(cairn::fuzz::AsFile(data, size, full ? ".ot" : ".bt"), options);
    (void)world;
  } catch (const std::exception&) {
  }
  return 0;
}
