#include "cairn/agent/team/yield_sender.h"

#include <algorithm>

namespace cairn::agent {

std::string CheckYieldSender(const std::string& own_id, const YieldCommand& c, const YieldOrigin& origin,
                             const std::vector<Peer>& heard) {
  const auto is_heard = [&](const std::string& id) {
    return std::any_of(heard.begin(), heard.end(), [&](const Peer& p) { return p.robot_id == id; });
  };
  const std::string request = "yield for " + c.passing_id + " (asked by " + c.sender_id + ")";
  if (!is_heard(c.passing_id)) {
    return request + " refused: passing robot " + c.passing_id + " is not heard by " + own_id +
           " (no peer state from it lately): a robot yields only to a robot it hears";
  }
  if (origin.commander_topic) return "";
  if (!origin.secure && origin.announced_base) return "";
  if (origin.peer_robot && is_heard(c.sender_id)) {
    if (c.sender_id == c.passing_id) return "";
    return request + " refused: robot " + c.sender_id + " may ask only for itself, not for " + c.passing_id;
  }
  std::string why = request + " refused: sender " + c.sender_id + " is neither a robot " + own_id +
                    " hears (its peer states from the same process) nor a basestation allowed to command " +
                    own_id;
  if (origin.secure && origin.announced_base) {
    why += " (under DDS Security a basestation asks on " + own_id +
           "'s own topic, which only its commanders may write)";
  }
  return why;
}

}  // namespace cairn::agent
