// The PointCloud2 reader against layouts real ROS 2 lidar drivers publish.
#include "cairn/ros2/point_cloud2.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

namespace cairn::ros2 {
namespace {

namespace sm = sensor_msgs::msg::dds_;

sm::PointField_ Field(const std::string& name, std::uint32_t offset, PointFieldType type,
                      std::uint32_t count = 1) {
  sm::PointField_ f;
  f.name(name);
  f.offset(offset);
  f.datatype(static_cast<std::uint8_t>(type));
  f.count(count);
  return f;
}

// A cloud of `points` (x, y, z) in `height` rows, with `fields` and `point_step`; x, y, z written at the
// offsets of the fields named so, every other byte 0xAB (padding and other fields).
sm::PointCloud2_ Cloud(const std::vector<sm::PointField_>& fields, std::uint32_t point_step,
                       const std::vector<Eigen::Vector3f>& points, std::uint32_t height = 1,
                       std::uint32_t row_padding = 0) {
  sm::PointCloud2_ c;
  c.header().frame_id("velodyne");
  c.fields(fields);
  c.height(height);
  c.width(static_cast<std::uint32_t>(points.size()) / height);
  c.point_step(point_step);
  c.row_step(c.width() * point_step + row_padding);
  std::vector<std::uint8_t> data(static_cast<std::size_t>(c.row_step()) * height, 0xAB);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const std::size_t row = i / c.width(), col = i % c.width();
    std::uint8_t* p = data.data() + row * c.row_step() + col * point_step;
    for (const auto& f : fields) {
      const int axis = f.name() == "x" ? 0 : f.name() == "y" ? 1 : f.name() == "z" ? 2 : -1;
      // A field placed outside the point (a bad layout under test) is not written.
      if (axis >= 0 && f.offset() + sizeof(float) <= point_step) {
        std::memcpy(p + f.offset(), &points[i][axis], sizeof(float));
      }
    }
  }
  c.data(data);
  return c;
}

const std::vector<Eigen::Vector3f> kPoints = {{1, 2, 3}, {-4, 5.5f, -0.25f}, {10, 0, 0}, {0.1f, 0.1f, 0}};

std::vector<Eigen::Vector3f> ReadAll(const sm::PointCloud2_& c, CloudReadCounts* counts = nullptr) {
  std::vector<Eigen::Vector3f> points;
  CloudReadCounts local;
  EXPECT_EQ(ReadPointCloud2(c, CloudRangeFilter{}, &points, counts ? counts : &local), "");
  return points;
}

TEST(PointCloud2, VelodyneLayoutWithIntensityRingAndPadding) {
  // velodyne_driver: x y z intensity (FLOAT32) ring (UINT16) time (FLOAT32), point_step 22 -> padded to 32.
  const auto c =
      Cloud({Field("x", 0, PointFieldType::kFloat32), Field("y", 4, PointFieldType::kFloat32),
             Field("z", 8, PointFieldType::kFloat32), Field("intensity", 12, PointFieldType::kFloat32),
             Field("ring", 16, PointFieldType::kUint16), Field("time", 18, PointFieldType::kFloat32)},
            32, kPoints);
  const auto points = ReadAll(c);
  ASSERT_EQ(points.size(), kPoints.size());
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(points[i], kPoints[i]) << i;
}

TEST(PointCloud2, FieldsInAnyOrderAndUnalignedOffsets) {
  // z first, then an odd-sized field before x and y: offsets 0, 5, 9 in a 13-byte point.
  const auto c = Cloud({Field("z", 0, PointFieldType::kFloat32), Field("tag", 4, PointFieldType::kUint8),
                        Field("x", 5, PointFieldType::kFloat32), Field("y", 9, PointFieldType::kFloat32)},
                       13, kPoints);
  const auto points = ReadAll(c);
  ASSERT_EQ(points.size(), kPoints.size());
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(points[i], kPoints[i]) << i;
}

TEST(PointCloud2, OrganisedCloudWithRowPaddingAndNoReturnCells) {
  std::vector<Eigen::Vector3f> grid = kPoints;
  grid[1] = Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());  // no return
  grid[2].x() = std::numeric_limits<float>::infinity();
  const auto c = Cloud({Field("x", 0, PointFieldType::kFloat32), Field("y", 4, PointFieldType::kFloat32),
                        Field("z", 8, PointFieldType::kFloat32)},
                       16, grid, /*height=*/2, /*row_padding=*/8);
  CloudReadCounts counts;
  const auto points = ReadAll(c, &counts);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points[0], kPoints[0]);
  EXPECT_EQ(points[1], kPoints[3]);
  EXPECT_EQ(counts.not_finite, 2u);
  EXPECT_EQ(counts.kept, 2u);
}

TEST(PointCloud2, RangeFilterDropsAndCounts) {
  const auto c = Cloud({Field("x", 0, PointFieldType::kFloat32), Field("y", 4, PointFieldType::kFloat32),
                        Field("z", 8, PointFieldType::kFloat32)},
                       12, kPoints);
  std::vector<Eigen::Vector3f> points;
  CloudReadCounts counts;
  ASSERT_EQ(ReadPointCloud2(c, CloudRangeFilter{0.3, 9.0}, &points, &counts), "");
  // {0.1, 0.1, 0} is 0.14 m away, {10, 0, 0} 10 m.
  EXPECT_EQ(points.size(), 2u);
  EXPECT_EQ(counts.out_of_range, 2u);
}

TEST(PointCloud2, BadLayoutsAreRefusedNamingTheFieldAndValue) {
  const std::vector<sm::PointField_> xyz = {Field("x", 0, PointFieldType::kFloat32),
                                            Field("y", 4, PointFieldType::kFloat32),
                                            Field("z", 8, PointFieldType::kFloat32)};
  auto error = [](const sm::PointCloud2_& c) {
    std::vector<Eigen::Vector3f> points;
    CloudReadCounts counts;
    return ReadPointCloud2(c, CloudRangeFilter{}, &points, &counts);
  };
  sm::PointCloud2_ no_z =
      Cloud({xyz[0], xyz[1], Field("intensity", 8, PointFieldType::kFloat32)}, 12, kPoints);
  EXPECT_EQ(error(no_z), "no FLOAT32 field 'z' (fields: x, y, intensity)");
  sm::PointCloud2_ double_z = Cloud({xyz[0], xyz[1], Field("z", 8, PointFieldType::kFloat64)}, 16, kPoints);
  EXPECT_NE(error(double_z).find("'z' has datatype 8, FLOAT32 is 7"), std::string::npos) << error(double_z);
  sm::PointCloud2_ big = Cloud(xyz, 12, kPoints);
  big.is_bigendian(true);
  EXPECT_NE(error(big).find("big-endian"), std::string::npos);
  sm::PointCloud2_ outside = Cloud({xyz[0], xyz[1], Field("z", 10, PointFieldType::kFloat32)}, 12, kPoints);
  EXPECT_EQ(error(outside), "field 'z' at offset 10 does not fit in point_step 12");
  sm::PointCloud2_ short_data = Cloud(xyz, 12, kPoints);
  short_data.data().resize(20);
  EXPECT_NE(error(short_data).find("data holds 20 bytes"), std::string::npos) << error(short_data);
  sm::PointCloud2_ short_row = Cloud(xyz, 12, kPoints);
  short_row.row_step(8);
  EXPECT_NE(error(short_row).find("row_step 8"), std::string::npos) << error(short_row);
  // A huge height x row_step must not overflow into a small number of bytes needed.
  sm::PointCloud2_ huge = Cloud(xyz, 12, kPoints);
  huge.height(0x80000000u);
  huge.row_step(0x10000u);
  EXPECT_NE(error(huge).find("data holds"), std::string::npos) << error(huge);
  sm::PointCloud2_ vector_x =
      Cloud({Field("x", 0, PointFieldType::kFloat32, 3), xyz[1], xyz[2]}, 12, kPoints);
  EXPECT_NE(error(vector_x).find("'x' has count 3"), std::string::npos);
}

TEST(PointCloud2, AnEmptyCloudIsReadAsNoPoints) {
  sm::PointCloud2_ empty =
      Cloud({Field("x", 0, PointFieldType::kFloat32), Field("y", 4, PointFieldType::kFloat32),
             Field("z", 8, PointFieldType::kFloat32)},
            12, {});
  EXPECT_TRUE(ReadAll(empty).empty());
}

}  // namespace
}  // namespace cairn::ros2
