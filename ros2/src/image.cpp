#include "cairn/ros2/image.h"

#include <algorithm>
#include <cctype>

#include "cairn/perception/jpeg.h"

namespace cairn::ros2 {

std::string ImageToGray(const sensor_msgs::msg::dds_::Image_& image, GrayImage* gray) {
  struct Layout {
    const char* encoding;
    int channels;
    int r, g, b;  // channel of each colour (-1: grey)
  };
  static const Layout kLayouts[] = {{"mono8", 1, -1, -1, -1},
                                    {"rgb8", 3, 0, 1, 2},
                                    {"bgr8", 3, 2, 1, 0},
                                    {"rgba8", 4, 0, 1, 2},
                                    {"bgra8", 4, 2, 1, 0}};
  const Layout* layout = nullptr;
  for (const Layout& l : kLayouts) {
    if (image.encoding() == l.encoding) layout = &l;
  }
  if (layout == nullptr)
    return "encoding '" + image.encoding() + "' is not read (mono8, rgb8, bgr8, rgba8, bgra8)";
  const std::uint32_t width = image.width(), height = image.height();
  if (width == 0 || height == 0 || width > kMaxImageSidePx || height > kMaxImageSidePx)
    return "size " + std::to_string(width) + " x " + std::to_string(height) + " is outside 1.." +
           std::to_string(kMaxImageSidePx) + " pixels a side";
  const std::uint64_t row_bytes = static_cast<std::uint64_t>(width) * layout->channels;
  if (image.step() < row_bytes)
    return "step " + std::to_string(image.step()) + " is less than width " + std::to_string(width) + " x " +
           std::to_string(layout->channels) + " bytes";
  const std::uint64_t needed = static_cast<std::uint64_t>(height) * image.step();
  if (image.data().size() < needed)
    return "data holds " + std::to_string(image.data().size()) + " bytes, height " + std::to_string(height) +
           " x step " + std::to_string(image.step()) + " needs " + std::to_string(needed);
  gray->width_px = static_cast<int>(width);
  gray->height_px = static_cast<int>(height);
  gray->pixels.resize(static_cast<std::size_t>(width) * height);
  for (std::uint32_t y = 0; y < height; ++y) {
    const std::uint8_t* row = image.data().data() + static_cast<std::size_t>(y) * image.step();
    std::uint8_t* out = gray->pixels.data() + static_cast<std::size_t>(y) * width;
    for (std::uint32_t x = 0; x < width; ++x) {
      const std::uint8_t* p = row + static_cast<std::size_t>(x) * layout->channels;
      // BT.601 luma in fixed point (weights 77, 150, 29 of 256).
      out[x] = layout->channels == 1
                   ? p[0]
                   : static_cast<std::uint8_t>(
                         (77 * p[layout->r] + 150 * p[layout->g] + 29 * p[layout->b] + 128) >> 8);
    }
  }
  return "";
}

std::string CompressedImageToGray(const sensor_msgs::msg::dds_::CompressedImage_& image, GrayImage* gray) {
  // image_transport's compressed plugin writes "jpeg" or "rgb8; jpeg compressed bgr8".
  std::string format = image.format();
  std::transform(format.begin(), format.end(), format.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  if (format.find("jpeg") == std::string::npos && format.find("jpg") == std::string::npos)
    return "format '" + image.format() + "' is not read (jpeg)";
  try {
    perception::GrayFrame frame = perception::DecodeGrayJpeg(image.data());
    gray->width_px = frame.width_px;
    gray->height_px = frame.height_px;
    gray->pixels = std::move(frame.pixels);
  } catch (const std::exception& e) {
    return std::string("JPEG not decoded: ") + e.what();
  }
  return "";
}

Eigen::Isometry3d OpticalFromCameraC() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  // Columns: C's axes in the optical frame (x_C forward = z_opt, y_C left = -x_opt, z_C up = -y_opt).
  T.linear() << 0, -1, 0,  //
      0, 0, -1,            //
      1, 0, 0;
  return T;
}

}  // namespace cairn::ros2
