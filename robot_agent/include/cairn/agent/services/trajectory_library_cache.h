// The agent's cache of built trajectory libraries (nav::TrajectoryLibrary): building the local planner's
// library is the largest part of an agent's start (~0.15-0.25 s of ~0.65 s on a 2-core x86-64 VM with the
// agent's 0.05 m voxels, more on an ARM robot computer), and it is the same every start with the same
// options. CMU's FALCO planner loads its precomputed correspondence from files the same way.
//
// One file per option set, a zstd frame (with its content checksum) of TrajectoryLibrary::Serialize(), named
// by TrajectoryLibrary::Fingerprint. A file that does not load (damaged, from another build or format, other
// options) is reported and replaced; a folder that cannot be written only costs the rebuild. The cache never
// stops an agent from starting.
#pragma once

#include <memory>
#include <string>

#include "cairn/nav/local_planner.h"

namespace cairn::agent {

/// The cache folder: `configured` (AgentOptions::library_cache_dir, config local_planner.library_cache_dir)
/// when set, "" for "off"; else $XDG_CACHE_HOME/cairn, else $HOME/.cache/cairn; "" when neither is set.
std::string TrajectoryLibraryCacheDir(const std::string& configured);

/// File name of the library of `options` in a cache folder: "trajectory_library_v<format>_<fingerprint, 16
/// hex digits>.zst".
std::string TrajectoryLibraryCacheFile(const nav::TrajectoryLibraryOptions& options);

/// A library and how it was obtained.
struct CachedLibrary {
  std::shared_ptr<const nav::TrajectoryLibrary> library;
  bool loaded = false;        ///< true: read from the cache; false: built
  bool cache_failed = false;  ///< a cache file was refused, or could not be written (worth a warning)
  /// For the log: "loaded from F in 31 ms" | "built in 240 ms, cached in F" | "built in 240 ms; F was
  /// refused (reason) and replaced" | "built in 240 ms; not cached: reason".
  std::string how;
};

/// The library of `options`, from `cache_dir` (TrajectoryLibraryCacheDir; "" = no cache) when a valid file is
/// there, else built and written there (atomically: a temporary file renamed, so that agents starting
/// together never read a half-written file).
/// @throws std::invalid_argument if `options` is invalid (as nav::TrajectoryLibrary).
CachedLibrary LoadOrBuildTrajectoryLibrary(const nav::TrajectoryLibraryOptions& options,
                                           const std::string& cache_dir);

}  // namespace cairn::agent
