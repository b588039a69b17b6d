// Copyright Cairn authors.
//
// Map telemetry codec (zstd; the only translation unit that includes zstd.h) and robot-side sender.
#include "cairn/perception/map_telemetry.h"

#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <utility>

namespace cairn::perception {
namespace {

constexpr std::uint8_t kMagic[4] = {'C', 'V', 'X', '1'};
constexpr std::uint8_t kVersion = 1;
constexpr std::size_t kHeaderBytes = 9;
constexpr std::size_t kMaxVarintBytes = 5;         // A uint32 in LEB128.
constexpr std::size_t kMaxBodyBytesPerVoxel = 12;  // Three zigzag deltas < 2^22: 4 varint bytes each.
constexpr std::uint8_t kZstdFrameMagic[4] = {0x28, 0xB5, 0x2F, 0xFD};
constexpr std::size_t kMinMessageBytes = 256;
constexpr std::size_t kMaxRobotIdChars = 64;

// Voxel key: each index offset by kMaxCoarseIndex into 21 bits, x in the high bits, so key order is
// lexicographic (ix, iy, iz) order.
std::uint64_t PackKey(std::int32_t ix, std::int32_t iy, std::int32_t iz) {
  const auto u = [](std::int32_t i) {
    return static_cast<std::uint64_t>(static_cast<std::int64_t>(i) + kMaxCoarseIndex);
  };
  return (u(ix) << 42) | (u(iy) << 21) | u(iz);
}

CoarseVoxel UnpackKey(std::uint64_t key, CoarseState state) {
  const auto s = [](std::uint64_t u) {
    return static_cast<std::int32_t>(static_cast<std::int64_t>(u & ((1u << 21) - 1)) - kMaxCoarseIndex);
  };
  CoarseVoxel v;
  v.ix = s(key >> 42);
  v.iy = s(key >> 21);
  v.iz = s(key);
  v.state = state;
  return v;
}

bool IndexInRange(std::int64_t i) { return i >= -kMaxCoarseIndex && i < kMaxCoarseIndex; }

bool StateValid(CoarseState s) { return s == CoarseState::kFree || s == CoarseState::kOccupied; }

std::string VoxelName(const CoarseVoxel& v) {
  std::ostringstream msg;
  msg << "(" << v.ix << ", " << v.iy << ", " << v.iz << ")";
  return msg.str();
}

void CheckVoxel(const CoarseVoxel& v, const char* where) {
  if (!IndexInRange(v.ix) || !IndexInRange(v.iy) || !IndexInRange(v.iz)) {
    throw std::invalid_argument(std::string(where) + ": voxel " + VoxelName(v) + " has an index outside [-" +
                                std::to_string(kMaxCoarseIndex) + ", " + std::to_string(kMaxCoarseIndex - 1) +
                                "]");
  }
  if (!StateValid(v.state)) {
    throw std::invalid_argument(std::string(where) + ": voxel " + VoxelName(v) + " has invalid state " +
                                std::to_string(static_cast<int>(v.state)) +
                                " (expected 1 = free, 2 = occupied)");
  }
}

bool LexLess(const CoarseVoxel& a, const CoarseVoxel& b) {
  return std::tie(a.ix, a.iy, a.iz) < std::tie(b.ix, b.iy, b.iz);
}

void PutVarint(std::uint32_t value, std::vector<std::uint8_t>* out) {
  while (value >= 0x80) {
    out->push_back(static_cast<std::uint8_t>(value | 0x80));
    value >>= 7;
  }
  out->push_back(static_cast<std::uint8_t>(value));
}

std::uint32_t ZigZag(std::int32_t v) {
  return (static_cast<std::uint32_t>(v) << 1) ^ static_cast<std::uint32_t>(v >> 31);
}

std::int32_t UnZigZag(std::uint32_t u) { return static_cast<std::int32_t>((u >> 1) ^ (~(u & 1) + 1)); }

struct CCtxDeleter {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
struct DCtxDeleter {
  void operator()(ZSTD_DCtx* d) const { ZSTD_freeDCtx(d); }
};

ZSTD_CCtx* ThreadCCtx() {
  thread_local std::unique_ptr<ZSTD_CCtx, CCtxDeleter> ctx(ZSTD_createCCtx());
  return ctx.get();
}

ZSTD_DCtx* ThreadDCtx() {
  thread_local std::unique_ptr<ZSTD_DCtx, DCtxDeleter> ctx(ZSTD_createDCtx());
  return ctx.get();
}

bool Fail(std::string* error, const std::string& message) {
  if (error != nullptr) *error = message;
  return false;
}

// Reads the varint at body[*pos] (voxel #`voxel` of `count`, its index on `axis`) into `value`, moving *pos
// past it; false (and `error`) for one too long, cut off by the body's end, or over 32 bits.
bool ReadVarint(const std::uint8_t* body, std::size_t size, std::size_t* pos, std::size_t count,
                std::size_t voxel, const char* axis, std::uint32_t* value, std::string* error) {
  std::uint64_t v = 0;
  for (std::size_t i = 0;; ++i) {
    if (i == kMaxVarintBytes) {
      std::ostringstream msg;
      msg << "varint of voxel #" << voxel << " axis " << axis << " at body byte " << *pos
          << " is longer than " << kMaxVarintBytes << " bytes";
      return Fail(error, msg.str());
    }
    if (*pos >= size) {
      std::ostringstream msg;
      msg << "truncated varint: body ends (" << size << " bytes) inside voxel #" << voxel << " axis " << axis
          << " of " << count;
      return Fail(error, msg.str());
    }
    const std::uint8_t b = body[(*pos)++];
    v |= static_cast<std::uint64_t>(b & 0x7F) << (7 * i);
    if ((b & 0x80) == 0) break;
  }
  if (v > 0xFFFFFFFFull) {
    std::ostringstream msg;
    msg << "varint of voxel #" << voxel << " axis " << axis << " overflows 32 bits";
    return Fail(error, msg.str());
  }
  *value = static_cast<std::uint32_t>(v);
  return true;
}

// The body's first part: `count` voxel indices, each axis a zigzag varint of the difference to the voxel
// before, strictly ascending in (ix, iy, iz), into `out` (states not set); *pos moves past them.
bool ParseIndices(const std::uint8_t* body, std::size_t size, std::size_t count, std::size_t* pos,
                  std::vector<CoarseVoxel>* out, std::string* error) {
  out->clear();
  out->reserve(count);
  std::int64_t prev[3] = {0, 0, 0};
  static const char* const kAxis[3] = {"x", "y", "z"};
  for (std::size_t k = 0; k < count; ++k) {
    std::int64_t cur[3];
    for (int a = 0; a < 3; ++a) {
      std::uint32_t u = 0;
      if (!ReadVarint(body, size, pos, count, k, kAxis[a], &u, error)) return false;
      cur[a] = prev[a] + UnZigZag(u);
      if (!IndexInRange(cur[a])) {
        std::ostringstream msg;
        msg << "voxel #" << k << " index " << kAxis[a] << " = " << cur[a] << " is outside [-"
            << kMaxCoarseIndex << ", " << kMaxCoarseIndex - 1 << "]";
        return Fail(error, msg.str());
      }
    }
    CoarseVoxel v;
    v.ix = static_cast<std::int32_t>(cur[0]);
    v.iy = static_cast<std::int32_t>(cur[1]);
    v.iz = static_cast<std::int32_t>(cur[2]);
    if (k > 0) {
      const CoarseVoxel& p = out->back();
      if (!LexLess(p, v)) {
        std::ostringstream msg;
        if (p.ix == v.ix && p.iy == v.iy && p.iz == v.iz) {
          msg << "duplicate voxel " << VoxelName(v) << " at #" << k;
        } else {
          msg << "voxels not in ascending (ix, iy, iz) order: #" << k << " " << VoxelName(v) << " after "
              << VoxelName(p);
        }
        return Fail(error, msg.str());
      }
    }
    out->push_back(v);
    std::copy(cur, cur + 3, prev);
  }
  return true;
}

// The body's second part, from body[pos]: a 2-bit state per voxel of `out`, four to a byte, zero padding, and
// nothing after.
bool ParseStates(const std::uint8_t* body, std::size_t size, std::size_t pos, std::vector<CoarseVoxel>* out,
                 std::string* error) {
  const std::size_t count = out->size();
  const std::size_t state_bytes = (count + 3) / 4;
  if (size - pos < state_bytes) {
    std::ostringstream msg;
    msg << "truncated states: " << size - pos << " bytes left for " << count << " voxels, need "
        << state_bytes;
    return Fail(error, msg.str());
  }
  for (std::size_t k = 0; k < count; ++k) {
    const unsigned code = (body[pos + k / 4] >> (2 * (k % 4))) & 3u;
    if (code != static_cast<unsigned>(CoarseState::kFree) &&
        code != static_cast<unsigned>(CoarseState::kOccupied)) {
      std::ostringstream msg;
      msg << "voxel #" << k << " " << VoxelName((*out)[k]) << " has invalid state code " << code
          << " (expected 1 = free, 2 = occupied)";
      return Fail(error, msg.str());
    }
    (*out)[k].state = static_cast<CoarseState>(code);
  }
  if (count % 4 != 0) {
    const unsigned padding = body[pos + state_bytes - 1] >> (2 * (count % 4));
    if (padding != 0) return Fail(error, "padding bits after the last state are not 0");
  }
  pos += state_bytes;
  if (pos != size) {
    std::ostringstream msg;
    msg << size - pos << " trailing bytes after the states of " << count << " voxels";
    return Fail(error, msg.str());
  }
  return true;
}

// Parses the decompressed body of `count` voxels into `out`.
bool ParseBody(const std::uint8_t* body, std::size_t size, std::size_t count, std::vector<CoarseVoxel>* out,
               std::string* error) {
  std::size_t pos = 0;
  return ParseIndices(body, size, count, &pos, out, error) && ParseStates(body, size, pos, out, error);
}

}  // namespace

std::vector<std::uint8_t> EncodeCoarseVoxels(std::vector<CoarseVoxel> voxels, int zstd_level) {
  if (zstd_level < 1 || zstd_level > 19) {
    throw std::invalid_argument("EncodeCoarseVoxels: zstd_level = " + std::to_string(zstd_level) +
                                " must be in [1, 19]");
  }
  if (voxels.size() > 0xFFFFFFFFull)
    throw std::invalid_argument("EncodeCoarseVoxels: more than 2^32 - 1 voxels");
  for (const CoarseVoxel& v : voxels) CheckVoxel(v, "EncodeCoarseVoxels");
  std::sort(voxels.begin(), voxels.end(), LexLess);
  for (std::size_t k = 1; k < voxels.size(); ++k) {
    if (!LexLess(voxels[k - 1], voxels[k])) {
      throw std::invalid_argument("EncodeCoarseVoxels: voxel " + VoxelName(voxels[k]) + " appears twice");
    }
  }

  const std::size_t n = voxels.size();
  std::vector<std::uint8_t> body;
  body.reserve(n * 3 + (n + 3) / 4 + 16);
  std::int32_t prev[3] = {0, 0, 0};
  for (const CoarseVoxel& v : voxels) {
    const std::int32_t cur[3] = {v.ix, v.iy, v.iz};
    for (int a = 0; a < 3; ++a) PutVarint(ZigZag(cur[a] - prev[a]), &body);  // |difference| < 2^21.
    std::copy(cur, cur + 3, prev);
  }
  const std::size_t states_at = body.size();
  body.resize(states_at + (n + 3) / 4, 0);
  for (std::size_t k = 0; k < n; ++k) {
    body[states_at + k / 4] |=
        static_cast<std::uint8_t>(static_cast<unsigned>(voxels[k].state) << (2 * (k % 4)));
  }

  std::vector<std::uint8_t> out(kHeaderBytes);
  std::memcpy(out.data(), kMagic, 4);
  out[4] = kVersion;
  const auto count = static_cast<std::uint32_t>(n);
  for (int i = 0; i < 4; ++i) out[5 + i] = static_cast<std::uint8_t>(count >> (8 * i));
  ZstdCompressAppend(body, zstd_level, "EncodeCoarseVoxels", &out);
  return out;
}

void ZstdCompressAppend(const std::vector<std::uint8_t>& raw, int zstd_level, const char* caller,
                        std::vector<std::uint8_t>* out) {
  if (zstd_level < 1 || zstd_level > 19) {
    throw std::invalid_argument(std::string(caller) + ": zstd_level = " + std::to_string(zstd_level) +
                                " must be in [1, 19]");
  }
  const std::size_t at = out->size();
  out->resize(at + ZSTD_compressBound(raw.size()));
  ZSTD_CCtx* cctx = ThreadCCtx();
  if (cctx == nullptr) throw std::runtime_error(std::string(caller) + ": ZSTD_createCCtx failed");
  ZSTD_CCtx_reset(cctx, ZSTD_reset_session_and_parameters);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_compressionLevel, zstd_level);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_checksumFlag, 1);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_contentSizeFlag, 1);
  const std::size_t written =
      ZSTD_compress2(cctx, out->data() + at, out->size() - at, raw.data(), raw.size());
  if (ZSTD_isError(written)) {
    throw std::runtime_error(std::string(caller) + ": zstd: " + ZSTD_getErrorName(written));
  }
  out->resize(at + written);
}

bool ZstdDecompress(const std::uint8_t* frame, std::size_t frame_size, std::size_t max_bytes,
                    std::vector<std::uint8_t>* out, std::string* error) {
  out->clear();
  if (frame == nullptr && frame_size > 0) return Fail(error, "null data with a non-zero size");
  if (frame_size < 4 || std::memcmp(frame, kZstdFrameMagic, 4) != 0) {
    return Fail(error, "no zstd frame (missing or bad frame magic)");
  }
  const std::size_t compressed = ZSTD_findFrameCompressedSize(frame, frame_size);
  if (ZSTD_isError(compressed)) {
    return Fail(error, std::string("corrupt or truncated zstd frame: ") + ZSTD_getErrorName(compressed));
  }
  if (compressed != frame_size) {
    return Fail(error, std::to_string(frame_size - compressed) + " trailing bytes after the zstd frame");
  }
  const unsigned long long declared = ZSTD_getFrameContentSize(frame, frame_size);
  if (declared == ZSTD_CONTENTSIZE_ERROR) return Fail(error, "corrupt zstd frame header");
  if (declared == ZSTD_CONTENTSIZE_UNKNOWN)
    return Fail(error, "zstd frame does not declare its content size");
  if (declared > max_bytes) {
    return Fail(error, "zstd frame declares " + std::to_string(declared) +
                           " decompressed bytes, over the cap of " + std::to_string(max_bytes) +
                           " (decompression bomb?)");
  }
  out->resize(static_cast<std::size_t>(declared));
  ZSTD_DCtx* dctx = ThreadDCtx();
  if (dctx == nullptr) return Fail(error, "ZSTD_createDCtx failed");
  ZSTD_DCtx_reset(dctx, ZSTD_reset_session_and_parameters);
  // `out` has exactly the declared size: zstd never writes past it (it fails with dstSize_tooSmall).
  const std::size_t got = ZSTD_decompressDCtx(dctx, out->data(), out->size(), frame, frame_size);
  if (ZSTD_isError(got)) {
    out->clear();
    return Fail(error, std::string("zstd decompression failed: ") + ZSTD_getErrorName(got));
  }
  if (got != out->size()) {
    const std::size_t want = out->size();
    out->clear();
    return Fail(error, "zstd frame decompressed to " + std::to_string(got) + " bytes, declared " +
                           std::to_string(want));
  }
  return true;
}

bool DecodeCoarseVoxels(const std::uint8_t* data, std::size_t size, std::size_t max_voxels,
                        std::vector<CoarseVoxel>* out, std::string* error) {
  out->clear();
  if (data == nullptr && size > 0) return Fail(error, "null data with a non-zero size");
  if (size < kHeaderBytes) {
    return Fail(error,
                "truncated header: " + std::to_string(size) + " bytes, need " + std::to_string(kHeaderBytes));
  }
  if (std::memcmp(data, kMagic, 4) != 0) {
    std::ostringstream msg;
    msg << "bad magic 0x" << std::hex;
    for (int i = 0; i < 4; ++i) msg << (data[i] < 16 ? "0" : "") << static_cast<int>(data[i]);
    msg << " (expected \"CVX1\")";
    return Fail(error, msg.str());
  }
  if (data[4] != kVersion) {
    return Fail(error, "unsupported version " + std::to_string(data[4]) + " (this decoder reads version " +
                           std::to_string(kVersion) + ")");
  }
  std::uint32_t count = 0;
  for (int i = 0; i < 4; ++i) count |= static_cast<std::uint32_t>(data[5 + i]) << (8 * i);
  if (count > max_voxels) {
    return Fail(error, "voxel count " + std::to_string(count) + " exceeds the limit of " +
                           std::to_string(max_voxels));
  }

  const std::size_t cap = static_cast<std::size_t>(count) * kMaxBodyBytesPerVoxel + (count + 3) / 4;
  std::vector<std::uint8_t> body;
  std::string why;
  if (!ZstdDecompress(data + kHeaderBytes, size - kHeaderBytes, cap, &body, &why)) {
    return Fail(error, why + " (after the header, for " + std::to_string(count) + " voxels)");
  }
  if (!ParseBody(body.data(), body.size(), count, out, error)) {
    out->clear();
    return false;
  }
  return true;
}

// ---------------------------------------------------------------------------------------------------------
// MapTelemetrySender
// ---------------------------------------------------------------------------------------------------------

bool MapTelemetryOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  if (!std::isfinite(budget_bits_per_s) || budget_bits_per_s < 1e3 || budget_bits_per_s > 1e8) {
    msg << "MapTelemetryOptions::budget_bits_per_s = " << budget_bits_per_s << " must be in [1e3, 1e8]";
  } else if (!std::isfinite(period_s) || period_s < 0.01 || period_s > 60.0) {
    msg << "MapTelemetryOptions::period_s = " << period_s << " must be in [0.01, 60] s";
  } else if (!std::isfinite(burst_s) || burst_s < 0.1 || burst_s > 60.0) {
    msg << "MapTelemetryOptions::burst_s = " << burst_s << " must be in [0.1, 60] s";
  } else if (per_message_overhead_bytes < 0 || per_message_overhead_bytes > 10000) {
    msg << "MapTelemetryOptions::per_message_overhead_bytes = " << per_message_overhead_bytes
        << " must be in [0, 10000]";
  } else if (max_message_bytes < kMinMessageBytes || max_message_bytes > (1u << 20)) {
    msg << "MapTelemetryOptions::max_message_bytes = " << max_message_bytes << " must be in [256, 1048576]";
  } else if (zstd_level < 1 || zstd_level > 19) {
    msg << "MapTelemetryOptions::zstd_level = " << zstd_level << " must be in [1, 19]";
  } else if (budget_bits_per_s * burst_s / 8.0 <
             per_message_overhead_bytes + static_cast<double>(kMinMessageBytes)) {
    msg << "MapTelemetryOptions: the token bucket (budget_bits_per_s * burst_s / 8 = "
        << budget_bits_per_s * burst_s / 8.0
        << " bytes) must hold per_message_overhead_bytes + 256 = " << per_message_overhead_bytes + 256
        << " bytes";
  } else {
    return true;
  }
  if (why != nullptr) *why = msg.str();
  return false;
}

MapTelemetrySender::MapTelemetrySender(std::string robot_id, double resolution_m,
                                       const MapTelemetryOptions& options)
    : robot_id_(std::move(robot_id)), resolution_m_(resolution_m), options_(options) {
  if (robot_id_.empty() || robot_id_.size() > kMaxRobotIdChars) {
    throw std::invalid_argument("MapTelemetrySender: robot_id '" + robot_id_ +
                                "' must have 1 to 64 characters");
  }
  if (!std::isfinite(resolution_m_) || resolution_m_ <= 0.0) {
    throw std::invalid_argument("MapTelemetrySender: resolution_m = " + std::to_string(resolution_m_) +
                                " must be finite and > 0");
  }
  std::string why;
  if (!options_.IsValid(&why)) throw std::invalid_argument("MapTelemetrySender: " + why);
}

void MapTelemetrySender::AddChanges(const std::vector<CoarseVoxel>& changes) {
  for (const CoarseVoxel& v : changes) CheckVoxel(v, "MapTelemetrySender::AddChanges");
  std::lock_guard<std::mutex> lock(mutex_);
  for (const CoarseVoxel& v : changes) {
    const std::uint64_t key = PackKey(v.ix, v.iy, v.iz);
    const auto sent = sent_.find(key);
    if (sent != sent_.end() && sent->second == v.state) {
      pending_.erase(key);  // Back to what basestations have.
      continue;
    }
    const auto [it, inserted] = pending_.try_emplace(key, Pending{v.state, pending_counter_});
    if (inserted) {
      ++pending_counter_;
    } else {
      it->second.state = v.state;  // Keeps its age.
    }
  }
}

void MapTelemetrySender::RequestSnapshot() {
  std::lock_guard<std::mutex> lock(mutex_);
  ++stats_.snapshot_requests;
  const bool current_untouched = next_chunk_ < snapshot_chunks_.size() && next_chunk_ == 0;
  if (!current_untouched) snapshot_requested_ = true;
}

std::size_t MapTelemetrySender::ChunkLimitBytes() const {
  const double bucket_bytes =
      options_.budget_bits_per_s * options_.burst_s / 8.0 - options_.per_message_overhead_bytes;
  return std::min(options_.max_message_bytes, static_cast<std::size_t>(bucket_bytes));
}

namespace {

// Encodes voxels [begin, begin + n) of `voxels` with as many voxels n as fit in `limit` bytes (0 if not even
// one fits), starting from the estimate `guess`; returns n and the payload in `payload`.
std::size_t EncodeFitting(const std::vector<CoarseVoxel>& voxels, std::size_t begin, std::size_t guess,
                          std::size_t limit, int zstd_level, std::vector<std::uint8_t>* payload) {
  const std::size_t available = std::min(voxels.size() - begin, kMaxVoxelsPerUpdate);
  std::size_t n = std::clamp<std::size_t>(guess, 1, available);
  std::size_t best_n = 0;
  std::vector<std::uint8_t> best;
  std::size_t too_big = available + 1;  // Smallest count known not to fit.
  for (int attempt = 0; attempt < 12 && n >= 1; ++attempt) {
    std::vector<std::uint8_t> enc =
        EncodeCoarseVoxels(std::vector<CoarseVoxel>(voxels.begin() + static_cast<std::ptrdiff_t>(begin),
                                                    voxels.begin() + static_cast<std::ptrdiff_t>(begin + n)),
                           zstd_level);
    const double ratio = static_cast<double>(limit) / static_cast<double>(enc.size());
    if (enc.size() <= limit) {
      if (n > best_n) {
        best_n = n;
        best = std::move(enc);
      }
      // Good enough: everything, or over 80 % of the limit, or the next count up is known to be too big.
      if (n == available || ratio < 1.25 || n + 1 >= too_big) break;
      n = std::min(
          {available, too_big - 1, static_cast<std::size_t>(static_cast<double>(n) * ratio * 0.9) + 1});
      if (n <= best_n) break;
    } else {
      too_big = std::min(too_big, n);
      if (n == 1) break;
      n = std::max<std::size_t>(
          1, std::min(n - 1, static_cast<std::size_t>(static_cast<double>(n) * ratio * 0.9)));
      if (n <= best_n) break;
    }
  }
  if (best_n == 0 && available > 0) {  // The estimates never fitted: one voxel always fits a valid limit.
    std::vector<std::uint8_t> one = EncodeCoarseVoxels({voxels[begin]}, zstd_level);
    if (one.size() <= limit) {
      best_n = 1;
      best = std::move(one);
    }
  }
  *payload = std::move(best);
  return best_n;
}

}  // namespace

void MapTelemetrySender::StartSnapshot() {
  std::vector<CoarseVoxel> voxels;
  voxels.reserve(sent_.size());
  for (const auto& [key, state] : sent_) voxels.push_back(UnpackKey(key, state));
  std::sort(voxels.begin(), voxels.end(), LexLess);  // Spatially coherent chunks compress best.
  const std::size_t limit = ChunkLimitBytes();
  std::vector<std::vector<std::uint8_t>> payloads;
  std::size_t begin = 0;
  std::size_t guess =
      std::max<std::size_t>(1, static_cast<std::size_t>(static_cast<double>(limit) / bytes_per_voxel_));
  do {
    std::vector<std::uint8_t> payload;
    std::size_t n = 0;
    if (voxels.empty()) {
      payload = EncodeCoarseVoxels({}, options_.zstd_level);
    } else {
      n = EncodeFitting(voxels, begin, guess, limit, options_.zstd_level, &payload);
      if (n == 0) throw std::logic_error("MapTelemetrySender: one voxel does not fit a message");  // IsValid.
      guess = n;
    }
    payloads.push_back(std::move(payload));
    begin += n;
  } while (begin < voxels.size());

  ++last_snapshot_id_;
  snapshot_chunks_.clear();
  next_chunk_ = 0;
  for (std::size_t i = 0; i < payloads.size(); ++i) {
    MapUpdate m;
    m.robot_id = robot_id_;
    m.seq = last_seq_;
    m.snapshot_id = last_snapshot_id_;
    m.kind = MapUpdateKind::kSnapshot;
    m.chunk_index = static_cast<std::uint32_t>(i);
    m.chunk_count = static_cast<std::uint32_t>(payloads.size());
    m.base_seq = last_seq_;
    m.resolution_m = resolution_m_;
    m.data = std::move(payloads[i]);
    snapshot_chunks_.push_back(std::move(m));
  }
}

bool MapTelemetrySender::EmitDelta(std::vector<MapUpdate>* out) {
  const double overhead_bits = 8.0 * options_.per_message_overhead_bytes;
  const double room_bytes = (tokens_bits_ - overhead_bits) / 8.0;
  if (room_bytes < 1.0) return false;
  const std::size_t limit = std::min(ChunkLimitBytes(), static_cast<std::size_t>(room_bytes));

  // Priority: occupied before free, then oldest first (see the class comment).
  std::vector<std::pair<std::uint64_t, const Pending*>> order;
  order.reserve(pending_.size());
  for (const auto& [key, p] : pending_) order.emplace_back(key, &p);
  const auto before = [](const std::pair<std::uint64_t, const Pending*>& a,
                         const std::pair<std::uint64_t, const Pending*>& b) {
    const bool occ_a = a.second->state == CoarseState::kOccupied;
    const bool occ_b = b.second->state == CoarseState::kOccupied;
    if (occ_a != occ_b) return occ_a;
    return a.second->since < b.second->since;
  };
  // Only the voxels this message can hold are ordered: the count the running bytes-per-voxel estimate
  // guesses, with room to grow when they compress better (a thin link with a large backlog sends a few
  // hundred voxels per message; ordering up to 65,536 of the backlog for each was most of its cost).
  const auto guess = static_cast<std::size_t>(static_cast<double>(limit) / bytes_per_voxel_);
  const std::size_t useful = std::min({order.size(), kMaxVoxelsPerUpdate, 2 * guess + 64});
  std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(useful), order.end(), before);
  order.resize(useful);
  std::vector<CoarseVoxel> voxels;
  voxels.reserve(order.size());
  for (const auto& [key, p] : order) voxels.push_back(UnpackKey(key, p->state));

  std::vector<std::uint8_t> payload;
  const std::size_t n = EncodeFitting(voxels, 0, guess, limit, options_.zstd_level, &payload);
  if (n == 0) return false;
  if (n >= 16)
    bytes_per_voxel_ = std::max(0.05, static_cast<double>(payload.size()) / static_cast<double>(n));

  for (std::size_t k = 0; k < n; ++k) {
    const std::uint64_t key = order[k].first;
    sent_[key] = voxels[k].state;
    pending_.erase(key);
  }
  MapUpdate m;
  m.robot_id = robot_id_;
  m.seq = ++last_seq_;
  m.snapshot_id = 0;
  m.kind = MapUpdateKind::kDelta;
  m.chunk_index = 0;
  m.chunk_count = 1;
  m.base_seq = m.seq - 1;
  m.resolution_m = resolution_m_;
  m.data = std::move(payload);
  tokens_bits_ -= 8.0 * static_cast<double>(m.data.size()) + overhead_bits;
  ++stats_.delta_messages_sent;
  stats_.voxels_sent += n;
  stats_.payload_bytes_sent += m.data.size();
  stats_.budget_bytes_sent += m.data.size() + static_cast<std::size_t>(options_.per_message_overhead_bytes);
  ++stats_.messages_sent;
  out->push_back(std::move(m));
  return true;
}

void MapTelemetrySender::SetRateShare(double share) {
  if (!(share > 0.0 && share <= 1.0)) {
    throw std::invalid_argument("MapTelemetrySender::SetRateShare: share = " + std::to_string(share) +
                                " must be in (0, 1]");
  }
  std::lock_guard<std::mutex> lock(mutex_);
  rate_share_ = share;
}

std::vector<MapUpdate> MapTelemetrySender::Poll(double now_s) {
  if (!std::isfinite(now_s)) throw std::invalid_argument("MapTelemetrySender::Poll: now_s is not finite");
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<MapUpdate> out;
  const double depth_bits = options_.budget_bits_per_s * options_.burst_s;
  if (!started_) {
    started_ = true;
    tokens_bits_ = depth_bits;
    last_now_s_ = now_s;
    next_send_s_ = now_s;
  }
  if (now_s > last_now_s_) {
    tokens_bits_ =
        std::min(depth_bits, tokens_bits_ + rate_share_ * options_.budget_bits_per_s * (now_s - last_now_s_));
    last_now_s_ = now_s;
  }
  // Tolerance: a caller polling every period_s on a floating-point clock must not skip periods.
  if (last_now_s_ + 1e-6 * options_.period_s < next_send_s_) {
    stats_.tokens_bits = tokens_bits_;
    return out;
  }
  next_send_s_ = last_now_s_ + options_.period_s;

  const double overhead_bits = 8.0 * options_.per_message_overhead_bytes;
  for (;;) {
    if (next_chunk_ >= snapshot_chunks_.size() && snapshot_requested_) {
      snapshot_requested_ = false;
      StartSnapshot();
    }
    if (next_chunk_ < snapshot_chunks_.size()) {
      MapUpdate& chunk = snapshot_chunks_[next_chunk_];
      const double cost = 8.0 * static_cast<double>(chunk.data.size()) + overhead_bits;
      if (cost > tokens_bits_) break;  // Strict priority: DELTAs wait for the snapshot.
      tokens_bits_ -= cost;
      ++next_chunk_;
      ++stats_.snapshot_messages_sent;
      ++stats_.messages_sent;
      stats_.payload_bytes_sent += chunk.data.size();
      stats_.budget_bytes_sent +=
          chunk.data.size() + static_cast<std::size_t>(options_.per_message_overhead_bytes);
      out.push_back(std::move(chunk));
      if (next_chunk_ == snapshot_chunks_.size()) {
        ++stats_.snapshots_served;
        snapshot_chunks_.clear();
        next_chunk_ = 0;
      }
      continue;
    }
    if (pending_.empty() || !EmitDelta(&out)) break;
  }
  stats_.tokens_bits = tokens_bits_;
  return out;
}

MapTelemetryStats MapTelemetrySender::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  MapTelemetryStats s = stats_;
  s.voxels_pending = pending_.size();
  s.voxels_known = sent_.size();
  s.snapshot_chunks_queued = snapshot_chunks_.size() - next_chunk_;
  s.last_seq = last_seq_;
  return s;
}

}  // namespace cairn::perception
