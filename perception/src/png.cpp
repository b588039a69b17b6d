#include "cairn/perception/png.h"

#include <png.h>

#include <string>

namespace cairn::perception {

namespace {

void AppendBytes(png_structp png, png_bytep data, png_size_t length) {
  auto* out = static_cast<std::vector<std::uint8_t>*>(png_get_io_ptr(png));
  try {
    out->insert(out->end(), data, data + length);
  } catch (const std::exception&) {  // no C++ exception may cross libpng's C frames
    png_error(png, "out of memory");
  }
}

void Flush(png_structp) {}  // the bytes are in memory already

void OnError(png_structp png, png_const_charp message) {
  *static_cast<std::string*>(png_get_error_ptr(png)) = message;
  png_longjmp(png, 1);
}

void OnWarning(png_structp, png_const_charp) {}

}  // namespace

std::vector<std::uint8_t> EncodeGrayPng(const GrayFrame& frame) {
  if (frame.width_px < 1 || frame.height_px < 1 || frame.width_px > 16384 || frame.height_px > 16384) {
    throw JpegError("image size " + std::to_string(frame.width_px) + "x" + std::to_string(frame.height_px) +
                    " is outside [1, 16384] a side");
  }
  if (frame.pixels.size() !=
      static_cast<std::size_t>(frame.width_px) * static_cast<std::size_t>(frame.height_px)) {
    throw JpegError("image pixels " + std::to_string(frame.pixels.size()) + " != width * height " +
                    std::to_string(frame.width_px * frame.height_px));
  }
  std::string error;
  std::vector<std::uint8_t> out;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &error, OnError, OnWarning);
  if (png == nullptr) throw JpegError("PNG encoder init failed");
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    throw JpegError("PNG encoder init failed");
  }
  std::vector<png_bytep> rows(static_cast<std::size_t>(frame.height_px));
  for (int y = 0; y < frame.height_px; ++y) {
    rows[static_cast<std::size_t>(y)] =
        const_cast<png_bytep>(frame.pixels.data() + static_cast<std::size_t>(y) * frame.width_px);
  }
  if (setjmp(png_jmpbuf(png)) != 0) {  // NOLINT(cert-err52-cpp): libpng reports errors by longjmp
    png_destroy_write_struct(&png, &info);
    throw JpegError("PNG encoding failed: " + error);
  }
  png_set_write_fn(png, &out, AppendBytes, Flush);
  png_set_IHDR(png, info, static_cast<png_uint_32>(frame.width_px), static_cast<png_uint_32>(frame.height_px),
               8, PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

}  // namespace cairn::perception
