#include "cairn/ros2/point_cloud2.h"

#include <cmath>
#include <cstring>

namespace cairn::ros2 {
namespace {

std::string FieldNames(const std::vector<sensor_msgs::msg::dds_::PointField_>& fields) {
  std::string names;
  for (const auto& f : fields) names += (names.empty() ? "" : ", ") + f.name();
  return names.empty() ? "none" : names;
}

}  // namespace

std::string FindXyzLayout(const sensor_msgs::msg::dds_::PointCloud2_& cloud, XyzLayout* layout) {
  if (cloud.is_bigendian()) return "is_bigendian is true: big-endian clouds are not read";
  const std::uint32_t point_step = cloud.point_step();
  std::uint32_t* offsets[3] = {&layout->x_offset, &layout->y_offset, &layout->z_offset};
  const char* names[3] = {"x", "y", "z"};
  for (int axis = 0; axis < 3; ++axis) {
    const sensor_msgs::msg::dds_::PointField_* found = nullptr;
    for (const auto& f : cloud.fields()) {
      if (f.name() == names[axis]) found = &f;
    }
    if (found == nullptr || found->datatype() != static_cast<std::uint8_t>(PointFieldType::kFloat32)) {
      return std::string("no FLOAT32 field '") + names[axis] + "' (fields: " + FieldNames(cloud.fields()) +
             (found ? "; '" + std::string(names[axis]) + "' has datatype " +
                          std::to_string(found->datatype()) + ", FLOAT32 is 7"
                    : "") +
             ")";
    }
    if (found->count() > 1) {
      return std::string("field '") + names[axis] + "' has count " + std::to_string(found->count()) +
             ": one value per point expected";
    }
    if (static_cast<std::uint64_t>(found->offset()) + 4 > point_step) {
      return std::string("field '") + names[axis] + "' at offset " + std::to_string(found->offset()) +
             " does not fit in point_step " + std::to_string(point_step);
    }
    *offsets[axis] = found->offset();
  }
  const std::uint64_t width = cloud.width(), height = cloud.height();
  if (static_cast<std::uint64_t>(cloud.row_step()) < width * point_step) {
    return "row_step " + std::to_string(cloud.row_step()) + " is less than width " + std::to_string(width) +
           " x point_step " + std::to_string(point_step);
  }
  if (height * cloud.row_step() > cloud.data().size()) {
    return "data holds " + std::to_string(cloud.data().size()) + " bytes, height " + std::to_string(height) +
           " x row_step " + std::to_string(cloud.row_step()) + " needs " +
           std::to_string(height * cloud.row_step());
  }
  return "";
}

std::string ReadPointCloud2(const sensor_msgs::msg::dds_::PointCloud2_& cloud, const CloudRangeFilter& filter,
                            std::vector<Eigen::Vector3f>* points_S, CloudReadCounts* counts) {
  points_S->clear();
  *counts = CloudReadCounts{};
  XyzLayout layout;
  if (std::string why = FindXyzLayout(cloud, &layout); !why.empty()) return why;
  const double min2 = filter.min_range_m * filter.min_range_m;
  const double max2 = filter.max_range_m * filter.max_range_m;
  const std::uint8_t* data = cloud.data().data();
  points_S->reserve(static_cast<std::size_t>(cloud.width()) * cloud.height());
  auto read = [](const std::uint8_t* at) {
    float v;
    std::memcpy(&v, at, sizeof(v));  // unaligned in general (any point_step)
    return v;
  };
  for (std::uint32_t row = 0; row < cloud.height(); ++row) {
    const std::uint8_t* row_start = data + static_cast<std::size_t>(row) * cloud.row_step();
    for (std::uint32_t col = 0; col < cloud.width(); ++col) {
      const std::uint8_t* p = row_start + static_cast<std::size_t>(col) * cloud.point_step();
      const Eigen::Vector3f point(read(p + layout.x_offset), read(p + layout.y_offset),
                                  read(p + layout.z_offset));
      if (!point.allFinite()) {
        ++counts->not_finite;
        continue;
      }
      const double r2 = point.cast<double>().squaredNorm();
      if (r2 < min2 || r2 > max2) {
        ++counts->out_of_range;
        continue;
      }
      points_S->push_back(point);
    }
  }
  counts->kept = points_S->size();
  return "";
}

}  // namespace cairn::ros2
