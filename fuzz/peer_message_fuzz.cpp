// Fuzz harness: samples from peers as a robot or a basestation decodes them. The first byte picks the type;
// the rest is its CDR payload, deserialized by the fastddsgen type (what Fast DDS does with every sample from
// the link), then checked and converted as the receiver does: ids (core::CheckId), waypoint goals
// (agent::CheckGoal), explore claims with their zstd coverage (agent::ClaimFromMessage, CheckExploreClaim),
// map updates (FleetMap::Apply). Every input must decode or be refused; no crash, no
// unbounded allocation.
#include <fastdds/rtps/common/SerializedPayload.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "cairn/agent/agent_dds.h"
#include "cairn/agent/commands.h"
#include "cairn/agent/explore_claims.h"
#include "cairn/core/peer_input.h"
#include "cairn/perception/map_telemetry.h"
#include "cairn_msgsPubSubTypes.h"

namespace {

namespace msgs = cairn_msgs;

template <class PubSubT>
bool Deserialize(const std::uint8_t* data, std::size_t size, typename PubSubT::type* out) {
  PubSubT type;
  eprosima::fastrtps::rtps::SerializedPayload_t payload(static_cast<std::uint32_t>(size));
  if (size > 0) std::memcpy(payload.data, data, size);
  payload.length = static_cast<std::uint32_t>(size);
  try {
    return type.deserialize(&payload, out);
  } catch (...) {
    return false;
  }
}

void Goal(const msgs::WaypointGoal& m) {
  (void)cairn::core::CheckId("base id", m.base_id());
  cairn::agent::GoalCommand goal;
  goal.frame_id = m.frame_id();
  goal.x_m = m.x_m();
  goal.y_m = m.y_m();
  goal.tolerance_m = m.tolerance_m();
  goal.z_m = m.z_m();
  (void)cairn::agent::CheckGoal(goal);
}

void Claim(const msgs::ExploreClaim& m) {
  std::string fault;
  (void)cairn::agent::CheckExploreClaim(cairn::agent::ClaimFromMessage(m, &fault));
}

void Map(const msgs::MapUpdate& m) {
  cairn::perception::MapUpdate u;
  u.robot_id = m.robot_id();
  u.seq = m.seq();
  u.snapshot_id = m.snapshot_id();
  u.kind = static_cast<cairn::perception::MapUpdateKind>(m.kind());
  u.chunk_index = m.chunk_index();
  u.chunk_count = m.chunk_count();
  u.base_seq = m.base_seq();
  u.resolution_m = m.resolution_m();
  u.data = m.data();
  cairn::perception::FleetMap fleet;
  std::string error;
  (void)fleet.Apply(u.robot_id, u, &error);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t kind = data[0] % 6;
  ++data;
  --size;
  switch (kind) {
    case 0: {
      msgs::WaypointGoal m;
      if (Deserialize<msgs::WaypointGoalPubSubType>(data, size, &m)) Goal(m);
      break;
    }
    case 1: {
      msgs::ExploreClaim m;
      if (Deserialize<msgs::ExploreClaimPubSubType>(data, size, &m)) Claim(m);
      break;
    }
    case 2: {
      msgs::MapUpdate m;
      if (Deserialize<msgs::MapUpdatePubSubType>(data, size, &m)) Map(m);
      break;
    }
    case 3: {
      msgs::ControlRequest m;
      if (Deserialize<msgs::ControlRequestPubSubType>(data, size, &m))
        (void)cairn::core::CheckId("base id", m.base_id());
      break;
    }
    case 4: {
      msgs::StaircaseDetection m;
      (void)Deserialize<msgs::StaircaseDetectionPubSubType>(data, size, &m);
      break;
    }
    default: {
      msgs::RobotState m;
      (void)Deserialize<msgs::RobotStatePubSubType>(data, size, &m);
      break;
    }
  }
  return 0;
}
