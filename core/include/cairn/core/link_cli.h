// The link flags of cairn_agent and cairn_base (--link, --link-kbps, --subnet, --interface), one definition
// for both programs. Header-only: only programs that parse a command line with CLI11 include it.
#pragma once

#include <CLI/CLI.hpp>

#include "cairn/core/link_options.h"

namespace cairn::core {

/// Adds the link flags to `app`, writing into `*link` (checked later by CheckLinkOptions).
inline void AddLinkFlags(CLI::App& app, LinkOptions* link) {
  app.add_option("--link", link->link, "loopback | lan | radio: the network DDS talks on (lan and radio need "
                                       "--subnet or --interface; nothing else is listened on or sent to; radio "
                                       "also --link-kbps)")
      ->capture_default_str();
  app.add_option("--link-kbps", link->link_kbps, "with --link radio: the link's budget, kbit/s (a robot holds its "
                                                 "map and camera to shares of it)");
  app.add_option("--subnet", link->subnet, "with --link lan|radio: the IPv4 subnet to use, e.g. 10.77.0.0/24 "
                                           "(this host's one address in it)");
  app.add_option("--interface", link->interface_name, "with --link lan|radio: the interface to use, e.g. eth1");
  app.add_option("--discovery-server", link->discovery_server,
                 "with --link lan|radio: ADDRESS:PORT of a discovery server in that network (cairn "
                 "discovery-server); no multicast then");
}

}  // namespace cairn::core
