// Reading sensor_msgs/PointCloud2 as ROS 2 lidar drivers publish it: any field layout that has `x`, `y` and
// `z` as FLOAT32, found by name and offset (Velodyne, Ouster, Livox and Hesai drivers each order and pad
// their fields differently), organised (height > 1) or not, little-endian. Returns that are NaN or infinite
// (an organised cloud's no-return cells) or outside the configured range are dropped and counted.
//
// Message definition: ros2/common_interfaces, sensor_msgs/msg/PointCloud2.msg and PointField.msg.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "ros2_msgs.h"

namespace cairn::ros2 {

/// sensor_msgs/PointField's datatype constants.
enum class PointFieldType : std::uint8_t {
  kInt8 = 1,
  kUint8 = 2,
  kInt16 = 3,
  kUint16 = 4,
  kInt32 = 5,
  kUint32 = 6,
  kFloat32 = 7,
  kFloat64 = 8,
};

/// Which returns are kept, by their distance from the sensor (frame S), metres.
struct CloudRangeFilter {
  double min_range_m = 0.0;
  double max_range_m = std::numeric_limits<double>::infinity();
};

/// Where x, y and z lie in each point of a cloud, bytes from the point's start.
struct XyzLayout {
  std::uint32_t x_offset = 0;
  std::uint32_t y_offset = 0;
  std::uint32_t z_offset = 0;
};

/// What one read kept and dropped.
struct CloudReadCounts {
  std::size_t kept = 0;          ///< points returned
  std::size_t not_finite = 0;    ///< NaN or infinite coordinates (no return)
  std::size_t out_of_range = 0;  ///< closer than min_range_m or farther than max_range_m
};

/// Finds `x`, `y`, `z` in `cloud.fields()` and checks the layout: each a FLOAT32 with count 1 (0 is read as
/// 1, as some drivers send), within point_step; the cloud little-endian; row_step >= width * point_step; data
/// holding height * row_step bytes. @return "" and sets `*layout`, or the problem naming the field and value
/// (e.g. "no FLOAT32 field 'z' (fields: x, y, intensity)", "is_bigendian is true: big-endian clouds are not
/// read").
std::string FindXyzLayout(const sensor_msgs::msg::dds_::PointCloud2_& cloud, XyzLayout* layout);

/// The cloud's returns, frame S (the cloud's frame_id), metres, into `*points_S` (cleared first; capacity
/// reused); counts into `*counts`. @return "" or the layout problem (FindXyzLayout), then nothing is read.
std::string ReadPointCloud2(const sensor_msgs::msg::dds_::PointCloud2_& cloud, const CloudRangeFilter& filter,
                            std::vector<Eigen::Vector3f>* points_S, CloudReadCounts* counts);

}  // namespace cairn::ros2
