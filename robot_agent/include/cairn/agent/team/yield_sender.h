// Who may ask a robot to get out of the way (cairn/yield_request): a peer robot this robot hears, asking for
// itself, or a basestation allowed to command this robot; and only for a robot this robot hears. A request
// naming a robot that is not heard (a robot that does not exist, or one out of range) would otherwise send
// an idle robot aside for nothing. DDS-free: the adapter (AgentDds) says where a request came from.
#pragma once

#include <string>
#include <vector>

#include "cairn/agent/team/peers.h"
#include "cairn/agent/team/yield.h"

namespace cairn::agent {

/// Where a yield request came from, as the DDS adapter saw it.
struct YieldOrigin {
  /// DDS Security is on: the request's sender id is the certificate it came under (the adapter drops the
  /// others before they get here).
  bool secure = false;
  /// It came on this robot's own command topic (cairn/yield_request/<robot>, under DDS Security only), which
  /// the signed permissions let only the basestations allowed to command this robot write.
  bool commander_topic = false;
  /// The sender id is a base id that the sending process announced (cairn/base_info).
  bool announced_base = false;
  /// The sender id is a robot whose peer states (cairn/peer_state) come from the sending process.
  bool peer_robot = false;
};

/// "" when robot `own_id` may act on the (checked, CheckYieldCommand) request `c` from `origin`, given the
/// peers it hears now (`heard`, PeerTracker::Live), else why not, naming the sender and the passing robot:
///  - the passing robot must be heard (a peer state within the peers' timeout);
///  - the sender must be a basestation allowed to command this robot: under DDS Security one that wrote on
///    this robot's own yield topic (its permissions), without it any basestation that announced its id
///    from the sending process (without security every basestation may command every robot);
///  - or a peer robot this robot hears, from the process its peer states come from, asking for itself
///    (sender = passing robot: robots ask only to let themselves pass).
std::string CheckYieldSender(const std::string& own_id, const YieldCommand& c, const YieldOrigin& origin,
                             const std::vector<Peer>& heard);

}  // namespace cairn::agent
