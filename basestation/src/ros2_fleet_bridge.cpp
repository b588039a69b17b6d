#include "cairn/base/ros2_fleet_bridge.h"

#include <spdlog/spdlog.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <map>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>

#include "cairn/core/time.h"
#include "cairn/ros2/raw_cdr.h"
#include "cairn/ros2/wire.h"
#include "cairn_msgsPubSubTypes.h"
#include "ros2_msgsPubSubTypes.h"

namespace cairn::base {
namespace {

namespace gm = geometry_msgs::msg::dds_;
namespace nm = nav_msgs::msg::dds_;
namespace sm = sensor_msgs::msg::dds_;
namespace tm = tf2_msgs::msg::dds_;
namespace vm = visualization_msgs::msg::dds_;

// visualization_msgs/Marker's type and action constants.
constexpr std::int32_t kCube = 1, kSphere = 2, kTextViewFacing = 9;
constexpr std::int32_t kDeleteAll = 3;

constexpr const char* kMapFrame = "map";

// One of Cairn's own topics forwarded unchanged (the same CDR) under ROS 2's names, each robot's sample when
// it changed.
template <class Name>
class Forwarded {
 public:
  Forwarded(core::Participant& participant, const std::string& topic)
      : writer_(participant, topic, "ros2.reliable") {}
  // Writes `cdr` for `robot_id` unless it is what was written for that robot last. True if written.
  bool Write(const std::string& robot_id, ros2::RawCdrSample cdr) {
    if (cdr.payload.empty()) return false;
    std::vector<std::uint8_t>& last = last_[robot_id];
    if (cdr.payload == last) return false;
    last = cdr.payload;
    return writer_.Write(cdr);
  }

 private:
  core::Writer<ros2::RawCdrPubSubType<Name>> writer_;
  std::map<std::string, std::vector<std::uint8_t>> last_;  // robot -> the CDR last written
};

std_msgs::msg::dds_::Header_ Header(double wall_s, const std::string& frame) {
  std_msgs::msg::dds_::Header_ h;
  h.stamp(ros2::ToStamp(wall_s));
  h.frame_id(frame);
  return h;
}

vm::Marker_ MarkerOf(const std::string& ns, std::int32_t id, std::int32_t type, double wall_s, double x,
                     double y, double z, double yaw_rad, double sx, double sy, double sz, float r, float g,
                     float b, float a) {
  vm::Marker_ m;
  m.header(Header(wall_s, kMapFrame));
  m.ns(ns);
  m.id(id);
  m.type(type);
  m.action(0);  // ADD
  m.pose().position().x(x);
  m.pose().position().y(y);
  m.pose().position().z(z);
  m.pose().orientation().z(std::sin(yaw_rad / 2));
  m.pose().orientation().w(std::cos(yaw_rad / 2));
  m.scale().x(sx);
  m.scale().y(sy);
  m.scale().z(sz);
  m.color().r(r);
  m.color().g(g);
  m.color().b(b);
  m.color().a(a);
  return m;
}

// What identifies a global path's content: a new one is published only when it changed.
std::string PathKey(const cairn_msgs::GlobalPath& p) {
  return std::to_string(p.goal_id()) + "/" + std::to_string(p.map_version()) + "/" +
         std::to_string(p.replans()) + "/" + std::to_string(p.path_M().size());
}

}  // namespace

bool Ros2FleetOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& text) {
    *why = text;
    return false;
  };
  if (domain_id < 0 || domain_id > 232)
    return fail("--ros2-domain " + std::to_string(domain_id) + " must be in [0, 232]");
  if (!(state_rate_hz > 0 && state_rate_hz <= 50))
    return fail("ros2 state_rate_hz " + std::to_string(state_rate_hz) + " must be in (0, 50]");
  if (!(map_period_s >= 0.2 && map_period_s <= 60))
    return fail("ros2 map_period_s " + std::to_string(map_period_s) + " must be in [0.2, 60]");
  return true;
}

class Ros2FleetBridge::Impl {
 public:
  Impl(FleetClient& client, const Ros2FleetOptions& options)
      : client_(client),
        options_(options),
        participant_([&] {
          core::ParticipantOptions p;
          p.domain_id = options.domain_id;
          p.profiles_file = options.profiles_file;
          p.participant_profile = options.participant_profile;
          p.name = "cairn_base_ros2";
          return p;
        }()),
        tf_writer_(participant_, "rt/tf", "ros2.reliable"),
        map_writer_(participant_, "rt/cairn/fleet_map", "ros2.latched"),
        markers_writer_(participant_, "rt/cairn/markers", "ros2.reliable"),
        robot_state_(participant_, "rt/cairn/robot_state"),
        bt_state_(participant_, "rt/cairn/bt_state"),
        global_path_(participant_, "rt/cairn/global_path"),
        health_(participant_, "rt/cairn/health") {
    thread_ = std::thread([this] { Run(); });
  }
  ~Impl() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    thread_.join();
  }

  Ros2FleetStats Stats() const {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    return stats_;
  }

 private:
  void Run() {
    const auto period = std::chrono::duration<double>(1.0 / options_.state_rate_hz);
    auto next_map = std::chrono::steady_clock::now();
    std::unique_lock<std::mutex> lock(mutex_);
    while (!stop_) {
      lock.unlock();
      try {
        const std::vector<RobotView> robots = client_.Robots();
        PublishTransforms(robots);
        PublishPaths(robots);
        PublishCameras(robots);
        ForwardCairnTopics(robots);
        if (std::chrono::steady_clock::now() >= next_map) {
          PublishMap();
          PublishMarkers(robots);
          next_map = std::chrono::steady_clock::now() +
                     std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                         std::chrono::duration<double>(options_.map_period_s));
        }
      } catch (const std::exception& e) {
        spdlog::error("cairn_base: ROS 2 fleet publisher: {}", e.what());
      }
      lock.lock();
      wake_.wait_for(lock, period, [this] { return stop_; });
    }
  }

  void PublishTransforms(const std::vector<RobotView>& robots) {
    tm::TFMessage_ message;
    const double now_s = core::WallNowS();
    for (const RobotView& v : robots) {
      if (!v.state || v.lost) continue;
      const auto& pose = v.state->pose_MB();
      gm::TransformStamped_ t;
      t.header(Header(now_s, kMapFrame));
      t.child_frame_id(v.robot_id + "/base_link");
      t.transform().translation().x(pose.position().x_m());
      t.transform().translation().y(pose.position().y_m());
      t.transform().translation().z(pose.position().z_m());
      t.transform().rotation().x(pose.orientation().x());
      t.transform().rotation().y(pose.orientation().y());
      t.transform().rotation().z(pose.orientation().z());
      t.transform().rotation().w(pose.orientation().w());
      message.transforms().push_back(std::move(t));
    }
    if (message.transforms().empty()) return;
    tf_writer_.Write(message);
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.tf_messages;
  }

  void PublishPaths(const std::vector<RobotView>& robots) {
    for (const RobotView& v : robots) {
      if (!v.global_path) continue;
      const std::string key = PathKey(*v.global_path);
      auto sent = path_sent_.find(v.robot_id);
      if (sent != path_sent_.end() && sent->second == key) continue;
      auto& writer = path_writers_[v.robot_id];
      if (!writer) {
        writer = std::make_unique<core::Writer<nm::Path_PubSubType>>(
            participant_, "rt/" + v.robot_id + "/path", "ros2.latched");
      }
      nm::Path_ path;
      const double now_s = core::WallNowS();
      path.header(Header(now_s, kMapFrame));
      for (const auto& p : v.global_path->path_M()) {
        gm::PoseStamped_ pose;
        pose.header(Header(now_s, kMapFrame));
        pose.pose().position().x(p.x_m());
        pose.pose().position().y(p.y_m());
        pose.pose().position().z(p.z_m());
        pose.pose().orientation().w(1.0);
        path.poses().push_back(std::move(pose));
      }
      writer->Write(path);
      path_sent_[v.robot_id] = key;
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.paths;
    }
  }

  // Staircases (a block per step, a label), each robot's id and mode above it, and the frontier each
  // exploring robot drives to, as one MarkerArray (DELETEALL first: what is gone disappears).
  void PublishMarkers(const std::vector<RobotView>& robots) {
    vm::MarkerArray_ array;
    const double now_s = core::WallNowS();
    vm::Marker_ clear;
    clear.header(Header(now_s, kMapFrame));
    clear.action(kDeleteAll);
    array.markers().push_back(clear);
    for (const auto& entry : client_.perception().Staircases()) {
      const perception::Staircase& st = entry.staircase;
      const double c = std::cos(st.yaw_rad), sn = std::sin(st.yaw_rad);
      for (int k = 1; k <= st.num_steps; ++k) {
        const double along = (k - 0.5) * st.run_m, h = k * st.rise_m;
        array.markers().push_back(MarkerOf("staircases", entry.id * 1000 + k, kCube, now_s,
                                           st.p_W_first_step.x() + c * along,
                                           st.p_W_first_step.y() + sn * along, st.p_W_first_step.z() + h / 2,
                                           st.yaw_rad, st.run_m, st.width_m, h, 1.0f, 0.78f, 0.1f, 0.6f));
      }
      vm::Marker_ label = MarkerOf(
          "staircase_labels", entry.id, kTextViewFacing, now_s, st.p_W_first_step.x(), st.p_W_first_step.y(),
          st.p_W_first_step.z() + st.num_steps * st.rise_m + 0.5, 0, 0, 0, 0.4, 1.0f, 0.85f, 0.3f, 1.0f);
      label.text("staircase " + std::to_string(entry.id) + ": " + std::to_string(st.num_steps) + " steps");
      array.markers().push_back(label);
    }
    std::int32_t index = 0;
    for (const RobotView& v : robots) {
      ++index;
      if (!v.state || v.lost) continue;
      const auto& p = v.state->pose_MB().position();
      vm::Marker_ label = MarkerOf("robots", index, kTextViewFacing, now_s, p.x_m(), p.y_m(), p.z_m() + 1.0,
                                   0, 0, 0, 0.35, 1.0f, 1.0f, 1.0f, 1.0f);
      label.text(v.robot_id + " (" + v.state->mode() + ")");
      array.markers().push_back(label);
      if (v.state->explore_has_target()) {
        const auto& t = v.state->explore_target_M();
        array.markers().push_back(MarkerOf("frontier_targets", index, kSphere, now_s, t.x_m(), t.y_m(),
                                           t.z_m(), 0, 0.5, 0.5, 0.5, 0.2f, 0.9f, 0.3f, 0.9f));
      }
    }
    markers_writer_.Write(array);
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.marker_arrays;
  }

  // Cairn's robot state, behaviour-tree state, global paths and health, as they are, under ROS 2's names.
  void ForwardCairnTopics(const std::vector<RobotView>& robots) {
    std::uint64_t written = 0;
    for (const RobotView& v : robots) {
      if (v.state)
        written += robot_state_.Write(v.robot_id, ros2::ToCdr<cairn_msgs::RobotStatePubSubType>(*v.state));
      if (v.tree)
        written += bt_state_.Write(v.robot_id, ros2::ToCdr<cairn_msgs::BehaviorTreeStatePubSubType>(*v.tree));
      if (v.global_path) {
        written +=
            global_path_.Write(v.robot_id, ros2::ToCdr<cairn_msgs::GlobalPathPubSubType>(*v.global_path));
      }
      if (v.health)
        written += health_.Write(v.robot_id, ros2::ToCdr<cairn_msgs::AgentHealthPubSubType>(*v.health));
    }
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.forwarded += written;
  }

  // Each robot's newest camera frame (JPEG), once, on /ROBOT/camera/image/compressed.
  void PublishCameras(const std::vector<RobotView>& robots) {
    for (const RobotView& v : robots) {
      const std::optional<CameraView> frame = client_.perception().LatestFrame(v.robot_id);
      if (!frame) continue;
      auto& sent = camera_sent_[v.robot_id];
      if (sent == frame->frames_received) continue;
      sent = frame->frames_received;
      auto& writer = camera_writers_[v.robot_id];
      if (!writer) {
        writer = std::make_unique<core::Writer<sm::CompressedImage_PubSubType>>(
            participant_, "rt/" + v.robot_id + "/camera/image/compressed", "ros2.reliable");
      }
      sm::CompressedImage_ image;
      image.header(Header(core::WallNowS(), v.robot_id + "/camera"));
      image.format("jpeg");
      image.data(frame->frame.data());
      writer->Write(image);
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.camera_frames;
    }
  }

  void PublishMap() {
    const double res = client_.perception().MapResolution();
    if (!(res > 0)) return;
    // The merged map changes only when a robot's map message is applied: unchanged since the last cloud, it
    // is not built nor sent again (the topic is latched).
    const perception::FleetMapStats stats = client_.perception().MapStats();
    const std::array<std::uint64_t, 3> version = {stats.updates_applied, stats.voxels, stats.robots};
    if (map_version_sent_ && *map_version_sent_ == version) return;
    const std::vector<perception::CoarseVoxel> voxels = client_.perception().MapVoxels();
    std::vector<float> xyz;
    xyz.reserve(voxels.size() * 3);
    for (const perception::CoarseVoxel& v : voxels) {
      if (v.state != perception::CoarseState::kOccupied) continue;
      xyz.push_back(static_cast<float>((v.ix + 0.5) * res));
      xyz.push_back(static_cast<float>((v.iy + 0.5) * res));
      xyz.push_back(static_cast<float>((v.iz + 0.5) * res));
    }
    const std::size_t points = xyz.size() / 3;
    sm::PointCloud2_ cloud;
    cloud.header(Header(core::WallNowS(), kMapFrame));
    cloud.height(1);
    cloud.width(static_cast<std::uint32_t>(points));
    const char* names[3] = {"x", "y", "z"};
    for (std::uint32_t i = 0; i < 3; ++i) {
      sm::PointField_ f;
      f.name(names[i]);
      f.offset(4 * i);
      f.datatype(7);  // FLOAT32
      f.count(1);
      cloud.fields().push_back(f);
    }
    cloud.is_bigendian(false);  // this host's floats: x86-64 and ARM are little-endian
    cloud.point_step(12);
    cloud.row_step(12 * static_cast<std::uint32_t>(points));
    cloud.data().resize(xyz.size() * sizeof(float));
    if (!xyz.empty()) std::memcpy(cloud.data().data(), xyz.data(), cloud.data().size());
    cloud.is_dense(true);
    map_writer_.Write(cloud);
    map_version_sent_ = version;
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.map_clouds;
    stats_.map_points = points;
  }

  FleetClient& client_;
  Ros2FleetOptions options_;
  core::Participant participant_;
  core::Writer<tm::TFMessage_PubSubType> tf_writer_;
  core::Writer<sm::PointCloud2_PubSubType> map_writer_;
  core::Writer<vm::MarkerArray_PubSubType> markers_writer_;
  Forwarded<ros2::RobotStateName> robot_state_;
  Forwarded<ros2::BehaviorTreeStateName> bt_state_;
  Forwarded<ros2::GlobalPathName> global_path_;
  Forwarded<ros2::AgentHealthName> health_;
  std::map<std::string, std::unique_ptr<core::Writer<sm::CompressedImage_PubSubType>>> camera_writers_;
  std::map<std::string, std::uint64_t> camera_sent_;  // robot -> frames_received of the frame last published
  std::map<std::string, std::unique_ptr<core::Writer<nm::Path_PubSubType>>>
      path_writers_;                              // publisher thread
  std::map<std::string, std::string> path_sent_;  // robot -> PathKey of the path last published
  std::optional<std::array<std::uint64_t, 3>> map_version_sent_;  // the map's MapStats as last published
  std::mutex mutex_;                                              // guards stop_
  std::condition_variable wake_;
  bool stop_ = false;
  mutable std::mutex stats_mutex_;
  Ros2FleetStats stats_;
  std::thread thread_;
};

Ros2FleetBridge::Ros2FleetBridge(FleetClient& client, const Ros2FleetOptions& options) {
  if (std::string why; !options.IsValid(&why)) throw std::invalid_argument(why);
  impl_ = std::make_unique<Impl>(client, options);
}

Ros2FleetBridge::~Ros2FleetBridge() = default;

Ros2FleetStats Ros2FleetBridge::Stats() const { return impl_->Stats(); }

}  // namespace cairn::base
