// Copyright Cairn authors.
#include "cairn/sim/survey_scan.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

namespace cairn::sim {
namespace {

// Distance from `p` to the segment [a, b], metres.
double DistanceToSegment(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (p - (a + t * ab)).norm();
}

// True if no floor point may lie at (x, y): in a hole, a well or a missing strip.
bool InHole(const SurveyScanOptions& o, double x, double y) {
  const Eigen::Vector2d p(x, y);
  for (const Eigen::Vector2d& c : o.hole_centres_W) {
    if ((p - c).norm() <= o.hole_radius_m) return true;
  }
  for (const SurveyWell& well : o.wells) {
    if ((p.array() >= well.box_W.min().array()).all() && (p.array() < well.box_W.max().array()).all())
      return true;
  }
  for (const SurveyStrip& strip : o.missing_strips) {
    if (DistanceToSegment(p, strip.p_W_start, strip.p_W_end) <= strip.width_m / 2) return true;
  }
  return false;
}

// Occupancy as the scan's neighbour tests read it: outside the grid is occupied when outside_is_solid.
bool Solid(const World& world, const Eigen::Vector3i& index, bool outside_is_solid) {
  return world.Contains(index) ? world.IsOccupiedIndex(index) : outside_is_solid;
}

// True if every one of the six face neighbours of `index` is solid (a voxel inside a solid).
bool IsInterior(const World& world, const Eigen::Vector3i& index, bool outside_is_solid) {
  for (int axis = 0; axis < 3; ++axis) {
    for (int step : {-1, 1}) {
      Eigen::Vector3i n = index;
      n[axis] += step;
      if (!Solid(world, n, outside_is_solid)) return false;
    }
  }
  return true;
}

// True if no occupied voxel of `world` lies within `clearance_m` of `p_W` in x, y and z.
bool InOpenSpace(const World& world, const Eigen::Vector3d& p_W, double clearance_m) {
  const double res = world.resolution_m();
  for (double dx = -clearance_m; dx <= clearance_m; dx += res) {
    for (double dy = -clearance_m; dy <= clearance_m; dy += res) {
      for (double dz = -clearance_m; dz <= clearance_m; dz += res) {
        if (world.IsOccupied(p_W + Eigen::Vector3d(dx, dy, dz))) return false;
      }
    }
  }
  return true;
}

}  // namespace

bool SurveyScanOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& field, const auto& value, const char* rule) {
    std::ostringstream message;
    message << "SurveyScanOptions::" << field << " = " << value << " " << rule;
    if (why != nullptr) *why = message.str();
    return false;
  };
  if (!(std::isfinite(floor_points_per_m2) && floor_points_per_m2 > 0.0)) {
    return fail("floor_points_per_m2", floor_points_per_m2, "must be finite and > 0 points/m^2");
  }
  if (!(wall_keep_fraction >= 0.0 && wall_keep_fraction <= 1.0)) {
    return fail("wall_keep_fraction", wall_keep_fraction, "must be in [0, 1]");
  }
  if (!(hole_radius_m >= 0.0 && hole_radius_m <= 10.0)) {
    return fail("hole_radius_m", hole_radius_m, "must be in [0, 10] m");
  }
  if (num_strays < 0 || num_strays > 100000) return fail("num_strays", num_strays, "must be in [0, 100000]");
  if (!(std::isfinite(stray_clearance_m) && stray_clearance_m >= 0.0)) {
    return fail("stray_clearance_m", stray_clearance_m, "must be finite and >= 0 m");
  }
  if (!(std::isfinite(stray_spacing_m) && stray_spacing_m >= 0.0)) {
    return fail("stray_spacing_m", stray_spacing_m, "must be finite and >= 0 m");
  }
  for (std::size_t i = 0; i < missing_strips.size(); ++i) {
    const SurveyStrip& strip = missing_strips[i];
    const std::string name = "missing_strips[" + std::to_string(i) + "]";
    for (const auto& [field, p] :
         {std::pair{".p_W_start", strip.p_W_start}, std::pair{".p_W_end", strip.p_W_end}}) {
      if (!p.allFinite()) return fail(name + field, p.transpose(), "must be finite");
    }
    if (!(strip.width_m > 0.0 && strip.width_m <= 10.0)) {
      return fail(name + ".width_m", strip.width_m, "must be in (0, 10] m");
    }
  }
  return true;
}

SurveyScan MakeSurveyScan(const World& truth, const SurveyScanOptions& o, std::uint32_t seed) {
  if (std::string why; !o.IsValid(&why)) throw WorldError(why);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const double res = truth.resolution_m();
  SurveyScan out;
  const double p_floor = o.floor_points_per_m2 * res * res;  // Points per floor column.
  const bool below_rule = o.floor_below_z_m.has_value();
  std::int64_t region_points = 0, region_columns = 0;
  auto in_density_region = [&o](double x, double y) {
    const Eigen::AlignedBox2d& r = o.density_region_W;
    return r.isEmpty() || (x > r.min().x() && x < r.max().x() && y > r.min().y() && y < r.max().y());
  };
  const Eigen::Vector3i& dims = truth.dims();
  for (int ix = 0; ix < dims.x(); ++ix) {
    for (int iy = 0; iy < dims.y(); ++iy) {
      for (int iz = 0; iz < dims.z(); ++iz) {
        const Eigen::Vector3i index(ix, iy, iz);
        if (!truth.IsOccupiedIndex(index)) continue;
        if (!below_rule && IsInterior(truth, index, o.outside_is_solid)) continue;
        const Eigen::Vector3d c = truth.CenterOf(index);
        const Eigen::Vector3d jitter(res * (u01(rng) - 0.5), res * (u01(rng) - 0.5), res * (u01(rng) - 0.5));
        const bool top = !Solid(truth, {ix, iy, iz + 1}, o.outside_is_solid);
        const bool floor = below_rule ? c.z() < *o.floor_below_z_m : top;
        if (floor) {
          // Only the top of a floor is scanned, thinned to floor_points_per_m2.
          if (!top) continue;
          const bool counted = in_density_region(c.x(), c.y());
          region_columns += counted;
          if (u01(rng) >= p_floor || InHole(o, c.x(), c.y())) continue;
          region_points += counted;
          const double z = below_rule ? *o.floor_below_z_m - 0.06 + 0.05 * u01(rng) : c.z() + jitter.z();
          out.points_W.emplace_back(Eigen::Vector3d(c.x() + jitter.x(), c.y() + jitter.y(), z).cast<float>());
        } else if (u01(rng) < o.wall_keep_fraction) {
          out.points_W.emplace_back((c + jitter).cast<float>());
        }
      }
    }
  }
  out.floor_points_per_m2 = region_columns > 0 ? region_points / (region_columns * res * res) : 0.0;
  // Well bottoms seen through the openings, dense enough to be supported.
  for (const SurveyWell& well : o.wells) {
    if (!well.bottom_z_m) continue;
    for (double x = well.box_W.min().x(); x < well.box_W.max().x(); x += 0.05) {
      for (double y = well.box_W.min().y(); y < well.box_W.max().y(); y += 0.05) {
        out.points_W.emplace_back(x, y, *well.bottom_z_m);
      }
    }
  }
  // Single stray returns in open space.
  const Eigen::AlignedBox3d region = o.stray_region_W.isEmpty() ? truth.bounds() : o.stray_region_W;
  std::uniform_real_distribution<double> ux(region.min().x(), region.max().x());
  std::uniform_real_distribution<double> uy(region.min().y(), region.max().y());
  std::uniform_real_distribution<double> uz(region.min().z(), region.max().z());
  const std::int64_t max_draws = 1000 * static_cast<std::int64_t>(o.num_strays);
  for (std::int64_t draw = 0; static_cast<int>(out.strays_W.size()) < o.num_strays && draw < max_draws;
       ++draw) {
    const Eigen::Vector3d p(ux(rng), uy(rng), uz(rng));
    bool open = true;
    for (const Eigen::Vector3d& q : out.strays_W) open = open && (q - p).norm() > o.stray_spacing_m;
    if (!open || !InOpenSpace(truth, p, o.stray_clearance_m)) continue;
    out.strays_W.push_back(p);
    out.points_W.emplace_back(p.cast<float>());
  }
  return out;
}

SurveyScanOptions DegradedGeb079Options() {
  SurveyScanOptions o;
  o.floor_below_z_m = 0.0;
  for (int i = 0; i < 10; ++i) o.hole_centres_W.emplace_back(2.0 * i, i % 2 == 0 ? 0.4 : -0.2);
  o.hole_radius_m = 0.2;
  o.wells.push_back({Eigen::AlignedBox2d(Eigen::Vector2d(8.0, -1.2), Eigen::Vector2d(8.5, -0.7)), -2.03});
  o.wells.push_back(
      {Eigen::AlignedBox2d(Eigen::Vector2d(20.0, -1.4), Eigen::Vector2d(21.2, -0.4)), std::nullopt});
  o.stray_region_W = Eigen::AlignedBox3d(Eigen::Vector3d(-6.0, -6.0, 0.3), Eigen::Vector3d(28.0, 6.0, 2.3));
  o.density_region_W = Eigen::AlignedBox2d(Eigen::Vector2d(-4.0, -1.0), Eigen::Vector2d(26.0, 1.0));
  return o;
}

void WritePcd(const std::string& path, const std::vector<Eigen::Vector3f>& points) {
  std::ofstream out(path, std::ios::binary);
  out << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH "
      << points.size() << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << points.size()
      << "\nDATA binary\n";
  for (const Eigen::Vector3f& p : points)
    out.write(reinterpret_cast<const char*>(p.data()), 3 * sizeof(float));
  if (!out) throw WorldError("cannot write PCD file '" + path + "'");
}

}  // namespace cairn::sim
