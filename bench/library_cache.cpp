// The agent's trajectory library: built at start against loaded from its cache (trajectory_library_cache.h),
// in the same process, for each platform's library as the agent makes it (AgentOptions::LibraryForPlatform).
// Prints the median of N runs of each, their ratio, the cache file's size and the library's memory.
//   build/bench/cairn_bench_library_cache [--runs N]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "bench_util.h"
#include "cairn/agent/agent_options.h"
#include "cairn/agent/services/trajectory_library_cache.h"

namespace {

using cairn::bench::Median;
using cairn::bench::TimeMs;

}  // namespace

int main(int argc, char** argv) {
  int runs = 5;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--runs" && i + 1 < argc) {
      runs = cairn::bench::RunsOrExit(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: %s [--runs N]\n", argv[0]);
      return 2;
    }
  }
  char pattern[] = "/tmp/cairn_bench_library_cache_XXXXXX";
  if (mkdtemp(pattern) == nullptr) {
    std::perror("mkdtemp");
    return 1;
  }
  const std::string dir = pattern;
  std::printf(
      "trajectory library of the agent: built (baseline) against loaded from the cache, median of %d\n",
      runs);
  std::printf("%-8s %10s %10s %7s %10s %10s\n", "platform", "build ms", "load ms", "ratio", "file MB",
              "memory MB");
  for (const std::string platform : {"wheeled", "legged"}) {
    cairn::agent::AgentOptions options;
    options.SetPlatform(platform);
    const auto library_options = options.LibraryForPlatform();
    std::vector<double> build_ms, load_ms;
    std::size_t memory = 0;
    for (int r = 0; r < runs; ++r) {
      build_ms.push_back(TimeMs([&] {
        const auto built = cairn::agent::LoadOrBuildTrajectoryLibrary(library_options, "");
        memory = built.library->memory_bytes();
      }));
    }
    cairn::agent::LoadOrBuildTrajectoryLibrary(library_options, dir);  // writes the file
    for (int r = 0; r < runs; ++r) {
      load_ms.push_back(TimeMs([&] {
        const auto loaded = cairn::agent::LoadOrBuildTrajectoryLibrary(library_options, dir);
        if (!loaded.loaded) {
          std::fprintf(stderr, "not loaded: %s\n", loaded.how.c_str());
          std::exit(1);
        }
      }));
    }
    const std::string file = dir + "/" + cairn::agent::TrajectoryLibraryCacheFile(library_options);
    const double build = Median(build_ms), load = Median(load_ms);
    std::printf("%-8s %10.1f %10.1f %7.2f %10.2f %10.1f\n", platform.c_str(), build, load, build / load,
                std::filesystem::file_size(file) / 1e6, memory / 1e6);
  }
  std::filesystem::remove_all(dir);
  return 0;
}
