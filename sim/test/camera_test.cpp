// Copyright Cairn authors.
#include "cairn/sim/camera.h"

#include <gtest/gtest.h>

#include <stdexcept>

#include "cairn/sim/builtin_worlds.h"
#include "test_util.h"

namespace cairn::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

// An empty 12 x 12 x 12 m grid of 0.1 m voxels around the origin (x in [-1, 11], y and z in [-6, 6]).
World MakeEmptyWorld() {
  return World("boxes", Eigen::Vector3d(-1.0, -6.0, -6.0), 0.1, Eigen::Vector3i(120, 120, 120));
}

// Fills the voxels whose centres lie in the box [lo, hi] (metres, frame W).
void AddBox(World* world, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  const Eigen::Vector3i dims = world->dims();
  for (int ix = 0; ix < dims.x(); ++ix) {
    for (int iy = 0; iy < dims.y(); ++iy) {
      for (int iz = 0; iz < dims.z(); ++iz) {
        const Eigen::Vector3d c = world->CenterOf(Eigen::Vector3i(ix, iy, iz));
        if ((c.array() >= lo.array()).all() && (c.array() <= hi.array()).all()) {
          world->SetOccupied(Eigen::Vector3i(ix, iy, iz));
        }
      }
    }
  }
}

// Centroid (u, v) of the non-black pixels and their number.
Eigen::Vector2d LitCentroid(const GrayImage& image, int* count) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  *count = 0;
  for (int v = 0; v < image.height_px; ++v) {
    for (int u = 0; u < image.width_px; ++u) {
      if (image.at(u, v) == 0) continue;
      sum += Eigen::Vector2d(u + 0.5, v + 0.5);
      ++*count;
    }
  }
  return *count > 0 ? Eigen::Vector2d(sum / *count) : sum;
}

TEST(CameraOptionsTest, DefaultsAreValidAndInvalidFieldsAreNamed) {
  std::string why;
  EXPECT_TRUE(CameraOptions{}.IsValid(&why)) << why;
  const World world = MakeEmptyWorld();
  GrayImage image;
  struct Case {
    const char* field;
    void (*breaks)(CameraOptions*);
  };
  const Case cases[] = {
      {"width_px = 0", [](CameraOptions* o) { o->width_px = 0; }},
      {"height_px = -2", [](CameraOptions* o) { o->height_px = -2; }},
      {"horizontal_fov_rad", [](CameraOptions* o) { o->horizontal_fov_rad = kPi; }},
      {"max_range_m", [](CameraOptions* o) { o->max_range_m = 0.0; }},
  };
  for (const Case& c : cases) {
    CameraOptions options;
    c.breaks(&options);
    EXPECT_FALSE(options.IsValid(&why)) << c.field;
    EXPECT_CONTAINS(why, c.field);
    try {
      RenderShadedDepth(world, Eigen::Isometry3d::Identity(), options, &image);
      ADD_FAILURE() << "no throw for " << c.field;
    } catch (const std::invalid_argument& e) {
      EXPECT_CONTAINS(std::string(e.what()), c.field);
    }
  }
}

TEST(CameraTest, ImageSizeAndNoHitPixelsAreBlack) {
  const World world = MakeEmptyWorld();
  CameraOptions options;
  options.width_px = 64;
  options.height_px = 48;
  GrayImage image;
  image.pixels.assign(100000, 7);  // Stale contents must go.
  RenderShadedDepth(world, Eigen::Isometry3d::Identity(), options, &image);
  EXPECT_EQ(image.width_px, 64);
  EXPECT_EQ(image.height_px, 48);
  ASSERT_EQ(image.pixels.size(), 64u * 48u);
  for (const std::uint8_t g : image.pixels) EXPECT_EQ(g, 0);
}

TEST(CameraTest, BoxStraightAheadIsInTheImageCentre) {
  World world = MakeEmptyWorld();
  // A 0.4 m cube 5 m ahead, seen by the default camera (320 x 240, f = 160 px).
  AddBox(&world, Eigen::Vector3d(5.0, -0.2, -0.2), Eigen::Vector3d(5.4, 0.2, 0.2));
  const CameraOptions options;
  GrayImage image;
  RenderShadedDepth(world, Eigen::Isometry3d::Identity(), options, &image);
  int count = 0;
  const Eigen::Vector2d centroid = LitCentroid(image, &count);
  EXPECT_NEAR(centroid.x(), 160.0, 0.5);
  EXPECT_NEAR(centroid.y(), 120.0, 0.5);
  // The front face spans 0.4 m at 5 m: 160 * 0.4 / 5 = 12.8 px square.
  EXPECT_GT(count, 11 * 11);
  EXPECT_LT(count, 15 * 15);
  EXPECT_GT(image.at(160, 120), 0);
  EXPECT_EQ(image.at(0, 0), 0);
  EXPECT_EQ(image.at(319, 239), 0);
}

TEST(CameraTest, ImageRightIsMinusYAndImageUpIsPlusZ) {
  World world = MakeEmptyWorld();
  AddBox(&world, Eigen::Vector3d(5.0, 1.8, -0.2), Eigen::Vector3d(5.4, 2.2, 0.2));  // Left of the camera.
  GrayImage image;
  RenderShadedDepth(world, Eigen::Isometry3d::Identity(), CameraOptions{}, &image);
  int count = 0;
  Eigen::Vector2d centroid = LitCentroid(image, &count);
  ASSERT_GT(count, 0);
  // Front face at u in [89.6, 102.4], the side facing the camera beyond it: left of the centre (u = 160).
  EXPECT_NEAR(centroid.x(), 160.0 - 160.0 * 2.0 / 5.0, 4.0);
  EXPECT_NEAR(centroid.y(), 120.0, 1.0);

  // From 2 m below the box's level, the box appears in the top half (front face at v in [49.6, 62.4]).
  Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
  T_W_C.translation() = Eigen::Vector3d(0.0, 2.0, -2.0);
  RenderShadedDepth(world, T_W_C, CameraOptions{}, &image);
  centroid = LitCentroid(image, &count);
  ASSERT_GT(count, 0);
  EXPECT_NEAR(centroid.x(), 160.0, 1.0);
  EXPECT_NEAR(centroid.y(), 120.0 - 160.0 * 2.0 / 5.0, 4.0);

  // Yawed +90 deg, the camera looks along +y: the box is now straight ahead.
  T_W_C.translation() = Eigen::Vector3d(5.2, -2.0, 0.0);
  T_W_C.linear() = Eigen::AngleAxisd(kPi / 2.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  RenderShadedDepth(world, T_W_C, CameraOptions{}, &image);
  centroid = LitCentroid(image, &count);
  ASSERT_GT(count, 0);
  EXPECT_NEAR(centroid.x(), 160.0, 1.0);
  EXPECT_NEAR(centroid.y(), 120.0, 1.0);
}

TEST(CameraTest, NearerWallsAreBrighter) {
  World world = MakeEmptyWorld();
  AddBox(&world, Eigen::Vector3d(3.0, 0.5, -1.0), Eigen::Vector3d(3.4, 3.0, 1.0));    // Left, at 3 m.
  AddBox(&world, Eigen::Vector3d(8.0, -5.0, -1.0), Eigen::Vector3d(8.4, -0.5, 1.0));  // Right, at 8 m.
  GrayImage image;
  RenderShadedDepth(world, Eigen::Isometry3d::Identity(), CameraOptions{}, &image);
  const int near = image.at(160 - 40, 120);  // Ray towards y = 3 * 40/160 = 0.75 m at x = 3.
  const int far = image.at(160 + 40, 120);   // Towards y = -2 m at x = 8.
  ASSERT_GT(near, 0);
  ASSERT_GT(far, 0);
  EXPECT_GT(near, far + 30);
}

TEST(CameraTest, FloorAndWallOfOneRangeHaveDifferentGreys) {
  World world = MakeEmptyWorld();
  AddBox(&world, Eigen::Vector3d(-1.0, -6.0, -1.2), Eigen::Vector3d(11.0, 6.0, -1.0));  // Floor, top z = -1.
  AddBox(&world, Eigen::Vector3d(4.0, -6.0, -1.0), Eigen::Vector3d(4.4, 6.0, 6.0));     // Wall, face x = 4.
  GrayImage image;
  RenderShadedDepth(world, Eigen::Isometry3d::Identity(), CameraOptions{}, &image);
  // The wall-floor corner is at v = 120 + 160 * 1 / 4 = 160: row 155 sees the wall (~4.1 m, head-on), row
  // 162 the floor (~3.9 m, at a grazing angle).
  const int wall = image.at(160, 155);
  const int floor = image.at(160, 162);
  ASSERT_GT(wall, 0);
  ASSERT_GT(floor, 0);
  EXPECT_GT(wall, 2 * floor);
}

TEST(CameraTest, TunnelViewIsMostlyLit) {
  const World world = MakeBuiltinWorld("tunnels");
  Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
  T_W_C.translation() = Eigen::Vector3d(4.0, 20.0, 0.8);
  GrayImage image;
  RenderShadedDepth(world, T_W_C, CameraOptions{}, &image);
  int count = 0;
  LitCentroid(image, &count);
  // Looking down the tunnel (+x): walls, floor and ceiling everywhere except far along the axis.
  EXPECT_GT(count, 320 * 240 * 8 / 10);
  EXPECT_LT(count, 320 * 240);
  EXPECT_EQ(image.at(160, 120), 0);  // The junction at x = 30 and the room beyond are > 20 m away.
}

}  // namespace
}  // namespace cairn::sim
