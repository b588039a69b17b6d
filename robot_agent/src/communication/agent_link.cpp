#include "cairn/agent/communication/agent_link.h"

#include <stdexcept>
#include <utility>

namespace cairn::agent {

void RequireAllHandlers(const AgentDdsHandlers& h) {
  const std::pair<const char*, bool> handlers[] = {{"control", bool(h.control)},
                                                   {"mode", bool(h.mode)},
                                                   {"goal", bool(h.goal)},
                                                   {"explore", bool(h.explore)},
                                                   {"convoy", bool(h.convoy)},
                                                   {"home", bool(h.home)},
                                                   {"stop", bool(h.stop)},
                                                   {"restart", bool(h.restart)},
                                                   {"teleop", bool(h.teleop)},
                                                   {"base_announced", bool(h.base_announced)},
                                                   {"base_liveliness", bool(h.base_liveliness)},
                                                   {"path_query", bool(h.path_query)},
                                                   {"map_sync", bool(h.map_sync)},
                                                   {"explore_claim", bool(h.explore_claim)},
                                                   {"peer_state", bool(h.peer_state)},
                                                   {"yield", bool(h.yield)}};
  for (const auto& [name, set] : handlers) {
    if (!set) throw std::invalid_argument(std::string("agent link: handler '") + name + "' is required");
  }
}

}  // namespace cairn::agent
