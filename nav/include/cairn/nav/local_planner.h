// Copyright Cairn authors.
//
// Trajectory-library local planner after FALCO (Zhang, Hu, Chen, Scherer & Singh, "Falco: Fast
// likelihood-based collision avoidance with extension to human-guided navigation", Journal of Field
// Robotics 37(8), 2020): a fixed set of short paths in the robot body frame is generated once, together with
// a voxel -> path correspondence, so that each cycle an obstacle cloud only has to be binned into voxels and
// each occupied voxel marks the paths it blocks (and the paths it passes close to) in O(1) per path. The
// planner then picks the best path that is free for the required length, toward a goal or, in smart-joystick
// mode, toward the operator's direction. DDS-free; Eigen only.
//
// Frame B (robot body): x forward, y left, z up, metres; angles in radians, counter-clockwise about +z,
// 0 = +x.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace cairn::nav {

/// Options of TrajectoryLibrary.
///
/// The paths of one heading form a three-level tree of circular arcs of equal length path_length_m / 3: the
/// first arc turns by one of num_groups heading changes (the path's group), the second and third by one of
/// sqrt(paths_per_group) heading changes each. The heading changes of a level are spread evenly over
/// [-max_segment_turn_rad, +max_segment_turn_rad] (0 when a level has one choice). That set of
/// num_groups * paths_per_group paths is rotated to num_headings headings k * 2 pi / num_headings; headings
/// farther than heading_range_rad from +x (frame B) are dropped. Defaults: 7 groups x 49 = 343 paths of 3 m,
/// 36 headings, 12,348 paths (the sizes of the CMU FALCO implementation).
struct TrajectoryLibraryOptions {
  /// Arc length of every path, metres, range [0.1, 10].
  double path_length_m = 3.0;
  /// Heading changes of the first arc (= path groups), range [1, 63].
  int num_groups = 7;
  /// Paths sharing a first arc, k * k for k (heading changes of the second and third arcs) in [1, 15].
  int paths_per_group = 49;
  /// Rotations of the path set around the full circle, range [1, 360].
  int num_headings = 36;
  /// Only headings within this angle of +x (frame B) are kept, radians, range [0, pi]; pi = all (a robot
  /// that turns in place), pi/2 = never start a path backwards.
  double heading_range_rad = 3.14159265358979323846;
  /// Largest heading change of one arc, radians, range [0, pi/2]. 27 deg: a 1 m arc then has a 2.1 m
  /// turning radius, and a whole path turns by at most 81 deg.
  double max_segment_turn_rad = 0.47123889803846897;
  /// Arc length between path samples, metres, range [0.005, 1]; rounded so that path_length_m is a whole
  /// number (1..250) of samples.
  double sample_spacing_m = 0.05;
  /// Edge of the square voxels (x-y) of the blocking grid, metres, range [0.02, 1]. Blocking is conservative
  /// by up to a voxel diagonal (see TrajectoryLibrary): 0.1 m voxels may block at up to 0.14 m beyond
  /// collision_radius_m + sample_spacing_m / 2; smaller voxels cost memory and time (~4x per halving).
  double voxel_size_m = 0.1;
  /// Edge of the voxels of the coarser clearance grid (the clearance band only affects the score), metres,
  /// range [0.02, 2].
  double clearance_voxel_size_m = 0.2;
  /// Robot radius plus safety margin, metres, range [0, 5]: an obstacle point closer than this (in x-y) to a
  /// path blocks the path from there on.
  double collision_radius_m = 0.35;
  /// Obstacle points between collision_radius_m and collision_radius_m + clearance_band_m from a path lower
  /// its clearance score, metres, range [0, 5].
  double clearance_band_m = 0.5;
  /// Points with z (metres, frame B) in [obstacle_min_z_m, obstacle_max_z_m] are obstacles; the others
  /// (ground, overhangs above the robot) are ignored. Finite, min < max.
  double obstacle_min_z_m = -0.3;
  /// Upper end of the obstacle z band, metres, frame B.
  double obstacle_max_z_m = 1.5;

  /// True when every field is in range (and the library stays within 65,535 path tree nodes, see
  /// TrajectoryLibrary, and 1,000 x 1,000 voxels per grid); otherwise false and, if `why` is not null, a
  /// message naming the field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// Description of one path of a TrajectoryLibrary.
struct TrajectoryInfo {
  int group = 0;                 ///< First-arc choice, 0..num_groups-1 (0 = hardest right turn).
  int heading_index = 0;         ///< Rotation k of the path set, angle k * 2 pi / num_headings.
  float heading_rad = 0.0f;      ///< Start direction (tangent at the origin), radians, frame B, (-pi, pi].
  float end_bearing_rad = 0.0f;  ///< Direction from the origin to the end point, radians, frame B.
  float end_heading_rad = 0.0f;  ///< Tangent direction at the end point, radians, frame B, (-pi, pi].
  float total_turn_rad = 0.0f;   ///< Sum of the absolute heading changes of the three arcs, radians.
  float length_m = 0.0f;         ///< Arc length, metres.
  Eigen::Vector2f end_B = Eigen::Vector2f::Zero();  ///< End point (x, y), metres, frame B.
};

/// One (blocking voxel, path tree node) pair of the correspondence: the voxel blocks the node's arc.
struct BlockingEntry {
  std::uint16_t node = 0;         ///< Path tree node id (see TrajectoryLibrary).
  std::uint8_t first_sample = 0;  ///< First sample of the node's arc the voxel blocks (0-based path sample).
  std::uint8_t unused = 0;
};

/// One (clearance voxel, path tree node) pair of the correspondence: the voxel has a clearance below
/// clearance_band_m to the node's arc.
struct BandEntry {
  std::uint16_t node = 0;           ///< Path tree node id.
  std::uint8_t closest_sample = 0;  ///< Sample of the node's arc nearest to the voxel centre (first if tied).
  std::uint8_t clearance_bucket = 0;  ///< Clearance, see TrajectoryLibrary::BucketClearanceM().
};

/// A read-only view of consecutive elements.
template <typename T>
struct ConstSpan {
  const T* first = nullptr;
  const T* last = nullptr;
  const T* begin() const { return first; }
  const T* end() const { return last; }
  std::size_t size() const { return static_cast<std::size_t>(last - first); }
};

/// A fixed set of planar paths starting at the origin of frame B, their samples, and the voxel -> path
/// correspondence used by LocalPlanner. Immutable after construction, so one instance can be shared by
/// several planners and threads.
///
/// Samples: sample i (0-based) of a path lies at arc length (i + 1) * sample_spacing_m(), i <
/// samples_per_path(); the last one is the end point. The origin itself is not a sample: an obstacle already
/// within collision_radius_m of the robot's position does not block paths that lead away from it.
///
/// Blocking grid (voxel_size_m) and blocking entries: a voxel blocks a path from sample i on if its centre is
/// within voxel_blocking_radius_m() = collision_radius_m + sample_spacing_m() / 2 + voxel_size_m * sqrt(2) /
/// 2 of sample i. This is conservative, so it holds for every point and for the continuous path, not just for
/// voxel centres and samples: a point that does not block a path is farther than collision_radius_m +
/// sample_spacing_m() / 2 from each of its samples, hence farther than collision_radius_m from every point of
/// the path after arc length sample_spacing_m() / 2. The price: a point may block at up to collision_radius_m
/// + sample_spacing_m() / 2 + voxel_size_m * sqrt(2) (0.52 m with the defaults, 0.375 m at best).
/// Points near the origin (within near_origin_radius_m()) skip the voxels and are tested exactly against the
/// path's segments (origin to sample 0, sample 0 to sample 1, ...): one blocks a path from the first segment
/// that passes it closer than collision_radius_m, or, when the robot already stands closer than that to it,
/// closer than the robot stands now (less 1 mm): the robot may move along it or away, never closer. Through
/// its voxel such a point would block the first samples of every path, those leading away from it too, so
/// that a robot standing just inside the collision radius of a door jamb, or of a stair flight's side wall,
/// could never leave; a path thus kept free keeps at least min(collision_radius_m, that distance) from the
/// point.
///
/// Clearance grid (clearance_voxel_size_m) and band entries: the clearance of a voxel to an arc is (distance
/// from the voxel centre to the arc's nearest sample) - clearance_voxel_size_m * sqrt(2) / 2 -
/// collision_radius_m, a lower bound of how far any point in the voxel stays outside the collision radius.
/// Voxels with a clearance below clearance_band_m to an arc are its band entries, the clearance quantised
/// down to a bucket of clearance_band_m / 254 (0 if negative). A coarser grid suffices since the clearance
/// only feeds the score, and it keeps the band (the larger area) cheap.
///
/// Path tree: the correspondence is stored per arc, not per path, as the paths of one heading share arcs:
/// the paths of a group share their first arc (a level 0 node, samples [0, level_end_sample(0))), those that
/// also share the second arc share a level 1 node (samples [level_end_sample(0), level_end_sample(1))), and
/// each path owns its third arc (level 2 node, up to the end). A path's first blocked sample is the least of
/// its three nodes'. This is exact (shared samples are bitwise equal) and stores a voxel near the robot once
/// per group instead of once per path: with the defaults 14,364 nodes, and a voxel next to the robot costs
/// 252 entries per cycle instead of 12,348.
///
/// Both grids are square, centred on the origin, with the origin on a voxel corner; each covers every voxel
/// that has an entry, so points outside both can be ignored. Costs with the defaults (12,348 paths; see
/// build_time_s() and memory_bytes()): ~0.4 s and 22 MB (2.2 M blocking + 1.8 M band entries of 4 bytes,
/// 5.9 MB of samples) on a 2-core x86-64 VM; with voxel_size_m = 0.05, ~0.5 s and 42 MB.
class TrajectoryLibrary {
 public:
  /// Builds the library. Throws std::invalid_argument with the IsValid() message if `options` is invalid.
  explicit TrajectoryLibrary(const TrajectoryLibraryOptions& options = {});

  /// Options given at construction.
  const TrajectoryLibraryOptions& options() const { return options_; }
  /// Number of paths; ids are 0..num_paths()-1, ordered by kept heading, then group, then the later arcs.
  int num_paths() const { return static_cast<int>(info_.size()); }
  /// Number of kept headings.
  int num_kept_headings() const { return num_kept_headings_; }
  /// Paths per kept heading (num_groups * paths_per_group).
  int paths_per_heading() const { return paths_per_heading_; }
  /// Samples per path.
  int samples_per_path() const { return samples_per_path_; }
  /// Actual arc length between samples (path_length_m / samples_per_path()), metres.
  double sample_spacing_m() const { return spacing_m_; }
  /// Description of path `path_id` (0 <= path_id < num_paths(), unchecked).
  const TrajectoryInfo& info(int path_id) const { return info_[static_cast<std::size_t>(path_id)]; }
  /// The samples_per_path() samples of path `path_id` ((x, y), metres, frame B), unchecked id.
  const Eigen::Vector2f* samples_B(int path_id) const {
    return samples_B_.data() +
           static_cast<std::size_t>(path_id) * static_cast<std::size_t>(samples_per_path_);
  }

  /// Number of path tree nodes (ids 0..num_nodes()-1: level 0 nodes, then level 1, then level 2 = one per
  /// path, node id of level 2 = level 2 base + path id).
  int num_nodes() const { return num_nodes_; }
  /// The three node ids (levels 0, 1, 2) of path `path_id` (unchecked); consecutive paths' ids follow.
  const std::uint16_t* path_nodes(int path_id) const {
    return node_of_path_.data() + static_cast<std::size_t>(path_id) * 3;
  }
  /// End (exclusive) of the samples of tree level `level` (0, 1 or 2; unchecked); level 2 ends at
  /// samples_per_path().
  int level_end_sample(int level) const { return level_end_sample_[level]; }

  /// collision_radius_m + sample_spacing_m() / 2, metres: a point this near a sample always blocks the path
  /// (one farther than it from every sample keeps collision_radius_m from the path).
  double point_blocking_radius_m() const { return point_blocking_radius_m_; }
  /// Distance from a sample within which a blocking voxel's centre blocks the path: point_blocking_radius_m()
  /// + half the voxel diagonal, metres.
  double voxel_blocking_radius_m() const { return voxel_blocking_radius_m_; }
  /// voxel_blocking_radius_m() + sample_spacing_m(), metres: obstacle points nearer the origin than this are
  /// tested against the path's segments exactly, not through their voxel (see the class comment).
  double near_origin_radius_m() const { return near_origin_radius_m_; }
  /// Clearance (metres) that a band entry's clearance_bucket stands for: a lower bound, bucket *
  /// clearance_band_m / 254; bucket 255 stands for "nothing in the band" and returns clearance_band_m.
  double BucketClearanceM(std::uint8_t bucket) const;

  /// Voxels per side of the blocking grid.
  int grid_size() const { return block_grid_.size; }
  /// Number of blocking voxels, grid_size()^2.
  int num_voxels() const { return block_grid_.size * block_grid_.size; }
  /// Lower (x and y) edge of the blocking grid, metres, frame B; it spans [grid_min_m(), -grid_min_m()).
  double grid_min_m() const { return block_grid_.min_m; }
  /// Index ix + grid_size() * iy of the blocking voxel containing (x_m, y_m) (metres, frame B), or -1 if
  /// outside the grid or not finite.
  int VoxelIndex(float x_m, float y_m) const { return block_grid_.Index(x_m, y_m); }
  /// Centre (x, y) of blocking voxel `index` (0 <= index < num_voxels(), unchecked), metres, frame B.
  Eigen::Vector2d VoxelCenter(int index) const { return block_grid_.Center(index); }
  /// Path tree nodes whose arcs blocking voxel `index` blocks, ascending node ids (unchecked index).
  ConstSpan<BlockingEntry> blocking_entries(int index) const;

  /// Voxels per side of the clearance grid.
  int clearance_grid_size() const { return band_grid_.size; }
  /// Number of clearance voxels, clearance_grid_size()^2.
  int num_clearance_voxels() const { return band_grid_.size * band_grid_.size; }
  /// Lower (x and y) edge of the clearance grid, metres, frame B.
  double clearance_grid_min_m() const { return band_grid_.min_m; }
  /// Index of the clearance voxel containing (x_m, y_m) (metres, frame B), or -1 if outside or not finite.
  int ClearanceVoxelIndex(float x_m, float y_m) const { return band_grid_.Index(x_m, y_m); }
  /// Centre (x, y) of clearance voxel `index` (unchecked), metres, frame B.
  Eigen::Vector2d ClearanceVoxelCenter(int index) const { return band_grid_.Center(index); }
  /// Path tree nodes whose arcs have clearance voxel `index` in their band, ascending node ids (unchecked).
  ConstSpan<BandEntry> band_entries(int index) const;

  /// Total blocking entries.
  std::size_t num_blocking_entries() const { return blocking_.size(); }
  /// Total band entries.
  std::size_t num_band_entries() const { return band_.size(); }

  /// Heap memory held by the library (samples, path descriptions, correspondence), bytes.
  std::size_t memory_bytes() const;
  /// Wall-clock time the constructor (or Deserialize) took, seconds.
  double build_time_s() const { return build_time_s_; }

  /// Version of the Serialize() format. Bumped whenever the format or what the build computes changes, so
  /// that a cache written by an older build is refused rather than used.
  static constexpr std::uint32_t kFormatVersion = 1;

  /// The library as bytes, for a cache file (the agent keeps one per option set:
  /// LoadOrBuildTrajectoryLibrary): a header (magic, kFormatVersion, a byte-order mark, the options) and the
  /// correspondence (blocking and band rows); the paths are not stored, Deserialize rebuilds them from the
  /// options (a few ms). Native byte order: a cache is local to one machine. With the agent's options (0.05 m
  /// voxels) ~33 MB before compression.
  std::string Serialize() const;

  /// A 64-bit fingerprint (FNV-1a) of kFormatVersion and `options` as Serialize() stores them: equal options
  /// give equal fingerprints; a cache names its files by it.
  static std::uint64_t Fingerprint(const TrajectoryLibraryOptions& options);

  /// The library that `bytes` (from Serialize()) holds, or nullptr with `*why` (not null) saying what does
  /// not match: the magic, the version, the byte order, an option (named, both values), an array size, offset
  /// or id out of range, or the spot check. Spot check: the correspondence of one heading is built again and
  /// must equal the stored one (catches a file from a build that computed it differently, and most damage).
  /// Never reads outside `bytes`, whatever they hold.
  /// @throws std::invalid_argument if `options` is invalid (as the constructor).
  static std::unique_ptr<TrajectoryLibrary> Deserialize(const std::string& bytes,
                                                        const TrajectoryLibraryOptions& options,
                                                        std::string* why);

 private:
  // The paths, their descriptions and the path tree of `options` (validated), without the correspondence.
  struct PathsOnly {};
  TrajectoryLibrary(const TrajectoryLibraryOptions& options, PathsOnly);
  // The correspondence rows of the path tree nodes `keep` accepts (all: the library's).
  struct Correspondence {
    std::vector<std::uint32_t> blocking_offsets;
    std::vector<BlockingEntry> blocking;
    std::vector<std::uint32_t> band_offsets;
    std::vector<BandEntry> band;
  };
  Correspondence BuildCorrespondence(const std::function<bool(int node)>& keep) const;
  // The kept-heading slot (0..num_kept_headings()-1) of path tree node `node`.
  int HeadingSlotOfNode(int node) const;

  // A square grid centred on the origin.
  struct Grid {
    double voxel_m = 1.0;
    double inv_voxel = 1.0;  // 1 / voxel_m
    double min_m = 0.0;      // Lower edge (x and y).
    int size = 0;            // Voxels per side.
    int Index(float x_m, float y_m) const {
      const double fx = (static_cast<double>(x_m) - min_m) * inv_voxel;
      const double fy = (static_cast<double>(y_m) - min_m) * inv_voxel;
      if (!(fx >= 0.0 && fy >= 0.0 && fx < size && fy < size)) return -1;  // Also NaN.
      const int ix = static_cast<int>(fx) < size ? static_cast<int>(fx) : size - 1;
      const int iy = static_cast<int>(fy) < size ? static_cast<int>(fy) : size - 1;
      return ix + size * iy;
    }
    Eigen::Vector2d Center(int index) const {
      // NOLINTNEXTLINE(bugprone-integer-division): index / size is the cell's row, floored on purpose
      return Eigen::Vector2d(min_m + (index % size + 0.5) * voxel_m, min_m + (index / size + 0.5) * voxel_m);
    }
  };

  TrajectoryLibraryOptions options_;
  int num_kept_headings_ = 0;
  int paths_per_heading_ = 0;
  int samples_per_path_ = 0;
  double spacing_m_ = 0.0;
  double point_blocking_radius_m_ = 0.0;
  double voxel_blocking_radius_m_ = 0.0;
  double near_origin_radius_m_ = 0.0;
  Grid block_grid_;
  Grid band_grid_;
  int num_nodes_ = 0;
  int level_end_sample_[3] = {0, 0, 0};
  std::vector<TrajectoryInfo> info_;
  std::vector<std::uint16_t> node_of_path_;  // 3 per path.
  std::vector<Eigen::Vector2f> samples_B_;
  // Compressed rows: entries of voxel v are [offsets[v], offsets[v + 1]).
  std::vector<std::uint32_t> blocking_offsets_;
  std::vector<BlockingEntry> blocking_;
  std::vector<std::uint32_t> band_offsets_;
  std::vector<BandEntry> band_;
  double build_time_s_ = 0.0;
};

/// Options of LocalPlanner: the scoring of free paths.
///
/// Score of a usable path p (higher is better), every term in [0, 1]:
///   score = goal_direction_weight * (1 - |end_bearing_p - target_direction| / pi)
///         + heading_change_weight * (1 - |heading_p| / pi)
///         + turning_weight        * (1 - total_turn_p / (3 * max_segment_turn_rad))   (1 if that is 0)
///         + clearance_weight      * clearance_p / clearance_band_m   (1 when clearance_band_m is 0)
///         + hysteresis_weight     * (1 - |end_bearing_p - end_bearing_previous| / pi)   (0 without one)
/// where angle differences are wrapped to [0, pi]; target_direction is the direction of
/// LocalPlanRequest::goal_B; heading_p the path's start direction (the turn the robot needs from its current
/// heading, +x of B); end_bearing the direction from the origin to the path's end; total_turn_p the sum of
/// the absolute heading changes of its arcs (of two paths ending in the same direction the straighter one
/// wins); and clearance_p the least clearance (TrajectoryLibrary) over the occupied clearance voxels and the
/// path's three arcs for which the arc's sample nearest to the voxel lies within the required free length
/// (obstacles beside the path beyond that do not count). Ties go to the lowest path id.
///
/// The angle terms are linear, and with the default weights the goal term dominates: a degree of goal
/// alignment outweighs five degrees of initial turn, so the heading change and turning terms mostly break
/// ties between paths ending in about the same direction. clearance_weight trades alignment for room: 0.15 is
/// worth 27 deg of goal alignment when the clearance goes from 0 to the full band. The goal term follows
/// FALCO's idea of scoring a path by its direction to the goal; the formula is ours.
struct LocalPlannerOptions {
  /// Weight of the goal (or joystick) direction term, range [0, 100].
  double goal_direction_weight = 1.0;
  /// Weight of the heading change term (prefers paths that start straight ahead), range [0, 100].
  double heading_change_weight = 0.2;
  /// Weight of the turning term (prefers paths that turn less), range [0, 100].
  double turning_weight = 0.05;
  /// Weight of the clearance term (prefers paths away from obstacles), range [0, 100].
  double clearance_weight = 0.15;
  /// Weight of the hysteresis term (prefers paths like the previous choice), range [0, 100].
  double hysteresis_weight = 0.1;
  /// Smallest free length a usable path needs, even when the goal is nearer (room to brake), metres, range
  /// [0, 100]; capped at the path length.
  double min_free_length_m = 0.3;
  /// Smart-joystick mode only considers paths whose start direction and end bearing are both within this
  /// angle of the joystick direction, radians, range [0, pi].
  double max_joystick_deviation_rad = 1.5707963267948966;

  /// True when every field is in range; otherwise false and, if `why` is not null, a message naming the
  /// field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// How LocalPlanner::Plan() uses LocalPlanRequest::goal_B.
enum class LocalPlanMode {
  /// Drive toward goal_B; paths need to be free up to the goal distance (capped at the path length).
  kGoal,
  /// Smart joystick: goal_B is the operator's direction (its length is ignored); paths need to be free for
  /// their whole length and never deviate more than max_joystick_deviation_rad from the direction.
  kJoystick,
};

/// Name of a mode: "kGoal", "kJoystick".
const char* ToString(LocalPlanMode mode);

/// Input of one LocalPlanner::Plan() cycle besides the obstacles.
struct LocalPlanRequest {
  /// kGoal or kJoystick.
  LocalPlanMode mode = LocalPlanMode::kGoal;
  /// Goal position (kGoal) or joystick direction (kJoystick), (x, y), metres, frame B. Must be finite and
  /// longer than 1e-6 m.
  Eigen::Vector2d goal_B = Eigen::Vector2d(1.0, 0.0);
  /// Upper limit of the required free length, metres, > 0 (NaN is invalid); +inf = no limit. The required
  /// free length is clamp(min(goal distance [kGoal only], this), min_free_length_m, path length).
  double max_required_free_length_m = std::numeric_limits<double>::infinity();
  /// Path chosen in the previous cycle, for hysteresis; -1 = none. Must be -1 or a path id of the library.
  int previous_path_id = -1;
};

/// Result of LocalPlanner::Plan().
struct LocalPlanResult {
  /// How the cycle ended.
  enum class Status {
    kPathFound,     ///< path_id holds the best usable path.
    kBoxedIn,       ///< No usable path (or none within the joystick limit): stop; message says why.
    kInvalidInput,  ///< The request is invalid (e.g. NaN goal); message says which field. Nothing else is
                    ///< set.
  };
  Status status = Status::kInvalidInput;
  /// Outcome naming the values, e.g. "boxed in: 0 of 12348 paths free for 3.00 m, nearest obstacle 0.21 m".
  std::string message;
  /// Chosen path id, -1 unless kPathFound.
  int path_id = -1;
  /// The origin followed by the chosen path's samples up to its free length ((x, y, 0), metres, frame B);
  /// empty unless kPathFound.
  std::vector<Eigen::Vector3f> path_B;
  /// Free length of the chosen path (arc length before its first blocked sample), metres.
  double free_length_m = 0.0;
  /// Free length every usable path needed this cycle, metres.
  double required_free_length_m = 0.0;
  /// Score of the chosen path (see LocalPlannerOptions).
  double score = 0.0;
  /// Clearance of the chosen path used in the score, metres, in [0, clearance_band_m].
  double clearance_m = 0.0;
  /// Paths free for the required length (ignoring the joystick limit).
  int num_free_paths = 0;
  /// Free paths that the mode allows (within the joystick limit in kJoystick; = num_free_paths in kGoal).
  int num_candidate_paths = 0;
  /// Bit i % 64 of word i / 64 is set when path i is free for the required length, for display.
  std::vector<std::uint64_t> free_mask;
  /// Points used as obstacles (finite, in the z band, inside the blocking or the clearance grid).
  int num_points_used = 0;
  /// Finite points in the z band but outside both grids (too far to matter).
  int num_points_outside_grid = 0;
  /// Finite points outside the z band.
  int num_points_outside_z_band = 0;
  /// Points with a NaN or infinite coordinate (skipped).
  int num_points_non_finite = 0;
  /// Distinct occupied voxels of the blocking grid.
  int num_occupied_voxels = 0;
  /// Distinct occupied voxels of the clearance grid.
  int num_occupied_clearance_voxels = 0;
  /// Planar distance from the origin to the nearest finite point in the z band, metres; +inf if none.
  double nearest_obstacle_m = std::numeric_limits<double>::infinity();
  /// Wall-clock time of the cycle, seconds.
  double planning_time_s = 0.0;

  /// True when status is kPathFound.
  bool IsUsable() const { return status == Status::kPathFound; }
  /// True when path `path_id` is free for the required length (false for ids out of range).
  bool IsFree(int path_id) const;
};

/// Name of a status, e.g. "kBoxedIn".
const char* ToString(LocalPlanResult::Status status);

/// Per-cycle trajectory-library planner (see the file comment). Holds reusable buffers, so a cycle does not
/// allocate once the result's buffers have grown (pass the same LocalPlanResult every cycle). Not
/// thread-safe; use one planner per thread (they may share the library).
class LocalPlanner {
 public:
  /// Throws std::invalid_argument if `library` is null or `options` is invalid (IsValid() message).
  explicit LocalPlanner(std::shared_ptr<const TrajectoryLibrary> library,
                        const LocalPlannerOptions& options = {});

  /// One cycle: obstacles_B (N points, metres, frame B, any N; NaN/inf points are counted and skipped) and
  /// the request give `*result` (buffers reused). Invalid requests give kInvalidInput, never exceptions.
  void Plan(const std::vector<Eigen::Vector3f>& obstacles_B, const LocalPlanRequest& request,
            LocalPlanResult* result);
  /// As above, returning a fresh result (allocates).
  LocalPlanResult Plan(const std::vector<Eigen::Vector3f>& obstacles_B, const LocalPlanRequest& request);

  /// Library given at construction.
  const TrajectoryLibrary& library() const { return *library_; }
  /// Options given at construction.
  const LocalPlannerOptions& options() const { return options_; }
  /// Free length of path `path_id` (unchecked) in the last cycle that was not kInvalidInput, metres: arc
  /// length before its first blocked sample, the path length if none.
  double free_length_m(int path_id) const;
  /// Clearance of path `path_id` (unchecked) used for scoring in that cycle, metres.
  double clearance_m(int path_id) const;

 private:
  // The steps of Plan(), in order (see local_planner.cpp).
  void MarkOccupiedVoxels(const std::vector<Eigen::Vector3f>& obstacles_B, LocalPlanResult* result);
  void BlockPaths(int required_samples);
  int ChoosePath(const LocalPlanRequest& request, int required_samples, LocalPlanResult* result,
                 float* best_score) const;

  std::shared_ptr<const TrajectoryLibrary> library_;
  LocalPlannerOptions options_;
  std::uint32_t cycle_ = 0;
  std::vector<std::uint32_t> voxel_stamp_;      // Per blocking voxel: the cycle that last occupied it.
  std::vector<int> occupied_;                   // Occupied blocking voxels of this cycle.
  std::vector<std::uint32_t> band_stamp_;       // Per clearance voxel: the cycle that last occupied it.
  std::vector<int> occupied_band_;              // Occupied clearance voxels of this cycle.
  std::vector<std::uint8_t> first_blocked_;     // Per path: first blocked sample, samples_per_path() if none.
  std::vector<std::uint8_t> clearance_bucket_;  // Per path: least counted clearance bucket, 255 if none.
  std::vector<std::uint8_t> node_first_blocked_;  // Per path tree node, as first_blocked_.
  std::vector<std::uint8_t> node_bucket_;         // Per path tree node, as clearance_bucket_.
  std::vector<float> heading_rad_;                // Per path: TrajectoryInfo::heading_rad.
  std::vector<float> end_bearing_rad_;            // Per path: TrajectoryInfo::end_bearing_rad.
  std::vector<float> static_score_;  // Per path: the heading change and turning terms of the score.
  // This cycle's points within near_origin_radius_m() (capacity fixed), with their squared blocking distance.
  struct NearPoint {
    float x = 0.0f;
    float y = 0.0f;
    double block2 = 0.0;
  };
  std::vector<NearPoint> near_points_;
  // Path tree nodes with samples a near point may block: samples [first, end) of path `path` (any path
  // through the node) lie within near_origin_radius_m() + point_blocking_radius_m() of the origin.
  struct NearNode {
    int node = 0;
    int path = 0;
    int first = 0;
    int end = 0;
  };
  std::vector<NearNode> near_nodes_;
};

/// Reference classification without the correspondence, for tests and benchmarks: for every path and each
/// of its arcs, every obstacle point (finite, z in the band) near the arc's bounding box, and every sample of
/// the arc, the same distance tests as the correspondence, applied to the point's voxel centres (the grids
/// extended beyond their edges): the blocking voxel centre within voxel_blocking_radius_m() blocks; the
/// clearance voxel centre gives a clearance (TrajectoryLibrary). Returns the free length of each path
/// (metres: arc length before the first blocked sample, path length if none). If `clearance_m` is not null it
/// receives each path's clearance as LocalPlanner::clearance_m() defines it for the required free length
/// `required_free_length_m` (metres, clamped to [0, path length]).
std::vector<double> BruteForceFreeLengths(
    const TrajectoryLibrary& library, const std::vector<Eigen::Vector3f>& obstacles_B,
    double required_free_length_m = std::numeric_limits<double>::infinity(),
    std::vector<double>* clearance_m = nullptr);

}  // namespace cairn::nav
