// A transform tree as ROS 2's tf2 keeps it (REP-103 frames, REP-105 map -> odom -> base_link): each frame has
// one parent; a transform parent -> child is static (/tf_static: for all times) or dynamic (/tf, odometry: a
// history of stamped samples, interpolated between them). Lookup(target, source, t) chains the edges through
// the frames' nearest common ancestor, as tf2's lookupTransform does.
//
// Conventions: T_parent_child is the pose of `child` in `parent` (maps child coordinates to parent ones).
// Times are seconds on one clock (the caller's); frame names have any leading '/' removed.
#pragma once

#include <Eigen/Geometry>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace cairn::ros2 {

/// Options of a TfBuffer.
struct TfBufferOptions {
  /// Dynamic samples older than this behind the newest of their edge are forgotten, seconds, > 0.
  double history_s = 10.0;
  /// A lookup up to this far past an edge's newest sample uses that sample (a scan stamped just after the
  /// last odometry), seconds, >= 0. tf2 itself never extrapolates; a little tolerance keeps scans that raced
  /// their pose.
  double future_tolerance_s = 0.05;
};

class TfBuffer {
 public:
  /// @throws std::invalid_argument for invalid options (naming the field and value).
  explicit TfBuffer(const TfBufferOptions& options = {});

  /// Adds `T_parent_child` at `stamp_s` (dynamic) or for all times (`is_static`). @return "" or why it was
  /// refused: an empty frame, parent == child, a non-finite or non-rigid transform, a child that already has
  /// another parent (tf's tree), or a static edge given as dynamic (or the reverse).
  std::string Set(const std::string& parent, const std::string& child,
                  const Eigen::Isometry3d& T_parent_child, double stamp_s, bool is_static);

  /// The pose of `source` in `target` at `stamp_s` (T_target_source), or nullopt and `*why` (naming the
  /// frames, the edge and the times: no path between the frames, a sample older than the history, or not
  /// yet heard).
  std::optional<Eigen::Isometry3d> Lookup(const std::string& target, const std::string& source,
                                          double stamp_s, std::string* why) const;

  /// The newest stamp of dynamic edge parent -> child, or nullopt if it has no sample.
  std::optional<double> NewestStamp(const std::string& parent, const std::string& child) const;

  /// Every frame known, sorted (for error messages).
  std::vector<std::string> Frames() const;

  /// Removes every edge.
  void Clear();

 private:
  struct Sample {
    double stamp_s;
    Eigen::Vector3d translation;
    Eigen::Quaterniond rotation;
  };
  struct Edge {
    std::string parent;
    bool is_static = false;
    std::deque<Sample> samples;  // by stamp; a static edge holds one
  };
  // T_parent_child of `child`'s edge at `stamp_s`.
  std::optional<Eigen::Isometry3d> EdgeAt(const std::string& child, const Edge& edge, double stamp_s,
                                          std::string* why) const;
  // `frame` and its ancestors, nearest first.
  std::vector<std::string> Chain(const std::string& frame) const;

  TfBufferOptions options_;
  std::map<std::string, Edge> edges_;  // by child frame
};

/// `name` without leading '/' (tf2 frame ids carry none; ROS 1 data and some drivers do).
std::string FrameId(const std::string& name);

}  // namespace cairn::ros2
