// The link flags of cairn_agent and cairn_base (--link, --link-kbps, --subnet, --interface, --secure), one
// definition for both programs. Header-only: only programs that parse a command line with CLI11 include it.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "cairn/core/link_options.h"

namespace cairn::core {

/// Adds the link flags to `app`, writing into `*link` (checked later by CheckLinkOptions).
inline void AddLinkFlags(CLI::App& app, LinkOptions* link) {
  app.add_option("--link", link->link,
                 "loopback | lan | radio: the network DDS talks on (lan and radio need "
                 "--subnet or --interface; nothing else is listened on or sent to; radio "
                 "also --link-kbps)")
      ->capture_default_str();
  app.add_option("--link-kbps", link->link_kbps,
                 "with --link radio: the link's budget, kbit/s (a robot holds its "
                 "map and camera to shares of it)");
  app.add_option("--subnet", link->subnet,
                 "with --link lan|radio: the IPv4 subnet to use, e.g. 10.77.0.0/24 "
                 "(this host's one address in it)");
  app.add_option("--interface", link->interface_name,
                 "with --link lan|radio: the interface to use, e.g. eth1");
  app.add_option("--discovery-server", link->discovery_server,
                 "with --link lan|radio: ADDRESS:PORT of a discovery server in that network (cairn "
                 "discovery-server); no multicast then");
}

/// Adds --secure DIR to `app`, writing into `security->dir` (the identity is the program's own id, set by
/// it).
inline void AddSecureFlag(CLI::App& app, SecurityOptions* security) {
  app.add_option(
      "--secure", security->dir,
      "DDS Security from DIR (made by ./cairn keys): authenticate with this id's certificate (PKI-DH), "
      "encrypt (AES-GCM) and apply its signed permissions; peers without a certificate from the same "
      "CA are neither heard nor answered");
}

/// Sets `security->identity` to `id` and checks that --secure names a folder. @throws std::invalid_argument
/// naming the flag and the value.
inline void CheckSecureFlag(const std::string& id, SecurityOptions* security) {
  security->identity = id;
  if (!security->enabled()) return;
  std::error_code ec;
  if (!std::filesystem::is_directory(security->dir, ec)) {
    throw std::invalid_argument("--secure '" + security->dir +
                                "' is not a folder (make one with ./cairn keys)");
  }
}

}  // namespace cairn::core
