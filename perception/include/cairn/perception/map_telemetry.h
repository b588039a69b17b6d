// Copyright Cairn authors.
//
// Map telemetry: robots send basestations the coarse voxels of their map that changed since the last update
// (DELTA), compressed, within a bit budget; a basestation that joins late asks for the whole coarse map
// (SNAPSHOT, in chunks). Basestations merge every robot's map into one fleet map and can save it as an
// OctoMap .bt. Plain C++ without DDS: MapUpdate and MapSyncRequest mirror the IDL messages that the DDS layer
// fills from and into these structs.
//
// Protocol (one sender per robot, any number of basestations):
//  - DELTA messages are numbered seq = 1, 2, 3, ... (one number per DELTA, snapshots take none). A DELTA
//    carries the latest state of voxels that changed since the previous DELTA, and base_seq = seq - 1.
//  - A SNAPSHOT is the voxel set that the DELTAs 1..base_seq built (nothing newer), split in chunk_count
//    chunks that can be applied independently and in any order; every chunk carries the same snapshot_id
//    (1, 2, ... per sender), base_seq and chunk_count, and seq = base_seq.
//  - The map before DELTA 1 is empty, so a basestation that receives DELTA 1 needs no snapshot.
//  - A basestation keeps, per robot and voxel, the seq that last set it, and lets an update set a voxel only
//    if that seq is older than the update's (DELTA: seq; SNAPSHOT: base_seq), so late or reordered messages
//    never undo newer ones. Voxels never become unknown again, so no update deletes a voxel.
//  - A basestation knows a robot's map completely through seq c once it has all DELTAs up to c or a whole
//    SNAPSHOT with base_seq >= c followed by all DELTAs up to c. When it misses a DELTA (gap) or starts in
//    the middle of the stream, FleetMap::NeedsSnapshot() turns true and the DDS layer sends a
//    MapSyncRequest (rate-limited by the caller), which makes the robot call MapTelemetrySender::
//    RequestSnapshot().
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#include "cairn/perception/coarse_voxel.h"

namespace cairn::perception {

// ---------------------------------------------------------------------------------------------------------
// Codec
// ---------------------------------------------------------------------------------------------------------

/// Largest accepted |voxel index| on any axis: indices lie in [-kMaxCoarseIndex, kMaxCoarseIndex - 1]
/// (21-bit signed). OctoMap's own key space is smaller (|i| <= 2^15 at the finest level).
inline constexpr std::int32_t kMaxCoarseIndex = 1 << 20;

/// Most voxels in one MapUpdate payload; senders never exceed it, receivers decode with it as max_voxels.
/// Bounds a decoded message to ~0.8 MB of memory.
inline constexpr std::size_t kMaxVoxelsPerUpdate = 1 << 16;

/// Encodes `voxels` (any order; no two with the same (ix, iy, iz); indices within ±kMaxCoarseIndex, see
/// above; state kFree or kOccupied) into a payload for MapUpdate::data.
///
/// Format, version 1 (all integers little-endian):
///   header, 9 bytes: magic "CVX1" (4 bytes), version (1 byte, = 1), voxel count n (uint32);
///   then one zstd frame (content size declared, XXH64 checksum on) of the body:
///     n voxels in lexicographic (ix, iy, iz) order, each as three varints (LEB128) of the zigzag-coded
///     per-axis difference to the previous voxel (the first to (0, 0, 0));
///     then ceil(n / 4) bytes of 2-bit states (the CoarseState values 1 and 2), voxel k in bits 2(k % 4)
///     of byte k / 4; unused high bits are 0.
/// `zstd_level` in [1, 19] (3 is zstd's default; higher is smaller and slower).
/// Throws std::invalid_argument naming the voxel or value if a precondition is broken, std::runtime_error if
/// zstd fails (out of memory).
std::vector<std::uint8_t> EncodeCoarseVoxels(std::vector<CoarseVoxel> voxels, int zstd_level = 3);

/// Appends to `out` one zstd frame (content size declared, XXH64 checksum on) of `raw`, at `zstd_level` in
/// [1, 19]. The codec under EncodeCoarseVoxels, shared with other payloads (the explore claims' coverage).
/// @throws std::invalid_argument for a level out of range (naming `caller`), std::runtime_error if zstd
/// fails.
void ZstdCompressAppend(const std::vector<std::uint8_t>& raw, int zstd_level, const char* caller,
                        std::vector<std::uint8_t>* out);

/// Decompresses exactly one zstd frame `frame[0, frame_size)` made by ZstdCompressAppend into `out`. Returns
/// false, with `*error` (if not null) saying why and `out` empty, when the frame magic is missing, the frame
/// is corrupt or truncated or followed by extra bytes, it does not declare its size or declares more than
/// `max_bytes` (checked before any allocation), or the checksum fails. `out` must not be null.
bool ZstdDecompress(const std::uint8_t* frame, std::size_t frame_size, std::size_t max_bytes,
                    std::vector<std::uint8_t>* out, std::string* error);

/// Decodes a payload made by EncodeCoarseVoxels into `out` (lexicographic (ix, iy, iz) order).
///
/// Returns false, leaves `out` empty and, if `error` is not null, sets a message naming what is wrong when:
/// the header is truncated, the magic or version is wrong, the count exceeds `max_voxels`, the zstd frame is
/// missing, corrupt (bad checksum included), does not declare its content size, declares more than the
/// largest possible body for the count (12 bytes per voxel + states; the decompression-bomb guard, checked
/// before any allocation), or is followed by extra bytes; a varint is truncated or too long; an index is out
/// of range; voxels are not in strictly ascending order (duplicates included); a state code is not 1 or 2 or
/// the padding bits are not 0; the body has trailing bytes. `out` must not be null.
bool DecodeCoarseVoxels(const std::uint8_t* data, std::size_t size, std::size_t max_voxels,
                        std::vector<CoarseVoxel>* out, std::string* error);

// ---------------------------------------------------------------------------------------------------------
// Messages (mirror the IDL; the DDS layer copies field by field)
// ---------------------------------------------------------------------------------------------------------

/// Kind of a MapUpdate.
enum class MapUpdateKind : std::uint8_t {
  kDelta = 0,     ///< Voxels changed since the previous DELTA.
  kSnapshot = 1,  ///< One chunk of a whole coarse map.
};

/// One map telemetry message from a robot (IDL `MapUpdate`). See the protocol at the top of this file.
struct MapUpdate {
  /// Sending robot, non-empty, at most 64 characters.
  std::string robot_id;
  /// DELTA: its number, >= 1, +1 per DELTA. SNAPSHOT: equal to base_seq.
  std::uint32_t seq = 0;
  /// SNAPSHOT: >= 1, +1 per snapshot of this sender. DELTA: 0 (ignored by receivers).
  std::uint32_t snapshot_id = 0;
  /// DELTA or SNAPSHOT.
  MapUpdateKind kind = MapUpdateKind::kDelta;
  /// SNAPSHOT: this chunk, in [0, chunk_count). DELTA: 0.
  std::uint32_t chunk_index = 0;
  /// SNAPSHOT: chunks in the snapshot, >= 1. DELTA: 1.
  std::uint32_t chunk_count = 1;
  /// SNAPSHOT: the last DELTA seq whose content the snapshot includes (0: none). DELTA: seq - 1.
  std::uint32_t base_seq = 0;
  /// Coarse voxel edge, metres, > 0; constant per robot.
  double resolution_m = 0.0;
  /// EncodeCoarseVoxels() payload.
  std::vector<std::uint8_t> data;
};

/// A basestation's request for a full map (IDL `MapSyncRequest`); the robot answers with
/// MapTelemetrySender::RequestSnapshot().
struct MapSyncRequest {
  std::string robot_id;      ///< Robot whose map is asked for.
  std::string requester_id;  ///< Basestation asking (for logs).
};

// ---------------------------------------------------------------------------------------------------------
// Robot side
// ---------------------------------------------------------------------------------------------------------

/// Options of MapTelemetrySender.
struct MapTelemetryOptions {
  /// Long-run average rate of the robot's map telemetry, payload plus per-message overhead, bits per second,
  /// range [1e3, 1e8].
  double budget_bits_per_s = 100000;
  /// Poll() sends at most once per period (batching voxels saves overhead and compresses better), seconds,
  /// range [0.01, 60].
  double period_s = 0.5;
  /// Depth of the token bucket, seconds of budget: the most the sender may send at once after an idle
  /// time, range [0.1, 60]. budget_bits_per_s * burst_s / 8 must be at least per_message_overhead_bytes +
  /// 256 so that any message fits the bucket.
  double burst_s = 1.0;
  /// Bytes counted against the budget per message for RTPS, UDP and IP headers, range [0, 10000].
  int per_message_overhead_bytes = 120;
  /// Largest payload (MapUpdate::data) of one message, bytes, range [256, 1048576]. Messages are also kept
  /// within the bucket depth.
  std::size_t max_message_bytes = 16000;
  /// zstd compression level, range [1, 19].
  int zstd_level = 3;

  /// True when every field is in range; otherwise false and, if `why` is not null, a message naming the
  /// field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// Counters of a MapTelemetrySender, since construction.
struct MapTelemetryStats {
  std::uint64_t messages_sent = 0;           ///< DELTA and SNAPSHOT messages returned by Poll().
  std::uint64_t delta_messages_sent = 0;     ///< DELTA messages.
  std::uint64_t snapshot_messages_sent = 0;  ///< SNAPSHOT chunks.
  std::uint64_t payload_bytes_sent = 0;      ///< Sum of MapUpdate::data sizes, bytes.
  std::uint64_t budget_bytes_sent = 0;       ///< Payload plus per-message overhead, bytes.
  std::uint64_t voxels_sent = 0;             ///< Voxels in DELTAs (snapshots not counted).
  std::uint64_t snapshot_requests = 0;       ///< RequestSnapshot() calls.
  std::uint64_t snapshots_served = 0;        ///< Snapshots whose last chunk has been sent.
  std::size_t voxels_pending = 0;            ///< Changed voxels waiting for a DELTA.
  std::size_t voxels_known = 0;              ///< Voxels basestations following the DELTAs have.
  std::size_t snapshot_chunks_queued = 0;    ///< Chunks of the current snapshot not yet sent.
  std::uint32_t last_seq = 0;                ///< Seq of the last DELTA (0: none yet).
  double tokens_bits = 0.0;                  ///< Token bucket level after the last Poll(), bits.
};

/// Robot side of map telemetry: collects changed coarse voxels, and at each period returns the messages to
/// publish within the bit budget (a token bucket: rate budget_bits_per_s, depth budget_bits_per_s * burst_s,
/// full at the first Poll(); a message costs (payload + per_message_overhead_bytes) * 8 bits and is only
/// sent when the bucket holds that much, so over any window of T seconds the sender sends at most
/// budget_bits_per_s * (T + burst_s) bits).
///
/// When the budget is short, Poll() sends in this order:
///  1. the chunks of a requested snapshot, in order (a late joiner sees nothing useful until it has them);
///     DELTAs wait until the last chunk is out;
///  2. pending voxels now occupied (obstacles matter most to operators and planners), then free ones;
///     within each, the ones pending longest first.
/// Nothing is dropped: voxels that do not fit wait for the next period, keeping only their latest state.
/// A voxel that changes back to the state the DELTAs last sent is no longer pending.
///
/// Thread-safe: AddChanges() (mapping thread), RequestSnapshot() (DDS listener) and Poll() (telemetry timer)
/// may be called from different threads.
class MapTelemetrySender {
 public:
  /// Sender for robot `robot_id` (non-empty, at most 64 characters) whose coarse voxels have edge
  /// `resolution_m` (metres, finite, > 0). Throws std::invalid_argument if an argument or the options are
  /// invalid (with the IsValid() message).
  MapTelemetrySender(std::string robot_id, double resolution_m, const MapTelemetryOptions& options = {});

  /// Merges changed voxels (each with its current state; later entries win) into the pending set. Throws
  /// std::invalid_argument, changing nothing, if a voxel's index is out of ±kMaxCoarseIndex or its state is
  /// invalid.
  void AddChanges(const std::vector<CoarseVoxel>& changes);

  /// A basestation asked for the full map (MapSyncRequest). The next Poll() starts a SNAPSHOT of what the
  /// DELTAs sent so far built (base_seq = last DELTA seq); DELTAs resume after its last chunk. A request
  /// while a snapshot is being sent queues one more snapshot after it, unless no chunk of the current one
  /// has been sent yet (then the current one serves both).
  void RequestSnapshot();

  /// Messages to publish now, in order, at time `now_s` (seconds, any monotonic clock; a value smaller than
  /// the previous one is taken as the previous one). Call it often (e.g. every period_s or faster): it acts
  /// at the first call and then at the first call at least period_s after the last acting one, and returns
  /// nothing at other calls or when nothing fits the bucket. Throws std::invalid_argument if `now_s` is not
  /// finite.
  std::vector<MapUpdate> Poll(double now_s);

  /// Counters, see MapTelemetryStats.
  MapTelemetryStats stats() const;

  /// Sends at `share` of budget_bits_per_s from now on, (0, 1] (a radio link shared by several robots): the
  /// bucket refills that much slower; its depth, and so the largest message, stay those of the full budget.
  /// Thread-safe. @throws std::invalid_argument naming the value when out of range.
  void SetRateShare(double share);

  /// Robot id given at construction.
  const std::string& robot_id() const { return robot_id_; }
  /// Coarse voxel edge, metres.
  double resolution_m() const { return resolution_m_; }
  /// Options given at construction.
  const MapTelemetryOptions& options() const { return options_; }

 private:
  struct Pending {
    CoarseState state;
    std::uint64_t since;  // Order in which the voxel became pending (smaller = older).
  };

  std::size_t ChunkLimitBytes() const;
  void StartSnapshot();
  bool EmitDelta(std::vector<MapUpdate>* out);

  const std::string robot_id_;
  const double resolution_m_;
  const MapTelemetryOptions options_;

  mutable std::mutex mutex_;
  std::unordered_map<std::uint64_t, CoarseState> sent_;  // What DELTAs 1..last_seq_ built.
  std::unordered_map<std::uint64_t, Pending> pending_;   // Changed since, with their latest state.
  std::uint64_t pending_counter_ = 0;
  std::uint32_t last_seq_ = 0;
  std::uint32_t last_snapshot_id_ = 0;
  std::vector<MapUpdate> snapshot_chunks_;  // Current snapshot, chunks not yet sent are [next_chunk_, end).
  std::size_t next_chunk_ = 0;
  bool snapshot_requested_ = false;  // A snapshot to start at the next Poll() (after the current one).
  bool started_ = false;             // First Poll() seen.
  double last_now_s_ = 0.0;
  double next_send_s_ = 0.0;
  double tokens_bits_ = 0.0;
  double rate_share_ = 1.0;       // SetRateShare()
  double bytes_per_voxel_ = 2.0;  // Running estimate of payload bytes per DELTA voxel, to size messages.
  MapTelemetryStats stats_;
};

// ---------------------------------------------------------------------------------------------------------
// Basestation side
// ---------------------------------------------------------------------------------------------------------

/// Why FleetMap::Apply() dropped a message.
enum class MapDropReason : int {
  kBadHeader = 0,       ///< A field is out of its rules (empty or mismatched robot id, seq 0, chunk_index >=
                        ///< chunk_count, a SNAPSHOT whose seq != base_seq, non-finite resolution, ...).
  kMalformedPayload,    ///< DecodeCoarseVoxels() rejected the data.
  kResolutionMismatch,  ///< resolution_m differs from the fleet's.
  kDuplicate,           ///< A DELTA seq or SNAPSHOT chunk already received.
  kOutOfOrder,          ///< Older than what the map holds: a DELTA at or below the seq through which the
                        ///< robot's map is complete, or a chunk of an older snapshot than one seen.
  kSnapshotMismatch,  ///< A chunk whose chunk_count or base_seq differs from earlier chunks of its snapshot.
  kLimitExceeded,     ///< Too many robots, voxels for one robot, bytes or chunks (FleetMapOptions).
};
/// Number of MapDropReason values.
inline constexpr int kNumMapDropReasons = 7;
/// Short name of a reason, e.g. "malformed_payload".
const char* ToString(MapDropReason reason);

/// Dropped messages per reason.
struct MapDropCounts {
  std::array<std::uint64_t, kNumMapDropReasons> count{};  ///< Indexed by static_cast<int>(reason).
  /// Drops for `reason`.
  std::uint64_t operator[](MapDropReason reason) const { return count[static_cast<int>(reason)]; }
  /// All drops.
  std::uint64_t total() const;
};

/// Options of FleetMap.
struct FleetMapOptions {
  /// Coarse voxel edge of the fleet map, metres; 0 = take the first robot's (from its first accepted
  /// message); otherwise in (0, 1000].
  double resolution_m = 0.0;
  /// Most robots, range [1, 65535].
  std::size_t max_robots = 64;
  /// Most voxels one robot may have, range [1, 1e9]; a message that would exceed it is dropped.
  std::size_t max_voxels_per_robot = 5'000'000;
  /// Largest accepted payload, bytes, range [1, 1e8].
  std::size_t max_update_bytes = 1 << 20;
  /// Largest accepted SNAPSHOT chunk_count, range [1, 1e6].
  std::uint32_t max_chunk_count = 65536;

  /// True when every field is in range; otherwise false and, if `why` is not null, a message naming the
  /// field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// One robot's view in a FleetMap.
struct RobotMapStats {
  std::size_t voxels = 0;                     ///< Known voxels.
  std::size_t occupied = 0;                   ///< Of which occupied.
  std::uint64_t bytes_received = 0;           ///< Payload bytes of accepted messages.
  std::uint64_t deltas_applied = 0;           ///< Accepted DELTAs.
  std::uint64_t snapshot_chunks_applied = 0;  ///< Accepted SNAPSHOT chunks.
  std::uint64_t snapshots_completed = 0;      ///< Snapshots whose every chunk was accepted.
  std::uint32_t last_seq = 0;                 ///< Highest DELTA seq accepted.
  bool has_base = false;                      ///< Complete through some seq (DELTA 1 or a whole snapshot).
  std::uint32_t complete_through_seq = 0;     ///< The map holds everything through this seq (if has_base).
  bool needs_snapshot = false;                ///< Same as FleetMap::NeedsSnapshot().
};

/// Fleet-wide counters.
struct FleetMapStats {
  std::size_t robots = 0;             ///< Robots with at least one accepted message.
  std::size_t voxels = 0;             ///< Voxels in the merged map.
  std::size_t occupied = 0;           ///< Merged voxels that are occupied.
  std::uint64_t bytes_received = 0;   ///< Payload bytes of accepted messages.
  std::uint64_t updates_applied = 0;  ///< Accepted messages.
  MapDropCounts drops;                ///< Dropped messages by reason.
};

/// Basestation side: every robot's coarse map, and their merge. A voxel of the merged (fleet) map is occupied
/// if any robot says occupied, else free if any robot says free (a robot's stale "free" must not hide an
/// obstacle another robot sees; the merged map is conservative).
///
/// All robots must share one coarse resolution: FleetMapOptions::resolution_m, or else the resolution of the
/// first message accepted; a robot with another resolution is rejected (kResolutionMismatch) with a message
/// naming both values. Messages are checked entirely before anything changes: a dropped message leaves the
/// maps, the sync state and the stats (other than the drop counts) as they were.
///
/// Thread-safe: every method may be called from any thread (one mutex; Apply() decodes the payload before
/// taking it).
class FleetMap {
 public:
  /// Throws std::invalid_argument with the IsValid() message if `options` are invalid.
  explicit FleetMap(const FleetMapOptions& options = {});
  ~FleetMap();
  FleetMap(const FleetMap&) = delete;
  FleetMap& operator=(const FleetMap&) = delete;

  /// Applies `update` from robot `robot_id` (must equal update.robot_id). Returns true if accepted; else
  /// false, counts the drop under its MapDropReason, and, if `error` is not null, sets a message naming the
  /// robot, the field and the value, e.g. "robot r2: DELTA seq 7 already received". If `reason` is not null
  /// it receives the reason of a drop.
  bool Apply(const std::string& robot_id, const MapUpdate& update, std::string* error,
             MapDropReason* reason = nullptr);

  /// True if the map of `robot_id` is incomplete and a snapshot would complete it: no base yet (the first
  /// DELTA seen was not 1 and no whole snapshot arrived) or a DELTA is missing below one received. False
  /// for a robot never heard from. The caller sends MapSyncRequest, rate-limited (e.g. once per 2 s).
  bool NeedsSnapshot(const std::string& robot_id) const;

  /// Forgets the sync state of `robot_id` (seqs, snapshots) but keeps its voxels, which any later update
  /// may overwrite; call when the robot restarted (its seqs start again at 1). Returns false for an unknown
  /// robot.
  bool ResetRobot(const std::string& robot_id);

  /// Voxels of `robot_id`, or of the merged fleet map if `robot_id` is empty, in lexicographic (ix, iy, iz)
  /// order. Empty for an unknown robot.
  std::vector<CoarseVoxel> Voxels(const std::string& robot_id = "") const;

  /// Robots with at least one accepted message, sorted.
  std::vector<std::string> Robots() const;

  /// The fleet's coarse voxel edge, metres; 0 until set (see the class comment).
  double resolution_m() const;

  /// Fleet-wide counters.
  FleetMapStats Stats() const;

  /// Counters of `robot_id`; false (and `out` untouched) for an unknown robot. `out` must not be null.
  bool GetRobotStats(const std::string& robot_id, RobotMapStats* out) const;

  /// Writes the map of `robot_id` (or the merged fleet map if empty) as an OctoMap binary file (.bt) at the
  /// coarse resolution: voxel (ix, iy, iz) is the OcTree leaf with key (ix + 2^15, iy + 2^15, iz + 2^15),
  /// occupied or free with the tree's clamping log-odds, so isNodeOccupied() after readBinary() gives back
  /// exactly the voxel states; unknown space has no node. Returns false and sets `error` (if not null) when
  /// the robot is unknown, the resolution is not set yet, a voxel index is outside OctoMap's key range
  /// [-2^15, 2^15 - 1], or the file cannot be written.
  bool SaveBt(const std::string& path, const std::string& robot_id, std::string* error) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cairn::perception
