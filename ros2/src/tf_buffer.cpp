#include "cairn/ros2/tf_buffer.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "cairn/core/range_check.h"

namespace cairn::ros2 {
namespace {

std::string List(const std::vector<std::string>& names) {
  std::string text;
  for (const auto& n : names) text += (text.empty() ? "" : ", ") + n;
  return text.empty() ? "none" : text;
}

}  // namespace

std::string FrameId(const std::string& name) {
  std::size_t first = 0;
  while (first < name.size() && name[first] == '/') ++first;
  return name.substr(first);
}

TfBuffer::TfBuffer(const TfBufferOptions& options) : options_(options) {
  if (!(options_.history_s > 0) || !std::isfinite(options_.history_s))
    throw std::invalid_argument("tf history_s " + std::to_string(options_.history_s) + " must be > 0");
  if (!(options_.future_tolerance_s >= 0) || !std::isfinite(options_.future_tolerance_s))
    throw std::invalid_argument("tf future_tolerance_s " + std::to_string(options_.future_tolerance_s) +
                                " must be >= 0");
}

std::string TfBuffer::Set(const std::string& parent_name, const std::string& child_name,
                          const Eigen::Isometry3d& T_parent_child, double stamp_s, bool is_static) {
  const std::string parent = FrameId(parent_name), child = FrameId(child_name);
  if (parent.empty() || child.empty())
    return "a transform with an empty frame id ('" + parent_name + "' -> '" + child_name + "')";
  if (parent == child) return "a transform from frame '" + parent + "' to itself";
  if (!T_parent_child.matrix().allFinite() || !std::isfinite(stamp_s))
    return "transform '" + parent + "' -> '" + child + "' is not finite";
  const Eigen::Matrix3d R = T_parent_child.linear();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 || R.determinant() < 0)
    return "transform '" + parent + "' -> '" + child + "' is not a rotation (quaternion not unit?)";
  if (const std::vector<std::string> up = Chain(parent); std::find(up.begin(), up.end(), child) != up.end())
    return "transform '" + parent + "' -> '" + child + "' would close a loop ('" + child + "' is above '" +
           parent + "')";
  auto it = edges_.find(child);
  if (it != edges_.end()) {
    Edge& edge = it->second;
    if (edge.parent != parent)
      return "frame '" + child + "' already has parent '" + edge.parent + "': '" + parent + "' -> '" + child +
             "' ignored (a tf tree has one parent per frame)";
    if (edge.is_static != is_static)
      return "transform '" + parent + "' -> '" + child + "' came on " + (is_static ? "/tf_static" : "/tf") +
             " but is already on " + (edge.is_static ? "/tf_static" : "/tf");
  } else {
    it = edges_.emplace(child, Edge{parent, is_static, {}}).first;
  }
  Edge& edge = it->second;
  const Sample sample{stamp_s, T_parent_child.translation(), Eigen::Quaterniond(R).normalized()};
  if (is_static) {
    edge.samples.assign(1, sample);
    return "";
  }
  // In stamp order (samples come nearly in order: search from the back).
  auto at = edge.samples.end();
  while (at != edge.samples.begin() && std::prev(at)->stamp_s > stamp_s) --at;
  if (at != edge.samples.begin() && std::prev(at)->stamp_s == stamp_s) {
    *std::prev(at) = sample;  // the same stamp again (from /odom and /tf both): replaced
  } else {
    edge.samples.insert(at, sample);
  }
  const double oldest_kept_s = edge.samples.back().stamp_s - options_.history_s;
  while (edge.samples.size() > 2 && edge.samples.front().stamp_s < oldest_kept_s) edge.samples.pop_front();
  return "";
}

std::optional<Eigen::Isometry3d> TfBuffer::EdgeAt(const std::string& child, const Edge& edge, double stamp_s,
                                                  std::string* why) const {
  auto make = [](const Eigen::Vector3d& t, const Eigen::Quaterniond& q) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = q.toRotationMatrix();
    T.translation() = t;
    return T;
  };
  const std::deque<Sample>& s = edge.samples;
  if (s.empty()) {
    *why = "no transform '" + edge.parent + "' -> '" + child + "' heard yet";
    return std::nullopt;
  }
  if (edge.is_static) return make(s.front().translation, s.front().rotation);
  if (stamp_s > s.back().stamp_s) {
    if (stamp_s - s.back().stamp_s <= options_.future_tolerance_s)
      return make(s.back().translation, s.back().rotation);
    *why = "transform '" + edge.parent + "' -> '" + child + "' at " + core::Fixed(stamp_s, 3) +
           " s is newer than its last sample (" + core::Fixed(s.back().stamp_s, 3) + " s, " +
           core::Fixed(stamp_s - s.back().stamp_s, 3) + " s before)";
    return std::nullopt;
  }
  if (stamp_s < s.front().stamp_s) {
    *why = "transform '" + edge.parent + "' -> '" + child + "' at " + core::Fixed(stamp_s, 3) +
           " s is older than its history (oldest " + core::Fixed(s.front().stamp_s, 3) + " s)";
    return std::nullopt;
  }
  auto after =
      std::lower_bound(s.begin(), s.end(), stamp_s, [](const Sample& a, double t) { return a.stamp_s < t; });
  if (after->stamp_s == stamp_s || after == s.begin()) return make(after->translation, after->rotation);
  const Sample& b = *after;
  const Sample& a = *std::prev(after);
  const double f = (stamp_s - a.stamp_s) / (b.stamp_s - a.stamp_s);
  return make(a.translation + f * (b.translation - a.translation), a.rotation.slerp(f, b.rotation));
}

std::vector<std::string> TfBuffer::Chain(const std::string& frame) const {
  std::vector<std::string> chain = {frame};
  for (auto it = edges_.find(frame); it != edges_.end() && chain.size() <= edges_.size();
       it = edges_.find(it->second.parent)) {
    chain.push_back(it->second.parent);
  }
  return chain;
}

std::optional<Eigen::Isometry3d> TfBuffer::Lookup(const std::string& target_name,
                                                  const std::string& source_name, double stamp_s,
                                                  std::string* why) const {
  const std::string target = FrameId(target_name), source = FrameId(source_name);
  if (target == source) return Eigen::Isometry3d::Identity();
  const std::vector<std::string> up_source = Chain(source), up_target = Chain(target);
  // The nearest common ancestor: the first frame of the source's chain that the target's chain holds.
  auto common = std::find_first_of(up_source.begin(), up_source.end(), up_target.begin(), up_target.end());
  if (common == up_source.end()) {
    *why = "no transform from '" + source + "' to '" + target + "' (frames known: " + List(Frames()) + ")";
    return std::nullopt;
  }
  // T_ancestor_frame of each side, composed edge by edge up to the common ancestor.
  auto up_to = [&](const std::vector<std::string>& chain) -> std::optional<Eigen::Isometry3d> {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    for (const std::string& frame : chain) {
      if (frame == *common) return T;
      const Edge& edge = edges_.at(frame);
      const std::optional<Eigen::Isometry3d> T_parent_frame = EdgeAt(frame, edge, stamp_s, why);
      if (!T_parent_frame) return std::nullopt;
      T = *T_parent_frame * T;
    }
    return T;
  };
  const std::optional<Eigen::Isometry3d> T_common_source = up_to(up_source);
  if (!T_common_source) return std::nullopt;
  const std::optional<Eigen::Isometry3d> T_common_target = up_to(up_target);
  if (!T_common_target) return std::nullopt;
  return T_common_target->inverse() * *T_common_source;
}

std::optional<double> TfBuffer::NewestStamp(const std::string& parent, const std::string& child) const {
  auto it = edges_.find(FrameId(child));
  if (it == edges_.end() || it->second.parent != FrameId(parent) || it->second.samples.empty() ||
      it->second.is_static)
    return std::nullopt;
  return it->second.samples.back().stamp_s;
}

std::vector<std::string> TfBuffer::Frames() const {
  std::vector<std::string> frames;
  for (const auto& [child, edge] : edges_) {
    frames.push_back(child);
    frames.push_back(edge.parent);
  }
  std::sort(frames.begin(), frames.end());
  frames.erase(std::unique(frames.begin(), frames.end()), frames.end());
  return frames;
}

void TfBuffer::Clear() { edges_.clear(); }

}  // namespace cairn::ros2
