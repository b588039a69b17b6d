// Copyright Cairn authors.
#include "cairn/sim/simulated_platform.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "cairn/core/config.h"

namespace cairn::sim {
namespace {

bool InRange(const char* field, double value, double lo, double hi, bool lo_open, std::string* why) {
  const bool ok = std::isfinite(value) && (lo_open ? value > lo : value >= lo) && value <= hi;
  if (!ok && why != nullptr) {
    std::ostringstream out;
    out << "simulation." << field << " = " << value << " must be in " << (lo_open ? "(" : "[") << lo << ", "
        << hi << "]";
    *why = out.str();
  }
  return ok;
}

std::string Format2(double a, double b) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.2f,%.2f", a, b);
  return text;
}

std::shared_ptr<const World> LoadChecked(const SimulatedPlatformOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  WorldLoadOptions w;
  w.pcd_resolution_m = options.pcd_resolution_m;
  WorldLoadReport report;
  auto world = std::make_shared<const World>(LoadWorld(options.world, w, &report));
  if (report.kind != "builtin") {
    std::fprintf(stderr, "[sim] world %s: %s\n", options.world.c_str(), report.Summary().c_str());
  }
  return world;
}

// Start pose: given, or chosen deterministically among free cells of the ground truth.
PlanarPose ChooseStart(const SimulatedPlatformOptions& options, const BodyTerrain& terrain) {
  if (options.start_W) {
    const PlanarPose start = *options.start_W;
    if (!terrain.IsFootprintFree(start.x_m, start.y_m, options.footprint_radius_m) ||
        !terrain.GroundHeight(start.x_m, start.y_m)) {
      throw std::invalid_argument("--start " + Format2(start.x_m, start.y_m) +
                                  " is not free ground in world " + options.world +
                                  " (occupied, outside the map, or no floor there)");
    }
    return start;
  }
  if (options.start_slot) {
    const int k = *options.start_slot;
    if (options.world.rfind("builtin:", 0) == 0) {
      const auto& starts = GetBuiltinWorldInfo(options.world.substr(8)).suggested_starts;
      return starts[static_cast<std::size_t>(k) % starts.size()];
    }
    const auto starts = terrain.SampleFreeStarts(k + 1, 2.0, options.footprint_radius_m, /*seed=*/7);
    if (static_cast<int>(starts.size()) <= k) {
      throw std::invalid_argument("--start slot:" + std::to_string(k) + ": world " + options.world +
                                  " has only " + std::to_string(starts.size()) + " free starts 2 m apart");
    }
    return PlanarPose{starts[static_cast<std::size_t>(k)].x(), starts[static_cast<std::size_t>(k)].y(), 0.0};
  }
  const auto starts =
      terrain.SampleFreeStarts(1, 1.0, options.footprint_radius_m,
                               static_cast<std::uint32_t>(std::hash<std::string>{}(options.start_key)));
  if (starts.empty()) throw std::invalid_argument("world " + options.world + " has no free start cell");
  return PlanarPose{starts.front().x(), starts.front().y(), 0.0};
}

std::uint32_t SeedOf(const std::string& key) {
  return static_cast<std::uint32_t>(std::hash<std::string>{}(key));
}

// Strips blanks around a field, so "near 1.0" and " +8" read as written.
std::string Trimmed(const std::string& item) {
  const std::size_t first = item.find_first_not_of(" \t");
  if (first == std::string::npos) return std::string();
  return item.substr(first, item.find_last_not_of(" \t") - first + 1);
}

std::string TextOf(double x) {
  std::ostringstream o;
  o << x;
  return o.str();
}

// One entry of simulation.rockfalls, WHEN:X0,Y0,X1,Y1,HEIGHT_M[:CLEAR]; every error names the entry.
class RockfallEntry {
 public:
  explicit RockfallEntry(std::string entry) : entry_(std::move(entry)) {}

  Rockfall Parse() const {
    std::vector<std::string> parts;  // WHEN, the box and height, CLEAR
    std::stringstream colons(entry_);
    for (std::string part; std::getline(colons, part, ':');) parts.push_back(part);
    if (parts.size() < 2) Fail("missing ':' after the time");
    if (parts.size() > 3) Fail("too many ':' (at most WHEN:BOX,HEIGHT_M:CLEAR)");
    Rockfall rock;
    ReadWhen(parts[0], &rock);
    ReadBox(parts[1], &rock);
    if (parts.size() == 3) ReadClear(parts[2], &rock);
    return rock;
  }

 private:
  [[noreturn]] void Fail(const std::string& rule) const {
    throw std::invalid_argument("simulation.rockfalls entry '" + entry_ + "': " + rule +
                                " (format WHEN:X0,Y0,X1,Y1,HEIGHT_M[:CLEAR], WHEN = AT_S or nearR_M, CLEAR = "
                                "CLEAR_S or +S)");
  }
  double Number(const std::string& field, const std::string& item) const {
    double x = 0.0;
    std::size_t used = 0;
    try {
      x = std::stod(item, &used);
    } catch (const std::logic_error&) {
      Fail(field + " = '" + item + "' is not a number");
    }
    if (item.find_first_not_of(" \t", used) != std::string::npos || !std::isfinite(x)) {
      Fail(field + " = '" + item + "' is not a number");
    }
    return x;
  }
  void ReadWhen(const std::string& part, Rockfall* rock) const {
    const std::string when = Trimmed(part);
    if (when.rfind("near", 0) == 0) {
      const double near_m = Number("R_M", when.substr(4));
      if (!(near_m > 0 && near_m <= 100)) Fail("R_M = " + TextOf(near_m) + " must be in (0, 100] m");
      rock->near_m = near_m;
    } else {
      rock->at_s = Number("AT_S", part);
      if (rock->at_s < 0) Fail("AT_S = " + TextOf(rock->at_s) + " must be >= 0 s");
    }
  }
  void ReadBox(const std::string& part, Rockfall* rock) const {
    static const char* const kFields[] = {"X0", "Y0", "X1", "Y1", "HEIGHT_M"};
    std::vector<double> v;
    std::stringstream numbers(part);
    for (std::string item; std::getline(numbers, item, ',');) {
      if (v.size() >= 5) Fail("needs 5 numbers after WHEN (X0,Y0,X1,Y1,HEIGHT_M), has more");
      v.push_back(Number(kFields[v.size()], item));
    }
    if (v.size() != 5)
      Fail("needs 5 numbers after WHEN (X0,Y0,X1,Y1,HEIGHT_M), has " + std::to_string(v.size()));
    if (!(v[0] < v[2])) Fail("X0 = " + TextOf(v[0]) + " must be < X1 = " + TextOf(v[2]));
    if (!(v[1] < v[3])) Fail("Y0 = " + TextOf(v[1]) + " must be < Y1 = " + TextOf(v[3]));
    if (!(v[4] > 0 && v[4] <= 10)) Fail("HEIGHT_M = " + TextOf(v[4]) + " must be in (0, 10] m");
    rock->area_W = Eigen::AlignedBox2d(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]));
    rock->height_m = v[4];
  }
  void ReadClear(const std::string& part, Rockfall* rock) const {
    const std::string clear = Trimmed(part);
    if (!clear.empty() && clear.front() == '+') {
      const double after_s = Number("CLEAR (+S)", clear.substr(1));
      if (!(after_s > 0)) Fail("CLEAR = '" + clear + "': S must be > 0 s");
      rock->clear_after_s = after_s;
      return;
    }
    const double clear_s = Number("CLEAR_S", part);
    if (rock->near_m)
      Fail("CLEAR_S = " + TextOf(clear_s) + " with a near trigger: the fall time is not known, give '+S'");
    if (!(clear_s > rock->at_s))
      Fail("CLEAR_S = " + TextOf(clear_s) + " must be > AT_S = " + TextOf(rock->at_s) + " s");
    rock->clear_s = clear_s;
  }

  const std::string entry_;
};

}  // namespace

std::vector<Rockfall> ParseRockfalls(const std::string& text) {
  std::vector<Rockfall> out;
  std::stringstream entries(text);
  for (std::string entry; std::getline(entries, entry, ';');) {
    if (entry.find_first_not_of(" \t") != std::string::npos) out.push_back(RockfallEntry(entry).Parse());
  }
  std::stable_sort(out.begin(), out.end(), [](const Rockfall& a, const Rockfall& b) {
    if (a.near_m.has_value() != b.near_m.has_value()) return !a.near_m.has_value();
    return !a.near_m && a.at_s < b.at_s;
  });
  return out;
}

bool SimulatedPlatformOptions::IsValid(std::string* why) const {
  std::string inner;
  auto fail = [&](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (!limits.IsValid(&inner)) return fail("simulation: " + inner);
  if (!body.IsValid(&inner)) return fail("simulation." + inner);
  if (!lidar.IsValid(&inner)) return fail("simulation.lidar: " + inner);
  if (!slam.IsValid(&inner)) return fail("simulation.slam: " + inner);
  if (!camera.IsValid(&inner)) return fail("simulation.camera: " + inner);
  if (start_slot && (*start_slot < 0 || *start_slot > 99)) {
    return fail("--start slot:" + std::to_string(*start_slot) + " must be in [0, 99]");
  }
  if (start_W &&
      !(std::isfinite(start_W->x_m) && std::isfinite(start_W->y_m) && std::isfinite(start_W->yaw_rad))) {
    return fail("--start must be finite");
  }
  return InRange("pcd_resolution_m", pcd_resolution_m, 0.02, 2.0, false, why) &&
         InRange("footprint_radius_m", footprint_radius_m, 0.0, 2.0, true, why) &&
         InRange("lidar_height_m", lidar_height_m, 0.0, 3.0, false, why) &&
         InRange("physics_step_s", physics_step_s, 0.0, 0.1, true, why) &&
         InRange("command_timeout_s", command_timeout_s, 0.0, 10.0, true, why);
}

void SimulatedPlatformOptions::LoadConfigFile(const std::string& path) {
  try {
    const auto config = core::ConfigSection::LoadFile(path);
    const auto s = config.Section("simulation");
    std::string rockfall_text;
    s.ReadFields({{"lidar_rate_hz", &lidar.rate_hz},
                  {"lidar_beams", &lidar.num_beams},
                  {"lidar_points_per_beam", &lidar.points_per_beam},
                  {"lidar_max_range_m", &lidar.max_range_m},
                  {"lidar_range_noise_m", &lidar.range_noise_stddev_m},
                  {"lidar_height_m", &lidar_height_m},
                  {"slam_position_drift_per_sqrt_m", &slam.position_drift_per_sqrt_m},
                  {"slam_yaw_drift_rad_per_sqrt_m", &slam.yaw_drift_rad_per_sqrt_m},
                  {"camera_width_px", &camera.width_px},
                  {"camera_height_px", &camera.height_px},
                  {"command_timeout_s", &command_timeout_s},
                  {"rockfalls", &rockfall_text}});
    if (!rockfall_text.empty()) rockfalls = ParseRockfalls(rockfall_text);
  } catch (const core::ConfigError& e) {
    throw std::invalid_argument(e.what());
  }
  std::string why;
  if (!IsValid(&why)) throw std::invalid_argument(path + ": " + why);
}

SimulatedPlatform::SimulatedPlatform(const SimulatedPlatformOptions& options)
    : options_(options),
      world_(LoadChecked(options)),
      ground_truth_(std::make_shared<const BodyTerrain>(world_, options.body)),
      base_(options.limits, options.footprint_radius_m),
      slam_(options.slam, SeedOf(options.start_key) + 1),
      lidar_(options.lidar, SeedOf(options.start_key)) {
  const PlanarPose start = ChooseStart(options_, *ground_truth_);
  UnicycleState state;
  state.x_m = start.x_m;
  state.y_m = start.y_m;
  state.yaw_rad = start.yaw_rad;
  state.z_m = ground_truth_->GroundHeight(start.x_m, start.y_m).value_or(0.0);
  base_.set_state(state);
  T_MB_estimate_ = slam_.Update(TrueBodyPose());
  rock_dropped_.assign(options_.rockfalls.size(), false);
}

Eigen::Isometry3d SimulatedPlatform::TrueBodyPose() const {
  const UnicycleState& s = base_.state();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(s.x_m, s.y_m, s.z_m);
  T.linear() = Eigen::AngleAxisd(s.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

Eigen::Isometry3d SimulatedPlatform::SensorOnBody() const {
  Eigen::Isometry3d T_BS = Eigen::Isometry3d::Identity();
  T_BS.translation().z() = options_.lidar_height_m;
  return T_BS;
}

core::PlatformCapabilities SimulatedPlatform::Capabilities() const {
  core::PlatformCapabilities c;
  c.driver = "sim";
  c.description = options_.world;
  c.limits = options_.limits;
  c.footprint_radius_m = options_.footprint_radius_m;
  c.has_lidar = true;
  c.lidar_rate_hz = options_.lidar.rate_hz;
  c.lidar_min_elevation_rad = options_.lidar.min_elevation_rad;
  c.has_camera = true;
  return c;
}

std::vector<Eigen::Vector3i> SimulatedPlatform::FillRock(const Eigen::AlignedBox2d& area_W, double height_m) {
  std::shared_ptr<const World> world;
  std::shared_ptr<const BodyTerrain> terrain;
  {
    std::lock_guard<std::mutex> guard(world_mutex_);
    world = world_;
    terrain = ground_truth_;
  }
  auto changed = std::make_shared<World>(*world);
  const double floor_z =
      terrain->GroundHeight(area_W.center().x(), area_W.center().y()).value_or(world->p_W_min().z());
  std::vector<Eigen::Vector3i> filled;
  for (int ix = 0; ix < world->dims().x(); ++ix) {
    for (int iy = 0; iy < world->dims().y(); ++iy) {
      const Eigen::Vector3d c = world->CenterOf({ix, iy, 0});
      if (!area_W.contains(c.head<2>())) continue;
      for (int iz = 0; iz < world->dims().z(); ++iz) {
        const double z = world->CenterOf({ix, iy, iz}).z();
        if (z > floor_z - world->resolution_m() && z < floor_z + height_m &&
            !changed->IsOccupiedIndex({ix, iy, iz})) {
          changed->SetOccupied({ix, iy, iz});
          filled.emplace_back(ix, iy, iz);
        }
      }
    }
  }
  SwapWorld(std::move(changed));
  return filled;
}

void SimulatedPlatform::SwapWorld(std::shared_ptr<const World> changed) {
  auto truth = std::make_shared<const BodyTerrain>(changed, options_.body);
  std::lock_guard<std::mutex> guard(world_mutex_);
  world_ = std::move(changed);
  ground_truth_ = std::move(truth);
}

std::int64_t SimulatedPlatform::DropRock(const Eigen::AlignedBox2d& area_W, double height_m) {
  return static_cast<std::int64_t>(FillRock(area_W, height_m).size());
}

std::int64_t SimulatedPlatform::ClearRock(const std::vector<Eigen::Vector3i>& filled) {
  std::shared_ptr<const World> world;
  {
    std::lock_guard<std::mutex> guard(world_mutex_);
    world = world_;
  }
  auto changed = std::make_shared<World>(*world);
  std::int64_t freed = 0;
  for (const Eigen::Vector3i& index : filled) {
    if (!changed->IsOccupiedIndex(index)) continue;
    changed->SetOccupied(index, false);
    ++freed;
  }
  if (freed == 0) return 0;
  SwapWorld(std::move(changed));
  return freed;
}

void SimulatedPlatform::Update(double now_s) {
  Eigen::Vector2d p_W;  // the body's true position, for proximity triggers
  {
    std::lock_guard<std::mutex> guard(mutex_);
    p_W = Eigen::Vector2d(base_.state().x_m, base_.state().y_m);
  }
  for (std::size_t i = 0; i < options_.rockfalls.size(); ++i) {
    const Rockfall& r = options_.rockfalls[i];
    if (rock_dropped_[i]) continue;
    const bool due = r.near_m ? r.area_W.exteriorDistance(p_W) <= *r.near_m : r.at_s <= now_s;
    if (!due) continue;
    rock_dropped_[i] = true;
    std::vector<Eigen::Vector3i> filled = FillRock(r.area_W, r.height_m);
    if (r.clear_after_s) {
      pending_clears_.push_back({now_s + *r.clear_after_s, std::move(filled)});
    } else if (r.clear_s) {
      pending_clears_.push_back({*r.clear_s, std::move(filled)});
    }
  }
  for (auto it = pending_clears_.begin(); it != pending_clears_.end();) {
    if (it->clear_s > now_s) {
      ++it;
      continue;
    }
    ClearRock(it->filled);
    it = pending_clears_.erase(it);
  }
  const std::shared_ptr<const BodyTerrain> terrain = ground_truth();
  std::lock_guard<std::mutex> guard(mutex_);
  if (last_update_s_ < 0.0 || !(now_s > last_update_s_)) {
    last_update_s_ = std::max(last_update_s_, now_s);
    return;
  }
  // A late call integrates the whole interval (the real base kept moving), capped at 0.5 s.
  double remaining_s = std::min(now_s - last_update_s_, 0.5);
  last_update_s_ = now_s;
  const bool fresh = now_s - command_time_s_ <= options_.command_timeout_s;
  const double v = fresh ? command_v_mps_ : 0.0;
  const double w = fresh ? command_w_radps_ : 0.0;
  bool contact = false;
  while (remaining_s > 1e-9) {
    const double dt_s = std::min(remaining_s, options_.physics_step_s);
    remaining_s -= dt_s;
    contact = base_.Step(v, w, dt_s, *terrain).contact || contact;
  }
  in_contact_ = contact;
  T_MB_estimate_ = slam_.Update(TrueBodyPose());
}

core::PoseEstimate SimulatedPlatform::ReadPose() const {
  std::lock_guard<std::mutex> guard(mutex_);
  core::PoseEstimate p;
  p.stamp_s = std::max(last_update_s_, 0.0);
  p.T_MB = T_MB_estimate_;
  p.v_mps = base_.state().v_mps;
  p.w_radps = base_.state().w_radps;
  p.healthy = true;
  return p;
}

core::PlatformStatus SimulatedPlatform::ReadStatus() const {
  std::lock_guard<std::mutex> guard(mutex_);
  core::PlatformStatus s;
  s.in_contact = in_contact_;
  return s;
}

bool SimulatedPlatform::ReadLidarScan(double now_s, core::LidarScan* scan) {
  if (scan == nullptr) throw std::invalid_argument("SimulatedPlatform::ReadLidarScan: scan is null");
  std::lock_guard<std::mutex> lidar_guard(lidar_mutex_);
  if (now_s < next_scan_s_) return false;
  next_scan_s_ = std::max(next_scan_s_ + 1.0 / options_.lidar.rate_hz, now_s);  // no catch-up bursts
  Eigen::Isometry3d T_WB_true;
  Eigen::Isometry3d T_MB;
  {
    std::lock_guard<std::mutex> guard(mutex_);
    T_WB_true = TrueBodyPose();
    T_MB = T_MB_estimate_;
  }
  const Eigen::Isometry3d T_BS = SensorOnBody();
  lidar_.Scan(world(), T_WB_true * T_BS, &lidar_scan_);  // sensed from where the robot is...
  scan->stamp_s = now_s;
  scan->seq = ++lidar_seq_;
  // Swapped, not copied: the next Scan() rewrites lidar_scan_.points_S whole, in the caller's old buffer.
  scan->points_S.swap(lidar_scan_.points_S);
  scan->T_BS = T_BS;
  scan->T_MS = T_MB * T_BS;  // ...and registered where SLAM says it is
  return true;
}

bool SimulatedPlatform::ReadCameraImage(double now_s, core::CameraImage* image) {
  if (image == nullptr) throw std::invalid_argument("SimulatedPlatform::ReadCameraImage: image is null");
  Eigen::Isometry3d T_WB_true;
  Eigen::Isometry3d T_MB;
  {
    std::lock_guard<std::mutex> guard(mutex_);
    T_WB_true = TrueBodyPose();
    T_MB = T_MB_estimate_;
  }
  const Eigen::Isometry3d T_BC = SensorOnBody();
  const Eigen::Isometry3d T_WC = T_WB_true * T_BC;
  const std::shared_ptr<const World> shown = world();
  std::lock_guard<std::mutex> guard(camera_mutex_);
  if (shown != frame_world_ || T_WC.matrix() != frame_T_WC_.matrix()) {
    RenderShadedDepth(*shown, T_WC, options_.camera, &frame_);
    frame_world_ = shown;  // held, so a new world can never reuse its address
    frame_T_WC_ = T_WC;
  }
  image->stamp_s = now_s;
  image->seq = ++camera_seq_;
  image->width_px = frame_.width_px;
  image->height_px = frame_.height_px;
  image->pixels = frame_.pixels;
  image->T_MC = T_MB * T_BC;
  return true;
}

void SimulatedPlatform::CommandTwist(double linear_x_mps, double angular_z_radps, double now_s) {
  std::lock_guard<std::mutex> guard(mutex_);
  // Non-finite components become 0 in the base (Unicycle::Step), so a bad command never moves the robot.
  command_v_mps_ = linear_x_mps;
  command_w_radps_ = angular_z_radps;
  command_time_s_ = now_s;
}

UnicycleState SimulatedPlatform::TrueState() const {
  std::lock_guard<std::mutex> guard(mutex_);
  return base_.state();
}

void SimulatedPlatform::SetTrueState(const UnicycleState& state) {
  std::lock_guard<std::mutex> guard(mutex_);
  base_.set_state(state);
}

std::shared_ptr<const World> SimulatedPlatform::world() const {
  std::lock_guard<std::mutex> guard(world_mutex_);
  return world_;
}

std::shared_ptr<const BodyTerrain> SimulatedPlatform::ground_truth() const {
  std::lock_guard<std::mutex> guard(world_mutex_);
  return ground_truth_;
}

double SimulatedPlatform::distance_travelled_m() const {
  std::lock_guard<std::mutex> guard(mutex_);
  return slam_.distance_travelled_m();
}

double SimulatedPlatform::slam_error_m() const {
  std::lock_guard<std::mutex> guard(mutex_);
  return (T_MB_estimate_.translation() - TrueBodyPose().translation()).norm();
}

}  // namespace cairn::sim
