#include "cairn/core/dds.h"

#include <arpa/inet.h>
#include <fastdds/rtps/attributes/ServerAttributes.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#include <fmt/format.h>
#include <ifaddrs.h>
#include <netinet/in.h>
#include <openssl/sha.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <fastdds/rtps/flowcontrol/FlowControllerDescriptor.hpp>
#include <filesystem>
#include <fstream>
#include <optional>

#include "cairn/core/build_paths.h"
#include "cairn/core/peer_input.h"

namespace cairn::core {

namespace dds = eprosima::fastdds::dds;
using eprosima::fastrtps::types::ReturnCode_t;

int ParseDomainId(const std::string& text, const std::string& field) {
  std::size_t used = 0;
  long value = -1;
  try {
    value = std::stol(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  // stol skips leading white space (' 150' was taken while '150 ' was refused): neither is an integer.
  if (!text.empty() && std::isspace(static_cast<unsigned char>(text.front()))) used = 0;
  if (used == 0 || used != text.size()) {
    throw std::invalid_argument(field + " '" + text + "' is not an integer (valid DDS domain ids: 0..232)");
  }
  if (value < 0 || value > kMaxDomainId) {
    throw std::invalid_argument(field + " " + text + " is out of range: DDS domain ids are 0..232");
  }
  return static_cast<int>(value);
}

bool WaitForCount(const std::atomic<int>& value, int count, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (value.load() < count) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

namespace {

std::string DottedHex(const unsigned char* bytes, std::size_t n) {
  static const char* kHex = "0123456789abcdef";
  std::string text;
  text.reserve(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    if (i > 0) text += '.';
    text += kHex[bytes[i] >> 4];
    text += kHex[bytes[i] & 0xf];
  }
  return text;
}

}  // namespace

std::string ParticipantIdOf(const eprosima::fastrtps::rtps::InstanceHandle_t& handle) {
  if (!handle.isDefined()) return "";
  eprosima::fastrtps::rtps::GUID_t guid;
  eprosima::fastrtps::rtps::iHandle2GUID(guid, handle);
  return ParticipantIdOf(guid);
}

std::string ParticipantIdOf(const eprosima::fastrtps::rtps::GUID_t& guid) {
  return DottedHex(guid.guidPrefix.value, eprosima::fastrtps::rtps::GuidPrefix_t::size);
}

std::string WriterIdOf(const eprosima::fastrtps::rtps::InstanceHandle_t& handle) {
  if (!handle.isDefined()) return "";
  eprosima::fastrtps::rtps::GUID_t guid;
  eprosima::fastrtps::rtps::iHandle2GUID(guid, handle);
  unsigned char bytes[16];
  std::copy(guid.guidPrefix.value, guid.guidPrefix.value + 12, bytes);
  std::copy(guid.entityId.value, guid.entityId.value + 4, bytes + 12);
  return DottedHex(bytes, sizeof(bytes));
}

bool GuidPrefixHoldsIdentity(const eprosima::fastrtps::rtps::GuidPrefix_t& prefix, const std::string& id) {
  // The subject tools/keys.sh gives every identity, "/O=Cairn/CN=<id>", in DER as openssl writes it (a
  // SEQUENCE of two SETs, each one SEQUENCE of an attribute OID and a UTF8String). Ids are at most 64
  // characters, so every length fits one byte.
  if (!CheckId("identity", id).empty()) return false;
  const auto tlv = [](unsigned char tag, const std::string& content) {
    return std::string(1, static_cast<char>(tag)) + std::string(1, static_cast<char>(content.size())) +
           content;
  };
  const auto rdn = [&](unsigned char oid_last, const std::string& value) {
    const std::string oid =
        tlv(0x06, std::string("\x55\x04", 2) + std::string(1, static_cast<char>(oid_last)));
    return tlv(0x31, tlv(0x30, oid + tlv(0x0c, value)));
  };
  const std::string subject = tlv(0x30, rdn(0x0a, "Cairn") + rdn(0x03, id));
  unsigned char md[SHA256_DIGEST_LENGTH];
  SHA256(reinterpret_cast<const unsigned char*>(subject.data()), subject.size(), md);
  // Fast DDS PKIDH adjust_participant_key: byte 0 = 0x80 | md[0] >> 1, byte k = md[k-1] << 7 | md[k] >> 1.
  const unsigned char* p = prefix.value;
  if (p[0] != (0x80 | (md[0] >> 1))) return false;
  for (int k = 1; k < 6; ++k) {
    if (p[k] != static_cast<unsigned char>((md[k - 1] << 7) | (md[k] >> 1))) return false;
  }
  return true;
}

bool SentUnder(const SecurityOptions& security, const dds::SampleInfo& info, const std::string& claimed) {
  if (!security.enabled()) return true;
  eprosima::fastrtps::rtps::GUID_t guid;
  eprosima::fastrtps::rtps::iHandle2GUID(guid, info.publication_handle);
  return GuidPrefixHoldsIdentity(guid.guidPrefix, claimed);
}

std::string IdentityOfSubject(const std::string& subject) {
  const std::size_t at = subject.rfind("/CN=");
  if (at == std::string::npos) return "";
  const std::size_t end = subject.find('/', at + 4);
  return subject.substr(at + 4, end == std::string::npos ? std::string::npos : end - at - 4);
}

std::string Participant::CertifiedIdOf(const std::string& participant_id) const {
  std::lock_guard<std::mutex> lock(certified_mutex_);
  const auto it = certified_ids_.find(participant_id);
  return it == certified_ids_.end() ? "" : it->second;
}

std::string Participant::participant_id() const {
  std::lock_guard<std::mutex> lock(id_mutex_);
  return participant_id_;
}

std::string DefaultProfilesFile() {
  if (const char* env = std::getenv("CAIRN_DDS_PROFILES"); env != nullptr && *env != '\0') return env;
  return ConfigDir() + "/dds_profiles.xml";
}

namespace {

using eprosima::fastrtps::rtps::IPLocator;
using eprosima::fastrtps::rtps::Locator_t;
using eprosima::fastrtps::rtps::LocatorList_t;

std::string LocatorText(const Locator_t& locator) {
  if (locator.kind != LOCATOR_KIND_UDPv4)
    return "a locator of kind " + std::to_string(locator.kind) + " (not UDPv4)";
  return IPLocator::toIPv4string(locator) + ":" + std::to_string(locator.port);
}

std::uint32_t LocatorAddress(const Locator_t& locator) {
  return (static_cast<std::uint32_t>(locator.address[12]) << 24) |
         (static_cast<std::uint32_t>(locator.address[13]) << 16) |
         (static_cast<std::uint32_t>(locator.address[14]) << 8) | locator.address[15];
}

// The netmask of a prefix length in [0, 32], host byte order.
std::uint32_t PrefixMask(int prefix_length) {
  return prefix_length == 0 ? 0 : ~std::uint32_t{0} << (32 - prefix_length);
}

bool IsLoopbackAddress(std::uint32_t address) { return (address >> 24) == 127; }
bool IsMulticastAddress(std::uint32_t address) { return (address >> 28) == 0xE; }

// Every locator of a unicast list is UDPv4 on loopback or a named subnet; a multicast list may hold multicast
// groups only when the scope names multicast. `*why` names `list` and the locator at fault.
bool LocatorsInScope(const LocatorList_t& locators, const std::string& list, bool multicast_list,
                     const NetworkScope& scope, std::string* why) {
  for (const Locator_t& locator : locators) {
    const std::string text = LocatorText(locator);
    if (multicast_list) {
      if (!scope.multicast || locator.kind != LOCATOR_KIND_UDPv4 ||
          !IsMulticastAddress(LocatorAddress(locator))) {
        *why = "its " + list + " holds " + text +
               (scope.multicast ? " (not a UDPv4 multicast group)" : " (multicast leaves loopback)");
        return false;
      }
      continue;
    }
    if (locator.kind != LOCATOR_KIND_UDPv4 || !scope.Contains(LocatorAddress(locator))) {
      *why = "its " + list + " holds " + text + ", outside " + scope.Describe();
      return false;
    }
  }
  return true;
}

bool EndpointInScope(const dds::RTPSEndpointQos& endpoint, const NetworkScope& scope, std::string* why) {
  return LocatorsInScope(endpoint.unicast_locator_list, "unicastLocatorList", false, scope, why) &&
         LocatorsInScope(endpoint.remote_locator_list, "remoteLocatorList", false, scope, why) &&
         LocatorsInScope(endpoint.multicast_locator_list, "multicastLocatorList", true, scope, why);
}

std::string ScopeRefusal(const NetworkScope& scope) {
  return scope.subnets.empty() ? "is not loopback-only: "
                               : "leaves its network scope (" + scope.Describe() + "): ";
}

}  // namespace

Ipv4Subnet ParseIpv4Subnet(const std::string& text) {
  const auto slash = text.find('/');
  const std::string address = text.substr(0, slash);
  const std::string length = slash == std::string::npos ? "" : text.substr(slash + 1);
  std::uint32_t value = 0;
  int parts = 0;
  bool ok = !length.empty() && length.size() <= 2 &&
            std::all_of(length.begin(), length.end(), [](char c) { return c >= '0' && c <= '9'; });
  std::size_t at = 0;
  while (ok && at <= address.size() && parts < 4) {
    const std::size_t dot = std::min(address.find('.', at), address.size());
    const std::string part = address.substr(at, dot - at);
    ok = !part.empty() && part.size() <= 3 &&
         std::all_of(part.begin(), part.end(), [](char c) { return c >= '0' && c <= '9'; }) &&
         std::stoi(part) <= 255;
    if (ok) value = (value << 8) | static_cast<std::uint32_t>(std::stoi(part));
    ++parts;
    at = dot + 1;
  }
  ok = ok && parts == 4 && at == address.size() + 1 && std::stoi(length) <= 32;
  if (!ok) throw std::invalid_argument("subnet '" + text + "' must be an IPv4 CIDR, e.g. 10.77.0.0/24");
  Ipv4Subnet subnet;
  subnet.prefix_length = std::stoi(length);
  subnet.network = value & PrefixMask(subnet.prefix_length);
  subnet.text = text;
  return subnet;
}

bool Ipv4Subnet::Contains(std::uint32_t address) const {
  return (address & PrefixMask(prefix_length)) == network;
}

bool NetworkScope::Contains(std::uint32_t address) const {
  if (IsLoopbackAddress(address)) return true;
  return std::any_of(subnets.begin(), subnets.end(),
                     [address](const Ipv4Subnet& s) { return s.Contains(address); });
}

std::string NetworkScope::Describe() const {
  std::string text = "loopback (127.0.0.0/8)";
  for (const Ipv4Subnet& s : subnets) text += " and " + s.text;
  if (multicast) text += ", multicast on those";
  return text;
}

bool WithinNetworkScope(const dds::DomainParticipantQos& qos, const NetworkScope& scope, std::string* why) {
  if (qos.transport().use_builtin_transports) {
    *why = "it keeps Fast DDS built-in transports (UDP on every interface, multicast)";
    return false;
  }
  if (qos.transport().user_transports.empty()) {
    *why = "it defines no user transport";
    return false;
  }
  for (const auto& transport : qos.transport().user_transports) {
    const auto* udp = dynamic_cast<const eprosima::fastdds::rtps::UDPv4TransportDescriptor*>(transport.get());
    if (udp == nullptr) {
      *why = "it uses a transport other than UDPv4";
      return false;
    }
    if (udp->interfaceWhiteList.empty()) {
      *why = "its UDPv4 transport has no interface whitelist";
      return false;
    }
    for (const auto& address : udp->interfaceWhiteList) {
      const bool loopback_only = scope.subnets.empty();
      bool in_scope = address == "127.0.0.1";
      if (!in_scope && !loopback_only) {
        try {
          in_scope = scope.Contains(ParseIpv4Subnet(address + "/32").network);
        } catch (const std::invalid_argument&) {
          in_scope = false;  // an interface name or a malformed address: named by the reason below
        }
      }
      if (!in_scope) {
        *why = "its UDPv4 whitelist contains " + address +
               (loopback_only ? "" : ", outside " + scope.Describe());
        return false;
      }
    }
  }
  const auto& builtin = qos.wire_protocol().builtin;
  const std::pair<const LocatorList_t*, const char*> unicast[] = {
      {&builtin.metatrafficUnicastLocatorList, "metatrafficUnicastLocatorList"},
      {&builtin.initialPeersList, "initialPeersList"},
      {&qos.wire_protocol().default_unicast_locator_list, "defaultUnicastLocatorList"}};
  for (const auto& [list, name] : unicast) {
    if (!LocatorsInScope(*list, name, /*multicast_list=*/false, scope, why)) return false;
  }
  const std::pair<const LocatorList_t*, const char*> multicast[] = {
      {&builtin.metatrafficMulticastLocatorList, "metatrafficMulticastLocatorList"},
      {&qos.wire_protocol().default_multicast_locator_list, "defaultMulticastLocatorList"}};
  for (const auto& [list, name] : multicast) {
    if (!LocatorsInScope(*list, name, /*multicast_list=*/true, scope, why)) return false;
  }
  for (const auto& server : builtin.discovery_config.m_DiscoveryServers) {
    if (!LocatorsInScope(server.metatrafficUnicastLocatorList,
                         "discovery server's metatrafficUnicastLocatorList", false, scope, why) ||
        !LocatorsInScope(server.metatrafficMulticastLocatorList,
                         "discovery server's metatrafficMulticastLocatorList", true, scope, why)) {
      return false;
    }
  }
  return true;
}

namespace {

// The QoS of a `kind` ("writer" | "reader") profile as a participant with `options` uses it
// (Participant::WriterQos); `load(profile, qos)` reads the profile.
template <class EndpointQos, class Load>
EndpointQos EndpointQosFor(const char* kind, const std::string& profile, const ParticipantOptions& options,
                           const Load& load) {
  EndpointQos qos;
  if (load(profile, qos) != ReturnCode_t::RETCODE_OK) {
    throw DdsError(std::string(kind) + " QoS profile '" + profile + "' is not defined in " +
                   options.profiles_file);
  }
  std::string why;
  if (!EndpointInScope(qos.endpoint(), options.network, &why)) {
    throw DdsError(std::string(kind) + " QoS profile '" + profile + "' in " + options.profiles_file + " " +
                   ScopeRefusal(options.network) + why + "; refusing to create it");
  }
  // A finite AUTOMATIC liveliness lease shorter than kNetworkLivelinessLeaseS is raised to it.
  auto& liveliness = qos.liveliness();
  const eprosima::fastrtps::Duration_t shortest(kNetworkLivelinessLeaseS);
  if (IsNamedNetworkLink(options.link) && liveliness.kind == dds::AUTOMATIC_LIVELINESS_QOS &&
      liveliness.lease_duration != eprosima::fastrtps::c_TimeInfinite &&
      liveliness.lease_duration < shortest) {
    liveliness.lease_duration = shortest;
  }
  return qos;
}

}  // namespace

dds::DataWriterQos Participant::WriterQos(const std::string& profile) const {
  return EndpointQosFor<dds::DataWriterQos>("writer", profile, options_,
                                            [this](const std::string& p, auto& qos) {
                                              return publisher_->get_datawriter_qos_from_profile(p, qos);
                                            });
}

dds::DataReaderQos Participant::ReaderQos(const std::string& profile) const {
  return EndpointQosFor<dds::DataReaderQos>("reader", profile, options_,
                                            [this](const std::string& p, auto& qos) {
                                              return subscriber_->get_datareader_qos_from_profile(p, qos);
                                            });
}

void CheckLinkOptions(const LinkOptions& link) {
  if (link.link != "loopback" && link.link != "lan" && link.link != "radio") {
    throw std::invalid_argument("--link '" + link.link + "' must be loopback, lan or radio");
  }
  if (link.link == "radio" && !(link.link_kbps >= 8 && link.link_kbps <= 1e6)) {
    throw std::invalid_argument("--link-kbps " + std::to_string(link.link_kbps) +
                                ": a radio link needs its budget, in kbit/s in [8, 1e6]");
  }
  if (link.link != "radio" && link.link_kbps != 0) {
    throw std::invalid_argument("--link-kbps names a radio link's budget: add --link radio");
  }
  if (link.link == "loopback" && (!link.subnet.empty() || !link.interface_name.empty())) {
    throw std::invalid_argument(
        "--subnet and --interface name a lan link: add --link lan (the loopback link "
        "binds to 127.0.0.1 only)");
  }
  if (IsNamedNetworkLink(link) && link.subnet.empty() && link.interface_name.empty()) {
    throw std::invalid_argument("--link " + link.link +
                                " needs --subnet CIDR or --interface NAME: it binds only "
                                "to the network you name, never to every interface");
  }
  if (!link.subnet.empty()) ParseIpv4Subnet(link.subnet);
  if (!link.discovery_server.empty()) {
    if (!IsNamedNetworkLink(link)) {
      throw std::invalid_argument("--discovery-server names a server on a lan or radio link: add --link lan");
    }
    ParseDiscoveryServer(link.discovery_server);
  }
}

std::pair<std::string, std::uint32_t> ParseDiscoveryServer(const std::string& text) {
  const auto colon = text.rfind(':');
  std::uint32_t port = 0;
  in_addr address{};
  bool ok = colon != std::string::npos && inet_pton(AF_INET, text.substr(0, colon).c_str(), &address) == 1;
  if (ok) {
    const std::string port_text = text.substr(colon + 1);
    ok = !port_text.empty() && port_text.size() <= 5 &&
         port_text.find_first_not_of("0123456789") == std::string::npos;
    if (ok) port = static_cast<std::uint32_t>(std::stoul(port_text));
    ok = ok && port >= 1 && port <= 65535;
  }
  if (!ok) {
    throw std::invalid_argument("--discovery-server '" + text +
                                "' must be IPV4_ADDRESS:PORT, e.g. 10.77.0.2:11811");
  }
  return {text.substr(0, colon), port};
}

std::string ResolveLinkAddress(const LinkOptions& link, Ipv4Subnet* subnet) {
  CheckLinkOptions(link);
  std::optional<Ipv4Subnet> named;
  if (!link.subnet.empty()) named = ParseIpv4Subnet(link.subnet);
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) != 0) throw std::invalid_argument("cannot list this host's network interfaces");
  std::vector<std::pair<std::string, Ipv4Subnet>> matches;  // address, its interface's subnet
  std::string seen;
  for (const ifaddrs* i = list; i != nullptr; i = i->ifa_next) {
    if (i->ifa_addr == nullptr || i->ifa_addr->sa_family != AF_INET) continue;
    const std::uint32_t address = ntohl(reinterpret_cast<const sockaddr_in*>(i->ifa_addr)->sin_addr.s_addr);
    const std::uint32_t mask =
        i->ifa_netmask != nullptr
            ? ntohl(reinterpret_cast<const sockaddr_in*>(i->ifa_netmask)->sin_addr.s_addr)
            : ~0u;
    char text[INET_ADDRSTRLEN] = {};
    const in_addr raw = reinterpret_cast<const sockaddr_in*>(i->ifa_addr)->sin_addr;
    inet_ntop(AF_INET, &raw, text, sizeof(text));
    seen += (seen.empty() ? "" : ", ") + std::string(i->ifa_name) + " " + text;
    if (!link.interface_name.empty() && link.interface_name != i->ifa_name) continue;
    if (named && !named->Contains(address)) continue;
    int prefix = 0;
    while (prefix < 32 && (mask & (0x80000000u >> prefix)) != 0) ++prefix;
    Ipv4Subnet own;
    own.prefix_length = prefix;
    own.network = address & PrefixMask(prefix);
    own.text = std::string(text) + "/" + std::to_string(prefix);
    matches.emplace_back(text, own);
  }
  freeifaddrs(list);
  const std::string what = !link.interface_name.empty() ? "--interface '" + link.interface_name + "'" +
                                                              (named ? " in --subnet " + named->text : "")
                                                        : "--subnet " + named->text;
  if (matches.empty()) {
    throw std::invalid_argument(what + ": no interface of this host has an IPv4 address there (seen: " +
                                (seen.empty() ? "none" : seen) + ")");
  }
  if (matches.size() > 1) {
    throw std::invalid_argument(what + ": " + std::to_string(matches.size()) +
                                " addresses match (seen: " + seen + "); name one with --interface");
  }
  *subnet = named ? *named : matches.front().second;
  return matches.front().first;
}

Locator_t Udpv4Locator(const std::string& address, std::uint32_t port) {
  Locator_t l;
  l.kind = LOCATOR_KIND_UDPv4;
  IPLocator::setIPv4(l, address);
  l.port = port;
  return l;
}

namespace {

// Participant announcements on a radio link (the lan link keeps the shipped loopback profile's 250 ms
// announcements and 2 s lease). Each announcement (~0.3-0.5 kB) reaches every host, so their period is the
// largest idle cost of a fleet; loss is seen within 1 s by other means (state silence at the basestation,
// the writers' AUTOMATIC liveliness), so the participant lease only clears out a participant that is gone,
// and a longer one rides out short cuts without a rediscovery burst. The first announcements stay quick.
constexpr int kRadioAnnouncementPeriodMs = 1000;
constexpr int kRadioLeaseS = 6;
constexpr int kRadioInitialAnnouncements = 6;
constexpr int kRadioInitialAnnouncementPeriodMs = 100;

// The lan link (LinkOptions): the profile's QoS with its transport and locators on `address` only; on a radio
// link, the announcement timing above.
void ApplyLanLink(const std::string& address, int domain_id, const std::string& discovery_server, bool radio,
                  dds::DomainParticipantQos* qos) {
  auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
  // The profile's socket buffers and message size carry over (the ROS 2 driver's 4 MiB for clouds).
  for (const auto& transport : qos->transport().user_transports) {
    if (const auto* profile =
            dynamic_cast<const eprosima::fastdds::rtps::UDPv4TransportDescriptor*>(transport.get())) {
      udp->sendBufferSize = profile->sendBufferSize;
      udp->receiveBufferSize = profile->receiveBufferSize;
      udp->maxMessageSize = profile->maxMessageSize;
      break;
    }
  }
  udp->interfaceWhiteList = {address};
  qos->transport().use_builtin_transports = false;
  qos->transport().user_transports = {udp};
  // The discovery multicast group's port is RTPS's well-known PB + DG * domain + d0 (7400 + 250 d + 0);
  // unicast ports are left to Fast DDS (0: chosen per participant).
  const std::uint32_t base = 7400 + 250 * static_cast<std::uint32_t>(domain_id);
  auto& builtin = qos->wire_protocol().builtin;
  builtin.metatrafficUnicastLocatorList.clear();
  builtin.metatrafficUnicastLocatorList.push_back(Udpv4Locator(address, 0));
  builtin.metatrafficMulticastLocatorList.clear();
  builtin.metatrafficMulticastLocatorList.push_back(Udpv4Locator("239.255.0.1", base));
  builtin.initialPeersList.clear();  // none: Fast DDS announces on the metatraffic multicast locators then
  qos->wire_protocol().default_unicast_locator_list.clear();
  qos->wire_protocol().default_unicast_locator_list.push_back(Udpv4Locator(address, 0));
  qos->wire_protocol().default_multicast_locator_list.clear();
  if (radio) {
    auto& discovery = builtin.discovery_config;
    discovery.leaseDuration_announcementperiod =
        eprosima::fastrtps::Duration_t(kRadioAnnouncementPeriodMs / 1000.0);
    discovery.leaseDuration = eprosima::fastrtps::Duration_t(kRadioLeaseS, 0);
    discovery.initial_announcements.count = kRadioInitialAnnouncements;
    discovery.initial_announcements.period =
        eprosima::fastrtps::Duration_t(kRadioInitialAnnouncementPeriodMs / 1000.0);
  }
  if (!discovery_server.empty()) {
    // A client of the server: it announces itself there only and hears of its matches from it; no multicast.
    const auto [server_address, server_port] = ParseDiscoveryServer(discovery_server);
    eprosima::fastdds::rtps::RemoteServerAttributes server;
    server.ReadguidPrefix(kDiscoveryServerGuidPrefix);
    server.metatrafficUnicastLocatorList.push_back(Udpv4Locator(server_address, server_port));
    builtin.discovery_config.discoveryProtocol = eprosima::fastrtps::rtps::DiscoveryProtocol_t::CLIENT;
    // Until the server answers, a client pings it this often (Fast DDS default 450 ms, most of a join's
    // time).
    builtin.discovery_config.discoveryServer_client_syncperiod = eprosima::fastrtps::Duration_t(0.1);
    builtin.discovery_config.m_DiscoveryServers.clear();
    builtin.discovery_config.m_DiscoveryServers.push_back(server);
    builtin.metatrafficMulticastLocatorList.clear();
  }
}

// The properties of Fast DDS's built-in security plugins (Fast DDS docs, "Security"), from the files of
// `security`; each must be readable.
void ApplySecurity(const SecurityOptions& security, dds::DomainParticipantQos* qos) {
  if (const std::string why = CheckId("--secure identity", security.identity); !why.empty()) {
    throw std::invalid_argument(why);
  }
  const auto uri = [&](const std::string& name, bool own) {
    const std::string path = security.File(name, own);
    if (!std::ifstream(path).good()) {
      throw DdsError("DDS Security: '" + path + "' cannot be read (--secure " + security.dir +
                     ": make the folder with ./cairn keys, and the identity '" + security.identity +
                     "' with it)");
    }
    return "file://" + path;
  };
  auto& properties = qos->properties().properties();
  const auto set = [&](const std::string& name, const std::string& value) {
    properties.emplace_back(name, value);
  };
  set("dds.sec.auth.plugin", "builtin.PKI-DH");
  set("dds.sec.auth.builtin.PKI-DH.identity_ca", uri("ca.pem", false));
  set("dds.sec.auth.builtin.PKI-DH.identity_certificate", uri("cert.pem", true));
  set("dds.sec.auth.builtin.PKI-DH.private_key", uri("key.pem", true));
  set("dds.sec.access.plugin", "builtin.Access-Permissions");
  set("dds.sec.access.builtin.Access-Permissions.permissions_ca", uri("ca.pem", false));
  set("dds.sec.access.builtin.Access-Permissions.governance", uri("governance.p7s", false));
  set("dds.sec.access.builtin.Access-Permissions.permissions", uri("permissions.p7s", true));
  set("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
}

}  // namespace

std::string SecurityOptions::File(const std::string& name, bool own) const {
  std::error_code ec;
  std::filesystem::path folder = std::filesystem::absolute(dir, ec);
  if (ec) folder = dir;
  if (own) folder /= identity;
  return (folder / name).lexically_normal().string();
}

std::vector<std::string> SecurityOptions::CommandableRobots() const {
  const std::string path = File("robots", true);
  std::ifstream in(path);
  if (!in) {
    throw std::invalid_argument("DDS Security: '" + path + "' cannot be read (--secure " + dir + ": is '" +
                                identity +
                                "' a basestation of this fleet? ./cairn keys makes one per --commander "
                                "and --observer, with the robots it may command)");
  }
  std::vector<std::string> robots;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.empty()) continue;
    if (line != "*") {
      if (const std::string why = CheckId("robot id", line); !why.empty()) {
        throw std::invalid_argument(path + " line " + std::to_string(number) + ": " + why);
      }
    }
    robots.push_back(line);
  }
  return robots;
}

std::string CommandTopicFor(const std::string& topic, const std::string& robot_id, bool secure) {
  return secure ? topic + "/" + robot_id : topic;
}

const std::vector<std::string>& CommandTopics() {
  static const std::vector<std::string> topics = {
      "cairn/control_request", "cairn/mode_request",   "cairn/waypoint_goal", "cairn/explore_request",
      "cairn/home_request",    "cairn/stop_request",   "cairn/teleop",        "cairn/path_request",
      "cairn/restart_request", "cairn/convoy_request", "cairn/yield_request"};
  return topics;
}

std::string Participant::SecurityHint() const {
  if (!options_.security.enabled()) return "";
  return " (DDS Security: is it allowed by " + options_.security.File("permissions.xml", true) + "?)";
}

Participant::Participant(const ParticipantOptions& options) : options_(options) {
  if (options.domain_id < 0 || options.domain_id > kMaxDomainId) {
    throw std::invalid_argument("domain id " + std::to_string(options.domain_id) +
                                " is out of range: DDS domain ids are 0..232");
  }
  if (!std::ifstream(options.profiles_file).good()) {
    throw DdsError("DDS profiles file '" + options.profiles_file + "' cannot be read");
  }
  auto* factory = dds::DomainParticipantFactory::get_instance();
  if (factory->load_XML_profiles_file(options.profiles_file) != ReturnCode_t::RETCODE_OK) {
    throw DdsError("DDS profiles file '" + options.profiles_file + "' is not valid Fast DDS XML");
  }
  dds::DomainParticipantQos qos;
  if (factory->get_participant_qos_from_profile(options.participant_profile, qos) !=
      ReturnCode_t::RETCODE_OK) {
    throw DdsError("participant profile '" + options.participant_profile + "' is not defined in " +
                   options.profiles_file);
  }
  if (IsNamedNetworkLink(options.link)) {
    Ipv4Subnet subnet;
    const std::string address = ResolveLinkAddress(options.link, &subnet);
    ApplyLanLink(address, options.domain_id, options.link.discovery_server, IsRadioLink(options.link), &qos);
    options_.network.subnets = {subnet};
    options_.network.multicast = options.link.discovery_server.empty();
  } else {
    CheckLinkOptions(options.link);
  }
  std::string why;
  if (!WithinNetworkScope(qos, options_.network, &why)) {
    throw DdsError("participant profile '" + options.participant_profile + "' " +
                   ScopeRefusal(options_.network) + why + "; refusing to start it");
  }
  qos.name(options.name);
  if (options.security.enabled()) ApplySecurity(options.security, &qos);
  for (const FlowControllerOptions& flow : options.flow_controllers) {
    if (flow.name.empty() || FlowControllerName(flow.name) != nullptr) {
      throw DdsError("flow controller name '" + flow.name + "' is empty or used twice");
    }
    if (!(flow.budget_bits_per_s > 0.0) || !std::isfinite(flow.budget_bits_per_s)) {
      throw std::invalid_argument("flow controller '" + flow.name + "': budget_bits_per_s " +
                                  std::to_string(flow.budget_bits_per_s) + " must be > 0 and finite");
    }
    if (flow.period_ms < 1 || flow.period_ms > 10000) {
      throw std::invalid_argument("flow controller '" + flow.name + "': period_ms " +
                                  std::to_string(flow.period_ms) + " must be in [1, 10000]");
    }
    flow_controller_names_.push_back(flow.name);
    auto descriptor = std::make_shared<eprosima::fastdds::rtps::FlowControllerDescriptor>();
    descriptor->name = flow_controller_names_.back().c_str();
    descriptor->scheduler = eprosima::fastdds::rtps::FlowControllerSchedulerPolicy::FIFO;
    // A period must carry at least one full RTPS message (~1.5 kB): tight budgets get longer periods.
    constexpr double kMinBytesPerPeriod = 1500.0;
    double period_ms = flow.period_ms;
    double bytes = flow.budget_bits_per_s / 8.0 * period_ms / 1000.0;
    if (bytes < kMinBytesPerPeriod) {
      period_ms = std::ceil(kMinBytesPerPeriod * 8000.0 / flow.budget_bits_per_s);
      bytes = flow.budget_bits_per_s / 8.0 * period_ms / 1000.0;
    }
    descriptor->max_bytes_per_period = static_cast<int32_t>(std::clamp(bytes, kMinBytesPerPeriod, 2.0e9));
    descriptor->period_ms = static_cast<uint64_t>(period_ms);
    qos.flow_controllers().push_back(descriptor);
  }
  qos_ = qos;
  CreateEntities();
  const auto& discovery = qos_.wire_protocol().builtin.discovery_config;
  if (options_.rebuild_after_stall && discovery.leaseDuration != eprosima::fastrtps::c_TimeInfinite) {
    stall_threshold_s_ = std::max(0.5, discovery.leaseDuration.to_ns() * 1e-9 -
                                           discovery.leaseDuration_announcementperiod.to_ns() * 1e-9);
    watchdog_ = std::thread([this] { WatchForStalls(); });
  }
}

Participant::~Participant() {
  if (watchdog_.joinable()) {
    {
      std::lock_guard<std::mutex> lock(watchdog_mutex_);
      watchdog_stop_ = true;
    }
    watchdog_cv_.notify_all();
    watchdog_.join();
  }
  DeleteEntities();
}

void Participant::CreateEntities() {
  auto* factory = dds::DomainParticipantFactory::get_instance();
  // The listener hears participant discovery only (StatusMask::none: entity callbacks stay with the
  // entities).
  participant_ = factory->create_participant(static_cast<dds::DomainId_t>(options_.domain_id), qos_, this,
                                             dds::StatusMask::none());
  if (participant_ == nullptr) {
    throw DdsError(
        "cannot create DDS participant '" + options_.name + "' in domain " +
        std::to_string(options_.domain_id) + " with profile '" + options_.participant_profile + "'" +
        (options_.security.enabled()
             ? " and DDS Security from " + options_.security.dir + " as '" + options_.security.identity +
                   "' (a certificate, key or signed document that does not verify against ca.pem?)"
             : ""));
  }
  publisher_ = participant_->create_publisher(dds::PUBLISHER_QOS_DEFAULT);
  subscriber_ = participant_->create_subscriber(dds::SUBSCRIBER_QOS_DEFAULT);
  if (publisher_ == nullptr || subscriber_ == nullptr) {
    DeleteEntities();
    throw DdsError("cannot create the publisher/subscriber of participant '" + options_.name + "'");
  }
  std::lock_guard<std::mutex> lock(id_mutex_);
  participant_id_ = ParticipantIdOf(participant_->guid());
}

void Participant::DeleteEntities() {
  if (participant_ == nullptr) return;
  participant_->set_listener(nullptr);
  participant_->delete_contained_entities();
  dds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  participant_ = nullptr;
  publisher_ = nullptr;
  subscriber_ = nullptr;
}

void Participant::Register(ParticipantEndpoint* endpoint) {
  std::lock_guard<std::mutex> lock(endpoints_mutex_);
  endpoints_.insert(endpoint);
}

void Participant::Unregister(ParticipantEndpoint* endpoint) {
  std::lock_guard<std::mutex> lock(endpoints_mutex_);
  endpoints_.erase(endpoint);
}

void Participant::Rebuild(const std::string& why) {
  std::lock_guard<std::mutex> one_at_a_time(rebuild_mutex_);
  const std::string old_id = participant_id();
  std::size_t endpoints = 0;
  {
    std::unique_lock<std::shared_mutex> entities(entities_mutex_);
    std::lock_guard<std::mutex> lock(endpoints_mutex_);
    for (ParticipantEndpoint* endpoint : endpoints_) endpoint->DeleteEntity();
    DeleteEntities();
    CreateEntities();
    for (ParticipantEndpoint* endpoint : endpoints_) endpoint->CreateEntity();
    endpoints = endpoints_.size();
    ++rebuilds_;
  }
  {
    // Writers publish what waited, under the entities lock shared (taken before endpoints_mutex_, the order
    // Register keeps); an endpoint being destroyed meanwhile waits in Unregister.
    std::shared_lock<std::shared_mutex> entities(entities_mutex_);
    std::lock_guard<std::mutex> lock(endpoints_mutex_);
    for (ParticipantEndpoint* endpoint : endpoints_) endpoint->AfterRebuild();
  }
  const std::string new_id = participant_id();
  spdlog::warn("DDS participant '{}' re-created ({}): {} is now {}, {} endpoints back", options_.name, why,
               old_id, new_id, endpoints);
  if (options_.on_rebuilt) options_.on_rebuilt(new_id);
}

void Participant::WatchForStalls() {
  using Clock = std::chrono::steady_clock;
  constexpr auto kPeriod = std::chrono::milliseconds(100);
  std::unique_lock<std::mutex> lock(watchdog_mutex_);
  Clock::time_point last = Clock::now();
  while (!watchdog_cv_.wait_for(lock, kPeriod, [this] { return watchdog_stop_; })) {
    const Clock::time_point now = Clock::now();
    const double gap_s = std::chrono::duration<double>(now - last).count();
    last = now;
    if (gap_s <= stall_threshold_s_) continue;
    lock.unlock();
    try {
      Rebuild(fmt::format(
          "this process stalled for {:.1f} s, longer than the {:.2f} s after which peers may have "
          "dropped it",
          gap_s, stall_threshold_s_));
    } catch (const std::exception& e) {
      spdlog::error("DDS participant '{}' could not be re-created after a stall: {}", options_.name,
                    e.what());
    }
    lock.lock();
    last = Clock::now();
  }
}

void Participant::on_participant_discovery(dds::DomainParticipant*,
                                           eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) {
  using Status = eprosima::fastrtps::rtps::ParticipantDiscoveryInfo;
  const std::string id = ParticipantIdOf(info.info.m_guid);
  if (options_.security.enabled()) {
    // The certificate's id, for naming who sent a forged message (CertifiedIdOf): the identity token is not
    // itself authenticated, so it is kept only when the GUID prefix (which is) agrees.
    std::lock_guard<std::mutex> lock(certified_mutex_);
    if (info.status == Status::DISCOVERED_PARTICIPANT || info.status == Status::CHANGED_QOS_PARTICIPANT) {
      std::string certified;
      for (const auto& property : info.info.identity_token_.properties()) {
        if (property.name() == "dds.cert.sn") certified = IdentityOfSubject(property.value());
      }
      if (!certified.empty() && GuidPrefixHoldsIdentity(info.info.m_guid.guidPrefix, certified)) {
        certified_ids_[id] = certified;
      }
    } else if (info.status == Status::REMOVED_PARTICIPANT || info.status == Status::DROPPED_PARTICIPANT) {
      certified_ids_.erase(id);
    }
  }
  if (!options_.on_participant_gone) return;
  if (info.status == Status::REMOVED_PARTICIPANT || info.status == Status::DROPPED_PARTICIPANT) {
    options_.on_participant_gone(id, info.status == Status::DROPPED_PARTICIPANT);
  }
}

const char* Participant::FlowControllerName(const std::string& name) const {
  for (const std::string& registered : flow_controller_names_) {
    if (registered == name) return registered.c_str();
  }
  return nullptr;
}

dds::Topic* Participant::GetTopic(const std::string& topic_name, const dds::TypeSupport& type) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (participant_->find_type(type.get_type_name()).empty()) {
    if (type.register_type(participant_) != ReturnCode_t::RETCODE_OK) {
      throw DdsError("cannot register DDS type '" + type.get_type_name() + "'");
    }
  }
  if (auto* existing = dynamic_cast<dds::Topic*>(participant_->lookup_topicdescription(topic_name))) {
    return existing;
  }
  dds::Topic* topic = participant_->create_topic(topic_name, type.get_type_name(), dds::TOPIC_QOS_DEFAULT);
  if (topic == nullptr) throw DdsError("cannot create DDS topic '" + topic_name + "'");
  return topic;
}

}  // namespace cairn::core
