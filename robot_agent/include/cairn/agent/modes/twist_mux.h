// The mux (Sriganesh et al. 2024, § Behavior Tree and Mux; lesson L3: exactly one source drives navigation):
// forwards only the selected channel's twist, and a zero twist when that source is stale.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "cairn/core/time.h"

namespace cairn::agent {

/// Planar body-frame velocity command (frame B).
struct Twist2 {
  double linear_x_mps = 0.0;
  double angular_z_radps = 0.0;
};

/// One mux input.
struct MuxChannelOptions {
  std::string name;        ///< e.g. "teleop", "waypoint"; "none" is reserved (zero output)
  double timeout_s = 0.5;  ///< input older than this is stale -> zero twist; range (0, 60]
};

/// What the mux outputs now.
struct MuxOutput {
  Twist2 twist_B;              ///< command for the driver (zero unless the active channel is fresh)
  std::string active_channel;  ///< selected channel ("none" when nothing is selected)
  std::string reason;       ///< why: "teleop fresh (0.05 s old)", "teleop stale: no input for 0.62 s > 0.5 s"
  bool forwarding = false;  ///< true when twist_B comes from the channel (not a fail-safe zero)
};

/// Channel multiplexer with per-channel staleness.
class TwistMux {
 public:
  /// @throws std::invalid_argument for a duplicate/reserved name or a timeout outside (0, 60] s.
  explicit TwistMux(const std::vector<MuxChannelOptions>& channels);

  /// Stores the latest twist of `channel` received at `stamp`. @return false (and stores nothing) for an
  /// unknown channel or a non-finite twist.
  bool Submit(const std::string& channel, const Twist2& twist_B, core::SteadyTime stamp);

  /// Selects the channel that reaches the driver; "none" selects nothing. Clears the new channel's input so
  /// that a command sent before the switch is never replayed. @return false for an unknown channel.
  bool Select(const std::string& channel);

  const std::string& selected() const { return selected_; }
  /// The channels this mux was built with (not "none"), in name order.
  std::vector<std::string> channel_names() const;
  MuxOutput Compute(core::SteadyTime now) const;

 private:
  struct Channel {
    double timeout_s;
    Twist2 twist_B;
    core::SteadyTime stamp{};
    bool has_input = false;
  };
  std::map<std::string, Channel> channels_;
  std::string selected_ = "none";
};

}  // namespace cairn::agent
