// The link a DDS participant talks on and its DDS Security (no Fast DDS headers: agent and basestation
// options carry them).
#pragma once

#include <string>
#include <vector>

namespace cairn::core {

/// Which network a participant talks on.
///
/// - `loopback` (default): the participant profile as it is, which must stay on 127.0.0.0/8.
/// - `lan`: one named network. The participant's UDPv4 transport, its metatraffic and default unicast
///   locators are the one local IPv4 address the user names, by `subnet` (the interface holding an address in
///   it) or by `interface_name` (its address; the subnet is the interface's); discovery is multicast
///   (239.255.0.1, sent on that interface only).
///   Nothing listens on or sends to any other interface (WithinNetworkScope checks the result).
/// - `radio`: a lan link with a stated budget, `link_kbps` (a mesh radio of ~1 Mbit/s, as in SubT). The DDS
///   transport is the lan's; a robot holds its bulk traffic to shares of the budget (kRadioMapShare,
///   kRadioCameraShare) so that commands, the lock, state and events never queue behind maps and frames.
struct LinkOptions {
  std::string link = "loopback";  ///< "loopback" | "lan" | "radio"
  std::string subnet;             ///< lan, radio: "A.B.C.D/N", e.g. "10.77.0.0/24"
  std::string interface_name;     ///< lan, radio: e.g. "eth1" (instead of, or besides, subnet)
  double link_kbps = 0;           ///< radio: the link's budget, kbit/s, [8, 1e6]; 0 otherwise
  /// lan, radio: "A.B.C.D:PORT" of a Fast DDS discovery server in the named network (`cairn discovery-server`
  /// runs one); "" = multicast discovery. With one, the participant is its client: no multicast at all, each
  /// process announces itself to the server only and learns from it who matches (fleets where multicast is
  /// absent, or where everyone announcing to everyone costs too much).
  std::string discovery_server;
};

/// The well-known GUID prefix of Fast DDS discovery server 0 (`fast-discovery-server -i 0`), which clients
/// of Fast DDS 2.9 must name.
constexpr const char* kDiscoveryServerGuidPrefix = "44.53.00.5f.45.50.52.4f.53.49.4d.41";

/// Shares of a radio link's budget for a robot's map telemetry and camera frames (the rest: commands, state,
/// events, behavior tree and DDS's own traffic).
constexpr double kRadioMapShare = 0.25;
constexpr double kRadioCameraShare = 0.15;

/// True for the radio link class (a lan link with a stated budget, shared by the robots on it).
inline bool IsRadioLink(const LinkOptions& link) { return link.link == "radio"; }

/// The budget a link states, kbit/s: link_kbps on a radio link, 0 (none) otherwise.
inline double StatedBudgetKbps(const LinkOptions& link) { return IsRadioLink(link) ? link.link_kbps : 0.0; }

/// True for the links bound to a named network (lan, radio).
inline bool IsNamedNetworkLink(const LinkOptions& link) { return link.link == "lan" || link.link == "radio"; }

/// DDS Security (OMG DDS Security 1.1 with Fast DDS's built-in plugins: PKI-DH authentication,
/// Access-Permissions, AES-GCM-GMAC cryptography), from the folder `./cairn keys` writes (tools/keys.sh).
struct SecurityOptions {
  /// The fleet's folder: ca.pem, governance.p7s and <identity>/{cert.pem,key.pem,permissions.p7s}. "" = off.
  std::string dir;
  /// The robot or basestation id whose certificate and permissions this process uses.
  std::string identity;
  bool enabled() const { return !dir.empty(); }
  /// The file `name` of the fleet (ca.pem, governance.p7s) or, with `own`, of the identity (cert.pem, ...).
  std::string File(const std::string& name, bool own) const;
  /// The robots the identity may command (<identity>/robots: one id per line, "*" for all; empty for an
  /// observer or a robot). @throws std::invalid_argument naming the file when it cannot be read or holds a
  /// bad id.
  std::vector<std::string> CommandableRobots() const;
};

}  // namespace cairn::core
