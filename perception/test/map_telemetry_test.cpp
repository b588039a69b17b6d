// Copyright Cairn authors.
#include "cairn/perception/map_telemetry.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <stdlib.h>
#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <map>
#include <random>
#include <set>
#include <thread>
#include <tuple>

namespace cairn::perception {
namespace {

using Key = std::tuple<std::int32_t, std::int32_t, std::int32_t>;
using Truth = std::map<Key, CoarseState>;

CoarseVoxel V(std::int32_t ix, std::int32_t iy, std::int32_t iz, CoarseState s = CoarseState::kFree) {
  CoarseVoxel v;
  v.ix = ix;
  v.iy = iy;
  v.iz = iz;
  v.state = s;
  return v;
}
constexpr CoarseState kOcc = CoarseState::kOccupied;
constexpr CoarseState kFree = CoarseState::kFree;

bool LexLess(const CoarseVoxel& a, const CoarseVoxel& b) {
  return std::tie(a.ix, a.iy, a.iz) < std::tie(b.ix, b.iy, b.iz);
}

std::vector<CoarseVoxel> Sorted(std::vector<CoarseVoxel> v) {
  std::sort(v.begin(), v.end(), LexLess);
  return v;
}

std::vector<CoarseVoxel> ToVector(const Truth& truth) {
  std::vector<CoarseVoxel> out;
  for (const auto& [k, s] : truth) out.push_back(V(std::get<0>(k), std::get<1>(k), std::get<2>(k), s));
  return out;  // std::map order is lexicographic.
}

// `n` distinct voxels with indices in [-span, span), random states.
std::vector<CoarseVoxel> RandomVoxels(std::mt19937* rng, std::size_t n, std::int32_t span) {
  std::uniform_int_distribution<std::int32_t> index(-span, span - 1);
  std::set<Key> seen;
  std::vector<CoarseVoxel> out;
  while (out.size() < n) {
    const Key k{index(*rng), index(*rng), index(*rng)};
    if (!seen.insert(k).second) continue;
    out.push_back(V(std::get<0>(k), std::get<1>(k), std::get<2>(k), ((*rng)() & 1) ? kOcc : kFree));
  }
  return out;
}

std::vector<CoarseVoxel> Decode(const std::vector<std::uint8_t>& payload, std::string* error = nullptr,
                                std::size_t max_voxels = kMaxVoxelsPerUpdate) {
  std::vector<CoarseVoxel> out;
  std::string why;
  const bool ok = DecodeCoarseVoxels(payload.data(), payload.size(), max_voxels, &out, &why);
  if (error != nullptr) *error = ok ? "" : why;
  EXPECT_TRUE(ok || out.empty());
  return out;
}

// A raw payload: header with `count`, `version`, `magic`, then `body` compressed by zstd (content size
// declared only if `declare_size`).
std::vector<std::uint8_t> RawPayload(const std::vector<std::uint8_t>& body, std::uint32_t count,
                                     bool declare_size = true, std::uint8_t version = 1,
                                     const char* magic = "CVX1") {
  std::vector<std::uint8_t> out(magic, magic + 4);
  out.push_back(version);
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>(count >> (8 * i)));
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_checksumFlag, 1);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_contentSizeFlag, declare_size ? 1 : 0);
  std::vector<std::uint8_t> frame(ZSTD_compressBound(body.size()));
  const std::size_t n = ZSTD_compress2(cctx, frame.data(), frame.size(), body.data(), body.size());
  ZSTD_freeCCtx(cctx);
  EXPECT_FALSE(ZSTD_isError(n));
  out.insert(out.end(), frame.begin(), frame.begin() + static_cast<std::ptrdiff_t>(n));
  return out;
}

std::uint8_t StateByte(std::initializer_list<int> codes) {
  unsigned b = 0;
  int k = 0;
  for (int c : codes) b |= static_cast<unsigned>(c) << (2 * k++);
  return static_cast<std::uint8_t>(b);
}

// Decoded output must satisfy the documented guarantees.
void ExpectValidVoxelList(const std::vector<CoarseVoxel>& voxels, std::size_t max_voxels) {
  ASSERT_LE(voxels.size(), max_voxels);
  for (std::size_t k = 0; k < voxels.size(); ++k) {
    const CoarseVoxel& v = voxels[k];
    for (std::int32_t i : {v.ix, v.iy, v.iz}) {
      ASSERT_GE(i, -kMaxCoarseIndex);
      ASSERT_LT(i, kMaxCoarseIndex);
    }
    ASSERT_TRUE(v.state == kFree || v.state == kOcc);
    if (k > 0) {
      ASSERT_TRUE(LexLess(voxels[k - 1], v));
    }
  }
}

// ------------------------------------------------------------------------------------------------------------
// Options
// ------------------------------------------------------------------------------------------------------------

TEST(MapTelemetryOptionsTest, DefaultsAreValid) {
  std::string why;
  EXPECT_TRUE(MapTelemetryOptions{}.IsValid(&why)) << why;
  EXPECT_TRUE(FleetMapOptions{}.IsValid(&why)) << why;
}

TEST(MapTelemetryOptionsTest, InvalidFieldsAreNamed) {
  std::string why;
  MapTelemetryOptions o;
  o.period_s = 0.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("period_s"), std::string::npos) << why;
  o = MapTelemetryOptions{};
  o.budget_bits_per_s = 2000;  // 250 bytes of bucket: smaller than overhead + 256.
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("token bucket"), std::string::npos) << why;
  o = MapTelemetryOptions{};
  o.zstd_level = 30;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("zstd_level"), std::string::npos) << why;
  EXPECT_THROW(MapTelemetrySender("r1", 0.2, o), std::invalid_argument);
  EXPECT_THROW(MapTelemetrySender("", 0.2), std::invalid_argument);
  EXPECT_THROW(MapTelemetrySender("r1", -1.0), std::invalid_argument);
  FleetMapOptions f;
  f.max_robots = 0;
  EXPECT_FALSE(f.IsValid(&why));
  EXPECT_NE(why.find("max_robots"), std::string::npos) << why;
  EXPECT_THROW(FleetMap{f}, std::invalid_argument);
}

// ------------------------------------------------------------------------------------------------------------
// Codec
// ------------------------------------------------------------------------------------------------------------

TEST(CoarseCodecTest, EmptyRoundTrip) {
  const std::vector<std::uint8_t> payload = EncodeCoarseVoxels({});
  std::string error;
  EXPECT_TRUE(Decode(payload, &error).empty());
  EXPECT_EQ(error, "");
}

TEST(CoarseCodecTest, RandomSetsRoundTrip) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 60; ++trial) {
    const std::size_t n = 1 + rng() % 3000;
    const std::int32_t span = trial % 3 == 0 ? kMaxCoarseIndex : (trial % 3 == 1 ? 40 : 2000);
    std::vector<CoarseVoxel> voxels = RandomVoxels(&rng, n, span);
    if (trial == 0) {  // Extreme indices.
      voxels.push_back(V(-kMaxCoarseIndex, -kMaxCoarseIndex, -kMaxCoarseIndex, kOcc));
      voxels.push_back(V(kMaxCoarseIndex - 1, kMaxCoarseIndex - 1, kMaxCoarseIndex - 1, kFree));
    }
    std::string error;
    const std::vector<CoarseVoxel> back = Decode(EncodeCoarseVoxels(voxels, 1 + trial % 5), &error);
    ASSERT_EQ(error, "") << "trial " << trial;
    ASSERT_EQ(back, Sorted(voxels)) << "trial " << trial;
  }
}

// A corridor-and-room shell at 0.2 m: free inside, occupied walls, floor and ceiling.
std::vector<CoarseVoxel> BlockScene(int nx, int ny, int nz) {
  std::vector<CoarseVoxel> out;
  for (int x = 0; x < nx; ++x)
    for (int y = 0; y < ny; ++y)
      for (int z = 0; z < nz; ++z) {
        const bool shell = y == 0 || y == ny - 1 || z == 0 || z == nz - 1;
        out.push_back(V(x, y, z, shell ? kOcc : kFree));
      }
  return out;
}

TEST(CoarseCodecTest, LargeSetRoundTripAndCompressionRatio) {
  const std::vector<CoarseVoxel> voxels = BlockScene(200, 16, 16);  // 51,200 voxels.
  ASSERT_LE(voxels.size(), kMaxVoxelsPerUpdate);
  const std::vector<std::uint8_t> payload = EncodeCoarseVoxels(voxels);
  ASSERT_EQ(Decode(payload), voxels);
  const double raw_bytes = 13.0 * static_cast<double>(voxels.size());  // 3 x int32 + state byte.
  const double ratio = raw_bytes / static_cast<double>(payload.size());
  std::printf(
      "FIGURE codec_ratio_block %zu voxels: %zu bytes (%.3f bytes/voxel), %.0fx smaller than 13 B/voxel\n",
      voxels.size(), payload.size(), static_cast<double>(payload.size()) / voxels.size(), ratio);
  EXPECT_GT(ratio, 50.0);

  std::mt19937 rng(3);
  const std::vector<CoarseVoxel> scattered = RandomVoxels(&rng, 20000, 200);
  const std::vector<std::uint8_t> p2 = EncodeCoarseVoxels(scattered);
  ASSERT_EQ(Decode(p2), Sorted(scattered));
  std::printf("FIGURE codec_ratio_random 20000 random voxels in a 400^3 box: %.3f bytes/voxel, %.1fx\n",
              static_cast<double>(p2.size()) / 20000.0, 13.0 * 20000.0 / p2.size());
  // kMaxVoxelsPerUpdate voxels decode with max_voxels = kMaxVoxelsPerUpdate.
  const std::vector<CoarseVoxel> most = BlockScene(256, 16, 16);
  ASSERT_EQ(most.size(), kMaxVoxelsPerUpdate);
  EXPECT_EQ(Decode(EncodeCoarseVoxels(most)).size(), kMaxVoxelsPerUpdate);
}

TEST(CoarseCodecTest, EncoderRejectsBrokenPreconditions) {
  EXPECT_THROW(EncodeCoarseVoxels({V(1, 2, 3), V(1, 2, 3, kOcc)}), std::invalid_argument);
  EXPECT_THROW(EncodeCoarseVoxels({V(kMaxCoarseIndex, 0, 0)}), std::invalid_argument);
  EXPECT_THROW(EncodeCoarseVoxels({V(0, -kMaxCoarseIndex - 1, 0)}), std::invalid_argument);
  EXPECT_THROW(EncodeCoarseVoxels({V(0, 0, 0, static_cast<CoarseState>(3))}), std::invalid_argument);
  EXPECT_THROW(EncodeCoarseVoxels({V(0, 0, 0)}, 0), std::invalid_argument);
}

struct MalformedCase {
  const char* name;
  std::vector<std::uint8_t> payload;
  const char* expected;  // Substring of the error.
};

TEST(CoarseCodecTest, RejectsEveryMalformedClassWithAMessage) {
  const std::vector<std::uint8_t> valid = EncodeCoarseVoxels({V(1, 2, 3, kOcc), V(4, 5, 6), V(-7, 8, 9)});
  std::vector<MalformedCase> cases;
  cases.push_back({"empty", {}, "truncated header"});
  cases.push_back({"short header", {valid.begin(), valid.begin() + 6}, "truncated header"});
  auto bad_magic = valid;
  bad_magic[0] = 'X';
  cases.push_back({"bad magic", bad_magic, "bad magic"});
  auto bad_version = valid;
  bad_version[4] = 2;
  cases.push_back({"bad version", bad_version, "unsupported version 2"});
  cases.push_back({"count over max", RawPayload({}, 70000), "exceeds the limit"});
  cases.push_back({"header only", {valid.begin(), valid.begin() + 9}, "no zstd frame"});
  auto flipped = valid;
  flipped[valid.size() - 6] ^= 0x5A;  // Inside the compressed block or checksum.
  cases.push_back({"corrupt frame", flipped, "zstd"});
  cases.push_back({"truncated frame", {valid.begin(), valid.end() - 3}, "truncated zstd frame"});
  auto trailing = valid;
  trailing.push_back(0);
  cases.push_back({"bytes after frame", trailing, "trailing bytes after the zstd frame"});
  const std::vector<std::uint8_t> one_voxel_body = {2, 4, 6, StateByte({1})};  // (1, 2, 3) free.
  cases.push_back({"unknown content size", RawPayload(one_voxel_body, 1, false), "does not declare"});
  cases.push_back(
      {"decompression bomb", RawPayload(std::vector<std::uint8_t>(1 << 20, 0), 1), "decompression bomb"});
  cases.push_back({"truncated varint", RawPayload({2, 4, 0x86}, 1), "truncated varint"});
  cases.push_back(
      {"overlong varint", RawPayload({0x80, 0x80, 0x80, 0x80, 0x80, 0x01, 0, 0}, 1), "longer than"});
  // zigzag(2^20) = 2^21 as a varint: 0x80 0x80 0x80 0x01.
  cases.push_back(
      {"index out of range", RawPayload({0x80, 0x80, 0x80, 0x01, 0, 0, StateByte({1})}, 1), "outside"});
  cases.push_back(
      {"duplicate voxel", RawPayload({2, 4, 6, 0, 0, 0, StateByte({1, 2})}, 2), "duplicate voxel"});
  cases.push_back({"unsorted", RawPayload({2, 4, 6, 0, 0, 1, StateByte({1, 2})}, 2), "not in ascending"});
  cases.push_back({"bad state code 3", RawPayload({2, 4, 6, StateByte({3})}, 1), "invalid state code 3"});
  cases.push_back(
      {"bad state code 0", RawPayload({2, 4, 6, 0, 0, 2, StateByte({1, 0})}, 2), "invalid state code 0"});
  cases.push_back({"padding bits", RawPayload({2, 4, 6, StateByte({1, 1})}, 1), "padding"});
  cases.push_back({"truncated states", RawPayload({2, 4, 6, 0, 0, 2}, 2), "truncated states"});
  cases.push_back(
      {"trailing body", RawPayload({2, 4, 6, StateByte({1}), 0}, 1), "trailing bytes after the states"});
  for (const MalformedCase& c : cases) {
    std::vector<CoarseVoxel> out = {V(9, 9, 9)};
    std::string error;
    EXPECT_FALSE(DecodeCoarseVoxels(c.payload.data(), c.payload.size(), kMaxVoxelsPerUpdate, &out, &error))
        << c.name;
    EXPECT_TRUE(out.empty()) << c.name;
    EXPECT_NE(error.find(c.expected), std::string::npos) << c.name << ": got \"" << error << "\"";
  }
  // The raw builder itself makes valid payloads: the same body with a correct count decodes.
  EXPECT_EQ(Decode(RawPayload(one_voxel_body, 1)), std::vector<CoarseVoxel>{V(1, 2, 3)});
}

TEST(CoarseCodecTest, FuzzedPayloadsAreRejectedOrValid) {
  std::mt19937 rng(11);
  std::vector<std::vector<std::uint8_t>> seeds;
  for (std::size_t n : {1u, 5u, 60u, 700u}) seeds.push_back(EncodeCoarseVoxels(RandomVoxels(&rng, n, 50)));
  seeds.push_back(EncodeCoarseVoxels(BlockScene(20, 8, 8)));
  int accepted = 0;
  int rejected = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    std::vector<std::uint8_t> p = seeds[rng() % seeds.size()];
    std::vector<std::uint8_t> body;
    const int kind = trial % 4;
    if (kind == 0) {  // Flip 1-4 bytes anywhere.
      for (int k = 1 + rng() % 4; k > 0; --k)
        p[rng() % p.size()] ^= static_cast<std::uint8_t>(1 + rng() % 255);
    } else if (kind == 1) {  // Truncate.
      p.resize(rng() % p.size());
    } else if (kind == 2) {  // Insert or append random bytes.
      const std::size_t at = rng() % (p.size() + 1);
      for (int k = 1 + rng() % 8; k > 0; --k)
        p.insert(p.begin() + static_cast<std::ptrdiff_t>(at), rng() & 0xFF);
    } else {  // Mutate the decompressed body and recompress: exercises the body parser past the checksum.
      const std::size_t declared = ZSTD_getFrameContentSize(p.data() + 9, p.size() - 9);
      body.resize(declared);
      ZSTD_decompress(body.data(), body.size(), p.data() + 9, p.size() - 9);
      if (!body.empty()) {
        for (int k = 1 + rng() % 3; k > 0; --k)
          body[rng() % body.size()] ^= static_cast<std::uint8_t>(1 + rng() % 255);
      }
      if (rng() % 4 == 0 && !body.empty()) body.resize(rng() % body.size());
      std::uint32_t count = p[5] | (p[6] << 8) | (p[7] << 16) | (static_cast<std::uint32_t>(p[8]) << 24);
      if (rng() % 4 == 0) count += static_cast<std::uint32_t>(rng() % 3) - 1;
      p = RawPayload(body, count);
    }
    std::vector<CoarseVoxel> out;
    std::string error;
    if (DecodeCoarseVoxels(p.data(), p.size(), 1000, &out, &error)) {
      ++accepted;
      ExpectValidVoxelList(out, 1000);
    } else {
      ++rejected;
      EXPECT_FALSE(error.empty());
      EXPECT_TRUE(out.empty());
    }
  }
  std::printf("fuzz: %d mutated payloads rejected, %d decoded to valid voxel lists\n", rejected, accepted);
  EXPECT_GT(rejected, 2500);
}

// ------------------------------------------------------------------------------------------------------------
// Exploration: a robot at 1 m/s along a corridor, then into a room (all of it seen at once: a big burst).
// Coarse voxels of 0.4 m: corridor ix in [0, 75), iy in [-4, 4], iz in [-1, 8] (walls |iy| = 4, floor
// iz = -1, ceiling iz = 8 occupied); room ix in [75, 125), iy in [-25, 25], iz in [-1, 12] (shell occupied).
// Like a real map, it is rough: 15 % of the inside is unseen (never sent), 4 % is clutter (occupied). A
// person walks in the corridor: each second a column (iz 0..3) turns occupied and the previous one free.
// ------------------------------------------------------------------------------------------------------------

constexpr double kRes = 0.4;

// Deterministic pseudo-random number in [0, 1) per voxel.
double Noise(int ix, int iy, int iz) {
  std::uint64_t h = (static_cast<std::uint64_t>(ix + 1000) * 73856093u) ^
                    (static_cast<std::uint64_t>(iy + 1000) * 19349663u) ^
                    (static_cast<std::uint64_t>(iz + 1000) * 83492791u);
  h ^= h >> 33;
  h *= 0xff51afd7ed558ccdull;
  h ^= h >> 33;
  return static_cast<double>(h % 1000003u) / 1000003.0;
}

// Appends (ix, iy, iz) to `out` unless unseen; inside voxels may be clutter.
void AddSeen(int ix, int iy, int iz, bool shell, std::vector<CoarseVoxel>* out) {
  const double r = Noise(ix, iy, iz);
  if (shell) {
    out->push_back(V(ix, iy, iz, kOcc));
  } else if (r < 0.15) {
    return;  // Unseen.
  } else {
    out->push_back(V(ix, iy, iz, r < 0.19 ? kOcc : kFree));
  }
}

class Exploration {
 public:
  explicit Exploration(double end_s = 34.0) : end_s_(end_s) {}

  // Changes between the previous call and time t_s; also applied to truth().
  std::vector<CoarseVoxel> ChangesUntil(double t_s) {
    std::vector<CoarseVoxel> changes;
    if (t_s > end_s_) t_s = end_s_;
    const double x_m = t_s * 1.0;
    const int reach = std::min(75, static_cast<int>(std::floor((x_m + 6.0) / kRes)));
    for (; next_slice_ < reach; ++next_slice_) {
      for (int iy = -4; iy <= 4; ++iy)
        for (int iz = -1; iz <= 8; ++iz)
          AddSeen(next_slice_, iy, iz, std::abs(iy) == 4 || iz == -1 || iz == 8, &changes);
    }
    if (!room_seen_ && x_m >= 28.0) {
      room_seen_ = true;
      room_time_s_ = t_s;
      const std::size_t before = changes.size();
      for (int ix = 75; ix < 125; ++ix)
        for (int iy = -25; iy <= 25; ++iy)
          for (int iz = -1; iz <= 12; ++iz) {
            const bool shell = ix == 124 || std::abs(iy) == 25 || iz == -1 || iz == 12 ||
                               (ix == 75 && (std::abs(iy) >= 4 || iz >= 8));
            AddSeen(ix, iy, iz, shell, &changes);
          }
      room_voxels_ = changes.size() - before;
    }
    const int second = static_cast<int>(t_s);
    if (second != person_second_ && next_slice_ > 20) {
      const int col = 10 + second % 8;
      for (int iz = 0; iz <= 3; ++iz) {
        if (person_col_ >= 0) changes.push_back(V(person_col_, 1, iz, kFree));
        changes.push_back(V(col, 1, iz, kOcc));
      }
      person_col_ = col;
      person_second_ = second;
    }
    for (const CoarseVoxel& v : changes) truth_[{v.ix, v.iy, v.iz}] = v.state;
    return changes;
  }

  const Truth& truth() const { return truth_; }
  double room_time_s() const { return room_time_s_; }
  std::size_t room_voxels() const { return room_voxels_; }
  bool done(double t_s) const { return t_s >= end_s_; }

 private:
  double end_s_;
  int next_slice_ = 0;
  bool room_seen_ = false;
  double room_time_s_ = -1.0;
  std::size_t room_voxels_ = 0;
  int person_second_ = -1;
  int person_col_ = -1;
  Truth truth_;
};

struct Sent {
  double t_s;
  MapUpdate update;
};

void ApplyOk(FleetMap* map, const MapUpdate& u) {
  std::string error;
  EXPECT_TRUE(map->Apply(u.robot_id, u, &error)) << error;
}

// Every window [t_i, t_j] carries at most budget * (burst + t_j - t_i) bits.
void ExpectWithinBudget(const std::vector<Sent>& log, const MapTelemetryOptions& o) {
  for (std::size_t i = 0; i < log.size(); ++i) {
    double bits = 0.0;
    for (std::size_t j = i; j < log.size(); ++j) {
      bits += 8.0 * static_cast<double>(log[j].update.data.size() + o.per_message_overhead_bytes);
      const double allowed = o.budget_bits_per_s * (o.burst_s + log[j].t_s - log[i].t_s);
      ASSERT_LE(bits, allowed + 1e-6) << "window [" << log[i].t_s << ", " << log[j].t_s << "] s";
    }
  }
}

// Runs the exploration through a sender with options `o` into one basestation, until everything is sent.
// Checks the budget over every window, that the basestation ends equal to the robot's map, and the priority
// of occupied voxels in the room burst. Returns the largest number of voxels left pending after a Poll().
std::size_t RunExploration(const MapTelemetryOptions& o) {
  MapTelemetrySender sender("r1", kRes, o);
  Exploration world;
  FleetMap base;
  std::vector<Sent> log;
  std::size_t max_pending_after_poll = 0;
  double drained_s = -1.0;
  double room_sent_s = -1.0;  // When nothing was pending any more after the room burst.
  for (int step = 0; step <= 1200; ++step) {
    const double t = 0.1 * step;
    sender.AddChanges(world.ChangesUntil(t));
    for (MapUpdate& u : sender.Poll(t)) {
      ApplyOk(&base, u);
      log.push_back({t, std::move(u)});
    }
    const MapTelemetryStats s = sender.stats();
    max_pending_after_poll = std::max(max_pending_after_poll, s.voxels_pending);
    if (room_sent_s < 0.0 && world.room_time_s() >= 0.0 && s.voxels_pending == 0) room_sent_s = t;
    if (world.done(t) && s.voxels_pending == 0) {
      drained_s = t;
      break;
    }
  }
  EXPECT_GT(drained_s, 0.0) << "the sender never caught up";
  ExpectWithinBudget(log, o);
  EXPECT_EQ(base.Voxels("r1"), ToVector(world.truth()));
  EXPECT_FALSE(base.NeedsSnapshot("r1"));
  EXPECT_EQ(base.Stats().drops.total(), 0u);

  // Priority: after the room appeared, no occupied room voxel is sent after the first free room voxel.
  std::size_t first_free = log.size();
  std::size_t last_occupied = 0;
  for (std::size_t i = 0; i < log.size(); ++i) {
    if (log[i].t_s < world.room_time_s()) continue;
    for (const CoarseVoxel& v : Decode(log[i].update.data)) {
      if (v.ix < 75) continue;  // Corridor (the person keeps moving there).
      if (v.state == kOcc) last_occupied = std::max(last_occupied, i);
      if (v.state == kFree) first_free = std::min(first_free, i);
    }
  }
  EXPECT_LE(last_occupied, first_free);
  const MapTelemetryStats s = sender.stats();
  std::printf(
      "FIGURE exploration budget %.0f kbit/s: %zu voxels, %llu messages, %.1f kbit/s mean; room burst of %zu "
      "voxels at t = %.1f s, all sent by t = %.1f s, at most %zu voxels pending\n",
      o.budget_bits_per_s / 1000.0, world.truth().size(), static_cast<unsigned long long>(s.messages_sent),
      8.0 * static_cast<double>(s.budget_bytes_sent) / drained_s / 1000.0, world.room_voxels(),
      world.room_time_s(), room_sent_s, max_pending_after_poll);
  return max_pending_after_poll;
}

TEST(MapTelemetrySenderTest, ExplorationWithinDefaultBudgetLosesNothing) {
  RunExploration(MapTelemetryOptions{});
}

TEST(MapTelemetrySenderTest, ExplorationWithTightBudgetWaitsAndLosesNothing) {
  MapTelemetryOptions o;
  o.budget_bits_per_s = 20000;  // The room burst takes several seconds.
  // The burst did not fit: voxels waited (the test exercises the budget).
  EXPECT_GT(RunExploration(o), 10000u);
}

TEST(MapTelemetrySenderTest, ChangeBackIsNotSentAndLatestStateWins) {
  MapTelemetrySender sender("r1", kRes);
  FleetMap base;
  sender.AddChanges({V(0, 0, 0, kFree)});
  for (const MapUpdate& u : sender.Poll(0.0)) ApplyOk(&base, u);
  EXPECT_EQ(sender.stats().last_seq, 1u);
  sender.AddChanges({V(0, 0, 0, kOcc), V(1, 0, 0, kFree)});
  sender.AddChanges({V(0, 0, 0, kFree), V(1, 0, 0, kOcc)});  // (0,0,0) is back to what was sent.
  EXPECT_EQ(sender.stats().voxels_pending, 1u);
  const std::vector<MapUpdate> out = sender.Poll(0.1);
  EXPECT_TRUE(out.empty()) << "period not elapsed";
  const std::vector<MapUpdate> out2 = sender.Poll(0.5);
  ASSERT_EQ(out2.size(), 1u);
  EXPECT_EQ(Decode(out2[0].data), std::vector<CoarseVoxel>{V(1, 0, 0, kOcc)});
  EXPECT_THROW(sender.AddChanges({V(0, 0, 0), V(kMaxCoarseIndex, 0, 0)}), std::invalid_argument);
  EXPECT_EQ(sender.stats().voxels_pending, 0u) << "a rejected batch changes nothing";
}

// A radio link shared by four robots: each sends at a quarter of its budget (the bucket refills 4x slower).
TEST(MapTelemetrySenderTest, RateShareScalesTheRefillNotTheBurst) {
  auto sent_bytes_in_20_s = [](double share) {
    MapTelemetryOptions o;
    o.budget_bits_per_s = 20000;
    MapTelemetrySender sender("r1", kRes, o);
    sender.SetRateShare(share);
    std::vector<CoarseVoxel> changes;  // far more than 20 s of budget: noise-like states, poorly compressible
    std::uint32_t bits = 12345;
    for (int i = 0; i < 200000; ++i) {
      bits = bits * 1103515245u + 12345u;
      changes.push_back(V(i % 400 - 200, (i / 400) % 250 - 125, i / 100000, (bits >> 16) % 2 ? kOcc : kFree));
    }
    sender.AddChanges(changes);
    for (int step = 0; step <= 200; ++step) sender.Poll(0.1 * step);
    return static_cast<double>(sender.stats().budget_bytes_sent);
  };
  const double full = sent_bytes_in_20_s(1.0), quarter = sent_bytes_in_20_s(0.25);
  const double depth_bytes = 20000 * 1.0 / 8;
  EXPECT_LE(full, 20000 * 20.0 / 8 + depth_bytes);
  EXPECT_GE(full, 0.9 * 20000 * 20.0 / 8);  // the budget was the limit, not the changes
  EXPECT_LE(quarter, 0.25 * 20000 * 20.0 / 8 + depth_bytes);
  EXPECT_GE(quarter, 0.8 * 0.25 * 20000 * 20.0 / 8);
  MapTelemetrySender sender("r1", kRes);
  EXPECT_THROW(sender.SetRateShare(0.0), std::invalid_argument);
  EXPECT_THROW(sender.SetRateShare(1.5), std::invalid_argument);
}

// The DDS layer in a test: robot messages go to every basestation that has joined; a basestation whose map
// needs a snapshot asks, at most every 2 s.
struct Basestation {
  std::string name;
  double join_s = 0.0;
  std::size_t hold_chunks_for_deltas = 0;  // > 0: delays SNAPSHOT chunks (and reverses them) past deltas.
  FleetMap map;
  double last_request_s = -1e9;
  std::deque<MapUpdate> held;
  std::size_t deltas_since_hold = 0;
  double held_since_s = 0.0;

  void Receive(double t_s, const MapUpdate& u) {
    if (t_s < join_s) return;
    if (hold_chunks_for_deltas == 0) {
      Deliver(u);
      return;
    }
    if (u.kind == MapUpdateKind::kSnapshot) {
      if (held.empty()) held_since_s = t_s;
      held.push_front(u);  // Reversed order.
      return;
    }
    Deliver(u);
    ++deltas_since_hold;
    Flush(t_s, false);
  }
  void Flush(double t_s, bool force) {
    if (held.empty()) return;
    if (!force && deltas_since_hold < hold_chunks_for_deltas && t_s - held_since_s < 3.0) return;
    for (const MapUpdate& h : held) Deliver(h);
    held.clear();
    deltas_since_hold = 0;
  }
  void Deliver(const MapUpdate& u) {
    std::string error;
    MapDropReason reason{};
    if (!map.Apply(u.robot_id, u, &error, &reason)) {
      // Only stale snapshot chunks may be dropped (a newer snapshot overtook a held one).
      EXPECT_EQ(reason, MapDropReason::kOutOfOrder) << name << ": " << error;
    }
  }
};

TEST(MapTelemetrySenderTest, LateJoinersEndEqualToEarlyJoinerAndSender) {
  MapTelemetryOptions o;
  o.max_message_bytes = 1500;  // Several chunks per snapshot.
  MapTelemetrySender sender("r1", kRes, o);
  Exploration world;
  std::vector<std::unique_ptr<Basestation>> bases;
  for (const auto& [name, join, hold] :
       std::vector<std::tuple<const char*, double, std::size_t>>{{"early", 0.0, 0},
                                                                 {"late", 12.0, 0},
                                                                 {"during_burst", 29.0, 0},
                                                                 {"reordered", 12.0, 3},
                                                                 {"reordered_burst", 30.5, 2}}) {
    auto b = std::make_unique<Basestation>();
    b->name = name;
    b->join_s = join;
    b->hold_chunks_for_deltas = hold;
    bases.push_back(std::move(b));
  }
  std::vector<Sent> log;
  bool settled = false;
  for (int step = 0; step <= 2000 && !settled; ++step) {
    const double t = 0.1 * step;
    sender.AddChanges(world.ChangesUntil(t));
    for (MapUpdate& u : sender.Poll(t)) {
      for (auto& b : bases) b->Receive(t, u);
      log.push_back({t, std::move(u)});
    }
    for (auto& b : bases) {
      b->Flush(t, false);
      if (t >= b->join_s && b->map.NeedsSnapshot("r1") && t - b->last_request_s >= 2.0) {
        sender.RequestSnapshot();
        b->last_request_s = t;
      }
    }
    const MapTelemetryStats s = sender.stats();
    settled = world.done(t) && s.voxels_pending == 0 && s.snapshot_chunks_queued == 0;
    for (auto& b : bases) settled = settled && b->held.empty() && !b->map.NeedsSnapshot("r1");
  }
  ASSERT_TRUE(settled);
  ExpectWithinBudget(log, o);
  const std::vector<CoarseVoxel> truth = ToVector(world.truth());
  for (auto& b : bases) {
    EXPECT_EQ(b->map.Voxels("r1"), truth) << b->name;
    RobotMapStats rs;
    ASSERT_TRUE(b->map.GetRobotStats("r1", &rs));
    if (b->join_s > 0.0) {
      EXPECT_GE(rs.snapshots_completed, 1u) << b->name;
    }
  }
  const MapTelemetryStats s = sender.stats();
  EXPECT_GE(s.snapshots_served, 2u);
  std::printf("late joiners: %llu snapshot requests, %llu snapshots served in %llu chunks\n",
              static_cast<unsigned long long>(s.snapshot_requests),
              static_cast<unsigned long long>(s.snapshots_served),
              static_cast<unsigned long long>(s.snapshot_messages_sent));
}

TEST(MapTelemetrySenderTest, SnapshotChunksFitLimitsAndEmptySnapshotIsOneChunk) {
  MapTelemetryOptions o;
  o.max_message_bytes = 300;
  MapTelemetrySender sender("r1", kRes, o);
  sender.RequestSnapshot();
  std::vector<MapUpdate> out = sender.Poll(0.0);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].kind, MapUpdateKind::kSnapshot);
  EXPECT_EQ(out[0].chunk_count, 1u);
  EXPECT_EQ(out[0].base_seq, 0u);
  FleetMap late;
  ApplyOk(&late, out[0]);
  EXPECT_FALSE(late.NeedsSnapshot("r1"));

  std::mt19937 rng(5);
  sender.AddChanges(RandomVoxels(&rng, 3000, 30));
  double t = 0.5;
  while (sender.stats().voxels_pending > 0) sender.Poll(t += 0.5);
  sender.RequestSnapshot();
  sender.RequestSnapshot();  // Coalesced: no chunk sent yet.
  std::vector<MapUpdate> chunks;
  while (chunks.empty() || sender.stats().snapshot_chunks_queued > 0) {
    for (MapUpdate& u : sender.Poll(t += 0.5)) chunks.push_back(std::move(u));
  }
  ASSERT_GT(chunks.size(), 3u);
  for (const MapUpdate& c : chunks) {
    EXPECT_LE(c.data.size(), o.max_message_bytes);
    EXPECT_EQ(c.snapshot_id, 2u);
    EXPECT_EQ(c.chunk_count, chunks.size());
    EXPECT_EQ(c.base_seq, sender.stats().last_seq);
  }
  EXPECT_EQ(sender.stats().snapshots_served, 2u);
  std::size_t n = 0;
  for (const MapUpdate& c : chunks) n += Decode(c.data).size();
  EXPECT_EQ(n, 3000u);
}

// ------------------------------------------------------------------------------------------------------------
// FleetMap
// ------------------------------------------------------------------------------------------------------------

MapUpdate Delta(const std::string& robot, std::uint32_t seq, const std::vector<CoarseVoxel>& voxels,
                double res = kRes) {
  MapUpdate u;
  u.robot_id = robot;
  u.seq = seq;
  u.kind = MapUpdateKind::kDelta;
  u.base_seq = seq - 1;
  u.resolution_m = res;
  u.data = EncodeCoarseVoxels(voxels);
  return u;
}

MapUpdate Chunk(const std::string& robot, std::uint32_t id, std::uint32_t base, std::uint32_t index,
                std::uint32_t count, const std::vector<CoarseVoxel>& voxels) {
  MapUpdate u;
  u.robot_id = robot;
  u.seq = base;
  u.snapshot_id = id;
  u.kind = MapUpdateKind::kSnapshot;
  u.chunk_index = index;
  u.chunk_count = count;
  u.base_seq = base;
  u.resolution_m = kRes;
  u.data = EncodeCoarseVoxels(voxels);
  return u;
}

MapDropReason Reject(FleetMap* map, const MapUpdate& u, std::string* error = nullptr) {
  std::string why;
  MapDropReason reason{};
  EXPECT_FALSE(map->Apply(u.robot_id, u, &why, &reason));
  EXPECT_FALSE(why.empty());
  if (error != nullptr) *error = why;
  return reason;
}

TEST(FleetMapTest, GapDetectionAndHealing) {
  FleetMap map;
  ApplyOk(&map, Delta("r1", 1, {V(0, 0, 0)}));
  ApplyOk(&map, Delta("r1", 2, {V(1, 0, 0)}));
  EXPECT_FALSE(map.NeedsSnapshot("r1"));
  ApplyOk(&map, Delta("r1", 4, {V(3, 0, 0)}));  // 3 missed.
  EXPECT_TRUE(map.NeedsSnapshot("r1"));
  RobotMapStats rs;
  ASSERT_TRUE(map.GetRobotStats("r1", &rs));
  EXPECT_EQ(rs.complete_through_seq, 2u);
  EXPECT_EQ(rs.last_seq, 4u);
  ApplyOk(&map, Delta("r1", 3, {V(2, 0, 0), V(3, 0, 0, kOcc)}));  // Late: fills the hole, older than 4.
  EXPECT_FALSE(map.NeedsSnapshot("r1"));
  EXPECT_EQ(map.Voxels("r1"), (std::vector<CoarseVoxel>{V(0, 0, 0), V(1, 0, 0), V(2, 0, 0), V(3, 0, 0)}))
      << "a late DELTA must not undo a newer one";

  ApplyOk(&map, Delta("r1", 6, {V(5, 0, 0)}));  // 5 lost for good: a snapshot at base >= 5 heals it.
  EXPECT_TRUE(map.NeedsSnapshot("r1"));
  ApplyOk(&map, Chunk("r1", 1, 5, 1, 2, {V(4, 0, 0, kOcc), V(5, 0, 0, kOcc)}));
  EXPECT_TRUE(map.NeedsSnapshot("r1")) << "snapshot incomplete";
  ApplyOk(&map, Chunk("r1", 1, 5, 0, 2, {V(0, 0, 0), V(1, 0, 0), V(2, 0, 0), V(3, 0, 0)}));
  EXPECT_FALSE(map.NeedsSnapshot("r1"));
  ASSERT_TRUE(map.GetRobotStats("r1", &rs));
  EXPECT_EQ(rs.complete_through_seq, 6u);
  EXPECT_EQ(map.Voxels("r1")[4], V(4, 0, 0, kOcc));
  EXPECT_EQ(map.Voxels("r1")[5], V(5, 0, 0, kFree)) << "the snapshot (base 5) must not overwrite DELTA 6";

  // A first DELTA without a base.
  FleetMap late;
  ApplyOk(&late, Delta("r2", 9, {V(0, 0, 0)}));
  EXPECT_TRUE(late.NeedsSnapshot("r2"));
  EXPECT_FALSE(late.NeedsSnapshot("never-heard"));
}

TEST(FleetMapTest, SnapshotNeverOverwritesNewerDeltas) {
  // Sender-made stream: V free in DELTA 1; snapshot taken at base 1; V occupied in DELTA 2. The receiver gets
  // DELTA 2 first, then the snapshot.
  MapTelemetrySender sender("r1", kRes);
  sender.AddChanges({V(0, 0, 0, kFree), V(1, 0, 0, kOcc)});
  const std::vector<MapUpdate> d1 = sender.Poll(0.0);
  sender.RequestSnapshot();
  sender.AddChanges({V(0, 0, 0, kOcc)});
  const std::vector<MapUpdate> s1 = sender.Poll(0.5);  // Snapshot chunk, then DELTA 2.
  ASSERT_EQ(d1.size(), 1u);
  ASSERT_EQ(s1.size(), 2u);
  ASSERT_EQ(s1[0].kind, MapUpdateKind::kSnapshot);
  ASSERT_EQ(s1[1].kind, MapUpdateKind::kDelta);
  EXPECT_EQ(s1[0].base_seq, 1u);
  FleetMap map;
  ApplyOk(&map, s1[1]);
  EXPECT_TRUE(map.NeedsSnapshot("r1"));
  ApplyOk(&map, s1[0]);
  EXPECT_FALSE(map.NeedsSnapshot("r1"));
  EXPECT_EQ(map.Voxels("r1"), (std::vector<CoarseVoxel>{V(0, 0, 0, kOcc), V(1, 0, 0, kOcc)}));
  EXPECT_EQ(Reject(&map, d1[0]), MapDropReason::kOutOfOrder);  // Covered by the snapshot.
}

TEST(FleetMapTest, MergeRuleOccupiedWinsThenFree) {
  FleetMap map;
  ApplyOk(&map, Delta("a", 1, {V(0, 0, 0, kOcc), V(1, 0, 0, kFree), V(2, 0, 0, kFree)}));
  ApplyOk(&map, Delta("b", 1, {V(0, 0, 0, kFree), V(1, 0, 0, kOcc), V(3, 0, 0, kFree)}));
  EXPECT_EQ(map.Voxels(), (std::vector<CoarseVoxel>{V(0, 0, 0, kOcc), V(1, 0, 0, kOcc), V(2, 0, 0, kFree),
                                                    V(3, 0, 0, kFree)}));
  ApplyOk(&map, Delta("a", 2, {V(0, 0, 0, kFree)}));  // Nobody says occupied any more.
  EXPECT_EQ(map.Voxels()[0], V(0, 0, 0, kFree));
  FleetMapStats s = map.Stats();
  EXPECT_EQ(s.robots, 2u);
  EXPECT_EQ(s.voxels, 4u);
  EXPECT_EQ(s.occupied, 1u);
  EXPECT_EQ(map.Robots(), (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(map.Voxels("a").size(), 3u);
  EXPECT_TRUE(map.Voxels("nobody").empty());
}

TEST(FleetMapTest, RejectsAndCountsBadMessagesWithReasons) {
  FleetMap map;
  ApplyOk(&map, Delta("r1", 1, {V(0, 0, 0)}));
  ApplyOk(&map, Delta("r1", 2, {V(1, 0, 0)}));
  std::string error;
  EXPECT_EQ(Reject(&map, Delta("r1", 2, {V(5, 0, 0)}), &error), MapDropReason::kOutOfOrder);
  EXPECT_NE(error.find("r1"), std::string::npos) << error;
  ApplyOk(&map, Delta("r1", 4, {V(3, 0, 0)}));
  EXPECT_EQ(Reject(&map, Delta("r1", 4, {V(3, 0, 0)}), &error), MapDropReason::kDuplicate);
  EXPECT_NE(error.find("already received"), std::string::npos) << error;
  EXPECT_EQ(Reject(&map, Delta("r2", 1, {V(0, 0, 0)}, 0.8), &error), MapDropReason::kResolutionMismatch);
  EXPECT_NE(error.find("0.8"), std::string::npos) << error;
  EXPECT_NE(error.find("0.4"), std::string::npos) << error;
  EXPECT_EQ(Reject(&map, Delta("r1", 5, {V(0, 0, 0)}, 0.2)), MapDropReason::kResolutionMismatch);
  MapUpdate u = Delta("r1", 5, {V(0, 0, 0)});
  EXPECT_FALSE(map.Apply("r9", u, &error));  // Robot id mismatch.
  u.base_seq = 7;
  EXPECT_EQ(Reject(&map, u), MapDropReason::kBadHeader);
  u = Delta("r1", 5, {V(0, 0, 0)});
  u.seq = 0;
  EXPECT_EQ(Reject(&map, u), MapDropReason::kBadHeader);
  u = Delta("r1", 5, {V(0, 0, 0)});
  u.resolution_m = std::nan("");
  EXPECT_EQ(Reject(&map, u), MapDropReason::kBadHeader);
  u = Delta("r1", 5, {V(0, 0, 0)});
  u.kind = static_cast<MapUpdateKind>(7);
  EXPECT_EQ(Reject(&map, u), MapDropReason::kBadHeader);
  u = Delta("r1", 5, {V(0, 0, 0)});
  u.data.back() ^= 0xFF;
  EXPECT_EQ(Reject(&map, u, &error), MapDropReason::kMalformedPayload);
  EXPECT_NE(error.find("payload"), std::string::npos) << error;
  // Snapshots.
  EXPECT_EQ(Reject(&map, Chunk("r1", 0, 4, 0, 1, {})), MapDropReason::kBadHeader);
  EXPECT_EQ(Reject(&map, Chunk("r1", 1, 4, 2, 2, {})), MapDropReason::kBadHeader);
  MapUpdate c = Chunk("r1", 1, 4, 0, 2, {});
  c.seq = 3;
  EXPECT_EQ(Reject(&map, c), MapDropReason::kBadHeader);
  ApplyOk(&map, Chunk("r1", 3, 4, 0, 2, {V(2, 0, 0)}));
  EXPECT_EQ(Reject(&map, Chunk("r1", 3, 4, 0, 2, {V(2, 0, 0)})), MapDropReason::kDuplicate);
  EXPECT_EQ(Reject(&map, Chunk("r1", 3, 4, 1, 3, {})), MapDropReason::kSnapshotMismatch);
  EXPECT_EQ(Reject(&map, Chunk("r1", 2, 4, 1, 2, {})), MapDropReason::kOutOfOrder);
  ApplyOk(&map, Chunk("r1", 3, 4, 1, 2, {}));
  EXPECT_EQ(Reject(&map, Chunk("r1", 3, 4, 1, 2, {})), MapDropReason::kOutOfOrder);  // Already complete.
  EXPECT_FALSE(map.NeedsSnapshot("r1"));
  FleetMapOptions small;
  small.max_robots = 1;
  small.max_voxels_per_robot = 3;
  FleetMap limited(small);
  ApplyOk(&limited, Delta("a", 1, {V(0, 0, 0)}));
  EXPECT_EQ(Reject(&limited, Delta("b", 1, {V(0, 0, 0)})), MapDropReason::kLimitExceeded);
  EXPECT_EQ(Reject(&limited, Delta("a", 2, {V(1, 0, 0), V(2, 0, 0), V(3, 0, 0)})),
            MapDropReason::kLimitExceeded);

  const MapDropCounts d = map.Stats().drops;
  EXPECT_EQ(d[MapDropReason::kOutOfOrder], 3u);
  EXPECT_EQ(d[MapDropReason::kDuplicate], 2u);
  EXPECT_EQ(d[MapDropReason::kResolutionMismatch], 2u);
  EXPECT_EQ(d[MapDropReason::kMalformedPayload], 1u);
  EXPECT_EQ(d[MapDropReason::kSnapshotMismatch], 1u);
  EXPECT_EQ(d[MapDropReason::kBadHeader], 8u);
  EXPECT_EQ(d.total(), 17u);
  EXPECT_STREQ(ToString(MapDropReason::kMalformedPayload), "malformed_payload");
}

struct MapState {
  std::vector<CoarseVoxel> fleet, r1;
  RobotMapStats stats;
  std::size_t voxels, occupied;
  std::uint64_t bytes, applied;
  bool operator==(const MapState& o) const {
    return fleet == o.fleet && r1 == o.r1 && stats.voxels == o.stats.voxels &&
           stats.last_seq == o.stats.last_seq && stats.complete_through_seq == o.stats.complete_through_seq &&
           stats.needs_snapshot == o.stats.needs_snapshot && stats.has_base == o.stats.has_base &&
           stats.bytes_received == o.stats.bytes_received && voxels == o.voxels && occupied == o.occupied &&
           bytes == o.bytes && applied == o.applied;
  }
};

MapState Capture(const FleetMap& map) {
  MapState s;
  s.fleet = map.Voxels();
  s.r1 = map.Voxels("r1");
  map.GetRobotStats("r1", &s.stats);
  const FleetMapStats f = map.Stats();
  s.voxels = f.voxels;
  s.occupied = f.occupied;
  s.bytes = f.bytes_received;
  s.applied = f.updates_applied;
  return s;
}

TEST(FleetMapTest, MalformedMessagesNeverAlterTheMap) {
  FleetMap map;
  ApplyOk(&map, Delta("r1", 1, BlockScene(10, 6, 6)));
  ApplyOk(&map, Delta("r1", 3, {V(0, 0, 0, kOcc)}));  // Leaves a gap: snapshot 1 is being collected below.
  ApplyOk(&map, Chunk("r1", 1, 2, 0, 3, {V(50, 0, 0)}));
  const MapState before = Capture(map);
  std::mt19937 rng(13);
  const std::vector<MapUpdate> goods = {Delta("r1", 4, {V(1, 1, 1, kOcc), V(2, 2, 2)}),
                                        Chunk("r1", 1, 2, 1, 3, RandomVoxels(&rng, 40, 20)),
                                        Chunk("r1", 2, 3, 0, 1, RandomVoxels(&rng, 40, 20))};
  int tried = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    MapUpdate u = goods[rng() % goods.size()];
    if (trial % 2 == 0) {
      for (int k = 1 + rng() % 3; k > 0; --k)
        u.data[rng() % u.data.size()] ^= static_cast<std::uint8_t>(1 + rng() % 255);
    } else {
      u.data.resize(rng() % u.data.size());
    }
    std::vector<CoarseVoxel> ignored;
    if (DecodeCoarseVoxels(u.data.data(), u.data.size(), kMaxVoxelsPerUpdate, &ignored, nullptr)) continue;
    ++tried;
    EXPECT_EQ(Reject(&map, u), MapDropReason::kMalformedPayload);
  }
  EXPECT_GT(tried, 2900);
  EXPECT_TRUE(Capture(map) == before);
  EXPECT_EQ(map.Stats().drops[MapDropReason::kMalformedPayload], static_cast<std::uint64_t>(tried));
  // And the good ones still apply afterwards.
  for (const MapUpdate& u : goods) ApplyOk(&map, u);
}

std::string TempPath(const std::string& name) { return ::testing::TempDir() + "cairn_map_telemetry_" + name; }

// Every leaf of the .bt at `path`, expanded to the tree's resolution, as voxels (key - 2^15).
std::vector<CoarseVoxel> ReadBtVoxels(const std::string& path, double* resolution_m) {
  octomap::OcTree tree(0.1);
  EXPECT_TRUE(tree.readBinary(path));
  *resolution_m = tree.getResolution();
  tree.expand();
  std::vector<CoarseVoxel> out;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    EXPECT_EQ(it.getDepth(), tree.getTreeDepth());
    const octomap::OcTreeKey k = it.getKey();
    out.push_back(V(k[0] - 32768, k[1] - 32768, k[2] - 32768, tree.isNodeOccupied(*it) ? kOcc : kFree));
  }
  return Sorted(out);
}

TEST(FleetMapTest, SaveBtRoundTripsThroughOctoMap) {
  FleetMap map;
  std::string error;
  EXPECT_FALSE(map.SaveBt(TempPath("none.bt"), "", &error));
  std::vector<CoarseVoxel> a = BlockScene(30, 8, 8);
  for (CoarseVoxel& v : a) v.ix -= 15;  // Negative indices too.
  ApplyOk(&map, Delta("a", 1, a));
  ApplyOk(&map, Delta("b", 1, {V(-15, 1, 1, kOcc), V(100, -200, 3, kFree), V(-32768, 32767, 0, kOcc)}));
  for (const std::string robot : {"", "a", "b"}) {
    const std::string path = TempPath("fleet_" + robot + ".bt");
    ASSERT_TRUE(map.SaveBt(path, robot, &error)) << error;
    double res = 0.0;
    EXPECT_EQ(ReadBtVoxels(path, &res), map.Voxels(robot)) << "robot '" << robot << "'";
    EXPECT_DOUBLE_EQ(res, kRes);
    std::remove(path.c_str());
  }
  EXPECT_FALSE(map.SaveBt(TempPath("x.bt"), "nobody", &error));
  EXPECT_NE(error.find("unknown robot"), std::string::npos) << error;
  EXPECT_FALSE(map.SaveBt("/nonexistent-dir/x.bt", "", &error));
  EXPECT_NE(error.find("cannot open"), std::string::npos) << error;
  ApplyOk(&map, Delta("b", 2, {V(40000, 0, 0)}));
  EXPECT_FALSE(map.SaveBt(TempPath("far.bt"), "b", &error));
  EXPECT_NE(error.find("key range"), std::string::npos) << error;
}

TEST(FleetMapTest, ConcurrentApplyAndReads) {
  FleetMap map;
  std::vector<std::thread> threads;
  threads.reserve(3);
  for (int r = 0; r < 3; ++r) {
    threads.emplace_back([&map, r] {
      const std::string id = "r" + std::to_string(r);
      for (std::uint32_t seq = 1; seq <= 200; ++seq) {
        std::string error;
        EXPECT_TRUE(map.Apply(
            id, Delta(id, seq, {V(static_cast<std::int32_t>(seq), r, 0, (seq % 2) ? kOcc : kFree)}), &error))
            << error;
      }
    });
  }
  threads.emplace_back([&map] {
    for (int i = 0; i < 200; ++i) {
      map.Voxels();
      map.Stats();
      map.NeedsSnapshot("r1");
    }
  });
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(map.Stats().voxels, 600u);
  EXPECT_EQ(map.Stats().occupied, 300u);
}

}  // namespace
}  // namespace cairn::perception
