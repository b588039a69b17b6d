// Copyright Cairn authors.
//
// Basestation side of map telemetry: per-robot coarse maps, their merge, and .bt export. The only translation
// unit of map telemetry that includes OctoMap headers.
// Silences OctoMap's "Writing N nodes to output stream" on stderr (its debug output, on unless NDEBUG).
#define OCTOMAP_NODEBUGOUT
#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>

#include "cairn/perception/map_telemetry.h"

namespace cairn::perception {
namespace {

constexpr std::size_t kMaxRobotIdChars = 64;
constexpr std::size_t kMaxTrackedSeqs = 65536;  // DELTA seqs remembered above a gap (oldest forgotten first).
constexpr std::int32_t kOctoKeyOffset = 1 << 15;  // OctoMap's tree_max_val at 16 levels.

// Same packing as map_telemetry.cpp: key order is lexicographic (ix, iy, iz) order.
std::uint64_t PackKey(const CoarseVoxel& v) {
  const auto u = [](std::int32_t i) {
    return static_cast<std::uint64_t>(static_cast<std::int64_t>(i) + kMaxCoarseIndex);
  };
  return (u(v.ix) << 42) | (u(v.iy) << 21) | u(v.iz);
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

// Why an update is dropped: the reason counted and the message returned.
struct MapDrop {
  MapDropReason reason;
  std::string message;
};

// Names the update in errors, e.g. "DELTA seq 7", "SNAPSHOT 3 chunk 1/4".
std::string UpdateName(const MapUpdate& update) {
  std::ostringstream what;
  if (update.kind == MapUpdateKind::kDelta) {
    what << "DELTA seq " << update.seq;
  } else {
    what << "SNAPSHOT " << update.snapshot_id << " chunk " << update.chunk_index << "/" << update.chunk_count;
  }
  return what.str();
}

// The header's own rules (no state needed): robot id, kind, resolution, size, and the seq and chunk fields of
// a delta or a snapshot chunk (see the protocol in map_telemetry.h).
std::optional<MapDrop> CheckHeader(const std::string& robot_id, const MapUpdate& update,
                                   const std::string& name, const FleetMapOptions& options) {
  const auto bad = [](const std::string& message) { return MapDrop{MapDropReason::kBadHeader, message}; };
  if (robot_id.empty() || robot_id.size() > kMaxRobotIdChars)
    return bad("robot id must have 1 to 64 characters");
  if (update.robot_id != robot_id) return bad("message robot_id '" + update.robot_id + "' differs");
  if (update.kind != MapUpdateKind::kDelta && update.kind != MapUpdateKind::kSnapshot) {
    return bad("unknown kind " + std::to_string(static_cast<int>(update.kind)));
  }
  if (!std::isfinite(update.resolution_m) || update.resolution_m <= 0.0) {
    return bad(name + ": resolution_m = " + std::to_string(update.resolution_m) + " must be finite and > 0");
  }
  if (update.data.size() > options.max_update_bytes) {
    return MapDrop{MapDropReason::kLimitExceeded,
                   name + ": payload of " + std::to_string(update.data.size()) +
                       " bytes exceeds max_update_bytes " + std::to_string(options.max_update_bytes)};
  }
  if (update.kind == MapUpdateKind::kDelta) {
    if (update.seq == 0) return bad(name + ": DELTA seq must be >= 1");
    if (update.chunk_index != 0 || update.chunk_count != 1) {
      return bad(name + ": a DELTA must have chunk_index 0 and chunk_count 1");
    }
    if (update.base_seq != update.seq - 1) {
      return bad(name + ": base_seq " + std::to_string(update.base_seq) + " must be seq - 1");
    }
    return std::nullopt;
  }
  if (update.snapshot_id == 0) return bad(name + ": snapshot_id must be >= 1");
  if (update.chunk_count == 0 || update.chunk_index >= update.chunk_count) {
    return bad(name + ": chunk_index must be < chunk_count");
  }
  if (update.chunk_count > options.max_chunk_count) {
    return MapDrop{MapDropReason::kLimitExceeded,
                   name + ": chunk_count exceeds max_chunk_count " + std::to_string(options.max_chunk_count)};
  }
  if (update.seq != update.base_seq) {
    return bad(name + ": seq " + std::to_string(update.seq) + " must equal base_seq " +
               std::to_string(update.base_seq));
  }
  return std::nullopt;
}

}  // namespace

const char* ToString(MapDropReason reason) {
  switch (reason) {
    case MapDropReason::kBadHeader:
      return "bad_header";
    case MapDropReason::kMalformedPayload:
      return "malformed_payload";
    case MapDropReason::kResolutionMismatch:
      return "resolution_mismatch";
    case MapDropReason::kDuplicate:
      return "duplicate";
    case MapDropReason::kOutOfOrder:
      return "out_of_order";
    case MapDropReason::kSnapshotMismatch:
      return "snapshot_mismatch";
    case MapDropReason::kLimitExceeded:
      return "limit_exceeded";
  }
  return "unknown";
}

std::uint64_t MapDropCounts::total() const {
  std::uint64_t sum = 0;
  for (std::uint64_t c : count) sum += c;
  return sum;
}

bool FleetMapOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  if (!std::isfinite(resolution_m) || resolution_m < 0.0 || resolution_m > 1000.0) {
    msg << "FleetMapOptions::resolution_m = " << resolution_m
        << " must be 0 (first robot's) or in (0, 1000] m";
  } else if (max_robots < 1 || max_robots > 65535) {
    msg << "FleetMapOptions::max_robots = " << max_robots << " must be in [1, 65535]";
  } else if (max_voxels_per_robot < 1 || max_voxels_per_robot > 1'000'000'000) {
    msg << "FleetMapOptions::max_voxels_per_robot = " << max_voxels_per_robot << " must be in [1, 1e9]";
  } else if (max_update_bytes < 1 || max_update_bytes > 100'000'000) {
    msg << "FleetMapOptions::max_update_bytes = " << max_update_bytes << " must be in [1, 1e8]";
  } else if (max_chunk_count < 1 || max_chunk_count > 1'000'000) {
    msg << "FleetMapOptions::max_chunk_count = " << max_chunk_count << " must be in [1, 1e6]";
  } else {
    return true;
  }
  if (why != nullptr) *why = msg.str();
  return false;
}

struct FleetMap::Impl {
  struct Voxel {
    CoarseState state;
    std::uint32_t set_seq;  // DELTA seq or SNAPSHOT base_seq that last set it.
  };
  struct Robot {
    double resolution_m = 0.0;
    std::unordered_map<std::uint64_t, Voxel> voxels;
    std::size_t occupied = 0;
    // Sync state (see the protocol in map_telemetry.h).
    bool has_base = false;
    std::uint32_t complete_through = 0;
    std::set<std::uint32_t> received;  // DELTA seqs received above complete_through (all, without a base).
    std::uint32_t last_seq = 0;
    std::uint32_t last_completed_snapshot = 0;
    std::uint32_t snap_id = 0;  // Snapshot being collected, 0 = none.
    std::uint32_t snap_base = 0;
    std::uint32_t snap_count = 0;
    std::vector<bool> snap_got;
    std::uint32_t snap_num_got = 0;
    // Counters.
    std::uint64_t bytes_received = 0;
    std::uint64_t deltas_applied = 0;
    std::uint64_t chunks_applied = 0;
    std::uint64_t snapshots_completed = 0;

    bool NeedsSnapshot() const { return !has_base || !received.empty(); }

    // Moves complete_through up over received seqs.
    void Advance() {
      if (!has_base) return;
      while (!received.empty() && *received.begin() <= complete_through + 1) {
        complete_through = std::max(complete_through, *received.begin());
        received.erase(received.begin());
      }
    }
  };
  struct Merged {
    std::uint16_t occupied = 0;  // Robots that say occupied.
    std::uint16_t free = 0;      // Robots that say free.
  };

  explicit Impl(const FleetMapOptions& o) : options(o), resolution_m(o.resolution_m) {}

  void AddMerged(std::uint64_t key, CoarseState state) {
    Merged& m = merged[key];
    if (state == CoarseState::kOccupied) {
      if (m.occupied++ == 0) ++merged_occupied;
    } else {
      ++m.free;
    }
  }
  void RemoveMerged(std::uint64_t key, CoarseState state) {
    const auto it = merged.find(key);
    if (state == CoarseState::kOccupied) {
      if (--it->second.occupied == 0) --merged_occupied;
    } else {
      --it->second.free;
    }
    if (it->second.occupied == 0 && it->second.free == 0) merged.erase(it);
  }

  // Sets the voxels of `robot` whose last-set seq is older than `stamp`.
  void SetVoxels(Robot* robot, const std::vector<CoarseVoxel>& voxels, std::uint32_t stamp) {
    for (const CoarseVoxel& v : voxels) {
      const std::uint64_t key = PackKey(v);
      const auto [it, inserted] = robot->voxels.try_emplace(key, Voxel{v.state, stamp});
      if (inserted) {
        AddMerged(key, v.state);
        if (v.state == CoarseState::kOccupied) ++robot->occupied;
        continue;
      }
      Voxel& old = it->second;
      if (old.set_seq >= stamp) continue;  // Newer information already there.
      old.set_seq = stamp;
      if (old.state == v.state) continue;
      RemoveMerged(key, old.state);
      AddMerged(key, v.state);
      if (old.state == CoarseState::kOccupied) --robot->occupied;
      if (v.state == CoarseState::kOccupied) ++robot->occupied;
      old.state = v.state;
    }
  }

  // All robots send coarse voxels of one size: the first update's (or the options').
  std::optional<MapDrop> CheckResolution(const MapUpdate& update, const std::string& name) const {
    if (resolution_m <= 0.0 || std::abs(update.resolution_m - resolution_m) <= 1e-9 * resolution_m) {
      return std::nullopt;
    }
    std::ostringstream msg;
    msg << name << ": resolution_m " << update.resolution_m << " differs from the fleet's " << resolution_m
        << " m ("
        << (resolution_set_by.empty() ? "set by FleetMapOptions" : "set by robot '" + resolution_set_by + "'")
        << "); all robots must send coarse voxels of one size";
    return MapDrop{MapDropReason::kResolutionMismatch, msg.str()};
  }

  // The update against what `robot` (nullptr: not heard yet) already has: a delta at or below its complete
  // seq, or received before; a snapshot chunk of a completed or older snapshot, disagreeing with the chunks
  // received, or received before.
  static std::optional<MapDrop> CheckSequence(const Robot* robot, const MapUpdate& update,
                                              const std::string& name) {
    if (robot == nullptr) return std::nullopt;
    if (update.kind == MapUpdateKind::kDelta) {
      if (robot->has_base && update.seq <= robot->complete_through) {
        return MapDrop{MapDropReason::kOutOfOrder, name + " is at or below seq " +
                                                       std::to_string(robot->complete_through) +
                                                       ", through which the map is already complete"};
      }
      if (robot->received.count(update.seq) != 0)
        return MapDrop{MapDropReason::kDuplicate, name + " already received"};
      return std::nullopt;
    }
    if (update.snapshot_id <= robot->last_completed_snapshot) {
      return MapDrop{
          MapDropReason::kOutOfOrder,
          name + ": snapshot " + std::to_string(robot->last_completed_snapshot) + " is already complete"};
    }
    if (robot->snap_id > update.snapshot_id) {
      return MapDrop{MapDropReason::kOutOfOrder,
                     name + ": newer snapshot " + std::to_string(robot->snap_id) + " is being received"};
    }
    if (robot->snap_id != update.snapshot_id) return std::nullopt;  // A new snapshot.
    if (robot->snap_count != update.chunk_count || robot->snap_base != update.base_seq) {
      return MapDrop{MapDropReason::kSnapshotMismatch,
                     name + " (base_seq " + std::to_string(update.base_seq) +
                         ") disagrees with earlier chunks: " + std::to_string(robot->snap_count) +
                         " chunks, base_seq " + std::to_string(robot->snap_base)};
    }
    if (robot->snap_got[update.chunk_index])
      return MapDrop{MapDropReason::kDuplicate, name + " already received"};
    return std::nullopt;
  }

  // The robot's map may not grow past max_voxels_per_robot.
  std::optional<MapDrop> CheckLimits(const Robot* robot, const std::vector<CoarseVoxel>& voxels,
                                     const std::string& name) const {
    const std::size_t have = robot == nullptr ? 0 : robot->voxels.size();
    std::size_t added = voxels.size();  // Upper bound; counted exactly only when it matters.
    if (have + added > options.max_voxels_per_robot) {
      added = 0;
      for (const CoarseVoxel& v : voxels) {
        if (robot == nullptr || robot->voxels.count(PackKey(v)) == 0) ++added;
      }
    }
    if (have + added <= options.max_voxels_per_robot) return std::nullopt;
    return MapDrop{MapDropReason::kLimitExceeded,
                   name + ": would grow the map to " + std::to_string(have + added) +
                       " voxels, over max_voxels_per_robot " + std::to_string(options.max_voxels_per_robot)};
  }

  // Applies a checked update of `robot_id` (`robot`: nullptr when not heard yet: it is added).
  void Commit(const std::string& robot_id, Robot* robot, const MapUpdate& update,
              const std::vector<CoarseVoxel>& voxels) {
    if (resolution_m == 0.0) {
      resolution_m = update.resolution_m;
      resolution_set_by = robot_id;
    }
    if (robot == nullptr) {
      robot = &robots[robot_id];
      robot->resolution_m = update.resolution_m;
    }
    if (update.kind == MapUpdateKind::kDelta) {
      CommitDelta(robot, update, voxels);
    } else {
      CommitSnapshotChunk(robot, update, voxels);
    }
    robot->bytes_received += update.data.size();
    bytes_received += update.data.size();
    ++updates_applied;
  }

  void CommitDelta(Robot* robot, const MapUpdate& update, const std::vector<CoarseVoxel>& voxels) {
    SetVoxels(robot, voxels, update.seq);
    if (!robot->has_base && update.seq == 1)
      robot->has_base = true;  // The empty map before DELTA 1 is a base.
    robot->received.insert(update.seq);
    while (robot->received.size() > kMaxTrackedSeqs) robot->received.erase(robot->received.begin());
    robot->last_seq = std::max(robot->last_seq, update.seq);
    robot->Advance();
    ++robot->deltas_applied;
  }

  // A chunk of the snapshot being collected, or the first of a new one (abandoning an older, incomplete
  // one); the last chunk completes the map through the snapshot's base seq.
  void CommitSnapshotChunk(Robot* robot, const MapUpdate& update, const std::vector<CoarseVoxel>& voxels) {
    if (robot->snap_id != update.snapshot_id) {
      robot->snap_id = update.snapshot_id;
      robot->snap_base = update.base_seq;
      robot->snap_count = update.chunk_count;
      robot->snap_got.assign(update.chunk_count, false);
      robot->snap_num_got = 0;
    }
    SetVoxels(robot, voxels, update.base_seq);
    robot->snap_got[update.chunk_index] = true;
    ++robot->snap_num_got;
    ++robot->chunks_applied;
    if (robot->snap_num_got != robot->snap_count) return;
    robot->last_completed_snapshot = robot->snap_id;
    ++robot->snapshots_completed;
    const std::uint32_t base = robot->snap_base;
    if (!robot->has_base) {
      robot->has_base = true;
      robot->complete_through = base;
    } else {
      robot->complete_through = std::max(robot->complete_through, base);
    }
    robot->received.erase(robot->received.begin(), robot->received.upper_bound(robot->complete_through));
    robot->Advance();
    robot->snap_id = 0;
    robot->snap_got.clear();
    robot->snap_num_got = 0;
  }

  FleetMapOptions options;
  mutable std::mutex mutex;
  double resolution_m;            // 0 until set.
  std::string resolution_set_by;  // Robot whose message set it (empty if from the options).
  std::map<std::string, Robot> robots;
  std::unordered_map<std::uint64_t, Merged> merged;
  std::size_t merged_occupied = 0;
  std::uint64_t bytes_received = 0;
  std::uint64_t updates_applied = 0;
  MapDropCounts drops;
};

FleetMap::FleetMap(const FleetMapOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument("FleetMap: " + why);
  impl_ = std::make_unique<Impl>(options);
}

FleetMap::~FleetMap() = default;

bool FleetMap::Apply(const std::string& robot_id, const MapUpdate& update, std::string* error,
                     MapDropReason* reason) {
  Impl& d = *impl_;
  std::unique_lock<std::mutex> lock(d.mutex, std::defer_lock);  // Taken after the pure checks below.
  const auto drop = [&](const MapDrop& why) {
    if (!lock.owns_lock()) lock.lock();
    ++d.drops.count[static_cast<int>(why.reason)];
    if (error != nullptr) *error = "robot '" + robot_id + "': " + why.message;
    if (reason != nullptr) *reason = why.reason;
    return false;
  };
  const std::string name = UpdateName(update);
  // 1. Header fields (options are constant: no lock needed).
  if (auto why = CheckHeader(robot_id, update, name, d.options)) return drop(*why);
  // 2. Payload (decoded before locking: the slow part).
  std::vector<CoarseVoxel> voxels;
  std::string payload_error;
  if (!DecodeCoarseVoxels(update.data.data(), update.data.size(), kMaxVoxelsPerUpdate, &voxels,
                          &payload_error)) {
    return drop({MapDropReason::kMalformedPayload, name + ": payload rejected: " + payload_error});
  }
  lock.lock();
  // 3. Resolution, 4. robot and sequencing, 5. limits.
  if (auto why = d.CheckResolution(update, name)) return drop(*why);
  const auto found = d.robots.find(robot_id);
  Impl::Robot* robot = found == d.robots.end() ? nullptr : &found->second;
  if (robot == nullptr && d.robots.size() >= d.options.max_robots) {
    return drop({MapDropReason::kLimitExceeded,
                 "already " + std::to_string(d.robots.size()) + " robots (max_robots); new robot refused"});
  }
  if (auto why = Impl::CheckSequence(robot, update, name)) return drop(*why);
  if (auto why = d.CheckLimits(robot, voxels, name)) return drop(*why);
  // 6. Commit: nothing above changed any state (but the drop counts).
  d.Commit(robot_id, robot, update, voxels);
  return true;
}

bool FleetMap::NeedsSnapshot(const std::string& robot_id) const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  const auto it = impl_->robots.find(robot_id);
  return it != impl_->robots.end() && it->second.NeedsSnapshot();
}

bool FleetMap::ResetRobot(const std::string& robot_id) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  const auto it = impl_->robots.find(robot_id);
  if (it == impl_->robots.end()) return false;
  Impl::Robot& r = it->second;
  for (auto& [key, voxel] : r.voxels) voxel.set_seq = 0;
  r.has_base = false;
  r.complete_through = 0;
  r.received.clear();
  r.last_seq = 0;
  r.last_completed_snapshot = 0;
  r.snap_id = 0;
  r.snap_base = 0;
  r.snap_count = 0;
  r.snap_got.clear();
  r.snap_num_got = 0;
  return true;
}

std::vector<CoarseVoxel> FleetMap::Voxels(const std::string& robot_id) const {
  std::vector<std::pair<std::uint64_t, CoarseState>> keyed;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    if (robot_id.empty()) {
      keyed.reserve(impl_->merged.size());
      for (const auto& [key, m] : impl_->merged) {
        keyed.emplace_back(key, m.occupied > 0 ? CoarseState::kOccupied : CoarseState::kFree);
      }
    } else {
      const auto it = impl_->robots.find(robot_id);
      if (it == impl_->robots.end()) return {};
      keyed.reserve(it->second.voxels.size());
      for (const auto& [key, v] : it->second.voxels) keyed.emplace_back(key, v.state);
    }
  }
  std::sort(keyed.begin(), keyed.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });  // Lexicographic (ix, iy, iz).
  std::vector<CoarseVoxel> out;
  out.reserve(keyed.size());
  for (const auto& [key, state] : keyed) out.push_back(UnpackKey(key, state));
  return out;
}

std::vector<std::string> FleetMap::Robots() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  std::vector<std::string> out;
  for (const auto& [id, robot] : impl_->robots) out.push_back(id);
  return out;
}

double FleetMap::resolution_m() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->resolution_m;
}

FleetMapStats FleetMap::Stats() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  FleetMapStats s;
  s.robots = impl_->robots.size();
  s.voxels = impl_->merged.size();
  s.occupied = impl_->merged_occupied;
  s.bytes_received = impl_->bytes_received;
  s.updates_applied = impl_->updates_applied;
  s.drops = impl_->drops;
  return s;
}

bool FleetMap::GetRobotStats(const std::string& robot_id, RobotMapStats* out) const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  const auto it = impl_->robots.find(robot_id);
  if (it == impl_->robots.end()) return false;
  const Impl::Robot& r = it->second;
  out->voxels = r.voxels.size();
  out->occupied = r.occupied;
  out->bytes_received = r.bytes_received;
  out->deltas_applied = r.deltas_applied;
  out->snapshot_chunks_applied = r.chunks_applied;
  out->snapshots_completed = r.snapshots_completed;
  out->last_seq = r.last_seq;
  out->has_base = r.has_base;
  out->complete_through_seq = r.complete_through;
  out->needs_snapshot = r.NeedsSnapshot();
  return true;
}

bool FleetMap::SaveBt(const std::string& path, const std::string& robot_id, std::string* error) const {
  const auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = "SaveBt('" + path + "'): " + message;
    return false;
  };
  double resolution_m = 0.0;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    resolution_m = impl_->resolution_m;
    if (!robot_id.empty() && impl_->robots.count(robot_id) == 0)
      return fail("unknown robot '" + robot_id + "'");
  }
  if (resolution_m <= 0.0) return fail("the fleet resolution is not known yet (no message accepted)");
  const std::vector<CoarseVoxel> voxels = Voxels(robot_id);  // Copied, so Apply() is not blocked below.

  octomap::OcTree tree(resolution_m);
  const float occupied_log_odds = tree.getClampingThresMaxLog();
  const float free_log_odds = tree.getClampingThresMinLog();
  for (const CoarseVoxel& v : voxels) {
    const std::int32_t i[3] = {v.ix, v.iy, v.iz};
    if (*std::min_element(i, i + 3) < -kOctoKeyOffset || *std::max_element(i, i + 3) >= kOctoKeyOffset) {
      std::ostringstream msg;
      msg << "voxel (" << v.ix << ", " << v.iy << ", " << v.iz
          << ") is outside OctoMap's key range [-32768, 32767]";
      return fail(msg.str());
    }
    const octomap::OcTreeKey key(static_cast<octomap::key_type>(v.ix + kOctoKeyOffset),
                                 static_cast<octomap::key_type>(v.iy + kOctoKeyOffset),
                                 static_cast<octomap::key_type>(v.iz + kOctoKeyOffset));
    tree.setNodeValue(key, v.state == CoarseState::kOccupied ? occupied_log_odds : free_log_odds, true);
  }
  tree.updateInnerOccupancy();
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file.is_open()) return fail("cannot open the file for writing");
  if (!tree.writeBinary(file)) return fail("OctoMap writeBinary failed");
  file.close();
  if (!file) return fail("write error (disk full?)");
  return true;
}

}  // namespace cairn::perception
