// Shared by the fuzz harnesses (fuzz/*_fuzz.cpp): the input as a file, for decoders that read files, and as a
// CDR sample, for decoders of DDS messages.
#pragma once

#include <fastdds/rtps/common/SerializedPayload.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
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

/// Deserializes `data` (a CDR payload with its encapsulation header) as fastddsgen type `PubSubT` into
/// `*out`, as Fast DDS does with every sample from the link: true if it decoded, false if it was refused or
/// threw.
template <class PubSubT>
bool DeserializeCdr(const std::uint8_t* data, std::size_t size, typename PubSubT::type* out) {
  PubSubT type;
  eprosima::fastrtps::rtps::SerializedPayload_t payload(static_cast<std::uint32_t>(size));
  if (size > 0) std::memcpy(payload.data, data, size);
  payload.length = static_cast<std::uint32_t>(size);
  try {
    return type.deserialize(&payload, out);
  } catch (...) {
    return false;
  }
}

}  // namespace cairn::fuzz
