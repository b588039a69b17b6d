#include "cairn/perception/perception_pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "cairn/core/range_check.h"
#include "cairn/perception/jpeg.h"

namespace cairn::perception {

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
  if (!map.IsValid(&inner)) return fail("map: " + inner);
  if (!staircase.IsValid(&inner)) return fail("staircase: " + inner);
  if (!telemetry.IsValid(&inner)) return fail("telemetry: " + inner);
  using core::InRange;
  if (!InRange("map_insert_period_s", map_insert_period_s, 0.05, 10.0, false, &inner) ||
      !InRange("staircase_period_s", staircase_period_s, 0.1, 60.0, false, &inner) ||
      !InRange("map_keyframe_distance_m", map_keyframe_distance_m, 0.0, 10.0, false, &inner) ||
      !InRange("map_keyframe_angle_rad", map_keyframe_angle_rad, 0.0, M_PI, false, &inner) ||
      !InRange("map_keyframe_max_interval_s", map_keyframe_max_interval_s, 0.05, 600.0, false, &inner) ||
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

PerceptionPipeline::PerceptionPipeline(const PerceptionOptions& options, const std::string& robot_id)
    : options_(Checked(options)),
      map_(std::make_shared<OccupancyMap>(options.map)),
      detector_(options.staircase),
      sender_(robot_id, options.coarse_resolution_m(), options.telemetry) {}

bool PerceptionPipeline::CameraDue(double now_s) const {
  return options_.enabled && options_.camera_rate_hz > 0 && now_s >= schedule_.next_camera_s;
}

std::vector<Staircase> PerceptionPipeline::Staircases() const {
  std::lock_guard<std::mutex> guard(staircases_mutex_);
  return staircases_;
}

std::vector<Eigen::Vector2i> PerceptionPipeline::TakeChangedTiles() {
  std::set<std::pair<int, int>> tiles;
  {
    std::lock_guard<std::mutex> guard(changed_.mutex);
    tiles.swap(changed_.tiles);
  }
  std::vector<Eigen::Vector2i> out;
  out.reserve(tiles.size());
  for (const auto& [x, y] : tiles) out.emplace_back(x, y);
  return out;
}

void PerceptionPipeline::LoadMap(const std::string& path) {
  OccupancyMap loaded = OccupancyMap::LoadBt(path, options_.map);
  if (std::abs(loaded.resolution_m() - options_.map.resolution_m) > 1e-9) {
    throw std::invalid_argument("map file '" + path + "' has resolution " +
                                std::to_string(loaded.resolution_m()) +
                                " m, not the robot's perception.map.resolution_m " +
                                std::to_string(options_.map.resolution_m) + " m");
  }
  map_ = std::make_shared<OccupancyMap>(std::move(loaded));
  CollectChanges();  // LoadBt marked all of it changed: the navigation map and map telemetry take it all
}

void PerceptionPipeline::RequestMapSnapshot() { sender_.RequestSnapshot(); }

void PerceptionPipeline::SetLinkShare(double share) {
  sender_.SetRateShare(share);  // checks the range
  link_share_ = share;
}

void PerceptionPipeline::CollectChanges() {
  std::vector<CoarseVoxel> changes = map_->TakeCoarseChanges(options_.map_coarse_levels);
  if (changes.empty()) return;
  // Coarse voxel (ix, iy, iz) covers [i * edge, (i + 1) * edge) per axis (coarse_voxel.h); a tile is 10 x 10
  // coarse columns.
  auto tile_of = [](std::int32_t i) { return static_cast<int>(i >= 0 ? i / 10 : -((-i + 9) / 10)); };
  {
    std::lock_guard<std::mutex> guard(changed_.mutex);
    for (const CoarseVoxel& v : changes) changed_.tiles.emplace(tile_of(v.ix), tile_of(v.iy));
  }
  if (options_.enabled) sender_.AddChanges(changes);
}

std::vector<MapUpdate> PerceptionPipeline::FlushMapTelemetry(double now_s) {
  const auto start = Clock::now();
  CollectChanges();
  std::vector<MapUpdate> updates = sender_.Poll(now_s);
  stats_.telemetry_ms_total += MsSince(start);
  return updates;
}

PerceptionOutput PerceptionPipeline::Tick(double now_s, const core::LidarScan* scan,
                                          const core::CameraImage* image) {
  PerceptionOutput out;
  // The map is built even when perception's outputs are off: navigation plans on it.
  if (scan != nullptr) MapScan(now_s, *scan);
  if (!options_.enabled) return out;
  if (now_s >= schedule_.next_staircase_s && now_s < schedule_.staircase_after_s) {
    ++stats_.staircase_runs_deferred;
    schedule_.next_staircase_s = schedule_.staircase_after_s;
  }
  if (now_s >= schedule_.next_staircase_s) DetectStaircases(now_s, &out);
  if (now_s >= schedule_.next_telemetry_s) {
    schedule_.next_telemetry_s = std::max(schedule_.next_telemetry_s + options_.telemetry.period_s, now_s);
    out.map_messages = FlushMapTelemetry(now_s);
  }
  if (image != nullptr && CameraDue(now_s)) EncodeCameraFrame(now_s, *image, &out);
  return out;
}

void PerceptionPipeline::MapScan(double now_s, const core::LidarScan& scan) {
  ++stats_.scans;
  const Eigen::Isometry3d& T_W_S_estimate = scan.T_MS;  // registered where SLAM says the sensor was
  T_W_B_estimate_ = scan.T_MS * scan.T_BS.inverse();
  auto start = Clock::now();
  local_cloud_.AddScan(scan.points_S, T_W_S_estimate, now_s);
  stats_.local_cloud_ms_total += MsSince(start);
  if (progress_) progress_();
  const bool keyframe =
      !last_keyframe_.T_W_S ||
      (T_W_S_estimate.translation() - last_keyframe_.T_W_S->translation()).norm() >=
          options_.map_keyframe_distance_m ||
      Eigen::AngleAxisd(last_keyframe_.T_W_S->linear().transpose() * T_W_S_estimate.linear()).angle() >=
          options_.map_keyframe_angle_rad ||
      (refresh_at_rest_ && now_s - last_keyframe_.stamp_s >= options_.map_keyframe_max_interval_s);
  const bool insert_due = now_s >= schedule_.next_insert_s && keyframe;
  if (insert_due && now_s < schedule_.insert_after_s) ++stats_.scans_deferred;
  if (insert_due && now_s >= schedule_.insert_after_s) {
    schedule_.next_insert_s = std::max(schedule_.next_insert_s + options_.map_insert_period_s, now_s);
    last_keyframe_.T_W_S = T_W_S_estimate;
    last_keyframe_.stamp_s = now_s;
    start = Clock::now();
    const InsertStats inserted = map_->InsertScan(scan.points_S, T_W_S_estimate);
    const double z = T_W_S_estimate.translation().z();
    if (!(z <= max_sensor_z_m_.load())) max_sensor_z_m_ = z;  // also replaces NaN
    const double insert_ms = MsSince(start);
    stats_.map_ms_total += insert_ms;
    const double scan_to_map_ms = 1000.0 * (now_s - scan.stamp_s) + insert_ms;
    stats_.scan_to_map_ms_total += scan_to_map_ms;
    stats_.scan_to_map_ms_max = std::max(stats_.scan_to_map_ms_max, scan_to_map_ms);
    if (schedule_.adapt_to_load) schedule_.insert_after_s = now_s + kLoadWait * insert_ms / 1000.0;
    stats_.points_dropped_non_finite += inserted.dropped_non_finite;
    ++stats_.scans_inserted;
    CollectChanges();
    if (progress_) progress_();
  }
}

void PerceptionPipeline::DetectStaircases(double now_s, PerceptionOutput* out) {
  schedule_.next_staircase_s = std::max(schedule_.next_staircase_s + options_.staircase_period_s, now_s);
  const auto start = Clock::now();
  const std::vector<Staircase> found = detector_.Detect(local_cloud_.Points(), T_W_B_estimate_.translation());
  bool registry_changed = false;
  for (const Staircase& staircase : found) {
    const auto merged = registry_.Add(staircase, "scan");
    if (!merged.is_new && !merged.changed) continue;
    registry_changed = true;
    for (const auto& entry : registry_.Entries()) {
      if (entry.id == merged.id) out->staircases.push_back(entry);
    }
  }
  if (registry_changed) {
    std::vector<Staircase> confirmed;
    for (const auto& entry : registry_.Entries()) {
      if (entry.detections >= kStairPriorDetections) confirmed.push_back(entry.staircase);
    }
    std::lock_guard<std::mutex> guard(staircases_mutex_);
    staircases_ = std::move(confirmed);
  }
  const double staircase_ms = MsSince(start);
  stats_.staircase_ms_total += staircase_ms;
  if (schedule_.adapt_to_load) schedule_.staircase_after_s = now_s + kLoadWait * staircase_ms / 1000.0;
  ++stats_.staircase_runs;
  if (progress_) progress_();
}

void PerceptionPipeline::EncodeCameraFrame(double now_s, const core::CameraImage& image,
                                           PerceptionOutput* out) {
  schedule_.next_camera_s = std::max(schedule_.next_camera_s + 1.0 / options_.camera_rate_hz, now_s);
  const auto start = Clock::now();
  CameraFrame frame;
  frame.seq = ++camera_seq_;
  frame.width_px = image.width_px;
  frame.height_px = image.height_px;
  frame.T_W_C = image.T_MC;
  frame.jpeg =
      EncodeGrayJpeg(GrayFrame{image.width_px, image.height_px, image.pixels}, options_.jpeg_quality);
  // Within the camera's budget: a frame of B bytes holds the next one back B * 8 / budget seconds, so the
  // robot never renders frames its link would only drop (on a radio link the budget is a share of it).
  schedule_.next_camera_s =
      std::max(schedule_.next_camera_s, now_s + static_cast<double>(frame.jpeg.size()) * 8.0 /
                                                    (link_share_ * options_.camera_budget_bits_per_s));
  out->camera = std::move(frame);
  stats_.camera_ms_total += MsSince(start);
  ++stats_.camera_frames;
}

}  // namespace cairn::perception
