// The operator GUI's server side (cairn_base --gui): the fleet as this basestation sees it (FleetClient),
// published over the Foxglove WebSocket protocol with Foxglove's well-known schemas, so that Cairn's own web
// GUI, Foxglove and Lichtblick connect to the same port; operator commands come back through the protocol's
// service and client-publish capabilities with exactly the CLI's semantics (a CommandShell runs them).
//
// Channels (JSON encoding, JSON schemas):
//   /fleet            cairn.FleetState         every robot: pose, mode, holder, nav status, the actions valid
//                                              now for this basestation (operator_text.h ValidActions), 10 Hz
//   /tf               foxglove.FrameTransforms map -> ROBOT_ID for every robot, 10 Hz
//   /robots           foxglove.SceneUpdate     robot bodies (the robot's colour), headings and labels (mode,
//                                              holder), 10 Hz
//   /paths            foxglove.SceneUpdate     global paths, local plans, trails, goals in the robot's
//   colour,
//                                              when they change
//   /places           foxglove.SceneUpdate     the named places (the places file) as labelled posts, when the
//                                              file changes
//   /staircases       foxglove.SceneUpdate     the fleet's staircases drawn as steps, when they change
//   /fleet_map        foxglove.SceneUpdate     the merged fleet map's occupied voxels coloured by height, one
//                                              entity per 4 x 4 m column of the map; every second only the
//                                              columns that changed (a new subscriber gets all of them)
//   /ROBOT_ID/camera  foxglove.CompressedImage each robot's latest JPEG frame, as it arrives
//   /events           foxglove.Log            operator events (arrived, failed, lost, locks, staircases, ...)
//   /cairn/commands   cairn.CommandTable       the console's command table (name, usage, help, argument
//                                              counts), once to each subscriber
// Service:  /cairn/command  a structured command, {"name": "goto", "robot": "r1", "args": [12, 4]}, or a
//           console line, {"command": "goto r1 12 4"} (gui_command.h) -> the CLI's --json result of it.
// Client publish: /cairn/teleop  cairn.Teleop {"robot_id", "linear_x_mps", "angular_z_radps"[,
// "linear_y_mps"]}:
//   one teleop twist, clamped to the robot's limits as the CLI's teleop command does.
#pragma once

#include <map>
#include <memory>
#include <string>

#include "cairn/base/command_shell.h"
#include "cairn/base/fleet_client.h"
#include "cairn/base/foxglove_server.h"

namespace cairn::base {

/// Options of the GUI server.
struct GuiOptions {
  FoxgloveServerOptions server;  ///< listen address (loopback by default), port, web root
  std::string places_file;       ///< the shell's places file (goto by place name), "" = none
  double state_rate_hz = 10.0;   ///< /fleet, /tf and /robots, (0, 50]
  double map_period_s = 1.0;     ///< /fleet_map changes at most this often, [0.1, 60]
  /// /fleet_map's share of the link to each GUI client, kB/s, [1, 1e6] (a new client's first full map is
  /// not counted). Columns that changed wait when it is spent.
  double map_budget_kBps = 150.0;
  double map_resend_s = 3.0;  ///< a column already sent is sent again at most this often, s, [0, 600]
  double trail_s = 120.0;     ///< trail length kept per robot, seconds, [0, 3600]
  /// @return false and sets `*why` naming the field, value and rule when invalid.
  bool IsValid(std::string* why) const;
};

/// Counters for tests and the bench.
struct GuiStats {
  FoxgloveServerStats server;
  std::uint64_t commands = 0;         ///< /cairn/command calls answered
  std::uint64_t teleop_messages = 0;  ///< /cairn/teleop twists published to robots
  std::uint64_t teleop_rejected = 0;  ///< malformed or unknown-robot teleop messages (answered with a status)
  std::uint64_t map_chunks_sent = 0;  ///< /fleet_map column entities published
  std::uint64_t map_chunks_deferred = 0;  ///< changed columns held back a period by map_budget_kBps
};

/// Serves the GUI for `client` until destroyed. Thread-safe.
class GuiBridge {
 public:
  /// Loads the Foxglove schemas written by the web build (WEB_ROOT/foxglove-schemas.json) and listens.
  /// @throws std::invalid_argument naming the option or file at fault; std::runtime_error when it cannot
  ///         listen (names address:port).
  GuiBridge(FleetClient& client, const GuiOptions& options);
  ~GuiBridge();
  GuiBridge(const GuiBridge&) = delete;
  GuiBridge& operator=(const GuiBridge&) = delete;

  /// "http://ADDRESS:PORT/".
  std::string url() const;
  GuiStats Stats() const;

  class Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

/// One distinct colour per robot, the same in every view of one basestation (3D body, label, paths, lists),
/// kept for the session. A robot is given the slot its trailing number names (r1 -> 0, r2 -> 1, ...), or its
/// name's hash, or the next free slot when that one is taken; so basestations usually agree for numbered
/// fleets. Ten colours, none of them red (red is STOP and warnings). Not thread-safe.
class RobotPalette {
 public:
  static constexpr int kSize = 10;
  /// "#rrggbb" of `robot_id`'s colour.
  std::string ColorOf(const std::string& robot_id);
  /// The same colour as RGB in [0, 1].
  void RgbOf(const std::string& robot_id, double* r, double* g, double* b);

 private:
  int SlotOf(const std::string& robot_id);
  std::map<std::string, int> slots_;
};

/// Colour of a robot mode in the GUI and the scene ("idle" grey, "manual" orange, "smart_joystick" purple,
/// "waypoint" blue, others teal), as RGB in [0, 1].
void ModeColor(const std::string& mode, double* r, double* g, double* b);

}  // namespace cairn::base
