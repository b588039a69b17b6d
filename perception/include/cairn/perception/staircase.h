// Copyright Cairn authors.
//
// Staircase detection in gravity-aligned lidar point clouds, the local cloud a robot accumulates for it, and
// the registry that merges detections across scans and robots (PCL and Ceres stay in src/staircase.cpp).
//
// Method. The outline follows Sriganesh, Bagree, Vundurthy & Travers, "Fast Staircase Detection and
// Estimation using 3D Point Clouds with Multi-detection Merging for Heterogeneous Robots", ICRA 2023: project
// the cloud to 2D, find step edges, chain them into a staircase, merge repeated detections. The edge rules,
// the side-view chaining, the model fit and the checks are ours:
//  1. crop a cylinder around the robot (optionally voxel-filter it, PCL VoxelGrid);
//  2. project onto a horizontal grid; per cell keep the lowest cluster of points (so ceilings and overhangs
//     do not hide the ground), its top and bottom heights;
//  3. step-edge cells: (a) the lowest cluster spans about one rise (a riser face, also when its tread is
//     above the sensor and unseen); (b) the top is one rise above a cell within edge_search_radius_m (a
//     nose above its lower tread); (c) walking away from the robot, the first occupied cell beyond an empty
//     shadow is one rise lower (a nose seen from above, e.g. from the top of the flight);
//  4. local 2D PCA of same-height edge cells gives edge normals; peaks of their histogram are the candidate
//     ascending axes;
//  5. per axis the edge cells are projected onto the side-view plane (position along the axis, height), where
//     each step edge is one compact blob; blobs are chained, in both senses, into risers of consistent rise
//     and run that overlap across the axis (one riser may be missing);
//  6. the chain's axis is refined from all its edges at once (pooled PCA), then seeds a Ceres least-squares
//     fit of a staircase model (yaw, first riser position, floor height, rise, run) to the nearby points
//     (PCL VoxelGrid): tread points give height residuals and must lie between their risers, riser points
//     give along-axis residuals, Huber-robustified, points reclassified between three rounds; width and
//     centre come from the lateral extent of each step's points;
//  7. a lowest step that is no step up from the floor in front of it (a fit slipped a step down the flight)
//     is dropped; the risers are counted where the points show them (across the width, a step in height
//     between a riser's two treads or a vertical face that ends at the nose, with a rise consistent with the
//     fit's) and the staircase keeps its longest run of such risers, refitted: one step and clutter behind
//     it never adds up to a flight. The fit is rejected unless it explains the data: min_risers observed
//     risers, rise/run/width in range, small residuals, each step covered across its width, and free space
//     above the treads away from the sides (shelves and terraced surfaces fail here);
//  8. a detection that continues another one up the same flight (whole runs and rises apart, same direction,
//     side by side) is merged into it: one flight, one detection.
// Accuracy over the built-in worlds, survey copies and synthetic scenes: bench/staircase_accuracy.cpp and
// docs/PERFORMANCE.md.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace cairn::perception {

/// One straight staircase, frame W (z up). Its treads are the horizontal surfaces at heights
/// p_W_first_step.z() + k * rise_m (k = 1..num_steps) and its risers are vertical faces at distances
/// (k - 1) * run_m (k = 1..num_steps) from p_W_first_step along the ascending direction (cos yaw, sin yaw,
/// 0). The last tread may continue into a landing. A staircase is always described ascending, whichever side
/// it was seen from.
struct Staircase {
  /// Foot of the first riser (at floor level), centred across the width, metres, frame W.
  Eigen::Vector3d p_W_first_step = Eigen::Vector3d::Zero();
  /// Ascending direction, radians about +z of W, wrapped to (-pi, pi].
  double yaw_rad = 0.0;
  /// Height of one riser, metres.
  double rise_m = 0.0;
  /// Depth of one tread (horizontal distance between consecutive risers), metres.
  double run_m = 0.0;
  /// Width across the ascending direction, metres.
  double width_m = 0.0;
  /// Number of risers (>= 1). From StaircaseDetector: the risers its points show, consecutive and of
  /// consistent rise (>= StaircaseDetectorOptions::min_risers), rise_m and run_m fitted to them; two
  /// detections of one flight merged into one (step 8) also count the at most two risers between them.
  int num_steps = 0;
  /// Heuristic confidence in [0, 1]: (mean fraction of the width covered by each step's points) x (1 - fit
  /// RMS / max_fit_rms_m) x min(1, num_steps / (min_risers + 2)). Typically 0.5-0.8 for a well seen flight.
  double confidence = 0.0;
  /// Number of cloud points (after filtering) that the fitted model explains as tread or riser points; for
  /// a registry entry, the sum over its merged detections.
  int support_points = 0;
};

/// Options of StaircaseDetector. Defaults suit a 16-beam lidar about 0.5 m above the floor and building
/// stairs (rise 0.10-0.25 m, run 0.20-0.50 m).
struct StaircaseDetectorOptions {
  /// Horizontal radius of the cylinder around the robot that is searched, metres, range [1, 30].
  double crop_radius_m = 6.0;
  /// Points lower than the robot's z minus this are dropped, metres, range (0, 10].
  double crop_below_m = 3.0;
  /// Points higher than the robot's z plus this are dropped (keeps tunnel ceilings out), metres,
  /// range (0, 10].
  double crop_above_m = 1.8;
  /// Leaf of a PCL VoxelGrid over the whole cropped cloud before the projection, metres, 0 (off) or range
  /// [0.01, 0.1]. Off by default: LocalCloud output is already deduplicated and the filter costs ~10 ms per
  /// 50k points; turn it on for dense clouds (depth cameras, unfiltered scans).
  double input_voxel_m = 0.0;
  /// Leaf of the PCL VoxelGrid applied to the points near a candidate staircase before the model fit (evens
  /// out the lidar's density, near surfaces would dominate otherwise), metres, range [0.01, 0.1].
  double fit_voxel_m = 0.03;
  /// Cell edge of the horizontal projection grid, metres, range [0.02, 0.1].
  double cell_size_m = 0.05;
  /// Smallest vertical gap that separates two surfaces in one grid cell, metres, range (max_rise_m, 2].
  double cluster_gap_m = 0.4;
  /// Cells within this horizontal distance are compared when looking for a nose above its lower tread
  /// (edge rule (b)), metres, range [cell_size_m, 0.5].
  double edge_search_radius_m = 0.15;
  /// Smallest rise accepted, metres, range (0, max_rise_m).
  double min_rise_m = 0.10;
  /// Largest rise accepted, metres, range (min_rise_m, 0.5].
  double max_rise_m = 0.25;
  /// Smallest run accepted, metres, range (0, max_run_m).
  double min_run_m = 0.20;
  /// Largest run accepted, metres, range (min_run_m, 1.0].
  double max_run_m = 0.50;
  /// Fewest risers of a staircase, each observed in the points over at least 25 % of its width (in 0.1 m
  /// lateral bins): as a step in height between its two flat treads, or as a vertical face below its nose
  /// that does not go on up, with a rise within riser_rise_tolerance_m of the staircase's, and shown in more
  /// bins than contradict it (two flat treads at other heights). Counted consecutively: an unseen riser
  /// splits a flight, the longest part is reported, refitted. Range [3, 50]: one or two steps (a platform, a
  /// podium, a curb), and clutter behind them, are not a staircase.
  int min_risers = 3;
  /// Largest difference between a riser's rise measured in one lateral bin (median height of its upper tread
  /// minus its lower tread's) and the staircase's fitted rise, metres, range [0.01, 0.1]; a face seen below
  /// its nose may reach at most this above the rise.
  double riser_rise_tolerance_m = 0.03;
  /// Narrowest staircase, metres, range [0.2, 10].
  double min_width_m = 0.5;
  /// Largest RMS residual of the model fit over its inlier points, metres, range (0, 0.1].
  double max_fit_rms_m = 0.025;
  /// Smallest mean fraction of a step's width covered by its points, range [0, 1].
  double min_step_coverage = 0.5;
  /// Largest fraction of points above the treads (0.1-1.0 m over the model surface, inside the footprint)
  /// relative to the supporting points, range [0, 1].
  double max_free_space_violation = 0.1;
  /// Detections with a lower confidence are not reported, range [0, 1].
  double min_confidence = 0.2;
  /// Most staircases reported per cloud, range [1, 20].
  int max_detections = 4;
  /// Refine the chain with a Ceres fit of the staircase model (false: parameters from the step edges alone,
  /// less accurate; for comparison and benchmarks).
  bool refine_with_ceres = true;

  /// True when every field is finite and in range; otherwise false and, if `why` is not null, a message
  /// naming the field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// Counters and timings of one StaircaseDetector::Detect() call.
struct DetectStats {
  /// Points given.
  std::int64_t points_in = 0;
  /// Points dropped because a coordinate was NaN or infinite.
  std::int64_t points_non_finite = 0;
  /// Finite points inside the crop cylinder.
  std::int64_t points_cropped = 0;
  /// Points projected (after the optional input voxel filter).
  std::int64_t points_filtered = 0;
  /// Occupied cells of the projection grid.
  std::int64_t cells_occupied = 0;
  /// Step-edge cells found.
  std::int64_t edge_cells = 0;
  /// Ascending-axis hypotheses tried.
  int axis_hypotheses = 0;
  /// Chains of >= min_risers risers that were fitted (at most 8 per call, the longest first).
  int chains_fitted = 0;
  /// Fitted chains rejected by a check (observed risers, fit, coverage, free space, ranges, confidence).
  int chains_rejected = 0;
  /// Why the last rejected chain was rejected (empty if none).
  std::string last_rejection;
  /// Why each rejected chain was rejected, in the order they were fitted (at most 8).
  std::vector<std::string> rejections;
  /// Wall time of the crop and the optional input voxel filter, milliseconds.
  double filter_ms = 0.0;
  /// Wall time of the projection, edge extraction and chaining, milliseconds.
  double projection_ms = 0.0;
  /// Wall time of the model fits and checks, milliseconds.
  double fit_ms = 0.0;
  /// Wall time of the whole call, milliseconds.
  double total_ms = 0.0;
};

/// Finds straight staircases in a gravity-aligned point cloud. Detect() is const and keeps no state, so one
/// detector may serve several threads.
class StaircaseDetector {
 public:
  /// Throws std::invalid_argument with the message of StaircaseDetectorOptions::IsValid() if `options` is
  /// invalid.
  explicit StaircaseDetector(const StaircaseDetectorOptions& options = {});

  /// Detects staircases in `points_W` (N points, metres, frame W, z up against gravity; e.g. LocalCloud::
  /// Points()) around `p_W_robot` (position of the robot's lidar, metres, frame W: the centre of the crop
  /// cylinder and the reference of its height band and of the line-of-sight rule). Non-finite points are
  /// dropped and counted; an empty cloud, or one without staircase, gives an empty result; never throws on
  /// bad data. Results are sorted by decreasing confidence, at most options.max_detections, each with
  /// num_steps >= options.min_risers observed risers. If `stats` is not null it is filled. Cost on one core
  /// (bench/staircase.cpp): about 4 ms for 65-80k points without staircase, 6 ms with one.
  ///
  /// Limits: a flight is counted from its lowest seen riser; a 16-beam lidar near the floor sees low-rise
  /// risers far away as single beams and misses them until closer (detections then grow; StaircaseRegistry
  /// merges them). From the top a level lidar sees no tread of a flight steeper than its lowest beam.
  std::vector<Staircase> Detect(const std::vector<Eigen::Vector3f>& points_W,
                                const Eigen::Vector3d& p_W_robot, DetectStats* stats = nullptr) const;

  /// Options given at construction.
  const StaircaseDetectorOptions& options() const { return options_; }

 private:
  StaircaseDetectorOptions options_;
};

/// Options of LocalCloud.
struct LocalCloudOptions {
  /// Edge of the deduplication voxels: one point (the running mean of the points that fell in it) is kept
  /// per voxel, metres, range [0.005, 0.5].
  double voxel_size_m = 0.025;
  /// Points farther than this from the latest sensor position are forgotten, metres, range [1, 100].
  double radius_m = 8.0;
  /// Points not seen again for longer than this (relative to the latest stamp) are forgotten, seconds,
  /// range (0, 600].
  double window_s = 3.0;
  /// Hard cap on the number of stored voxels; beyond it new voxels are not added until forgotten ones are
  /// reclaimed, range [1000, 1e7].
  std::int64_t max_points = 1'000'000;
  /// The sensor's blind zone: points below this elevation in the frame S of the latest scan (the lowest
  /// beam of a spinning lidar) cannot be seen again from there, so they are kept for blind_window_s instead
  /// of window_s. A low obstacle the robot drives up to (a stair's riser, a curb) drops out of a lidar's view
  /// under its lowest beam and must not be forgotten then (a 0.2 m riser is blind within 1.1 m of a VLP-16
  /// 0.5 m up). Radians, [-pi/2, pi/2]; NaN (default): no blind zone.
  double blind_below_elevation_rad = std::numeric_limits<double>::quiet_NaN();
  /// How long a point in the blind zone is kept since it was last seen, seconds, [window_s, 600].
  double blind_window_s = 30.0;

  /// True when every field is finite and in range; otherwise false and, if `why` is not null, a message
  /// naming the field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// A bounded, deduplicated cloud of the recent lidar scans around the robot, frame W: the input of
/// StaircaseDetector. Not thread-safe (one owner feeds and reads it).
class LocalCloud {
 public:
  /// Throws std::invalid_argument naming the field if `options` is invalid.
  explicit LocalCloud(const LocalCloudOptions& options = {});
  ~LocalCloud();
  LocalCloud(LocalCloud&&) noexcept;
  LocalCloud& operator=(LocalCloud&&) noexcept;
  LocalCloud(const LocalCloud&) = delete;
  LocalCloud& operator=(const LocalCloud&) = delete;

  /// Adds one scan: `points_S` (metres, frame S of the sensor) taken at pose `T_W_S` (sensor in W) at time
  /// `stamp_s` (seconds). Non-finite points are skipped, as are scans with a non-finite pose or stamp. From
  /// then on voxels not seen within window_s of the newest stamp, or farther than radius_m from this scan's
  /// sensor position, are forgotten (Points() and size() skip them; their memory is reclaimed every 4 scans).
  /// A stamp older than the newest one is accepted (its points may be forgotten at once). Cost: about 2-3 ms
  /// of one core for 28,800 points (open-addressing hash with a locality-preserving hash function).
  void AddScan(const std::vector<Eigen::Vector3f>& points_S, const Eigen::Isometry3d& T_W_S, double stamp_s);

  /// The kept points, one per voxel, metres, frame W (unspecified order).
  std::vector<Eigen::Vector3f> Points() const;
  /// Number of kept points (== Points().size()).
  std::size_t size() const;
  /// Sensor position of the latest scan, metres, frame W (zero before the first scan).
  Eigen::Vector3d p_W_latest_sensor() const;
  /// Forgets everything.
  void Clear();
  /// Forgets every point a new scan from the latest sensor pose could show again, keeping those in its blind
  /// zone (see LocalCloudOptions::blind_below_elevation_rad; with none, forgets everything): clearing a
  /// robot's obstacle memory must not lose the step it stands next to and can no longer see.
  void ForgetVisible();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Options of StaircaseRegistry: when two detections are the same staircase.
struct StaircaseRegistryOptions {
  /// Largest difference of ascending directions, radians, range (0, pi/2].
  double max_yaw_difference_rad = 0.5;
  /// Smallest overlap of the two footprints, as a fraction of the smaller footprint's area, range (0, 1].
  double min_overlap_fraction = 0.3;
  /// Largest difference of floor heights (p_W_first_step.z()) once whole steps are aligned, metres, range
  /// (0, 1]; keep it below half a rise.
  double max_floor_difference_m = 0.06;

  /// True when every field is finite and in range; otherwise false and, if `why` is not null, a message
  /// naming the field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// How two descriptions of straight staircases line up (frame W for both), by StaircaseRegistry's
/// same-staircase rule.
struct StaircaseMatch {
  /// True when `b` is the same staircase as `a` (all three conditions of the rule hold).
  bool same = false;
  /// Whole steps from a's first riser to b's, counted along a's ascending direction (negative: b starts
  /// lower on the flight). Set whenever both descriptions are usable, even if they are not the same
  /// staircase.
  int shift_steps = 0;
  /// Area of the intersection of the two footprints over the smaller footprint's area, [0, 1]; 0 unless
  /// the directions, whole steps and heights agree (conditions 1 and 2).
  double overlap = 0.0;
};

/// Compares `b` with `a` by the same-staircase rule of StaircaseRegistry (see there). A description with a
/// non-finite field, num_steps < 1 or a non-positive rise, run or width matches nothing.
StaircaseMatch MatchStaircases(const Staircase& a, const Staircase& b,
                               const StaircaseRegistryOptions& options);

/// One estimate from `views` (frame W) of a single staircase, as StaircaseRegistry merges the detections of
/// one entry: in order, each view is re-indexed onto the estimate so far (or the estimate onto the view, if
/// the view starts lower), then weighted means and the num_steps vote (see StaircaseRegistry). The caller
/// knows the views are one staircase; a view whose first riser is more whole steps away than the longer of
/// the two flights is counted from the nearest riser within that reach, and unusable views (see
/// MatchStaircases) are skipped. With no usable view, a Staircase with num_steps 0.
Staircase MergeStaircaseViews(const std::vector<Staircase>& views, const StaircaseRegistryOptions& options);

/// Merges staircase detections from many scans and robots into one estimate per physical staircase.
/// Thread-safe: every method may be called from any thread.
///
/// Same-staircase rule: a detection joins an entry when (1) their ascending directions differ by at most
/// max_yaw_difference_rad; (2) their first risers are k whole steps apart (|k| < the larger num_steps): the
/// positions along the ascending direction differ by k runs within half a run (k counted there), and the
/// floor heights by k rises within max_floor_difference_m when k = 0 (two views of the whole flight), within
/// half a rise when k != 0 (one view saw only the upper or lower part: its floor is a tread, estimated from
/// few points), or, when k = 0 with equal num_steps, floors within half a rise and the flights' tops (floor +
/// num_steps rises) within max_floor_difference_m (one view misjudged the floor, not the flight); and (3)
/// their footprints (rectangles from the foot of the first riser, num_steps * run_m along the ascending
/// direction and width_m across it, seen from above) overlap by at least min_overlap_fraction of the smaller
/// one. If several entries qualify the one with the largest overlap wins; entries are never merged with each
/// other. Since detections are always described ascending, a staircase seen from its top merges with the same
/// staircase seen from its foot. Two overlapping detections with opposite directions contradict each other
/// and are kept as separate entries so the consumer sees the conflict. A flight one floor up (more than
/// num_steps rises higher) is another staircase.
///
/// Merged estimate: the detection is first re-indexed onto the entry's first riser (or the entry onto the
/// detection's, if the detection starts lower); then weighted means with weight confidence x support_points
/// of each detection (position, rise, run, width; yaw as a circular mean). num_steps is the largest value
/// whose total weight is at least a quarter of the strongest one (partial views undercount; a lone outlier
/// does not win); confidence is the largest merged confidence; support_points is the sum.
class StaircaseRegistry {
 public:
  /// One merged staircase.
  struct Entry {
    /// Identifier, unique in this registry, assigned in order from 1. Entries are never removed or merged, so
    /// an id names one staircase for the registry's life and is never reused (a robot publishes it as its
    /// staircase id).
    int id = 0;
    /// Merged estimate.
    Staircase staircase;
    /// Distinct sources that contributed (robot names, "r1", "r2"...), in order of first contribution.
    std::vector<std::string> sources;
    /// Number of detections merged.
    int detections = 0;
  };
  /// What Add() did.
  struct MergeResult {
    /// Entry that received the detection.
    int id = 0;
    /// True if the detection created the entry.
    bool is_new = false;
    /// True if the entry is new or its estimate or sources changed enough to be worth republishing
    /// (position or width by >= 1 cm, yaw by >= 0.5 deg, rise or run by >= 2 mm, num_steps, confidence by
    /// >= 0.01, a new source).
    bool changed = false;
  };

  /// Throws std::invalid_argument naming the field if `options` is invalid.
  explicit StaircaseRegistry(const StaircaseRegistryOptions& options = {});

  /// Merges `staircase` (from `source`, e.g. a robot name) into the matching entry or creates one.
  /// Detections with a non-finite field, num_steps < 1 or non-positive rise, run or width are ignored and
  /// return {id 0, is_new false, changed false}.
  MergeResult Add(const Staircase& staircase, const std::string& source);
  /// Copy of all entries, in id order.
  std::vector<Entry> Entries() const;
  /// Number of entries.
  std::size_t size() const;

 private:
  struct Accumulator;
  StaircaseRegistryOptions options_;
  mutable std::mutex mutex_;
  std::vector<Entry> entries_;
  std::vector<std::shared_ptr<Accumulator>> accumulators_;
  int next_id_ = 1;
};

}  // namespace cairn::perception
