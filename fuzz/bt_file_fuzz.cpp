// Fuzz harness: an OctoMap .bt file from a peer or a user (a world, a map) through OccupancyMap::LoadBt.
// Every input must load or be refused with perception::MapError / std::invalid_argument; no crash, no
// unbounded allocation (a declared size is checked against the file first).
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "cairn/perception/occupancy_map.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const auto map = cairn::perception::OccupancyMap::LoadBt(cairn::fuzz::AsFile(data, size, ".bt"));
    (void)map.resolution_m();
  } catch (const cairn::perception::MapError&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
