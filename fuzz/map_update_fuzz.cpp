// Fuzz harness: map updates from peers (topic cairn/map_update) as a basestation applies them: the header
// fields and the payload come from the input, through FleetMap::Apply (header rules, DecodeCoarseVoxels,
// limits). Every message must be applied or dropped with a reason; no crash, no unbounded allocation.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "cairn/perception/map_telemetry.h"

namespace {

template <class T>
T Take(const std::uint8_t*& data, std::size_t& size) {
  T value{};
  const std::size_t n = std::min(size, sizeof(T));
  std::memcpy(&value, data, n);
  data += n;
  size -= n;
  return value;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  cairn::perception::FleetMapOptions options;
  options.max_voxels_per_robot = 200000;
  cairn::perception::FleetMap fleet(options);
  // Several messages per input: the first bytes say how many, each takes its header then a payload slice.
  const int messages = 1 + Take<std::uint8_t>(data, size) % 4;
  for (int i = 0; i < messages && size > 0; ++i) {
    cairn::perception::MapUpdate m;
    const std::uint8_t robot = Take<std::uint8_t>(data, size) % 4;
    m.robot_id = robot == 0 ? "" : "r" + std::to_string(robot);
    const std::string sender = (Take<std::uint8_t>(data, size) % 8 == 0) ? "r9" : m.robot_id;  // a mismatch
    m.kind = static_cast<cairn::perception::MapUpdateKind>(Take<std::uint8_t>(data, size) % 3);
    m.seq = Take<std::uint32_t>(data, size) % 8;
    m.snapshot_id = Take<std::uint32_t>(data, size) % 4;
    m.base_seq = Take<std::uint32_t>(data, size) % 8;
    m.chunk_index = Take<std::uint16_t>(data, size) % 4;
    m.chunk_count = Take<std::uint16_t>(data, size) % 5;
    m.resolution_m = Take<double>(data, size);
    const std::size_t payload = std::min<std::size_t>(size, Take<std::uint16_t>(data, size));
    m.data.assign(data, data + payload);
    data += payload;
    size -= payload;
    std::string error;
    (void)fleet.Apply(sender, m, &error);
    (void)fleet.NeedsSnapshot(m.robot_id);
  }
  (void)fleet.Stats();
  return 0;
}
