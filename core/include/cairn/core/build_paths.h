// Where this build found its sources and puts its products: absolute paths fixed when the build was
// configured, for the binaries' default files (the shipped config) and for tests and benches (data/, tools/,
// the built programs). They are compiled into one generated translation unit (build_paths.cpp in the build
// folder), not passed as compiler definitions: a path in a target's flags makes every object of that target
// differ between two clones, so a clone in another folder (a CI run's) would compile them all again instead
// of taking them from ccache.
#pragma once

#include <string>

namespace cairn::core {

/// The repository's root (CMake's CMAKE_SOURCE_DIR, absolute, no trailing slash): data/, config/ and tools/
/// are under it.
const std::string& SourceDir();
/// The shipped configuration folder, SourceDir() + "/config": dds_profiles.xml, mode_tree.xml, agent.yaml.
const std::string& ConfigDir();
/// The build folder (CMake's CMAKE_BINARY_DIR, absolute): the built programs and the tests' logs under it.
const std::string& BinaryDir();

}  // namespace cairn::core
