// Shared by the fuzz harnesses (fuzz/*_fuzz.cpp): the input as a file, for decoders that read files.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <fstream>
#include <string>

namespace cairn::fuzz {

/// Writes `data` to this process's scratch file with extension `ext` (".bt", ".pcd", ...) and returns its
/// path; the same path on every call, so a run leaves one file behind per harness and process.
inline std::string AsFile(const std::uint8_t* data, std::size_t size, const std::string& ext) {
  const std::string path = "/tmp/cairn_fuzz_" + std::to_string(::getpid()) + ext;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

}  // namespace cairn::fuzz
