#include "cairn/ros2/ros2_platform.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>

#include "cairn/core/config.h"
#include "cairn/core/range_check.h"
#include "cairn/core/shutdown.h"
#include "cairn/core/time.h"
#include "cairn/ros2/image.h"

namespace cairn::ros2 {
namespace {

namespace gm = geometry_msgs::msg::dds_;
namespace nm = nav_msgs::msg::dds_;
namespace sm = sensor_msgs::msg::dds_;
namespace tm = tf2_msgs::msg::dds_;

// A scan whose pose has not come this long after the scan (wall clock) is dropped, seconds.
constexpr double kScanPoseWaitS = 0.5;
// map -> odom older than this is stale (a SLAM publishes it at 1-50 Hz), seconds.
constexpr double kMapOdomTimeoutS = 2.0;

bool InRange(const char* field, double value, double low, double high, bool low_open, std::string* why) {
  const bool ok = std::isfinite(value) && (low_open ? value > low : value >= low) && value <= high;
  if (!ok)
    *why = std::string("ros2.") + field + " " + std::to_string(value) + " must be in " +
           (low_open ? "(" : "[") + std::to_string(low) + ", " + std::to_string(high) + "]";
  return ok;
}

Eigen::Isometry3d FromTransform(const gm::Transform_& t) {
  return ToIsometry({t.translation().x(), t.translation().y(), t.translation().z()}, t.rotation().x(),
                    t.rotation().y(), t.rotation().z(), t.rotation().w());
}

}  // namespace

bool Ros2PlatformOptions::IsValid(std::string* why) const {
  if (domain_id < 0 || domain_id > 232) {
    *why = "ros2 domain id " + std::to_string(domain_id) + " must be in [0, 232]";
    return false;
  }
  for (const auto& [field, topic] :
       {std::pair<const char*, const std::string*>{"points_topic", &points_topic},
        {"odom_topic", &odom_topic},
        {"cmd_vel_topic", &cmd_vel_topic},
        {"camera_topic", &camera_topic}}) {
    if (!topic->empty() && (*topic)[0] != '/') {
      *why = std::string("ros2.") + field + " '" + *topic + "' must start with '/' (a ROS 2 topic name)";
      return false;
    }
  }
  if (interface_name.size() > 15 || interface_name.find_first_of("/ \t") != std::string::npos) {
    *why = "ros2.interface '" + interface_name +
           "' is not a network interface name (1-15 characters, no '/' or spaces; \"\" = loopback)";
    return false;
  }
  if (odom_topic.empty() || cmd_vel_topic.empty()) {
    *why = "ros2.odom_topic and ros2.cmd_vel_topic must name topics (the pose and the base's commands)";
    return false;
  }
  if (odom_frame.empty() || base_frame.empty() || FrameId(map_frame) == FrameId(odom_frame)) {
    *why = "ros2.odom_frame and ros2.base_frame must be set, and ros2.map_frame ('" + map_frame +
           "') differ from the odometry frame";
    return false;
  }
  return InRange("pose_timeout_s", pose_timeout_s, 0, 10, true, why) &&
         InRange("tf_history_s", tf_history_s, 1, 60, false, why) &&
         InRange("start_wait_s", start_wait_s, 0, 120, false, why) &&
         InRange("lidar_rate_hz", lidar_rate_hz, 0, 100, true, why) &&
         InRange("lidar_min_range_m", lidar_min_range_m, 0, 1000, false, why) &&
         InRange("lidar_max_range_m", lidar_max_range_m, lidar_min_range_m, 1000, true, why) &&
         InRange("footprint_radius_m", footprint_radius_m, 0, 5, true, why);
}

void Ros2PlatformOptions::LoadConfigFile(const std::string& path) {
  try {
    const auto config = core::ConfigSection::LoadFile(path);
    const auto s = config.Section("ros2");
    std::string cmd_type = cmd_vel_stamped ? "twist_stamped" : "twist";
    std::string camera_type = camera_compressed ? "compressed" : "raw";
    double min_elevation_deg = lidar_min_elevation_rad * 180.0 / M_PI;
    s.ReadFields({{"interface", &interface_name},
                  {"points_topic", &points_topic},
                  {"odom_topic", &odom_topic},
                  {"cmd_vel_topic", &cmd_vel_topic},
                  {"cmd_vel_type", &cmd_type},
                  {"camera_topic", &camera_topic},
                  {"camera_type", &camera_type},
                  {"camera_optical_frame", &camera_optical_frame},
                  {"map_frame", &map_frame},
                  {"odom_frame", &odom_frame},
                  {"base_frame", &base_frame},
                  {"pose_timeout_s", &pose_timeout_s},
                  {"tf_history_s", &tf_history_s},
                  {"start_wait_s", &start_wait_s},
                  {"lidar_rate_hz", &lidar_rate_hz},
                  {"lidar_min_range_m", &lidar_min_range_m},
                  {"lidar_max_range_m", &lidar_max_range_m},
                  {"lidar_min_elevation_deg", &min_elevation_deg}});
    if (cmd_type != "twist" && cmd_type != "twist_stamped")
      throw core::ConfigError(s.Where("cmd_vel_type") + " '" + cmd_type +
                              "' is neither twist nor twist_stamped");
    cmd_vel_stamped = cmd_type == "twist_stamped";
    if (camera_type != "compressed" && camera_type != "raw")
      throw core::ConfigError(s.Where("camera_type") + " '" + camera_type +
                              "' is neither compressed nor raw");
    camera_compressed = camera_type == "compressed";
    lidar_min_elevation_rad = min_elevation_deg * M_PI / 180.0;
  } catch (const core::ConfigError& e) {
    throw std::invalid_argument(e.what());
  }
  std::string why;
  if (!IsValid(&why)) throw std::invalid_argument(path + ": " + why);
}

struct Ros2Platform::Impl {
  explicit Impl(const Ros2PlatformOptions& o)
      : options(o),
        participant([&] {
          core::ParticipantOptions p;
          p.domain_id = o.domain_id;
          p.profiles_file = o.profiles_file;
          p.participant_profile = o.participant_profile;
          p.name = "cairn_ros2_driver";
          if (!o.interface_name.empty()) {
            p.link.link = "lan";
            p.link.interface_name = o.interface_name;
          }
          return p;
        }()),
        tf(TfBufferOptions{o.tf_history_s, 0.05}),
        map_frame(FrameId(o.map_frame.empty() ? o.odom_frame : o.map_frame)) {}

  // What the odometry says; called on a Fast DDS thread.
  void OnOdometry(const nm::Odometry_& m) {
    const double received = core::WallNowS();
    const gm::Pose_& p = m.pose().pose();
    const Eigen::Isometry3d T_odom_base =
        ToIsometry({p.position().x(), p.position().y(), p.position().z()}, p.orientation().x(),
                   p.orientation().y(), p.orientation().z(), p.orientation().w());
    std::lock_guard<std::mutex> lock(mutex);
    const std::string parent = FrameId(m.header().frame_id()), child = FrameId(m.child_frame_id());
    if (parent != FrameId(options.odom_frame) || child != FrameId(options.base_frame)) {
      odom_problem = "odometry on " + options.odom_topic + " is from '" + parent + "' to '" + child +
                     "', not ros2.odom_frame '" + options.odom_frame + "' to ros2.base_frame '" +
                     options.base_frame + "'";
      return;
    }
    if (std::string why = tf.Set(parent, child, T_odom_base, StampS(m.header().stamp()), false);
        !why.empty()) {
      odom_problem = "odometry on " + options.odom_topic + " refused: " + why;
      ++counts.bad_transforms;
      return;
    }
    odom_problem.clear();
    odom_received_s = received;
    odom_stamp_s = StampS(m.header().stamp());
    T_odom_base_latest = T_odom_base;
    v_mps = m.twist().twist().linear().x();
    w_radps = m.twist().twist().angular().z();
    if (!std::isfinite(v_mps) || !std::isfinite(w_radps)) v_mps = w_radps = 0.0;
  }

  void OnTransforms(const tm::TFMessage_& m, bool is_static) {
    const double received = core::WallNowS();
    std::lock_guard<std::mutex> lock(mutex);
    for (const gm::TransformStamped_& t : m.transforms()) {
      const std::string parent = FrameId(t.header().frame_id()), child = FrameId(t.child_frame_id());
      const Eigen::Isometry3d T = FromTransform(t.transform());
      if (std::string why = tf.Set(parent, child, T, StampS(t.header().stamp()), is_static); !why.empty()) {
        ++counts.bad_transforms;
        if (why != last_tf_problem)
          spdlog::warn("ros2 driver: {} {}", is_static ? "/tf_static:" : "/tf:", why);
        last_tf_problem = why;
        continue;
      }
      if (!options.map_frame.empty() && parent == map_frame && child == FrameId(options.odom_frame)) {
        map_odom_received_s = received;
        T_map_odom_latest = T;
      }
    }
  }

  void OnImage(std::optional<sm::Image_> raw, std::optional<sm::CompressedImage_> compressed) {
    std::lock_guard<std::mutex> lock(mutex);
    image = std::move(raw);
    compressed_image = std::move(compressed);
  }

  void OnCloud(const sm::PointCloud2_& m) {
    std::lock_guard<std::mutex> lock(mutex);
    ++counts.clouds;
    cloud = m;  // the newest replaces one not read yet: the autonomy wants the latest scan
    cloud_received_s = core::WallNowS();
    MeasureLidarRate(StampS(m.header().stamp()));
  }

  // With mutex held: the lidar's rate as the stream shows it (by the clouds' stamps, every kRateWindow
  // clouds), told once, and again whenever it strays over 20 % from what the autonomy was told
  // (ros2.lidar_rate_hz).
  void MeasureLidarRate(double stamp_s) {
    constexpr int kRateWindow = 50;
    if (rate_clouds == 0) rate_window_start_s = stamp_s;
    if (++rate_clouds < kRateWindow) return;
    const double span_s = stamp_s - rate_window_start_s;
    rate_clouds = 0;
    if (!(span_s > 0)) return;
    measured_lidar_rate_hz = (kRateWindow - 1) / span_s;
    const bool off = std::abs(measured_lidar_rate_hz - options.lidar_rate_hz) > 0.2 * options.lidar_rate_hz;
    if (!rate_told || off != rate_off) {
      if (off) {
        spdlog::warn(
            "ros2 driver: lidar on {} at {:.1f} Hz (by its stamps), not ros2.lidar_rate_hz {:.1f}: set it "
            "to the lidar's rate",
            options.points_topic, measured_lidar_rate_hz, options.lidar_rate_hz);
      } else {
        spdlog::info("ros2 driver: lidar on {} at {:.1f} Hz (by its stamps; ros2.lidar_rate_hz {:.1f})",
                     options.points_topic, measured_lidar_rate_hz, options.lidar_rate_hz);
      }
    }
    rate_told = true;
    rate_off = off;
  }

  // With mutex held: the pose estimate as of wall time `wall_s`.
  core::PoseEstimate PoseAt(double wall_s) const {
    core::PoseEstimate pose;
    const std::string hint =
        " (ROS 2 domain " + std::to_string(options.domain_id) + "; is the driver running?)";
    if (!odom_problem.empty()) {
      pose.healthy = false;
      pose.problem = odom_problem;
    } else if (odom_received_s < 0) {
      pose.healthy = false;
      pose.problem = "no odometry on " + options.odom_topic + " yet" + hint;
    } else if (wall_s - odom_received_s > options.pose_timeout_s) {
      pose.healthy = false;
      pose.problem = "no odometry on " + options.odom_topic + " for " +
                     core::Fixed(wall_s - odom_received_s, 1) + " s" + hint;
    }
    pose.T_MB = T_odom_base_latest;
    pose.stamp_s = odom_stamp_s + wall_to_agent_s;
    pose.v_mps = v_mps;
    pose.w_radps = w_radps;
    if (!options.map_frame.empty()) {
      if (map_odom_received_s < 0 || wall_s - map_odom_received_s > kMapOdomTimeoutS) {
        if (pose.healthy) {
          pose.healthy = false;
          pose.problem = map_odom_received_s < 0
                             ? "no transform " + map_frame + " -> " + options.odom_frame +
                                   " on /tf yet (ROS 2 domain " + std::to_string(options.domain_id) +
                                   "; is the SLAM running?)"
                             : "no transform " + map_frame + " -> " + options.odom_frame + " on /tf for " +
                                   core::Fixed(wall_s - map_odom_received_s, 1) + " s (is the SLAM running?)";
        }
      }
      pose.T_MB = T_map_odom_latest * T_odom_base_latest;
    }
    return pose;
  }

  Ros2PlatformOptions options;
  core::Participant participant;
  mutable std::mutex mutex;  // guards everything below
  TfBuffer tf;
  const std::string map_frame;  // frame M: ros2.map_frame, or the odometry frame
  double odom_received_s = -1.0, odom_stamp_s = 0.0, map_odom_received_s = -1.0;  // wall clock
  Eigen::Isometry3d T_odom_base_latest = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_map_odom_latest = Eigen::Isometry3d::Identity();
  double v_mps = 0.0, w_radps = 0.0;
  std::string odom_problem, last_tf_problem, last_cloud_problem;
  std::optional<sm::PointCloud2_> cloud;
  std::optional<sm::Image_> image;  // the newest camera frame not read yet (one of the two)
  std::optional<sm::CompressedImage_> compressed_image;
  std::uint32_t image_seq = 0;
  int rate_clouds = 0;  // MeasureLidarRate's window
  double rate_window_start_s = 0.0, measured_lidar_rate_hz = 0.0;
  bool rate_told = false, rate_off = false;
  std::string last_image_problem;
  double cloud_received_s = 0.0;
  std::uint64_t scan_seq = 0;
  Counts counts;
  core::PoseEstimate pose;       // as of the last Update()
  double wall_to_agent_s = 0.0;  // agent clock = wall clock + this (read in each Update())

  std::unique_ptr<core::Reader<nm::Odometry_PubSubType>> odom_reader;
  std::unique_ptr<core::Reader<tm::TFMessage_PubSubType>> tf_reader, tf_static_reader;
  std::unique_ptr<core::Reader<sm::PointCloud2_PubSubType>> points_reader;
  std::unique_ptr<core::Reader<sm::Image_PubSubType>> image_reader;
  std::unique_ptr<core::Reader<sm::CompressedImage_PubSubType>> compressed_image_reader;
  std::unique_ptr<core::Writer<gm::Twist_PubSubType>> twist_writer;
  std::unique_ptr<core::Writer<gm::TwistStamped_PubSubType>> twist_stamped_writer;
};

Ros2Platform::Ros2Platform(const Ros2PlatformOptions& options) {
  if (std::string why; !options.IsValid(&why)) throw std::invalid_argument(why);
  impl_ = std::make_unique<Impl>(options);
  Impl* impl = impl_.get();
  impl->odom_reader = std::make_unique<core::Reader<nm::Odometry_PubSubType>>(
      impl->participant, DdsTopicName(options.odom_topic), "ros2.reliable",
      [impl](const nm::Odometry_& m, const eprosima::fastdds::dds::SampleInfo&) { impl->OnOdometry(m); });
  impl->tf_reader = std::make_unique<core::Reader<tm::TFMessage_PubSubType>>(
      impl->participant, "rt/tf", "ros2.tf",
      [impl](const tm::TFMessage_& m, const eprosima::fastdds::dds::SampleInfo&) {
        impl->OnTransforms(m, false);
      });
  impl->tf_static_reader = std::make_unique<core::Reader<tm::TFMessage_PubSubType>>(
      impl->participant, "rt/tf_static", "ros2.tf_static",
      [impl](const tm::TFMessage_& m, const eprosima::fastdds::dds::SampleInfo&) {
        impl->OnTransforms(m, true);
      });
  if (!options.points_topic.empty()) {
    impl->points_reader = std::make_unique<core::Reader<sm::PointCloud2_PubSubType>>(
        impl->participant, DdsTopicName(options.points_topic), "ros2.sensor_data",
        [impl](const sm::PointCloud2_& m, const eprosima::fastdds::dds::SampleInfo&) { impl->OnCloud(m); });
  }
  if (!options.camera_topic.empty() && options.camera_compressed) {
    impl->compressed_image_reader = std::make_unique<core::Reader<sm::CompressedImage_PubSubType>>(
        impl->participant, DdsTopicName(options.camera_topic), "ros2.sensor_data",
        [impl](const sm::CompressedImage_& m, const eprosima::fastdds::dds::SampleInfo&) {
          impl->OnImage(std::nullopt, m);
        });
  } else if (!options.camera_topic.empty()) {
    impl->image_reader = std::make_unique<core::Reader<sm::Image_PubSubType>>(
        impl->participant, DdsTopicName(options.camera_topic), "ros2.sensor_data",
        [impl](const sm::Image_& m, const eprosima::fastdds::dds::SampleInfo&) {
          impl->OnImage(m, std::nullopt);
        });
  }
  if (options.cmd_vel_stamped) {
    impl->twist_stamped_writer = std::make_unique<core::Writer<gm::TwistStamped_PubSubType>>(
        impl->participant, DdsTopicName(options.cmd_vel_topic), "ros2.reliable");
  } else {
    impl->twist_writer = std::make_unique<core::Writer<gm::Twist_PubSubType>>(
        impl->participant, DdsTopicName(options.cmd_vel_topic), "ros2.reliable");
  }
  // The robot's pose first: the autonomy starts from it.
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(options.start_wait_s);
  while (std::chrono::steady_clock::now() < deadline && !core::ShutdownRequested()) {
    {
      std::lock_guard<std::mutex> lock(impl->mutex);
      if (impl->odom_received_s >= 0 && (options.map_frame.empty() || impl->map_odom_received_s >= 0)) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::lock_guard<std::mutex> lock(impl->mutex);
  const core::PoseEstimate pose = impl->PoseAt(core::WallNowS());
  if (pose.healthy) {
    spdlog::info("ros2 driver: ROS 2 domain {}: odometry on {} ({} -> {}){}", options.domain_id,
                 options.odom_topic, options.odom_frame, options.base_frame,
                 options.map_frame.empty() ? "" : ", map -> odom on /tf");
  } else {
    spdlog::warn("ros2 driver: starting not localized: {}", pose.problem);
  }
}

Ros2Platform::~Ros2Platform() {
  // The base stops with the driver (its own watchdog would too, later).
  try {
    CommandTwist(0.0, 0.0, 0.0);
  } catch (const std::exception&) {
  }
}

core::PlatformCapabilities Ros2Platform::Capabilities() const {
  const Ros2PlatformOptions& o = impl_->options;
  core::PlatformCapabilities c;
  c.driver = "ros2";
  c.description = "ROS 2 domain " + std::to_string(o.domain_id) + " (" +
                  (o.points_topic.empty() ? std::string() : o.points_topic + ", ") + o.odom_topic + " -> " +
                  o.cmd_vel_topic + ")";
  c.limits = o.limits;
  c.footprint_radius_m = o.footprint_radius_m;
  c.has_lidar = !o.points_topic.empty();
  c.lidar_rate_hz = c.has_lidar ? o.lidar_rate_hz : 0.0;
  c.lidar_min_elevation_rad = o.lidar_min_elevation_rad;
  c.has_camera = !o.camera_topic.empty();
  return c;
}

void Ros2Platform::Update(double now_s) {
  const double wall_s = core::WallNowS();
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->wall_to_agent_s = now_s - wall_s;
  impl_->pose = impl_->PoseAt(wall_s);
}

core::PoseEstimate Ros2Platform::ReadPose() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->pose;
}

core::PlatformStatus Ros2Platform::ReadStatus() const { return core::PlatformStatus{}; }

bool Ros2Platform::ReadLidarScan(double /*now_s*/, core::LidarScan* scan) {
  Impl& impl = *impl_;
  std::optional<sensor_msgs::msg::dds_::PointCloud2_> cloud;
  double received_s = 0.0;
  {
    std::lock_guard<std::mutex> lock(impl.mutex);
    if (!impl.cloud) return false;
    cloud = std::move(impl.cloud);
    impl.cloud.reset();
    received_s = impl.cloud_received_s;
  }
  // The cloud is parsed without the lock (the readers' callbacks keep storing); everything after it under
  // one.
  CloudReadCounts read;
  const std::string why_unreadable = ReadPointCloud2(
      *cloud, CloudRangeFilter{impl.options.lidar_min_range_m, impl.options.lidar_max_range_m},
      &scan->points_S, &read);
  const std::string frame = FrameId(cloud->header().frame_id());
  const double stamp_wall_s = StampS(cloud->header().stamp());
  std::lock_guard<std::mutex> lock(impl.mutex);
  // With the lock held: logs a new problem once, keeps it for "used again".
  const auto drop = [&](const std::string& why) {
    if (why != impl.last_cloud_problem)
      spdlog::warn("ros2 driver: cloud on {} not used: {}", impl.options.points_topic, why);
    impl.last_cloud_problem = why;
    return false;
  };
  if (!why_unreadable.empty()) {
    ++impl.counts.bad_clouds;
    return drop("PointCloud2 on " + impl.options.points_topic + " " + why_unreadable);
  }
  std::string why_T_BS, why_T_MS;
  const std::optional<Eigen::Isometry3d> T_BS =
      impl.tf.Lookup(impl.options.base_frame, frame, stamp_wall_s, &why_T_BS);
  const std::optional<Eigen::Isometry3d> T_MS =
      impl.tf.Lookup(impl.map_frame, frame, stamp_wall_s, &why_T_MS);
  if (!T_BS || !T_MS) {
    // The pose of its time may still be on its way: kept for the next call (unless a newer scan came).
    const std::optional<double> newest =
        impl.tf.NewestStamp(impl.options.odom_frame, impl.options.base_frame);
    const bool pose_not_yet =
        newest && stamp_wall_s > *newest && core::WallNowS() - received_s < kScanPoseWaitS;
    if (pose_not_yet && !impl.cloud) {
      impl.cloud = std::move(cloud);
      impl.cloud_received_s = received_s;
      return false;
    }
    ++impl.counts.unregistered;
  }
  if (!T_BS) {
    return drop("cloud frame '" + frame + "' has no transform to " + impl.options.base_frame +
                " in /tf_static or /tf: " + why_T_BS);
  }
  if (!T_MS) return drop("no pose at the cloud's stamp: " + why_T_MS);
  scan->stamp_s = stamp_wall_s + impl.wall_to_agent_s;
  scan->T_BS = *T_BS;
  scan->T_MS = *T_MS;
  scan->seq = ++impl.scan_seq;
  ++impl.counts.scans;
  if (!impl.last_cloud_problem.empty())
    spdlog::info("ros2 driver: clouds on {} used again", impl.options.points_topic);
  impl.last_cloud_problem.clear();
  return true;
}

bool Ros2Platform::ReadCameraImage(double /*now_s*/, core::CameraImage* out) {
  Impl& impl = *impl_;
  std::optional<sm::Image_> raw;
  std::optional<sm::CompressedImage_> compressed;
  {
    std::lock_guard<std::mutex> lock(impl.mutex);
    raw = std::move(impl.image);
    compressed = std::move(impl.compressed_image);
    impl.image.reset();
    impl.compressed_image.reset();
  }
  if (!raw && !compressed) return false;
  const std_msgs::msg::dds_::Header_& header = raw ? raw->header() : compressed->header();
  GrayImage gray;
  std::string why = raw ? ImageToGray(*raw, &gray) : CompressedImageToGray(*compressed, &gray);
  std::optional<Eigen::Isometry3d> T_M_frame;
  std::lock_guard<std::mutex> lock(impl.mutex);
  if (why.empty()) {
    T_M_frame = impl.tf.Lookup(impl.map_frame, header.frame_id(), StampS(header.stamp()), &why);
    if (!T_M_frame) why = "no pose of camera frame '" + FrameId(header.frame_id()) + "': " + why;
  }
  if (!why.empty()) {
    ++impl.counts.bad_images;
    if (why != impl.last_image_problem)
      spdlog::warn("ros2 driver: image on {} not used: {}", impl.options.camera_topic, why);
    impl.last_image_problem = why;
    return false;
  }
  impl.last_image_problem.clear();
  ++impl.counts.images;
  out->stamp_s = StampS(header.stamp()) + impl.wall_to_agent_s;
  out->seq = ++impl.image_seq;
  out->width_px = gray.width_px;
  out->height_px = gray.height_px;
  out->pixels = std::move(gray.pixels);
  out->T_MC = impl.options.camera_optical_frame ? *T_M_frame * OpticalFromCameraC() : *T_M_frame;
  return true;
}

void Ros2Platform::CommandTwist(double linear_x_mps, double angular_z_radps, double /*now_s*/) {
  gm::Twist_ twist;
  twist.linear().x(std::isfinite(linear_x_mps) ? linear_x_mps : 0.0);
  twist.angular().z(std::isfinite(angular_z_radps) ? angular_z_radps : 0.0);
  if (impl_->twist_writer) {
    impl_->twist_writer->Write(twist);
    return;
  }
  gm::TwistStamped_ stamped;
  stamped.header().stamp(ToStamp(core::WallNowS()));
  stamped.header().frame_id(impl_->options.base_frame);
  stamped.twist(twist);
  impl_->twist_stamped_writer->Write(stamped);
}

Ros2Platform::Counts Ros2Platform::counts() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->counts;
}

std::string Ros2Platform::last_cloud_problem() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->last_cloud_problem;
}

}  // namespace cairn::ros2
