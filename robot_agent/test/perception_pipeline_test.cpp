// The perception component driven through a built-in world faster than real time, without DDS: mapping
// precision and recall against the world, map telemetry within its budget and complete (early and late
// basestations end with the robot's coarse map), staircases found once, camera frames that decode.
#include "cairn/perception/perception_pipeline.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <tuple>

#include "cairn/perception/jpeg.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/camera.h"
#include "cairn/sim/lidar.h"
#include "cairn/sim/slam_drift.h"

namespace cairn::agent {
namespace {

using Index = std::tuple<int, int, int>;

Eigen::Isometry3d Pose(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

// A drive through builtin:tunnels at 1 m/s: west end of the main tunnel, past the X junction, into the room,
// up to the foot of the staircase (which rises +x from x = 50 at y in [22.5, 25]).
std::vector<Eigen::Vector3d> Route() {
  return {{4.0, 20.0, 0.0}, {44.0, 20.0, 0.0}, {47.5, 22.0, 0.0}, {48.6, 23.7, 0.0}};
}

// Samples the route every `dt_s` at `speed_mps`, heading along each leg, then `hold_s` at the end.
std::vector<Eigen::Isometry3d> Drive(double speed_mps, double dt_s, double hold_s) {
  std::vector<Eigen::Isometry3d> poses;
  const auto route = Route();
  for (std::size_t i = 0; i + 1 < route.size(); ++i) {
    const Eigen::Vector3d a = route[i];
    const Eigen::Vector3d b = route[i + 1];
    const double length = (b - a).head<2>().norm();
    const double yaw = std::atan2(b.y() - a.y(), b.x() - a.x());
    for (double s = 0; s < length; s += speed_mps * dt_s) {
      const Eigen::Vector3d p = a + (b - a) * (s / length);
      poses.push_back(Pose(p.x(), p.y(), yaw));
    }
  }
  const Eigen::Isometry3d last = Pose(route.back().x(), route.back().y(), 0.0);  // face the stairs
  for (double t = 0; t < hold_s; t += dt_s) poses.push_back(last);
  return poses;
}

Index Key(const perception::CoarseVoxel& v) { return {v.ix, v.iy, v.iz}; }

std::map<Index, perception::CoarseState> AsMap(const std::vector<perception::CoarseVoxel>& voxels) {
  std::map<Index, perception::CoarseState> m;
  for (const auto& v : voxels) m[Key(v)] = v.state;
  return m;
}

class PerceptionPipelineTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    world_ = std::make_shared<const sim::World>(sim::MakeBuiltinWorld("tunnels"));
  }
  static std::shared_ptr<const sim::World> world_;
};
std::shared_ptr<const sim::World> PerceptionPipelineTest::world_;

TEST_F(PerceptionPipelineTest, DrivingTheTunnelsMapsStreamsAndFindsTheStaircase) {
  perception::PerceptionOptions options;
  options.camera_rate_hz = 0.5;
  // Mapping is judged at 0.1 m against the world, so the SLAM drift must stay well under that over the 46 m
  // drive: 0.1 % of the distance (the default, ~0.3 %, ends ~0.15 m off, which no 0.1 m comparison survives).
  // The platform's sensors, as the simulated platform makes them: scans sensed from the true pose, registered
  // with the drifting SLAM estimate; camera frames rendered from the true pose.
  sim::SlamDriftOptions slam_options;
  slam_options.position_drift_per_sqrt_m = 0.001;
  slam_options.yaw_drift_rad_per_sqrt_m = 0.0001;
  sim::SlamDrift slam(slam_options, /*seed=*/4);
  const sim::LidarOptions lidar_options;
  sim::SimulatedLidar lidar(lidar_options, /*seed=*/3);
  const sim::CameraOptions camera_options;
  Eigen::Isometry3d T_BS = Eigen::Isometry3d::Identity();
  T_BS.translation().z() = 0.5;
  perception::PerceptionPipeline pipeline(options, "r1");
  // Reference for recall: world voxels hit by the same rays without noise or drift (what the lidar could
  // see).
  sim::LidarOptions exact = lidar_options;
  exact.range_noise_stddev_m = 0.0;
  sim::SimulatedLidar reference(exact, 1);
  sim::LidarScan scan;
  std::set<Index> observed;

  perception::FleetMap early;  // listens from the start
  perception::FleetMap late;   // joins halfway and asks for a snapshot
  const double dt_s = 0.1;
  const std::vector<Eigen::Isometry3d> poses = Drive(1.0, dt_s, /*hold_s=*/30.0);
  const std::size_t late_join = poses.size() / 3;
  std::vector<std::pair<double, std::size_t>> sent;  // (time, bytes incl. overhead)
  int frames = 0;
  int late_requests = 0;
  std::vector<perception::StaircaseRegistry::Entry> staircase_updates;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const double now_s = k * dt_s;
    const Eigen::Isometry3d T_MB = slam.Update(poses[k]);
    core::LidarScan platform_scan;
    platform_scan.stamp_s = now_s;
    platform_scan.seq = k + 1;
    platform_scan.T_BS = T_BS;
    platform_scan.T_MS = T_MB * T_BS;
    lidar.Scan(*world_, poses[k] * T_BS, &scan);
    platform_scan.points_S = scan.points_S;
    core::CameraImage image;
    if (pipeline.CameraDue(now_s)) {
      sim::GrayImage gray;
      sim::RenderShadedDepth(*world_, poses[k] * T_BS, camera_options, &gray);
      image = core::CameraImage{
          now_s, static_cast<std::uint32_t>(k), gray.width_px, gray.height_px, gray.pixels, T_MB * T_BS};
    }
    const perception::PerceptionOutput out =
        pipeline.Tick(now_s, &platform_scan, image.pixels.empty() ? nullptr : &image);
    if (k % 5 == 0) {  // the reference at the map insertion rate
      const Eigen::Isometry3d T_W_S = poses[k] * T_BS;
      reference.Scan(*world_, T_W_S, &scan);
      for (const auto& p_S : scan.points_S) {
        const Eigen::Vector3d p_W = T_W_S * p_S.cast<double>();
        const Eigen::Vector3d inside = p_W + (p_W - T_W_S.translation()).normalized() * 0.01;
        if (const auto index = world_->IndexOf(inside)) observed.insert({index->x(), index->y(), index->z()});
      }
    }
    for (const auto& update : out.map_messages) {
      std::string error;
      ASSERT_TRUE(early.Apply("r1", update, &error)) << error;
      sent.emplace_back(now_s, update.data.size() + options.telemetry.per_message_overhead_bytes);
      if (k >= late_join) {
        late.Apply("r1", update, &error);  // may be refused until the snapshot arrives: that is the protocol
        if (late.NeedsSnapshot("r1") && late_requests == 0) {
          pipeline.RequestMapSnapshot();
          ++late_requests;
        }
      }
    }
    for (const auto& entry : out.staircases) staircase_updates.push_back(entry);
    if (out.camera) {
      ++frames;
      const perception::GrayFrame frame = perception::DecodeGrayJpeg(out.camera->jpeg);
      EXPECT_EQ(frame.width_px, 320);
      EXPECT_EQ(frame.height_px, 240);
    }
  }
  ASSERT_EQ(late_requests, 1);
  // The map stands still from here: send what the last scans changed (within the budget).
  for (double now_s = poses.size() * dt_s;
       pipeline.telemetry().stats().voxels_pending > 0 || now_s < poses.size() * dt_s + 1;
       now_s += options.telemetry.period_s) {
    for (const auto& update : pipeline.FlushMapTelemetry(now_s)) {
      std::string error;
      ASSERT_TRUE(early.Apply("r1", update, &error)) << error;
      ASSERT_TRUE(late.Apply("r1", update, &error)) << error;
    }
  }

  // Telemetry stayed within its budget: over every 5 s window, at most budget * (window + burst).
  const double budget = options.telemetry.budget_bits_per_s;
  double peak_bits_per_s = 0;
  double total_bits = 0;
  for (std::size_t i = 0; i < sent.size(); ++i) {
    double bits = 0;
    for (std::size_t j = i; j < sent.size() && sent[j].first < sent[i].first + 5.0; ++j)
      bits += sent[j].second * 8.0;
    EXPECT_LE(bits, budget * (5.0 + options.telemetry.burst_s) + 1e-6)
        << "window at " << sent[i].first << " s";
    peak_bits_per_s = std::max(peak_bits_per_s, bits / 5.0);
    total_bits += sent[i].second * 8.0;
  }
  const double duration_s = poses.size() * dt_s;
  std::printf(
      "FIGURE telemetry: %zu messages, mean %.1f kbit/s, peak 5 s window %.1f kbit/s, budget %.0f kbit/s\n",
      sent.size(), total_bits / duration_s / 1000, peak_bits_per_s / 1000, budget / 1000);
  EXPECT_LE(total_bits / duration_s, budget);

  // Nothing lost: after the hold, both basestations hold exactly the robot's coarse map.
  const auto robot = AsMap(pipeline.map()->CoarseSnapshot(options.map_coarse_levels));
  EXPECT_EQ(pipeline.telemetry().stats().voxels_pending, 0u);
  EXPECT_EQ(AsMap(early.Voxels("r1")), robot);
  EXPECT_EQ(AsMap(late.Voxels("r1")), robot);
  std::printf("FIGURE telemetry: robot coarse map %zu voxels; early and late basestations equal: %d %d\n",
              robot.size(), AsMap(early.Voxels("r1")) == robot, AsMap(late.Voxels("r1")) == robot);

  // Mapping precision and recall at 0.1 m: a map voxel counts as right when an occupied world voxel is within
  // 0.1 m of it (26-neighbourhood), and a world voxel the lidar saw counts as mapped when an occupied map
  // voxel is within 0.1 m. The strict figures (same voxel) are printed too.
  const double res = options.map.resolution_m;
  const Eigen::Vector3d p_min = world_->p_W_min().array() - 1.0;
  const Eigen::Vector3d p_max = world_->p_W_max().array() + 1.0;
  const std::vector<Eigen::Vector3d> map_occupied =
      pipeline.map()->OccupiedInBox(Eigen::AlignedBox3d(p_min, p_max));
  ASSERT_GT(map_occupied.size(), 10000u);
  auto world_near = [&](const Eigen::Vector3d& p, int reach) {
    for (int dx = -reach; dx <= reach; ++dx)
      for (int dy = -reach; dy <= reach; ++dy)
        for (int dz = -reach; dz <= reach; ++dz)
          if (world_->IsOccupied(p + Eigen::Vector3d(dx, dy, dz) * res)) return true;
    return false;
  };
  std::set<Index> map_set;
  std::size_t precise = 0;
  std::size_t precise_strict = 0;
  for (const auto& c : map_occupied) {
    map_set.insert({static_cast<int>(std::floor(c.x() / res)), static_cast<int>(std::floor(c.y() / res)),
                    static_cast<int>(std::floor(c.z() / res))});
    precise += world_near(c, 1);
    precise_strict += world_near(c, 0);
  }
  auto map_near = [&](const Eigen::Vector3d& p, int reach) {
    const int x = static_cast<int>(std::floor(p.x() / res));
    const int y = static_cast<int>(std::floor(p.y() / res));
    const int z = static_cast<int>(std::floor(p.z() / res));
    for (int dx = -reach; dx <= reach; ++dx)
      for (int dy = -reach; dy <= reach; ++dy)
        for (int dz = -reach; dz <= reach; ++dz)
          if (map_set.count({x + dx, y + dy, z + dz})) return true;
    return false;
  };
  std::size_t recalled = 0;
  std::size_t recalled_strict = 0;
  for (const auto& [ix, iy, iz] : observed) {
    const Eigen::Vector3d c = world_->CenterOf({ix, iy, iz});
    recalled += map_near(c, 1);
    recalled_strict += map_near(c, 0);
  }
  const double precision = static_cast<double>(precise) / map_occupied.size();
  const double recall = static_cast<double>(recalled) / observed.size();
  std::printf(
      "FIGURE mapping: %zu occupied map voxels, %zu observed world voxels; precision %.3f (strict %.3f), "
      "recall %.3f (strict %.3f); SLAM error %.3f m after %.1f m\n",
      map_occupied.size(), observed.size(), precision,
      static_cast<double>(precise_strict) / map_occupied.size(), recall,
      static_cast<double>(recalled_strict) / observed.size(),
      (slam.Estimate(poses.back()).translation() - poses.back().translation()).norm(),
      slam.distance_travelled_m());
  EXPECT_GE(precision, 0.9);
  EXPECT_GE(recall, 0.9);

  // The staircase was found, once, with its five steps.
  ASSERT_FALSE(staircase_updates.empty());
  std::set<int> ids;
  for (const auto& e : staircase_updates) ids.insert(e.id);
  EXPECT_EQ(ids.size(), 1u);
  const perception::Staircase& s = staircase_updates.back().staircase;
  std::printf(
      "FIGURE staircase: %d steps at (%.2f, %.2f, %.2f) yaw %.3f, rise %.3f, run %.3f, width %.2f after %d "
      "detections\n",
      s.num_steps, s.p_W_first_step.x(), s.p_W_first_step.y(), s.p_W_first_step.z(), s.yaw_rad, s.rise_m,
      s.run_m, s.width_m, staircase_updates.back().detections);
  EXPECT_EQ(s.num_steps, 5);
  EXPECT_NEAR(s.rise_m, 0.2, 0.01);
  EXPECT_NEAR(s.run_m, 0.5, 0.01);
  EXPECT_NEAR(s.p_W_first_step.x(), 50.0, 0.1);
  EXPECT_GT(frames, 10);

  const perception::PerceptionStats& st = pipeline.stats();
  std::printf(
      "FIGURE perception cost per robot (sensors simulated apart): local cloud %.2f ms/scan, map %.2f "
      "ms/insert, staircase %.2f ms/run, JPEG %.2f ms/frame, telemetry %.3f ms total per s; %.0f ms of CPU "
      "per s\n",
      st.local_cloud_ms_total / st.scans, st.map_ms_total / st.scans_inserted,
      st.staircase_ms_total / st.staircase_runs, st.camera_ms_total / std::max<int64_t>(1, st.camera_frames),
      st.telemetry_ms_total / duration_s,
      (st.local_cloud_ms_total + st.map_ms_total + st.staircase_ms_total + st.camera_ms_total +
       st.telemetry_ms_total) /
          duration_s);
}

// Keyframes: an idle robot at rest inserts one scan and leaves its map alone; with a task it waits on
// (set_refresh_at_rest) it inserts one every map_keyframe_max_interval_s, so the world's changes reach it.
TEST_F(PerceptionPipelineTest, ARobotAtRestRefreshesItsMapOnlyWhileItHasATask) {
  perception::PerceptionOptions options;
  options.camera_rate_hz = 0;
  options.map_keyframe_max_interval_s = 1.0;
  perception::PerceptionPipeline pipeline(options, "r1");
  sim::SimulatedLidar lidar(sim::LidarOptions{}, /*seed=*/3);
  Eigen::Isometry3d T_BS = Eigen::Isometry3d::Identity();
  T_BS.translation().z() = 0.5;
  const Eigen::Isometry3d T_MB = Pose(10.0, 20.0, 0.0);
  sim::LidarScan scan;
  auto tick = [&](double now_s) {
    core::LidarScan platform_scan;
    platform_scan.stamp_s = now_s;
    platform_scan.T_BS = T_BS;
    platform_scan.T_MS = T_MB * T_BS;
    lidar.Scan(*world_, T_MB * T_BS, &scan);
    platform_scan.points_S = scan.points_S;
    pipeline.Tick(now_s, &platform_scan, nullptr);
  };
  // Scans every 0.25 s (exact in binary, so the 1 s interval falls on a scan).
  for (int k = 0; k < 16; ++k) tick(0.25 * k);  // 0 .. 3.75 s idle at rest
  EXPECT_EQ(pipeline.stats().scans_inserted, 1);
  pipeline.set_refresh_at_rest(true);
  for (int k = 16; k < 32; ++k) tick(0.25 * k);  // 4 .. 7.75 s waiting on a goal: at 4, 5, 6 and 7 s
  EXPECT_EQ(pipeline.stats().scans_inserted, 1 + 4);
  pipeline.set_refresh_at_rest(false);
  for (int k = 32; k < 48; ++k) tick(0.25 * k);
  EXPECT_EQ(pipeline.stats().scans_inserted, 5);
}

// On a busy machine the map is updated less often instead of the thread falling behind: a scan whose
// insertion takes long (40 k rays) makes the next keyframes wait kLoadWait times as long; each step of a tick
// beats (slow, not hung).
TEST(PerceptionPipelineLoad, ASlowInsertionDefersTheNextKeyframesAndEveryStepBeats) {
  perception::PerceptionOptions options;
  options.camera_rate_hz = 0;
  options.map_insert_period_s = 0.05;
  options.map_keyframe_distance_m = 0.0;  // every scan is a keyframe
  perception::PerceptionPipeline pipeline(options, "r1");
  pipeline.set_adapt_to_load(true);
  int beats = 0;
  pipeline.SetProgress([&] { ++beats; });
  core::LidarScan scan;
  scan.T_BS = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 40000; ++i) {  // a dense sphere of returns 8 m away
    const double a = 0.001 * i * 2.399963, z = -0.9 + 1.8 * (i % 1000) / 1000.0;
    scan.points_S.emplace_back(8.0 * std::cos(a) * std::sqrt(1 - z * z),
                               8.0 * std::sin(a) * std::sqrt(1 - z * z), 8.0 * z);
  }
  const int ticks = 40;
  for (int k = 0; k < ticks; ++k) {
    const double now_s = 0.05 * k;
    scan.stamp_s = now_s;
    scan.T_MS = Pose(0.01 * k, 0.0, 0.0);  // moving a little: each scan a keyframe
    pipeline.Tick(now_s, &scan, nullptr);
  }
  const perception::PerceptionStats& stats = pipeline.stats();
  const double insert_ms = stats.map_ms_total / stats.scans_inserted;
  std::printf("insertion %.0f ms: %lld of %d keyframes inserted, %lld deferred\n", insert_ms,
              static_cast<long long>(stats.scans_inserted), ticks,
              static_cast<long long>(stats.scans_deferred));
  ASSERT_GT(insert_ms, 1000 * options.map_insert_period_s / perception::PerceptionPipeline::kLoadWait)
      << "this machine inserted 40 k rays faster than the test assumes";
  EXPECT_GT(stats.scans_deferred, 0);
  EXPECT_EQ(stats.scans_inserted + stats.scans_deferred, ticks);
  EXPECT_GE(beats, ticks + static_cast<int>(stats.scans_inserted))
      << "a beat after the local cloud and each insertion";
}

TEST(PerceptionOptionsTest, InvalidValuesNameTheField) {
  perception::PerceptionOptions o;
  std::string why;
  ASSERT_TRUE(o.IsValid(&why)) << why;
  o.jpeg_quality = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("perception.jpeg_quality"), std::string::npos) << why;
  o = perception::PerceptionOptions();
  o.map_insert_period_s = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("map_insert_period_s"), std::string::npos) << why;
  o = perception::PerceptionOptions();
  o.camera_rate_hz = 31;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("camera_rate_hz"), std::string::npos) << why;
  o = perception::PerceptionOptions();
  o.telemetry.budget_bits_per_s = -1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("budget"), std::string::npos) << why;
  EXPECT_THROW(perception::PerceptionPipeline(o, "r"), std::invalid_argument);
}

}  // namespace
}  // namespace cairn::agent
