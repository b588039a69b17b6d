// Copyright Cairn authors.
//
// JPEG compression of camera frames for telemetry, with libjpeg-turbo's TurboJPEG API. Grayscale only: the
// simulated camera renders shaded depth.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace cairn::perception {

/// Raised when an image cannot be encoded or a JPEG cannot be decoded; the message names the field and
/// value at fault (e.g. "JPEG quality 0 is outside [1, 100]") or TurboJPEG's own reason.
class JpegError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// An 8-bit grayscale image, row-major, top row first: pixels.size() == width_px * height_px.
struct GrayFrame {
  int width_px = 0;
  int height_px = 0;
  std::vector<std::uint8_t> pixels;
};

/// Compresses `frame` (width and height in [1, 16384], pixels.size() == width*height) to a baseline JPEG of
/// quality `quality` in [1, 100]. Throws JpegError naming the field and value otherwise.
std::vector<std::uint8_t> EncodeGrayJpeg(const GrayFrame& frame, int quality = 75);

/// Width and height of a JPEG, read from its header without decoding it. Throws JpegError if `jpeg` is not a
/// JPEG (empty, truncated header, garbage).
void ReadJpegSize(const std::vector<std::uint8_t>& jpeg, int* width_px, int* height_px);

/// Decodes `jpeg` to grayscale. Throws JpegError if it is not a valid JPEG or is larger than 16384 px a side.
GrayFrame DecodeGrayJpeg(const std::vector<std::uint8_t>& jpeg);

}  // namespace cairn::perception
