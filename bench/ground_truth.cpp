// The simulator's ground truth (sim::BodyTerrain: where a body stands and what it touches) against what the
// simulator built before it had its own: navigation's classifier on the true world (a TraversabilityGrid of
// the main level and a MultiLevelGrid of the others, nav::LeveledTerrain), in the same process, on the same
// worlds. Prints, per world, the median build time of each and their ratio, then the cost of the query the
// simulated base asks every physics step (IsFootprintFreeNear, a wheeled body, 0.3 m radius) at random free
// points of the main floor.
//   build/bench/cairn_bench_ground_truth [--runs N] [WORLD...]   (default: the built-in worlds and geb079.bt)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "bench_util.h"
#include "cairn/core/build_paths.h"
#include "cairn/nav/multilevel.h"
#include "cairn/nav/platform.h"
#include "cairn/nav/traversability.h"
#include "cairn/sim/body_terrain.h"
#include "cairn/sim/world.h"

namespace {

using cairn::bench::Median;
using cairn::bench::TimeMs;

}  // namespace

int main(int argc, char** argv) {
  int runs = 5;
  std::vector<std::string> worlds;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--runs" && i + 1 < argc) {
      runs = cairn::bench::RunsOrExit(argv[++i]);
    } else if (!arg.empty() && arg[0] != '-') {
      worlds.push_back(arg);
    } else {
      std::fprintf(stderr, "usage: %s [--runs N] [WORLD...]\n", argv[0]);
      return 2;
    }
  }
  if (worlds.empty()) {
    worlds = {"builtin:tunnels", "builtin:building", "builtin:arena"};
    const std::string geb079 = cairn::core::SourceDir() + "/data/geb079.bt";
    if (std::filesystem::exists(geb079)) worlds.push_back(geb079);
  }
  const cairn::nav::PlatformProfile profile = cairn::nav::GetPlatformProfile("wheeled");
  cairn::nav::TraversabilityOptions classifier = profile.traversability;
  classifier.robot_radius_m = profile.footprint_radius_m;
  const cairn::sim::BodyOptions body{profile.traversability.max_step_m,
                                     profile.traversability.robot_height_m};
  std::printf(
      "ground truth build, median of %d: navigation's classifier (baseline) against sim::BodyTerrain\n",
      runs);
  std::printf("%-18s %10s %12s %12s %7s %14s %14s\n", "world", "voxels", "classifier ms", "body ms", "ratio",
              "query ns base", "query ns body");
  for (const std::string& spec : worlds) {
    std::shared_ptr<const cairn::sim::World> world;
    try {
      world = std::make_shared<const cairn::sim::World>(cairn::sim::LoadWorld(spec));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s: %s\n", spec.c_str(), e.what());
      return 1;
    }
    std::vector<double> classifier_ms, body_ms;
    std::shared_ptr<const cairn::nav::LeveledTerrain> leveled;
    std::shared_ptr<const cairn::sim::BodyTerrain> truth;
    for (int r = 0; r < runs; ++r) {
      classifier_ms.push_back(TimeMs([&] {
        auto main_level = std::make_shared<const cairn::nav::TraversabilityGrid>(*world, classifier);
        leveled = std::make_shared<const cairn::nav::LeveledTerrain>(
            main_level, std::make_shared<const cairn::nav::MultiLevelGrid>(world, classifier));
      }));
      body_ms.push_back(
          TimeMs([&] { truth = std::make_shared<const cairn::sim::BodyTerrain>(world, body); }));
    }
    // Query points: free ground of the main floor by the body's own rules (the same points for both).
    const auto points = truth->SampleFreeStarts(2000, 0.0, profile.footprint_radius_m, 7);
    int agree = 0;
    auto query_ns = [&](const cairn::core::FootprintChecker& terrain) {
      int free = 0;
      const double ms = TimeMs([&] {
        for (int repeat = 0; repeat < 10; ++repeat) {
          for (const auto& p : points)
            free += terrain.IsFootprintFreeNear(p.x(), p.y(), p.z(), profile.footprint_radius_m);
        }
      });
      agree = free / 10;
      return points.empty() ? 0.0 : 1e6 * ms / (10.0 * static_cast<double>(points.size()));
    };
    const double base_ns = query_ns(*leveled);
    const int classifier_free = agree;
    const double body_ns = query_ns(*truth);
    const double c = Median(classifier_ms), b = Median(body_ms);
    std::string name = std::filesystem::path(spec).filename().string();
    if (spec.rfind("builtin:", 0) == 0) name = spec;
    std::printf(
        "%-18s %10lld %12.1f %12.1f %6.2fx %14.0f %14.0f   (%d of %zu free points free to the classifier)\n",
        name.c_str(), static_cast<long long>(world->num_voxels()), c, b, c / b, base_ns, body_ns,
        classifier_free, points.size());
  }
  return 0;
}
