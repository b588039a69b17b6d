#include <gtest/gtest.h>

#include <set>
#include <string>

#include "cairn/base/gui_bridge.h"

namespace cairn::base {
namespace {

TEST(RobotPaletteTest, NumberedRobotsTakeTheSlotTheirNumberNamesWhateverTheOrderHeard) {
  RobotPalette a, b;
  for (const char* id : {"r1", "r2", "r3"}) a.ColorOf(id);
  for (const char* id : {"r3", "r1", "r2"}) b.ColorOf(id);
  for (const char* id : {"r1", "r2", "r3"}) EXPECT_EQ(a.ColorOf(id), b.ColorOf(id)) << id;
  EXPECT_EQ(a.ColorOf("r1"), "#ff9f1c");
  EXPECT_EQ(a.ColorOf("r2"), "#ff70a6");
}

TEST(RobotPaletteTest, TenRobotsGetTenDistinctColoursAndKeepThem) {
  RobotPalette palette;
  std::set<std::string> colours;
  // Names whose preferred slots collide (r1 and r11, hashes of words) still get distinct colours.
  const char* ids[] = {"r1", "r11", "spot", "husky", "r21", "anymal", "r3", "drone", "r4", "x"};
  for (const char* id : ids) colours.insert(palette.ColorOf(id));
  EXPECT_EQ(colours.size(), 10U);
  EXPECT_EQ(palette.ColorOf("r11"), palette.ColorOf("r11"));
  double r = -1, g = -1, b = -1;
  palette.RgbOf("r1", &r, &g, &b);
  EXPECT_NEAR(r, 0xff / 255.0, 1e-9);
  EXPECT_NEAR(g, 0x9f / 255.0, 1e-9);
  EXPECT_NEAR(b, 0x1c / 255.0, 1e-9);
  // An eleventh robot shares a colour rather than failing.
  EXPECT_EQ(palette.ColorOf("r12").size(), 7U);
}

TEST(RobotPaletteTest, NoColourIsRed) {
  RobotPalette palette;
  for (int i = 1; i <= RobotPalette::kSize; ++i) {
    double r = 0, g = 0, b = 0;
    palette.RgbOf("r" + std::to_string(i), &r, &g, &b);
    EXPECT_FALSE(r > 0.7 && g < 0.35 && b < 0.35) << "r" << i;
  }
}

}  // namespace
}  // namespace cairn::base
