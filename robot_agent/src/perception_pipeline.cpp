#include "cairn/agent/perception_pipeline.h"

#include <chrono>
#include <cmath>
#include <stdexcept>

#include "cairn/perception/jpeg.h"
#include "range_check.h"

namespace cairn::agent {

namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace

bool PerceptionOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why != nullptr) *why = "perception." + message;
    return false;
  };
  std::string inner;
  if (!lidar.IsValid(&inner)) return fail("lidar: " + inner);
  if (!slam.IsValid(&inner)) return fail("slam: " + inner);
  if (!map.IsValid(&inner)) return fail("map: " + inner);
  if (!staircase.IsValid(&inner)) return fail("staircase: " + inner);
  if (!telemetry.IsValid(&inner)) return fail("telemetry: " + inner);
  if (!camera.IsValid(&inner)) return fail("camera: " + inner);
  using internal::InRange;
  if (!InRange("lidar_height_m", lidar_height_m, 0.0, 3.0, false, &inner) ||
      !InRange("map_insert_period_s", map_insert_period_s, 0.05, 10.0, false, &inner) ||
      !InRange("staircase_period_s", staircase_period_s, 0.1, 60.0, false, &inner) ||
      !InRange("map_keyframe_distance_m", map_keyframe_distance_m, 0.0, 10.0, false, &inner) ||
      !InRange("map_keyframe_angle_rad", map_keyframe_angle_rad, 0.0, M_PI, false, &inner) ||
      !InRange("camera_rate_hz", camera_rate_hz, 0.0, 30.0, false, &inner) ||
      !InRange("camera_budget_bits_per_s", camera_budget_bits_per_s, 1000.0, 1e9, false, &inner)) {
    return fail(inner);
  }
  if (map_coarse_levels < 0 || map_coarse_levels > 6) {
    return fail("map_coarse_levels = " + std::to_string(map_coarse_levels) + " must be in [0, 6]");
  }
  if (jpeg_quality < 1 || jpeg_quality > 100) {
    return fail("jpeg_quality = " + std::to_string(jpeg_quality) + " must be in [1, 100]");
  }
  return true;
}

namespace {

const PerceptionOptions& Checked(const PerceptionOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  return options;
}

}  // namespace

PerceptionPipeline::PerceptionPipeline(const PerceptionOptions& options, std::shared_ptr<const sim::World> world,
                                       const std::string& robot_id, std::uint32_t seed)
    : options_(Checked(options)),
      world_(std::move(world)),
      lidar_(options.lidar, seed),
      slam_(options.slam, seed + 1),
      map_(std::make_shared<perception::OccupancyMap>(options.map)),
      detector_(options.staircase),
      sender_(robot_id, options.coarse_resolution_m(), options.telemetry) {}

Eigen::Isometry3d PerceptionPipeline::SensorPose(const Eigen::Isometry3d& T_W_B) const {
  Eigen::Isometry3d T_B_S = Eigen::Isometry3d::Identity();
  T_B_S.translation().z() = options_.lidar_height_m;
  return T_W_B * T_B_S;
}

void PerceptionPipeline::RequestMapSnapshot() { sender_.RequestSnapshot(); }

std::vector<perception::MapUpdate> PerceptionPipeline::FlushMapTelemetry(double now_s) {
  const auto start = Clock::now();
  sender_.AddChanges(map_->TakeCoarseChanges(options_.map_coarse_levels));
  std::vector<perception::MapUpdate> updates = sender_.Poll(now_s);
  stats_.telemetry_ms_total += MsSince(start);
  return updates;
}

PerceptionOutput PerceptionPipeline::Tick(double now_s, const Eigen::Isometry3d& T_W_B_true) {
  PerceptionOutput out;
  if (!options_.enabled) return out;
  T_W_B_estimate_ = slam_.Update(T_W_B_true);
  stats_.distance_m = slam_.distance_travelled_m();
  stats_.slam_error_m = (T_W_B_estimate_.translation() - T_W_B_true.translation()).norm();

  const double scan_period_s = 1.0 / options_.lidar.rate_hz;
  if (now_s >= next_scan_s_) {
    next_scan_s_ = std::max(next_scan_s_ + scan_period_s, now_s);  // no catch-up after a late tick
    auto start = Clock::now();
    lidar_.Scan(*world_, SensorPose(T_W_B_true), &scan_);  // the world is sensed from where the robot is
    stats_.lidar_ms_total += MsSince(start);
    ++stats_.scans;
    const Eigen::Isometry3d T_W_S_estimate = SensorPose(T_W_B_estimate_);  // ...and registered where SLAM says
    start = Clock::now();
    local_cloud_.AddScan(scan_.points_S, T_W_S_estimate, now_s);
    stats_.local_cloud_ms_total += MsSince(start);
    const bool keyframe =
        !T_W_S_last_keyframe_ ||
        (T_W_S_estimate.translation() - T_W_S_last_keyframe_->translation()).norm() >=
            options_.map_keyframe_distance_m ||
        Eigen::AngleAxisd(T_W_S_last_keyframe_->linear().transpose() * T_W_S_estimate.linear()).angle() >=
            options_.map_keyframe_angle_rad;
    if (now_s >= next_insert_s_ && keyframe) {
      next_insert_s_ = std::max(next_insert_s_ + options_.map_insert_period_s, now_s);
      T_W_S_last_keyframe_ = T_W_S_estimate;
      start = Clock::now();
      const perception::InsertStats inserted = map_->InsertScan(scan_.points_S, T_W_S_estimate);
      stats_.map_ms_total += MsSince(start);
      stats_.points_dropped_non_finite += inserted.dropped_non_finite;
      ++stats_.scans_inserted;
    }
  }

  if (now_s >= next_staircase_s_) {
    next_staircase_s_ = std::max(next_staircase_s_ + options_.staircase_period_s, now_s);
    const auto start = Clock::now();
    const std::vector<perception::Staircase> found =
        detector_.Detect(local_cloud_.Points(), T_W_B_estimate_.translation());
    for (const perception::Staircase& staircase : found) {
      const auto merged = registry_.Add(staircase, "scan");
      if (!merged.is_new && !merged.changed) continue;
      for (const auto& entry : registry_.Entries()) {
        if (entry.id == merged.id) out.staircases.push_back(entry);
      }
    }
    stats_.staircase_ms_total += MsSince(start);
    ++stats_.staircase_runs;
  }

  if (now_s >= next_telemetry_s_) {
    next_telemetry_s_ = std::max(next_telemetry_s_ + options_.telemetry.period_s, now_s);
    out.map_messages = FlushMapTelemetry(now_s);
  }

  if (options_.camera_rate_hz > 0 && now_s >= next_camera_s_) {
    next_camera_s_ = std::max(next_camera_s_ + 1.0 / options_.camera_rate_hz, now_s);
    const auto start = Clock::now();
    sim::GrayImage image;
    const Eigen::Isometry3d T_W_C_true = SensorPose(T_W_B_true);
    sim::RenderShadedDepth(*world_, T_W_C_true, options_.camera, &image);
    CameraFrame frame;
    frame.seq = ++camera_seq_;
    frame.width_px = image.width_px;
    frame.height_px = image.height_px;
    frame.T_W_C = SensorPose(T_W_B_estimate_);
    frame.jpeg = perception::EncodeGrayJpeg(
        perception::GrayFrame{image.width_px, image.height_px, std::move(image.pixels)}, options_.jpeg_quality);
    out.camera = std::move(frame);
    stats_.camera_ms_total += MsSince(start);
    ++stats_.camera_frames;
  }
  return out;
}

}  // namespace cairn::agent
