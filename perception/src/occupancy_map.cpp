// Copyright Cairn authors.
//
// OccupancyMap: an OctoMap OcTree behind a pimpl. The only library translation unit that includes OctoMap
// headers.
//
// Insertion (InsertScan) computes the same update sets as OcTree::insertPointCloud, faster:
//  1. points are transformed to W and discretized with OctoMap's float arithmetic; end-point voxels are
//     deduplicated in a flat open-addressing hash set and, by default, one ray is cast per new end-point
//     voxel rather than one per point (a deviation, optional, see occupancy_map.h; the other is the floor
//     guard, OccupancyMapOptions::floor_guard_layers: descending rays carve no free space in the layers at
//     their end point's height);
//  2. ray voxels (OctoMap's computeRayKeys) go into a bitmap over the scan's key box instead of OctoMap's
//     node-based std::unordered_set (KeySet). The bitmap is stored in 8 x 8 x 8-voxel bricks of one cache
//     line each, whose bits are in Morton order, i.e. the depth-first order of the octree, so the set comes
//     out sorted: bricks sorted by Morton code, bits read in order, merged with the sorted end-point voxels
//     (which win over free). Scans whose box is huge use a flat hash set and a radix sort instead;
//  3. the sorted updates are applied in one recursive descent that visits every touched node once: each
//     leaf gets its log-odds update, each touched inner node is then pruned or given the max of its
//     children, exactly as OctoMap's non-lazy updateNode leaves them (same values, same pruning), instead of
//     one root-to-leaf descent per voxel. Pruned leaves already clamped in the direction of all their
//     updates are skipped, as OctoMap's updateNode early abort does.
// The descent also records, for map telemetry, the voxels whose occupancy state changed (new, or crossing
// the 0.5 threshold), at a coarse tracking level (see TakeCoarseChanges).
#include "cairn/perception/occupancy_map.h"

#include <octomap/OcTree.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <mutex>
#include <shared_mutex>
#include <sstream>
#include <system_error>
#include <utility>

#include "cairn/core/octomap_bt.h"

namespace cairn::perception {
namespace {

using octomap::OcTreeKey;
using octomap::OcTreeNode;
using octomap::point3d;

/// Depth of OctoMap's trees: keys have 16 bits per axis; depth 16 holds the finest voxels.
constexpr int kTreeDepth = 16;
/// Key of the voxel whose min corner is the origin of W (OctoMap's tree_max_val).
constexpr int kKeyOffset = 1 << (kTreeDepth - 1);

// -----------------------------------------------------------------------------------------------------------
// Keys and Morton codes.

/// Packs an OctoMap key into 48 bits: x | y << 16 | z << 32.
inline std::uint64_t PackKey(const OcTreeKey& key) {
  return static_cast<std::uint64_t>(key[0]) | (static_cast<std::uint64_t>(key[1]) << 16) |
         (static_cast<std::uint64_t>(key[2]) << 32);
}

/// Spreads the 16 low bits of v so that bit i moves to bit 3i.
inline std::uint64_t Spread3(std::uint64_t v) {
  v &= 0xFFFFull;
  v = (v | (v << 32)) & 0x001F'0000'0000'FFFFull;
  v = (v | (v << 16)) & 0x001F'0000'FF00'00FFull;
  v = (v | (v << 8)) & 0x100F'00F0'0F00'F00Full;
  v = (v | (v << 4)) & 0x10C3'0C30'C30C'30C3ull;
  v = (v | (v << 2)) & 0x1249'2492'4924'9249ull;
  return v;
}

/// Inverse of Spread3: gathers bits 0, 3, 6, ... of v into the low bits.
inline std::uint32_t Compact3(std::uint64_t v) {
  v &= 0x1249'2492'4924'9249ull;
  v = (v ^ (v >> 2)) & 0x10C3'0C30'C30C'30C3ull;
  v = (v ^ (v >> 4)) & 0x100F'00F0'0F00'F00Full;
  v = (v ^ (v >> 8)) & 0x001F'0000'FF00'00FFull;
  v = (v ^ (v >> 16)) & 0x001F'0000'0000'FFFFull;
  v = (v ^ (v >> 32)) & 0x001F'FFFFull;
  return static_cast<std::uint32_t>(v);
}

/// Morton code of a packed key: bit 3i + a holds bit i of axis a, so the 3-bit digit at level d (from the
/// top) is OctoMap's child index at depth d, and ascending codes follow the octree depth first.
inline std::uint64_t MortonOfPacked(std::uint64_t packed) {
  return Spread3(packed) | (Spread3(packed >> 16) << 1) | (Spread3(packed >> 32) << 2);
}

/// Coarse voxel of Morton code `code` at `levels` levels above the finest (the code has 3 * (16 - levels)
/// bits), see coarse_voxel.h.
CoarseVoxel CoarseFromMorton(std::uint64_t code, int levels, bool occupied) {
  const std::int32_t offset = kKeyOffset >> levels;
  CoarseVoxel v;
  v.ix = static_cast<std::int32_t>(Compact3(code)) - offset;
  v.iy = static_cast<std::int32_t>(Compact3(code >> 1)) - offset;
  v.iz = static_cast<std::int32_t>(Compact3(code >> 2)) - offset;
  v.state = occupied ? CoarseState::kOccupied : CoarseState::kFree;
  return v;
}

// -----------------------------------------------------------------------------------------------------------
// Flat hash set and radix sort.

/// Open-addressing hash set of 64-bit keys (linear probing, Fibonacci hashing, load <= 1/2) that also keeps
/// its keys in insertion order. The value ~0 is reserved (never a packed key or Morton code).
class FlatSet64 {
 public:
  FlatSet64() { Reset(kMinSlots); }

  /// Inserts `key`; true if it was not there.
  bool Insert(std::uint64_t key) {
    if ((items_.size() + 1) * 2 > slots_.size()) Reset(slots_.size() * 2);
    for (std::size_t i = Slot(key);; i = (i + 1) & mask_) {
      const std::uint64_t s = slots_[i];
      if (s == key) return false;
      if (s == kEmpty) {
        slots_[i] = key;
        items_.push_back(key);
        return true;
      }
    }
  }

  bool Contains(std::uint64_t key) const {
    for (std::size_t i = Slot(key);; i = (i + 1) & mask_) {
      const std::uint64_t s = slots_[i];
      if (s == key) return true;
      if (s == kEmpty) return false;
    }
  }

  /// Removes every key. Shrinks the table when it is far larger than what was stored, so one large burst does
  /// not pin memory.
  void Clear() {
    const std::size_t used = items_.size();
    items_.clear();
    if (slots_.size() > 4 * kMinSlots && used * 16 < slots_.size()) {
      std::size_t n = kMinSlots;
      while (n < used * 4) n *= 2;
      items_.shrink_to_fit();
      Reset(n);
    } else {
      std::fill(slots_.begin(), slots_.end(), kEmpty);
    }
  }

  std::size_t size() const { return items_.size(); }
  const std::vector<std::uint64_t>& items() const { return items_; }
  std::size_t MemoryBytes() const { return (slots_.capacity() + items_.capacity()) * sizeof(std::uint64_t); }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  static constexpr std::size_t kMinSlots = 1u << 10;

  std::size_t Slot(std::uint64_t key) const {
    return static_cast<std::size_t>((key * 0x9E37'79B9'7F4A'7C15ull) >> shift_);
  }

  // Rehashes into `n` slots (a power of two, > 2 * size()).
  void Reset(std::size_t n) {
    slots_.assign(n, kEmpty);
    mask_ = n - 1;
    shift_ = 64;
    for (std::size_t m = n; m > 1; m >>= 1) --shift_;
    for (const std::uint64_t key : items_) {
      std::size_t i = Slot(key);
      while (slots_[i] != kEmpty) i = (i + 1) & mask_;
      slots_[i] = key;
    }
  }

  std::vector<std::uint64_t> slots_;
  std::vector<std::uint64_t> items_;
  std::size_t mask_ = 0;
  int shift_ = 64;
};

/// Sorts `values` ascending: LSD radix sort with 11-bit digits over the bits that differ between values only
/// (a scan's Morton codes share their high bits).
void RadixSort(std::vector<std::uint64_t>* values, std::vector<std::uint64_t>* scratch) {
  if (values->size() < 512) {
    std::sort(values->begin(), values->end());
    return;
  }
  std::uint64_t any = 0;
  std::uint64_t all = ~std::uint64_t{0};
  for (const std::uint64_t v : *values) {
    any |= v;
    all &= v;
  }
  const std::uint64_t differ = any ^ all;
  int bits = 0;
  while (bits < 64 && (differ >> bits) != 0) ++bits;
  constexpr int kDigitBits = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kDigitBits;
  scratch->resize(values->size());
  std::vector<std::uint32_t> count(kBuckets);
  for (int shift = 0; shift < bits; shift += kDigitBits) {
    std::fill(count.begin(), count.end(), 0u);
    for (const std::uint64_t v : *values) ++count[(v >> shift) & (kBuckets - 1)];
    std::uint32_t sum = 0;
    for (std::uint32_t& c : count) {
      const std::uint32_t n = c;
      c = sum;
      sum += n;
    }
    for (const std::uint64_t v : *values) (*scratch)[count[(v >> shift) & (kBuckets - 1)]++] = v;
    values->swap(*scratch);
  }
}

/// The voxels crossed by the rays of one scan, turned into the scan's sorted update list. Mostly a bitmap
/// over the scan's key box stored as 8 x 8 x 8 bricks of 64 bytes (one cache line; a brick is one octree node
/// at depth 13, its bits in Morton order), so that a ray touches few lines and the voxels come out in Morton
/// order without sorting; a FlatSet64 plus a radix sort when the box is too large.
class ScanKeySet {
 public:
  /// Starts an empty set for a scan whose rays stay in the key box [lo, hi] (inclusive, per axis).
  void Begin(const std::array<int, 3>& lo, const std::array<int, 3>& hi) {
    fallback_.Clear();
    std::size_t bricks = 1;
    for (int i = 0; i < 3; ++i) {
      origin_[i] = lo[i] & ~7;
      num_bricks_[i] = ((hi[i] - origin_[i]) >> 3) + 1;
      bricks *= static_cast<std::size_t>(num_bricks_[i]);
    }
    use_bitmap_ = bricks <= kMaxBricks;
    if (use_bitmap_ && touched_flags_.size() < bricks) {
      bits_.resize(bricks * 8, 0);
      touched_flags_.resize(bricks, 0);
    }
  }

  /// Adds `key` (keys outside the Begin box go to the fallback set).
  void Insert(const OcTreeKey& key) {
    if (!use_bitmap_ || !InBox(key)) {
      fallback_.Insert(PackKey(key));
      return;
    }
    const unsigned x = static_cast<unsigned>(key[0] - origin_[0]);
    const unsigned y = static_cast<unsigned>(key[1] - origin_[1]);
    const unsigned z = static_cast<unsigned>(key[2] - origin_[2]);
    const std::size_t brick =
        (static_cast<std::size_t>(z >> 3) * static_cast<std::size_t>(num_bricks_[1]) + (y >> 3)) *
            static_cast<std::size_t>(num_bricks_[0]) +
        (x >> 3);
    const unsigned local = kSpread[x & 7u] | (kSpread[y & 7u] << 1) | (kSpread[z & 7u] << 2);  // 9 bits.
    if (touched_flags_[brick] == 0) {
      touched_flags_[brick] = 1;
      touched_.emplace_back(MortonOfPacked((PackKey(key) >> 3) & 0x1FFF'1FFF'1FFFull), brick);
    }
    bits_[brick * 8 + (local >> 6)] |= std::uint64_t{1} << (local & 63u);
  }

  /// Fills `updates` with one entry per voxel, (Morton code << 1) | hit, ascending: a hit for each key of
  /// `occupied` (packed), a miss for every other key inserted since Begin(). Empties the set. Returns the
  /// number of misses.
  std::size_t TakeUpdates(const FlatSet64& occupied, std::vector<std::uint64_t>* updates,
                          std::vector<std::uint64_t>* scratch) {
    hits_.clear();
    for (const std::uint64_t key : occupied.items()) hits_.push_back((MortonOfPacked(key) << 1) | 1u);
    updates->clear();
    std::size_t misses = 0;
    if (use_bitmap_ && fallback_.size() == 0) {
      // Bricks in Morton order, bits in Morton order within a brick, merged with the sorted hits.
      RadixSort(&hits_, scratch);
      std::sort(touched_.begin(), touched_.end());
      std::size_t h = 0;
      for (const auto& [brick_code, brick] : touched_) {
        for (unsigned w = 0; w < 8; ++w) {
          std::uint64_t word = bits_[brick * 8 + w];
          bits_[brick * 8 + w] = 0;
          while (word != 0) {
            const unsigned b = static_cast<unsigned>(__builtin_ctzll(word));
            word &= word - 1;
            const std::uint64_t miss = ((brick_code << 9) | (w << 6) | b) << 1;
            while (h < hits_.size() && hits_[h] < miss) updates->push_back(hits_[h++]);
            if (h < hits_.size() && hits_[h] == (miss | 1u)) continue;  // Occupied wins.
            updates->push_back(miss);
            ++misses;
          }
        }
        touched_flags_[brick] = 0;
      }
      updates->insert(updates->end(), hits_.begin() + static_cast<std::ptrdiff_t>(h), hits_.end());
    } else {
      for (const auto& [brick_code, brick] : touched_) {  // Rare: keys outside the box too.
        for (unsigned w = 0; w < 8; ++w) {
          for (std::uint64_t word = bits_[brick * 8 + w]; word != 0; word &= word - 1) {
            const std::uint64_t code =
                (brick_code << 9) | (w << 6) | static_cast<unsigned>(__builtin_ctzll(word));
            fallback_.Insert(PackKey(KeyOfMorton(code)));
          }
          bits_[brick * 8 + w] = 0;
        }
        touched_flags_[brick] = 0;
      }
      for (const std::uint64_t key : fallback_.items()) {
        if (!occupied.Contains(key)) updates->push_back(MortonOfPacked(key) << 1);
      }
      misses = updates->size();
      updates->insert(updates->end(), hits_.begin(), hits_.end());
      RadixSort(updates, scratch);
    }
    touched_.clear();
    return misses;
  }

  std::size_t MemoryBytes() const {
    return (bits_.capacity() + hits_.capacity()) * sizeof(std::uint64_t) + touched_flags_.capacity() +
           touched_.capacity() * sizeof(touched_[0]) + fallback_.MemoryBytes();
  }

 private:
  /// Largest bitmap, in bricks of 512 voxels: 2^19 bricks = 32 MiB, e.g. a 64 x 64 x 64 m box at 0.1 m.
  static constexpr std::size_t kMaxBricks = std::size_t{1} << 19;
  /// Spread3 of 0..7.
  static constexpr unsigned kSpread[8] = {0u, 1u, 8u, 9u, 64u, 65u, 72u, 73u};

  static OcTreeKey KeyOfMorton(std::uint64_t code) {
    return OcTreeKey(static_cast<octomap::key_type>(Compact3(code)),
                     static_cast<octomap::key_type>(Compact3(code >> 1)),
                     static_cast<octomap::key_type>(Compact3(code >> 2)));
  }

  bool InBox(const OcTreeKey& key) const {
    for (int i = 0; i < 3; ++i) {
      if (static_cast<unsigned>(key[i] - origin_[i]) >= 8u * static_cast<unsigned>(num_bricks_[i]))
        return false;
    }
    return true;
  }

  std::array<int, 3> origin_{};
  std::array<int, 3> num_bricks_{};
  bool use_bitmap_ = false;
  std::vector<std::uint64_t> bits_;
  std::vector<std::uint8_t> touched_flags_;
  std::vector<std::pair<std::uint64_t, std::size_t>> touched_;  // (brick Morton code, brick index).
  std::vector<std::uint64_t> hits_;
  FlatSet64 fallback_;
};

// -----------------------------------------------------------------------------------------------------------
// The tree.

/// Known state of a node's whole subtree once converted to maximum likelihood (for .bt writing).
enum class MlState { kMixed, kFree, kOccupied };

/// OctoMap's OcTree plus a batched update that reaches its protected members. Same node type and file type id
/// ("OcTree") as OcTree.
class Tree final : public octomap::OcTree {
 public:
  explicit Tree(double resolution_m) : OcTree(resolution_m) {}

  /// Applies `updates` (ascending, one per voxel, each (Morton code << 1) | hit) as OctoMap's non-lazy
  /// updateNode would one by one. Inserts into `changed` the Morton code >> (3 * track_levels) of every voxel
  /// whose occupancy state changed (unknown -> known, or across the threshold).
  void ApplySortedUpdates(const std::vector<std::uint64_t>& updates, int track_levels, FlatSet64* changed) {
    if (updates.empty()) return;
    bool created = false;
    if (root == nullptr) {
      root = new OcTreeNode();
      ++tree_size;
      size_changed = true;
      created = true;
    }
    track_shift_ = 1 + 3 * track_levels;
    changed_ = changed;
    UpdateRecurs(root, created, 0, updates.data(), updates.data() + updates.size());
    changed_ = nullptr;
  }

  /// Node covering the voxel of Morton code `code` at depth `depth` (code has 3 * depth bits): the node at
  /// that depth, or a pruned leaf above it; nullptr if unknown. `*node_depth` receives the node's depth.
  const OcTreeNode* FindCovering(std::uint64_t code, int depth, int* node_depth) const {
    const OcTreeNode* node = root;
    int d = 0;
    while (node != nullptr && d < depth && nodeHasChildren(node)) {
      const unsigned child = static_cast<unsigned>(code >> (3 * (depth - 1 - d))) & 7u;
      node = nodeChildExists(node, child) ? getNodeChild(node, child) : nullptr;
      ++d;
    }
    *node_depth = d;
    return node;
  }

  /// Appends (Morton code at `target_depth`, occupied) of every known voxel at target_depth inside `node`
  /// (at `depth`, Morton code `prefix`), in Morton order. A pruned leaf above target_depth yields all its
  /// voxels.
  void CollectAtDepth(const OcTreeNode* node, int depth, std::uint64_t prefix, int target_depth,
                      std::vector<std::pair<std::uint64_t, bool>>* out) const {
    if (depth == target_depth) {
      out->emplace_back(prefix, isNodeOccupied(node));
    } else if (!nodeHasChildren(node)) {
      const bool occupied = isNodeOccupied(node);
      const int shift = 3 * (target_depth - depth);
      const std::uint64_t first = prefix << shift;
      for (std::uint64_t j = 0; j < (std::uint64_t{1} << shift); ++j) out->emplace_back(first | j, occupied);
    } else {
      for (unsigned i = 0; i < 8; ++i) {
        if (nodeChildExists(node, i)) {
          CollectAtDepth(getNodeChild(node, i), depth + 1, (prefix << 3) | i, target_depth, out);
        }
      }
    }
  }

  /// How many entries CollectAtDepth would produce below `node` (at `depth`), or `limit` + 1 once there are
  /// more (a pruned leaf high in the tree stands for 8^levels voxels).
  std::uint64_t CountAtDepth(const OcTreeNode* node, int depth, int target_depth, std::uint64_t limit) const {
    if (depth == target_depth) return 1;
    if (!nodeHasChildren(node)) {
      const int shift = 3 * (target_depth - depth);
      return shift >= 63 || (std::uint64_t{1} << shift) > limit ? limit + 1 : std::uint64_t{1} << shift;
    }
    std::uint64_t n = 0;
    for (unsigned i = 0; i < 8 && n <= limit; ++i) {
      if (nodeChildExists(node, i))
        n += CountAtDepth(getNodeChild(node, i), depth + 1, target_depth, limit - n);
    }
    return std::min(n, limit + 1);
  }

  /// Counts the occupied and known finest voxels below `node` (at `depth`).
  void CountVoxels(const OcTreeNode* node, int depth, std::int64_t* occupied, std::int64_t* known) const {
    if (!nodeHasChildren(node)) {
      const std::int64_t n = std::int64_t{1} << (3 * (kTreeDepth - depth));
      *known += n;
      if (isNodeOccupied(node)) *occupied += n;
      return;
    }
    for (unsigned i = 0; i < 8; ++i) {
      if (nodeChildExists(node, i)) CountVoxels(getNodeChild(node, i), depth + 1, occupied, known);
    }
  }

  /// Appends the keys of the occupied finest voxels below `node` (at `depth`, min corner key `base`) inside
  /// the closed key box [lo, hi].
  // Appends the keys of the finest voxels in the key box [lo, hi] whose leaf is occupied (want_occupied) or
  // known free (!want_occupied); unknown space has no leaf and is never collected.
  void CollectInKeyBox(const OcTreeNode* node, int depth, const std::array<int, 3>& base,
                       const std::array<int, 3>& lo, const std::array<int, 3>& hi, bool want_occupied,
                       std::vector<std::array<int, 3>>* out) const {
    const int size = 1 << (kTreeDepth - depth);
    std::array<int, 3> a{};
    std::array<int, 3> b{};
    for (int i = 0; i < 3; ++i) {
      a[i] = std::max(lo[i], base[i]);
      b[i] = std::min(hi[i], base[i] + size - 1);
      if (a[i] > b[i]) return;
    }
    if (!nodeHasChildren(node)) {
      if (isNodeOccupied(node) != want_occupied) return;
      for (int x = a[0]; x <= b[0]; ++x) {
        for (int y = a[1]; y <= b[1]; ++y) {
          for (int z = a[2]; z <= b[2]; ++z) out->push_back({x, y, z});
        }
      }
      return;
    }
    const int half = size / 2;
    for (unsigned i = 0; i < 8; ++i) {
      if (!nodeChildExists(node, i)) continue;
      const std::array<int, 3> child_base{base[0] + ((i & 1u) ? half : 0), base[1] + ((i & 2u) ? half : 0),
                                          base[2] + ((i & 4u) ? half : 0)};
      CollectInKeyBox(getNodeChild(node, i), depth + 1, child_base, lo, hi, want_occupied, out);
    }
  }

  /// Appends to `data` OctoMap's binary stream of the subtree below `node` after maximum-likelihood
  /// conversion and pruning (what writeBinary() writes for it, without modifying the tree): the 2 child-code
  /// bytes of node, then its inner children's streams depth first. A non-root node whose 8 children all
  /// convert to leaves of one state is written by its parent as such a leaf (its stream is dropped).
  MlState WriteMaxLikelihood(const OcTreeNode* node, bool is_root, std::string* data) const {
    const std::size_t pos = data->size();
    data->append(2, '\0');
    std::array<unsigned char, 2> codes{0, 0};
    bool uniform = true;
    MlState first = MlState::kMixed;
    for (unsigned i = 0; i < 8; ++i) {
      MlState state = MlState::kMixed;
      if (!nodeHasChildren(node)) {
        // Only a fully pruned root gets here: write it as 8 leaves of its state.
        state = isNodeOccupied(node) ? MlState::kOccupied : MlState::kFree;
      } else if (!nodeChildExists(node, i)) {
        uniform = false;
        continue;
      } else {
        const OcTreeNode* child = getNodeChild(node, i);
        if (nodeHasChildren(child)) {
          state = WriteMaxLikelihood(child, false, data);
        } else {
          state = isNodeOccupied(child) ? MlState::kOccupied : MlState::kFree;
        }
      }
      // Child codes, two bits per child (bit 2i set: free, bit 2i + 1 set: occupied, both: inner node).
      const unsigned bits = state == MlState::kMixed ? 3u : state == MlState::kOccupied ? 2u : 1u;
      codes[i / 4] = static_cast<unsigned char>(codes[i / 4] | (bits << (2 * (i % 4))));
      if (i == 0) first = state;
      if (state == MlState::kMixed || state != first) uniform = false;
    }
    if (uniform && !is_root) {
      data->resize(pos);
      return first;
    }
    (*data)[pos] = static_cast<char>(codes[0]);
    (*data)[pos + 1] = static_cast<char>(codes[1]);
    return MlState::kMixed;
  }

 private:
  void UpdateRecurs(OcTreeNode* node, bool just_created, int depth, const std::uint64_t* begin,
                    const std::uint64_t* end) {
    if (depth == kTreeDepth) {  // A finest voxel: exactly one update.
      const bool hit = (*begin & 1u) != 0;
      const bool occupied_before = isNodeOccupied(node);
      updateNodeLogOdds(node, hit ? prob_hit_log : prob_miss_log);
      if (just_created || occupied_before != isNodeOccupied(node)) changed_->Insert(*begin >> track_shift_);
      return;
    }
    if (!just_created && !nodeHasChildren(node)) {
      // A pruned leaf. OctoMap's updateNode leaves it untouched for updates pushing it further into its
      // clamp; skip it when all updates below do, else expand it (children copy its value) as updateNode
      // does.
      const float log_odds = node->getLogOdds();
      const bool clamped_high = log_odds >= clamping_thres_max;
      if (clamped_high || log_odds <= clamping_thres_min) {
        const std::uint64_t want = clamped_high ? 1u : 0u;
        if (std::all_of(begin, end, [want](std::uint64_t u) { return (u & 1u) == want; })) return;
      }
      expandNode(node);
    }
    const int shift = 1 + 3 * (kTreeDepth - 1 - depth);
    for (const std::uint64_t* it = begin; it != end;) {
      const unsigned child = static_cast<unsigned>(*it >> shift) & 7u;
      const std::uint64_t* child_end = it + 1;
      while (child_end != end && (static_cast<unsigned>(*child_end >> shift) & 7u) == child) ++child_end;
      bool created = false;
      if (!nodeChildExists(node, child)) {
        createNodeChild(node, child);
        created = true;
      }
      UpdateRecurs(getNodeChild(node, child), created, depth + 1, it, child_end);
      it = child_end;
    }
    if (!pruneNode(node)) node->updateOccupancyChildren();
  }

  int track_shift_ = 1;
  FlatSet64* changed_ = nullptr;
};

// -----------------------------------------------------------------------------------------------------------
// .bt header and validation.

/// A parsed, validated .bt file (core::ParseBtFile), its resolution checked as a map's.
struct BtContents {
  double resolution_m = 0.0;
  std::int64_t num_nodes = 0;
  std::string data;  // The node stream.
};

/// Parses and validates the .bt file `bytes` read from `path`; throws MapError naming the path and the fault.
BtContents ParseBt(const std::string& bytes, const std::string& path) {
  const std::string where = "map file '" + path + "'";
  core::BtFile file;
  try {
    file = core::ParseBtFile(bytes, where);
  } catch (const std::invalid_argument& e) {
    throw MapError(e.what());
  }
  OccupancyMapOptions check;
  check.resolution_m = file.resolution_m;
  check.max_range_m = file.resolution_m;
  std::string why;
  if (!check.IsValid(&why)) throw MapError(where + " has an invalid resolution: " + why);
  return BtContents{file.resolution_m, file.num_nodes, std::move(file.data)};
}

std::string Vec3Text(double x, double y, double z) {
  std::ostringstream s;
  s << "(" << x << ", " << y << ", " << z << ")";
  return s.str();
}

void CheckCoarseLevels(int coarse_levels, const char* function) {
  if (coarse_levels < 0 || coarse_levels > OccupancyMap::kMaxCoarseLevels) {
    throw MapError(std::string(function) + ": coarse_levels = " + std::to_string(coarse_levels) +
                   " must be in [0, " + std::to_string(OccupancyMap::kMaxCoarseLevels) + "]");
  }
}

}  // namespace

// -----------------------------------------------------------------------------------------------------------

bool OccupancyMapOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& msg) {
    if (why != nullptr) *why = msg;
    return false;
  };
  auto text = [](double v) { return core::ShortestDecimal(v); };
  if (!(resolution_m >= 0.01 && resolution_m <= 10.0)) {
    return fail("resolution_m = " + text(resolution_m) + " must be in [0.01, 10]");
  }
  if (!(max_range_m > 0.0 && max_range_m <= 30000.0 * resolution_m)) {
    return fail("max_range_m = " + text(max_range_m) +
                " must be in (0, 30000 * resolution_m = " + text(30000.0 * resolution_m) + "]");
  }
  if (!(probability_hit > 0.5 && probability_hit < 1.0)) {
    return fail("probability_hit = " + text(probability_hit) + " must be in (0.5, 1)");
  }
  if (!(probability_miss > 0.0 && probability_miss < 0.5)) {
    return fail("probability_miss = " + text(probability_miss) + " must be in (0, 0.5)");
  }
  if (!(clamping_min > 0.0 && clamping_min < 0.5)) {
    return fail("clamping_min = " + text(clamping_min) + " must be in (0, 0.5)");
  }
  if (!(clamping_max > 0.5 && clamping_max < 1.0)) {
    return fail("clamping_max = " + text(clamping_max) + " must be in (0.5, 1)");
  }
  if (floor_guard_layers < 0 || floor_guard_layers > 8) {
    return fail("floor_guard_layers = " + std::to_string(floor_guard_layers) + " must be in [0, 8]");
  }
  return true;
}

struct OccupancyMap::Impl {
  explicit Impl(const OccupancyMapOptions& opts) : options(opts), tree(opts.resolution_m) {
    tree.setProbHit(opts.probability_hit);
    tree.setProbMiss(opts.probability_miss);
    tree.setClampingThresMin(opts.clamping_min);
    tree.setClampingThresMax(opts.clamping_max);
    tree.setOccupancyThres(0.5);
  }

  // Pass 1 of InsertScan: the scan's end points in W (frame of `T_W_S`), one per new end-point voxel (rays to
  // be cast), and ends clipped at max_range_m, into ray_ends (with the floor guard of each: ray_keep_below)
  // and occupied_keys; grows the key box [*lo, *hi] over all of them.
  void CollectRayEnds(const std::vector<Eigen::Vector3f>& points_S, const Eigen::Isometry3d& T_W_S,
                      const point3d& origin, const OcTreeKey& origin_key, InsertStats* stats,
                      std::array<int, 3>* lo, std::array<int, 3>* hi) {
    const Eigen::Matrix3d R_W_S = T_W_S.linear();
    const Eigen::Vector3d p_W_S = T_W_S.translation();
    const double max_range_m = options.max_range_m;
    const bool one_ray_per_endpoint_voxel = options.one_ray_per_endpoint_voxel;
    const int guard = options.floor_guard_layers;
    occupied_keys.Clear();
    ray_ends.clear();
    ray_keep_below.clear();
    for (const Eigen::Vector3f& p_S : points_S) {
      if (!p_S.allFinite()) {
        ++stats->dropped_non_finite;
        continue;
      }
      const Eigen::Vector3d p_W = R_W_S * p_S.cast<double>() + p_W_S;
      point3d end(static_cast<float>(p_W.x()), static_cast<float>(p_W.y()), static_cast<float>(p_W.z()));
      const point3d ray_W = end - origin;
      OcTreeKey end_key;
      const bool hit = ray_W.norm() <= max_range_m;
      if (hit) {
        if (!tree.coordToKeyChecked(end, end_key)) {
          ++stats->dropped_out_of_map;
          continue;
        }
        if (!occupied_keys.Insert(PackKey(end_key)) && one_ray_per_endpoint_voxel) {
          continue;  // A ray already reached this voxel.
        }
      } else {
        ++stats->clipped_max_range;
        // Same arithmetic as OccupancyOcTreeBase::computeUpdate.
        end = origin + ray_W.normalized() * static_cast<float>(max_range_m);
        if (!tree.coordToKeyChecked(end, end_key)) {
          ++stats->dropped_out_of_map;
          continue;
        }
      }
      ray_ends.push_back(end);
      const bool guarded =
          hit && guard > 0 && static_cast<int>(end_key[2]) + guard < static_cast<int>(origin_key[2]);
      ray_keep_below.push_back(guarded ? static_cast<int>(end_key[2]) + guard : 0);
      for (int i = 0; i < 3; ++i) {
        (*lo)[i] = std::min((*lo)[i], static_cast<int>(end_key[i]));
        (*hi)[i] = std::max((*hi)[i], static_cast<int>(end_key[i]));
      }
    }
  }

  /// Marks every known voxel at the tracking level as changed (after a load).
  void MarkAllKnownChanged() {
    if (tree.getRoot() == nullptr) return;
    std::vector<std::pair<std::uint64_t, bool>> all;
    tree.CollectAtDepth(tree.getRoot(), 0, 0, kTreeDepth - track_levels, &all);
    for (const auto& [code, occupied] : all) changed.Insert(code);
  }

  /// Key of coordinate `c` (metres) on one axis clamped to the map, as OctoMap's coordToKey computes it.
  int ClampedKey(double c) const {
    const double k = std::floor(c * (1.0 / options.resolution_m)) + kKeyOffset;
    return static_cast<int>(std::clamp(k, 0.0, 2.0 * kKeyOffset - 1.0));
  }

  OccupancyMapOptions options;
  Tree tree;
  /// Readers-writer lock of the tree and the change tracking: writers (InsertScan, TakeCoarseChanges) hold
  /// it exclusively, queries shared. Take it with ReadLock / WriteLock only.
  mutable std::shared_mutex mutex;
  /// Turnstile giving writers priority: glibc's std::shared_mutex prefers readers, so queries issued back to
  /// back from several threads could starve the mapping thread. A writer holds the turnstile while it waits
  /// for and holds `mutex`; a reader passes through it before taking `mutex` shared.
  mutable std::mutex turnstile;

  // Change tracking: Morton codes at track_levels above the finest of voxels whose state may have changed.
  int track_levels = OccupancyMap::kMaxCoarseLevels;
  FlatSet64 changed;

  // InsertScan scratch, kept between scans to avoid reallocation.
  octomap::KeyRay ray;
  FlatSet64 occupied_keys;
  ScanKeySet free_keys;
  std::vector<point3d> ray_ends;
  std::vector<int> ray_keep_below;  // per ray end: layers (z keys) below this are not carved (floor guard)
  std::vector<std::uint64_t> updates;
  std::vector<std::uint64_t> sort_scratch;
};

namespace {

/// Shared (query) lock of a map's `mutex`, taken after passing its `turnstile` (see OccupancyMap::Impl).
class ReadLock {
 public:
  ReadLock(std::mutex& turnstile, std::shared_mutex& mutex) {
    { const std::lock_guard<std::mutex> behind_waiting_writers(turnstile); }
    lock_ = std::shared_lock<std::shared_mutex>(mutex);
  }

 private:
  std::shared_lock<std::shared_mutex> lock_;
};

/// Exclusive (writer) lock of a map: its `turnstile`, then its `mutex`.
class WriteLock {
 public:
  WriteLock(std::mutex& turnstile, std::shared_mutex& mutex) : turnstile_(turnstile), lock_(mutex) {}
  void unlock() {
    lock_.unlock();
    turnstile_.unlock();
  }

 private:
  std::unique_lock<std::mutex> turnstile_;
  std::unique_lock<std::shared_mutex> lock_;
};

}  // namespace

OccupancyMap::OccupancyMap(const OccupancyMapOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw MapError("invalid OccupancyMapOptions: " + why);
  impl_ = std::make_unique<Impl>(options);
}

OccupancyMap::~OccupancyMap() = default;
OccupancyMap::OccupancyMap(OccupancyMap&& other) noexcept = default;
OccupancyMap& OccupancyMap::operator=(OccupancyMap&& other) noexcept = default;

const OccupancyMapOptions& OccupancyMap::options() const { return impl_->options; }

InsertStats OccupancyMap::InsertScan(const std::vector<Eigen::Vector3f>& points_S,
                                     const Eigen::Isometry3d& T_W_S) {
  Impl& m = *impl_;
  InsertStats stats;
  stats.points_in = static_cast<std::int64_t>(points_S.size());
  const Eigen::Vector3d p_W_S = T_W_S.translation();
  if (!T_W_S.matrix().allFinite()) {
    throw MapError("InsertScan: sensor pose T_W_S is not finite (translation " +
                   Vec3Text(p_W_S.x(), p_W_S.y(), p_W_S.z()) + " m)");
  }
  const point3d origin(static_cast<float>(p_W_S.x()), static_cast<float>(p_W_S.y()),
                       static_cast<float>(p_W_S.z()));
  OcTreeKey origin_key;
  if (!m.tree.coordToKeyChecked(origin, origin_key)) {
    throw MapError("InsertScan: sensor origin p_W_S = " + Vec3Text(p_W_S.x(), p_W_S.y(), p_W_S.z()) +
                   " m is outside the map (+-" + core::ShortestDecimal(kKeyOffset * m.options.resolution_m) +
                   " m)");
  }
  if (points_S.empty()) return stats;

  WriteLock lock(m.turnstile, m.mutex);
  std::array<int, 3> lo{origin_key[0], origin_key[1], origin_key[2]};
  std::array<int, 3> hi = lo;
  m.CollectRayEnds(points_S, T_W_S, origin, origin_key, &stats, &lo, &hi);
  // Pass 2: the voxels crossed by the rays (both ends are in the map, so computeRayKeys cannot fail).
  m.free_keys.Begin(lo, hi);
  for (std::size_t r = 0; r < m.ray_ends.size(); ++r) {
    m.tree.computeRayKeys(origin, m.ray_ends[r], m.ray);
    const int keep_below = m.ray_keep_below[r];
    for (const OcTreeKey& key : m.ray) {
      if (static_cast<int>(key[2]) >= keep_below) m.free_keys.Insert(key);
    }
  }

  stats.free_updates =
      static_cast<std::int64_t>(m.free_keys.TakeUpdates(m.occupied_keys, &m.updates, &m.sort_scratch));
  stats.unique_endpoints = static_cast<std::int64_t>(m.occupied_keys.size());
  stats.occupied_updates = stats.unique_endpoints;
  m.tree.ApplySortedUpdates(m.updates, m.track_levels, &m.changed);
  return stats;
}

Occupancy OccupancyMap::Query(const Eigen::Vector3d& p_W) const {
  const Impl& m = *impl_;
  OcTreeKey key;
  if (!p_W.allFinite() || !m.tree.coordToKeyChecked(p_W.x(), p_W.y(), p_W.z(), key)) {
    return Occupancy::kUnknown;
  }
  ReadLock lock(m.turnstile, m.mutex);
  const OcTreeNode* node = m.tree.search(key);
  if (node == nullptr) return Occupancy::kUnknown;
  return m.tree.isNodeOccupied(node) ? Occupancy::kOccupied : Occupancy::kFree;
}

std::optional<Eigen::Vector3d> OccupancyMap::CastRay(const Eigen::Vector3d& origin_W,
                                                     const Eigen::Vector3d& direction_W, double max_range_m,
                                                     bool unknown_is_occupied) const {
  if (!origin_W.allFinite()) {
    throw MapError("CastRay: origin_W = " + Vec3Text(origin_W.x(), origin_W.y(), origin_W.z()) +
                   " is not finite");
  }
  if (!direction_W.allFinite() || direction_W.norm() == 0.0) {
    throw MapError("CastRay: direction_W = " + Vec3Text(direction_W.x(), direction_W.y(), direction_W.z()) +
                   " must be finite and non-zero");
  }
  if (!(max_range_m >= 0.0 && std::isfinite(max_range_m))) {
    throw MapError("CastRay: max_range_m = " + core::ShortestDecimal(max_range_m) +
                   " must be finite and >= 0");
  }
  const Impl& m = *impl_;
  const double res = m.options.resolution_m;
  const Eigen::Vector3d dir = direction_W.normalized();
  OcTreeKey key;
  if (!m.tree.coordToKeyChecked(origin_W.x(), origin_W.y(), origin_W.z(), key)) return std::nullopt;
  // Amanatides & Woo, "A fast voxel traversal algorithm for ray tracing", Eurographics 1987.
  std::array<int, 3> k{key[0], key[1], key[2]};
  std::array<int, 3> step{};
  std::array<double, 3> t_max{};
  std::array<double, 3> t_delta{};
  for (int i = 0; i < 3; ++i) {
    if (dir[i] > 0.0) {
      step[i] = 1;
      t_max[i] = ((k[i] - kKeyOffset + 1) * res - origin_W[i]) / dir[i];
      t_delta[i] = res / dir[i];
    } else if (dir[i] < 0.0) {
      step[i] = -1;
      t_max[i] = ((k[i] - kKeyOffset) * res - origin_W[i]) / dir[i];
      t_delta[i] = -res / dir[i];
    } else {
      step[i] = 0;
      t_max[i] = std::numeric_limits<double>::infinity();
      t_delta[i] = std::numeric_limits<double>::infinity();
    }
  }
  ReadLock lock(m.turnstile, m.mutex);
  while (true) {
    const OcTreeKey current(static_cast<octomap::key_type>(k[0]), static_cast<octomap::key_type>(k[1]),
                            static_cast<octomap::key_type>(k[2]));
    const OcTreeNode* node = m.tree.search(current);
    if ((node != nullptr && m.tree.isNodeOccupied(node)) || (node == nullptr && unknown_is_occupied)) {
      return Eigen::Vector3d(m.tree.keyToCoord(current[0]), m.tree.keyToCoord(current[1]),
                             m.tree.keyToCoord(current[2]));
    }
    const int axis = t_max[0] < t_max[1] ? (t_max[0] < t_max[2] ? 0 : 2) : (t_max[1] < t_max[2] ? 1 : 2);
    if (t_max[axis] > max_range_m) return std::nullopt;
    k[axis] += step[axis];
    if (k[axis] < 0 || k[axis] >= 2 * kKeyOffset) return std::nullopt;
    t_max[axis] += t_delta[axis];
  }
}

std::vector<Eigen::Vector3d> OccupancyMap::OccupiedInBox(const Eigen::AlignedBox3d& box_W) const {
  return VoxelsInBox(box_W, /*occupied=*/true);
}

std::vector<Eigen::Vector3d> OccupancyMap::FreeInBox(const Eigen::AlignedBox3d& box_W) const {
  return VoxelsInBox(box_W, /*occupied=*/false);
}

std::vector<Eigen::Vector3d> OccupancyMap::VoxelsInBox(const Eigen::AlignedBox3d& box_W,
                                                       bool occupied) const {
  if (box_W.min().hasNaN() || box_W.max().hasNaN()) {
    throw MapError(std::string(occupied ? "OccupiedInBox" : "FreeInBox") + ": box_W corner is NaN: min " +
                   Vec3Text(box_W.min().x(), box_W.min().y(), box_W.min().z()) + ", max " +
                   Vec3Text(box_W.max().x(), box_W.max().y(), box_W.max().z()));
  }
  std::vector<Eigen::Vector3d> centers_W;
  if (box_W.isEmpty()) return centers_W;
  const Impl& m = *impl_;
  std::array<int, 3> lo{};
  std::array<int, 3> hi{};
  for (int i = 0; i < 3; ++i) {
    lo[i] = m.ClampedKey(box_W.min()[i]);
    hi[i] = m.ClampedKey(box_W.max()[i]);
  }
  std::vector<std::array<int, 3>> keys;
  {
    ReadLock lock(m.turnstile, m.mutex);
    if (m.tree.getRoot() == nullptr) return centers_W;
    m.tree.CollectInKeyBox(m.tree.getRoot(), 0, {0, 0, 0}, lo, hi, occupied, &keys);
  }
  centers_W.reserve(keys.size());
  const double res = m.options.resolution_m;
  for (const auto& k : keys) {
    centers_W.emplace_back((k[0] - kKeyOffset + 0.5) * res, (k[1] - kKeyOffset + 0.5) * res,
                           (k[2] - kKeyOffset + 0.5) * res);
  }
  return centers_W;
}

std::int64_t OccupancyMap::NumOccupiedLeaves() const {
  ReadLock lock(impl_->turnstile, impl_->mutex);
  std::int64_t occupied = 0;
  std::int64_t known = 0;
  if (impl_->tree.getRoot() != nullptr) impl_->tree.CountVoxels(impl_->tree.getRoot(), 0, &occupied, &known);
  return occupied;
}

std::int64_t OccupancyMap::NumKnownLeaves() const {
  ReadLock lock(impl_->turnstile, impl_->mutex);
  std::int64_t occupied = 0;
  std::int64_t known = 0;
  if (impl_->tree.getRoot() != nullptr) impl_->tree.CountVoxels(impl_->tree.getRoot(), 0, &occupied, &known);
  return known;
}

std::int64_t OccupancyMap::NumTreeNodes() const {
  ReadLock lock(impl_->turnstile, impl_->mutex);
  return static_cast<std::int64_t>(impl_->tree.size());
}

std::size_t OccupancyMap::MemoryBytes() const {
  const Impl& m = *impl_;
  ReadLock lock(m.turnstile, m.mutex);
  return m.tree.memoryUsage() + m.changed.MemoryBytes() + m.occupied_keys.MemoryBytes() +
         m.free_keys.MemoryBytes() + m.ray_ends.capacity() * sizeof(point3d) +
         m.ray_keep_below.capacity() * sizeof(int) +
         (m.updates.capacity() + m.sort_scratch.capacity()) * sizeof(std::uint64_t) +
         m.ray.sizeMax() * sizeof(OcTreeKey);
}

void OccupancyMap::WriteBinary(std::ostream& out) const {
  std::string data;
  {
    ReadLock lock(impl_->turnstile, impl_->mutex);
    if (impl_->tree.getRoot() != nullptr) impl_->tree.WriteMaxLikelihood(impl_->tree.getRoot(), true, &data);
  }
  std::string error;
  const std::int64_t num_nodes = core::CountBtNodes(data.data(), data.size(), &error);
  if (!error.empty()) throw MapError("WriteBinary: internal error, the node stream is " + error);
  out << core::BtFileHeader(static_cast<std::size_t>(num_nodes), impl_->options.resolution_m);
  out.write(data.data(), static_cast<std::streamsize>(data.size()));
  if (!out) throw MapError("WriteBinary: the output stream failed");
}

void OccupancyMap::SaveBt(const std::string& path) const {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw MapError("cannot open map file '" + tmp + "' for writing");
    try {
      WriteBinary(out);
    } catch (const MapError&) {
      out.close();
      std::remove(tmp.c_str());
      throw MapError("cannot write map file '" + tmp + "'");
    }
    out.close();
    if (!out) {
      std::remove(tmp.c_str());
      throw MapError("cannot write map file '" + tmp + "' (close failed)");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::remove(tmp.c_str());
    throw MapError("cannot rename map file '" + tmp + "' to '" + path + "': " + ec.message());
  }
}

namespace {
// Most change-tracking cubes a loaded map may expand to (8-16 bytes each in the tracking set): 10^7 cubes of
// 2^kMaxCoarseLevels voxels a side (6.4 m at 0.1 m) hold any site many times over.
constexpr std::uint64_t kMaxLoadedTrackedVoxels = 10'000'000;
}  // namespace

OccupancyMap OccupancyMap::LoadBt(const std::string& path, const OccupancyMapOptions& options) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) throw MapError("map file '" + path + "' does not exist");
  if (!std::filesystem::is_regular_file(status))
    throw MapError("map file '" + path + "' is not a regular file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MapError("map file '" + path + "' cannot be opened for reading");
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw MapError("map file '" + path + "' cannot be read");

  const BtContents contents = ParseBt(bytes, path);
  OccupancyMapOptions opts = options;
  opts.resolution_m = contents.resolution_m;
  std::string why;
  if (!opts.IsValid(&why)) {
    throw MapError("LoadBt('" + path + "'): invalid options with the file's resolution: " + why);
  }
  OccupancyMap map(opts);
  Impl& m = *map.impl_;
  // A root without children is an empty map (OctoMap would read it as one occupied root leaf).
  if (contents.num_nodes > 1) {
    // Hand OctoMap a canonical header and the validated node stream.
    std::istringstream stream(
        core::BtFileHeader(static_cast<std::size_t>(contents.num_nodes), contents.resolution_m) +
        contents.data);
    if (!m.tree.readBinary(stream) || static_cast<std::int64_t>(m.tree.size()) != contents.num_nodes) {
      throw MapError("map file '" + path + "' could not be read by OctoMap");
    }
    // readBinary leaves the root at the upper clamp; inner nodes get the max of their children.
    m.tree.updateInnerOccupancy();
    // A pruned leaf high in the tree stands for a huge cube of space: expanded into change tracking (and
    // later into coarse telemetry voxels) it would take gigabytes (found by fuzzing: a root with 8 leaves,
    // 61 bytes, took 22 GB). Such a file is no map of a site.
    const std::uint64_t tracked =
        m.tree.CountAtDepth(m.tree.getRoot(), 0, kTreeDepth - m.track_levels, kMaxLoadedTrackedVoxels);
    if (tracked > kMaxLoadedTrackedVoxels) {
      const double edge_m = contents.resolution_m * static_cast<double>(1 << m.track_levels);
      throw MapError("map file '" + path + "' expands to more than " +
                     std::to_string(kMaxLoadedTrackedVoxels) + " known cubes of " + std::to_string(edge_m) +
                     " m (pruned leaves covering kilometres of space); refusing to load it");
    }
  }
  m.MarkAllKnownChanged();
  return map;
}

std::vector<CoarseVoxel> OccupancyMap::TakeCoarseChanges(int coarse_levels) {
  CheckCoarseLevels(coarse_levels, "TakeCoarseChanges");
  Impl& m = *impl_;
  WriteLock lock(m.turnstile, m.mutex);
  const int target_depth = kTreeDepth - coarse_levels;
  std::vector<std::pair<std::uint64_t, bool>> found;
  if (coarse_levels >= m.track_levels) {
    // Each tracked voxel lies in one coarse voxel.
    FlatSet64 coarse;
    const int shift = 3 * (coarse_levels - m.track_levels);
    for (const std::uint64_t code : m.changed.items()) coarse.Insert(code >> shift);
    for (const std::uint64_t code : coarse.items()) {
      int depth = 0;
      const OcTreeNode* node = m.tree.FindCovering(code, target_depth, &depth);
      if (node != nullptr) found.emplace_back(code, m.tree.isNodeOccupied(node));
    }
  } else {
    // Finer than tracked: every known coarse voxel inside each tracked voxel.
    const int tracked_depth = kTreeDepth - m.track_levels;
    for (const std::uint64_t code : m.changed.items()) {
      int depth = 0;
      const OcTreeNode* node = m.tree.FindCovering(code, tracked_depth, &depth);
      if (node == nullptr) continue;
      if (depth < tracked_depth) {  // Inside a pruned leaf: all of it has the leaf's state.
        const int shift = 3 * (target_depth - tracked_depth);
        for (std::uint64_t j = 0; j < (std::uint64_t{1} << shift); ++j) {
          found.emplace_back((code << shift) | j, m.tree.isNodeOccupied(node));
        }
      } else {
        m.tree.CollectAtDepth(node, tracked_depth, code, target_depth, &found);
      }
    }
  }
  m.changed.Clear();
  m.track_levels = coarse_levels;
  lock.unlock();

  std::sort(found.begin(), found.end());
  std::vector<CoarseVoxel> voxels;
  voxels.reserve(found.size());
  for (const auto& [code, occupied] : found)
    voxels.push_back(CoarseFromMorton(code, coarse_levels, occupied));
  return voxels;
}

std::vector<CoarseVoxel> OccupancyMap::CoarseSnapshot(int coarse_levels) const {
  CheckCoarseLevels(coarse_levels, "CoarseSnapshot");
  const Impl& m = *impl_;
  std::vector<std::pair<std::uint64_t, bool>> found;
  {
    ReadLock lock(m.turnstile, m.mutex);
    if (m.tree.getRoot() != nullptr) {
      m.tree.CollectAtDepth(m.tree.getRoot(), 0, 0, kTreeDepth - coarse_levels, &found);
    }
  }
  std::vector<CoarseVoxel> voxels;
  voxels.reserve(found.size());
  for (const auto& [code, occupied] : found)
    voxels.push_back(CoarseFromMorton(code, coarse_levels, occupied));
  return voxels;
}

}  // namespace cairn::perception
