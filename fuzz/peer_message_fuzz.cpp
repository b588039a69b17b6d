// Fuzz harness: samples from peers as a robot or a basestation decodes them. The first byte picks the type;
// the rest is its CDR payload, deserialized by the fastddsgen type (what Fast DDS does with every sample from
// the link), then checked and converted as the receiver does: ids (core::CheckId), waypoint goals
// (agent::CheckGoal), explore claims with their zstd coverage (agent::ClaimFromMessage, CheckExploreClaim),
// map updates (FleetMap::Apply), staircases (base::StaircaseFromMessage), path requests (the agent's id
// and frame checks, then a real global planner over a small map, from and to the requested points), and peer
// states (agent::PeerFromMessage, PeerTracker, AppendPeerObstacles), yield requests (agent::YieldFromMessage,
// CheckYieldCommand, DecideYield's spot search on a small room). Every
// input must decode or be refused; no crash, no unbounded allocation.
#include <fastdds/rtps/common/SerializedPayload.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "cairn/agent/command/commands.h"
#include "cairn/agent/communication/agent_dds.h"
#include "cairn/agent/team/explore_claims.h"
#include "cairn/agent/team/peers.h"
#include "cairn/agent/team/yield.h"
#include "cairn/base/fleet_perception.h"
#include "cairn/core/peer_input.h"
#include "cairn/core/voxel_grid.h"
#include "cairn/nav/global_planner.h"
#include "cairn/perception/map_telemetry.h"
#include "cairn_msgsPubSubTypes.h"
#include "fuzz_input.h"

namespace {

namespace msgs = cairn_msgs;

using cairn::fuzz::DeserializeCdr;

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

void Staircase(const msgs::StaircaseDetection& m) {
  cairn::perception::Staircase staircase;
  std::string why;
  (void)cairn::base::StaircaseFromMessage(m, &staircase, &why);
}

// The agent's path request reader (agent_dds.cpp) and PlanningService::Answer, on a 4 m x 4 m room with a
// floor and a wall across its middle (a door at one end).
void Path(const msgs::PathRequest& m) {
  if (!cairn::core::CheckId("requester id", m.requester_id()).empty()) return;
  if (!m.platform().empty() && !cairn::core::CheckId("platform", m.platform()).empty()) return;
  if (m.frame_id() != "map") return;
  static const std::shared_ptr<cairn::nav::GlobalPlanner> planner = [] {
    auto room = std::make_shared<cairn::core::VoxelGrid>("room", Eigen::Vector3d(0, 0, -0.1), 0.1,
                                                         Eigen::Vector3i(40, 40, 20));
    for (int x = 0; x < 40; ++x) {
      for (int y = 0; y < 40; ++y) room->SetOccupied({x, y, 0});
    }
    for (int y = 0; y < 32; ++y) {
      for (int z = 1; z < 20; ++z) room->SetOccupied({20, y, z});
    }
    return std::make_shared<cairn::nav::GlobalPlanner>(
        room, std::vector<cairn::nav::PlatformProfile>{cairn::nav::GetPlatformProfile("wheeled")});
  }();
  cairn::nav::GlobalPlanRequest request;
  request.start_W = {m.start_M().x_m(), m.start_M().y_m()};
  request.goal_W = {m.goal_M().x_m(), m.goal_M().y_m()};
  request.platform = m.platform().empty() ? "wheeled" : m.platform();
  (void)planner->Plan(request);
}

// A peer's state as a robot takes it (AgentDds's id checks, PeerFromMessage, PeerTracker), then the obstacle
// points a robot at the origin would make of it.
void Peer(const msgs::PeerState& m) {
  if (!cairn::core::CheckId("robot id", m.robot_id()).empty() ||
      !cairn::core::CheckId("mode", m.mode()).empty()) {
    return;
  }
  cairn::agent::PeerTracker tracker("r1", cairn::agent::PeerOptions{});
  (void)tracker.OnPeerState(cairn::agent::PeerFromMessage(m), 0.0);
  std::vector<Eigen::Vector3f> points_B;
  const std::vector<cairn::agent::Peer> live = tracker.Live(0.5);
  cairn::nav::AppendPeerObstacles(std::vector<cairn::nav::PeerBody>(live.begin(), live.end()),
                                  cairn::core::BaseState{}, 3.5, 0.3, cairn::nav::PeerAvoidanceOptions{},
                                  &points_B);
}

// A yield request as a robot takes it (AgentDds's id check, YieldFromMessage, CheckYieldCommand), then the
// policy's spot search (DecideYield, nav::FindYieldSpot) for an idle robot in the middle of the room.
void Yield(const msgs::YieldRequest& m) {
  if (!cairn::core::CheckId("sender id", m.sender_id()).empty()) return;
  std::string fault;
  const cairn::agent::YieldCommand c = cairn::agent::YieldFromMessage(m, &fault);
  if (!fault.empty() || !cairn::agent::CheckYieldCommand(c).empty()) return;
  static const std::shared_ptr<const cairn::nav::TraversabilityGrid> grid = [] {
    cairn::core::VoxelGrid room("room", Eigen::Vector3d(0, 0, -0.1), 0.1, Eigen::Vector3i(40, 40, 20));
    for (int x = 0; x < 40; ++x) {
      for (int y = 0; y < 40; ++y) room.SetOccupied({x, y, 0});
    }
    return std::make_shared<const cairn::nav::TraversabilityGrid>(room);
  }();
  cairn::agent::YieldSituation situation;
  situation.own_id = "r1";
  situation.mode = "idle";
  situation.pose_M.x_m = 2.0;
  situation.pose_M.y_m = 2.0;
  situation.grid = grid.get();
  (void)cairn::agent::DecideYield(cairn::agent::YieldOptions{}, c, situation);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t kind = data[0] % 10;
  ++data;
  --size;
  switch (kind) {
    case 0: {
      msgs::WaypointGoal m;
      if (DeserializeCdr<msgs::WaypointGoalPubSubType>(data, size, &m)) Goal(m);
      break;
    }
    case 1: {
      msgs::ExploreClaim m;
      if (DeserializeCdr<msgs::ExploreClaimPubSubType>(data, size, &m)) Claim(m);
      break;
    }
    case 2: {
      msgs::MapUpdate m;
      if (DeserializeCdr<msgs::MapUpdatePubSubType>(data, size, &m)) Map(m);
      break;
    }
    case 3: {
      msgs::ControlRequest m;
      if (DeserializeCdr<msgs::ControlRequestPubSubType>(data, size, &m))
        (void)cairn::core::CheckId("base id", m.base_id());
      break;
    }
    case 4: {
      msgs::StaircaseDetection m;
      if (DeserializeCdr<msgs::StaircaseDetectionPubSubType>(data, size, &m)) Staircase(m);
      break;
    }
    case 5: {
      msgs::PathRequest m;
      if (DeserializeCdr<msgs::PathRequestPubSubType>(data, size, &m)) Path(m);
      break;
    }
    case 6: {
      msgs::RestartRequest m;
      if (DeserializeCdr<msgs::RestartRequestPubSubType>(data, size, &m)) {
        (void)cairn::core::CheckId("base id", m.base_id());
      }
      break;
    }
    case 8: {
      msgs::PeerState m;
      if (DeserializeCdr<msgs::PeerStatePubSubType>(data, size, &m)) Peer(m);
      break;
    }
    case 9: {
      msgs::YieldRequest m;
      if (DeserializeCdr<msgs::YieldRequestPubSubType>(data, size, &m)) Yield(m);
      break;
    }
    default: {
      msgs::RobotState m;
      (void)DeserializeCdr<msgs::RobotStatePubSubType>(data, size, &m);
      break;
    }
  }
  return 0;
}
