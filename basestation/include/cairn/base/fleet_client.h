// The basestation's view of the fleet and its command channel to robots: host discovery (agent info with
// liveliness), robot and behavior-tree state, and commands answered by the robots' command interfaces.
#pragma once

#include <Eigen/Geometry>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "cairn/base/fleet.h"
#include "cairn/core/link_options.h"
#include "cairn/core/time.h"
#include "cairn_msgs.h"

namespace cairn::base {

/// Options of the fleet client.
struct FleetClientOptions {
  std::string base_id;             ///< required; [A-Za-z0-9_-]{1,64}
  int domain_id = 0;               ///< [0, 232]
  std::string dds_profiles_file;   ///< "" = shipped loopback-only profiles
  core::LinkOptions link;          ///< loopback (default) or a named lan (core::LinkOptions)
  double command_timeout_s = 3.0;  ///< give up waiting for an acknowledgement, (0, 60]
  double command_retry_s = 0.5;    ///< resend an unacknowledged command (robots de-duplicate), (0, 10]
  double lost_after_s = 3.0;       ///< a robot whose state is silent this long is shown lost, (0, 60]
  /// Advertised in this basestation's agent info. "joystick": it can stream teleop twists, which the
  /// robots' IsJoystickAlive condition requires for smart joystick mode.
  std::vector<std::string> capabilities = {"joystick"};
  /// A robot not seen this long after start is unknown: commands to it are refused at once, (0, 60]. Until
  /// then a command to a robot not heard of yet waits for it, however short the command's timeout.
  double discovery_s = 1.5;
  FleetEventOptions events;       ///< what raises operator events (proximity distances)
  std::size_t events_kept = 200;  ///< recent events kept for RecentEvents(), [1, 100000]
  /// DDS Security (--secure DIR; identity = base_id). Commands to robots its permissions do not give it are
  /// refused here, naming them; the robots' access control refuses them anyway.
  core::SecurityOptions security;
};

/// DDS client of one basestation: the Fleet the console reads (fleet.h says what each of its members does).
/// Thread-safe.
class FleetClient : public Fleet {
 public:
  /// @throws core::DdsError / std::invalid_argument naming the field at fault.
  explicit FleetClient(const FleetClientOptions& options);
  ~FleetClient() override;

  const std::string& base_id() const override;
  /// This process's DDS participant id (core::ParticipantIdOf): robots answer it, and show it as the
  /// participant speaking for the holder (RobotState::holder_participant).
  std::string participant_id() const;

  std::vector<RobotView> Robots() const override;
  std::optional<RobotView> Robot(const std::string& robot_id) const override;

  bool WaitForRobot(const std::string& robot_id, double timeout_s) const override;

  std::optional<RobotView> WaitUntil(const std::string& robot_id, double timeout_s,
                                     const std::function<bool(const RobotView&)>& predicate) const override;

  CommandOutcome RequestControl(const std::string& robot_id) override;
  CommandOutcome ReleaseControl(const std::string& robot_id) override;
  CommandOutcome HandOverControl(const std::string& robot_id, const std::string& to_base_id) override;
  CommandOutcome DenyControl(const std::string& robot_id, const std::string& to_base_id) override;
  CommandOutcome RequestMode(const std::string& robot_id, const std::string& mode) override;
  CommandOutcome SendWaypoint(const std::string& robot_id, double x_m, double y_m, double tolerance_m = 0.0,
                              double z_m = std::numeric_limits<double>::quiet_NaN()) override;
  CommandOutcome SendExplore(const std::string& robot_id, const std::optional<Eigen::AlignedBox2d>& region_M,
                             double min_z_m = std::numeric_limits<double>::quiet_NaN(),
                             double max_z_m = std::numeric_limits<double>::quiet_NaN(),
                             double home_after_silence_s = 0.0) override;
  CommandOutcome SendConvoy(const std::string& robot_id, const std::vector<std::string>& ahead_ids) override;
  std::string SendYield(const std::string& robot_id, const std::string& passing_id, double passing_radius_m,
                        const std::vector<Eigen::Vector2d>& keep_clear_M) override;
  CommandOutcome SendHome(const std::string& robot_id,
                          const std::optional<Eigen::Vector3d>& point_M = std::nullopt) override;
  CommandOutcome Stop(const std::string& robot_id) override;
  CommandOutcome Restart(const std::string& robot_id, const std::string& component) override;
  bool PublishTeleop(const std::string& robot_id, double linear_x_mps, double angular_z_radps,
                     double linear_y_mps = 0.0) override;
  PathAnswer RequestPath(const std::string& robot_id, const std::string& platform, double start_x_m,
                         double start_y_m, double goal_x_m, double goal_y_m) override;

  FleetPerception& perception() override;

  std::vector<OperatorEvent> TakeEvents() override;
  bool HasEvents() const override;
  std::vector<OperatorEvent> RecentEvents() const override;
  /// Of the last events_kept events, those detected after the one numbered `*cursor` (OperatorEvent::seq),
  /// oldest first; sets `*cursor` to the newest. Independent of TakeEvents(): a GUI follows events this way
  /// without taking them from the console.
  std::vector<OperatorEvent> EventsSince(std::uint64_t* cursor) const;

  std::vector<std::string> RobotIds() const override;

  bool Knows(const std::string& robot_id) const override;
  core::SteadyTime started() const override;
  core::SteadyTime discovery_end() const override;
  std::string UnknownRobotReason(const std::string& robot_id) const override;
  class Impl;  ///< DDS entities and the fleet model, kept out of this header.

 private:
  // One ControlRequest (`action`, to `target_base_id` for a handover or a denial) and its answer.
  CommandOutcome SendControl(const std::string& robot_id, cairn_msgs::CommandKind kind,
                             cairn_msgs::ControlAction action, const std::string& target_base_id = "");

  std::unique_ptr<Impl> impl_;
};

}  // namespace cairn::base
