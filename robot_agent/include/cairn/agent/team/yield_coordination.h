// Getting out of each other's way, on one robot, both sides (team/yield.h holds the policy and the two
// sides' pieces; this composes them as the agent runs them):
//  - asked: a yield request — a peer's or an operator's — is checked (CheckYieldCommand, CheckYieldSender),
//    decided (DecideYield) and, when accepted, the robot moves aside in the yield mode, its running mission
//    held until the yield ends (MissionResumption). A request that comes before the robot listens to its
//    peers (an idle robot that never drove) waits until they could be heard, since the passing robot must be
//    heard (CheckYieldSender);
//  - asking: a robot driving a goal whose route a peer blocks in a narrow passage asks it to yield and holds
//    before it meanwhile (YieldAsker); the request is handed to the caller to send outside the agent lock.
//
// Not thread-safe: the agent's control thread and its DDS handlers, under the agent lock.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cairn/agent/modes/mission_resumption.h"
#include "cairn/agent/team/peers.h"
#include "cairn/agent/team/yield.h"
#include "cairn/agent/team/yield_sender.h"
#include "cairn/core/kinematics.h"
#include "cairn/nav/navigation.h"
#include "cairn/nav/traversability.h"

namespace cairn::agent {

class YieldCoordination {
 public:
  /// What the robot is and has, as the agent knows it now.
  struct Robot {
    double now_s = 0.0;                        ///< the agent's clock, seconds
    std::string mode;                          ///< the mode now (ModeControl::mode())
    core::BaseState pose_M;                    ///< the pose estimate, frame M
    const std::vector<Peer>* peers = nullptr;  ///< peers heard lately (PeerTracker::Live()); not null
    bool listening_to_peers = false;           ///< peers' states are read (AgentDds::ListenToPeers() done)
  };
  /// The traversability grid of the robot's platform (the passage's width, the spots aside); null: no map.
  using GridSource = std::function<std::shared_ptr<const nav::TraversabilityGrid>()>;
  /// A request that came before the robot listened to its peers is decided this long after it came, once
  /// they are read, seconds.
  static constexpr double kHearingS = 1.5;

  /// `yield` (the yield mode), `missions` and `navigation` outlive this object; `request_mode` asks the mode
  /// tree for a mode; `mission_commands` is CommandInterface::mission_commands().
  /// @throws std::invalid_argument for invalid options, an empty id or a null pointer.
  YieldCoordination(std::string robot_id, const YieldOptions& options, double radius_m, YieldMode* yield,
                    MissionResumption* missions, nav::Navigation* navigation, GridSource grid,
                    MissionResumption::RequestMode request_mode,
                    std::function<std::uint64_t()> mission_commands);

  /// A yield request `c` from `origin`; `fault` non-empty: the adapter already found it malformed (refused
  /// with that). Refused requests are shown on the yield mode's status (under a valid passing id) and
  /// logged once per reason.
  void OnRequest(const YieldCommand& c, const YieldOrigin& origin, const std::string& fault,
                 const Robot& robot);
  /// Once per control cycle, before the mode's step: asks a blocking peer to yield and holds before it
  /// (Navigation::SetHold), or lets go.
  void AskPeers(const Robot& robot);
  /// Once per control cycle: decides a request that waited for the peers (see kHearingS).
  void DecideWaitingRequest(const Robot& robot);
  /// True while a request waits for the peers to be heard (the caller starts listening to them).
  bool waiting_to_hear_peers() const { return unheard_.has_value(); }
  /// The request to send now, to the robot named first, if any (sent outside the agent lock).
  std::optional<std::pair<std::string, YieldCommand>> TakeRequestToSend();

  /// As this robot asks its peers (YieldAsker::status()).
  const YieldStatus& asking() const { return asker_.status(); }

 private:
  // True when the yield mode already shows `why` as its refusal of `c`'s passing robot (logged once).
  bool AlreadyRefused(const YieldCommand& c, const std::string& why) const;
  void Refuse(const YieldCommand& c, const std::string& why, double now_s);

  const std::string robot_id_;
  const YieldOptions options_;
  const double radius_m_;
  YieldMode* const yield_;
  MissionResumption* const missions_;
  nav::Navigation* const navigation_;
  const GridSource grid_;
  const MissionResumption::RequestMode request_mode_;
  const std::function<std::uint64_t()> mission_commands_;
  YieldAsker asker_;
  std::string asking_logged_;  // the asking status last logged
  std::optional<std::pair<std::string, YieldCommand>> to_send_;
  // A request that came before the robot listened to its peers, and when.
  std::optional<std::pair<YieldCommand, YieldOrigin>> unheard_;
  double unheard_at_s_ = 0.0;
};

}  // namespace cairn::agent
