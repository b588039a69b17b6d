// The link a DDS participant talks on (no Fast DDS headers: agent and basestation options carry it).
#pragma once

#include <string>

namespace cairn::core {

/// Which network a participant talks on (issue 13's link classes; DESIGN.md "QoS and links").
///
/// - `loopback` (default): the participant profile as it is, which must stay on 127.0.0.0/8.
/// - `lan`: one named network. The participant's UDPv4 transport, its metatraffic and default unicast
///   locators are the one local IPv4 address the user names, by `subnet` (the interface holding an address in
///   it) or by `interface_name` (its address; the subnet is the interface's); discovery is multicast
///   (239.255.0.1, sent on that interface only).
///   Nothing listens on or sends to any other interface (WithinNetworkScope checks the result).
struct LinkOptions {
  std::string link = "loopback";  ///< "loopback" | "lan"
  std::string subnet;              ///< lan: "A.B.C.D/N", e.g. "10.77.0.0/24"
  std::string interface_name;      ///< lan: e.g. "eth1" (instead of, or besides, subnet)
};

}  // namespace cairn::core
