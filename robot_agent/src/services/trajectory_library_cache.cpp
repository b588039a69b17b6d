#include "cairn/agent/services/trajectory_library_cache.h"

#include <unistd.h>
#include <zstd.h>

#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <system_error>

namespace cairn::agent {
namespace {

// Larger files or contents are refused before anything is allocated (the agent's library is ~33 MB raw).
constexpr std::uintmax_t kMaxFileBytes = 512ull << 20;
constexpr unsigned long long kMaxContentBytes = 1ull << 30;
constexpr int kZstdLevel = 3;

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

std::string Ms(double ms) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.0f ms", ms);
  return text;
}

// The library in `path`, or nullptr with `*why`.
std::unique_ptr<nav::TrajectoryLibrary> LoadFile(const std::string& path,
                                                 const nav::TrajectoryLibraryOptions& options,
                                                 std::string* why) {
  std::error_code error;
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  if (error) {
    *why = "cannot read its size: " + error.message();
    return nullptr;
  }
  if (size > kMaxFileBytes) {
    *why = std::to_string(size) + " bytes, more than a library's " + std::to_string(kMaxFileBytes);
    return nullptr;
  }
  std::ifstream in(path, std::ios::binary);
  std::string frame(static_cast<std::size_t>(size), '\0');
  if (!in.read(frame.data(), static_cast<std::streamsize>(frame.size()))) {
    *why = "cannot be read";
    return nullptr;
  }
  const unsigned long long declared = ZSTD_getFrameContentSize(frame.data(), frame.size());
  if (declared == ZSTD_CONTENTSIZE_ERROR || declared == ZSTD_CONTENTSIZE_UNKNOWN) {
    *why = "not a zstd frame that declares its size";
    return nullptr;
  }
  if (declared > kMaxContentBytes) {
    *why = "declares " + std::to_string(declared) + " bytes, more than a library's " +
           std::to_string(kMaxContentBytes);
    return nullptr;
  }
  std::string bytes(static_cast<std::size_t>(declared), '\0');
  // Checks the frame's content checksum (written with every file) and never writes past `bytes`.
  const std::size_t got = ZSTD_decompress(bytes.data(), bytes.size(), frame.data(), frame.size());
  if (ZSTD_isError(got) || got != bytes.size()) {
    *why = std::string("zstd: ") + (ZSTD_isError(got) ? ZSTD_getErrorName(got) : "shorter than declared");
    return nullptr;
  }
  return nav::TrajectoryLibrary::Deserialize(bytes, options, why);
}

// Writes `library` to `path` through a temporary file in the same folder; "" or the reason it could not.
std::string SaveFile(const nav::TrajectoryLibrary& library, const std::string& dir, const std::string& path) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) return "cannot create the folder " + dir + ": " + error.message();
  const std::string bytes = library.Serialize();
  std::string frame(ZSTD_compressBound(bytes.size()), '\0');
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  if (cctx == nullptr) return "zstd: cannot create a context";
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_compressionLevel, kZstdLevel);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_checksumFlag, 1);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_contentSizeFlag, 1);
  const std::size_t written = ZSTD_compress2(cctx, frame.data(), frame.size(), bytes.data(), bytes.size());
  ZSTD_freeCCtx(cctx);
  if (ZSTD_isError(written)) return std::string("zstd: ") + ZSTD_getErrorName(written);
  const std::string temporary = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out.write(frame.data(), static_cast<std::streamsize>(written)) || !out.flush()) {
      out.close();
      std::filesystem::remove(temporary, error);
      return "cannot write " + temporary;
    }
  }
  std::filesystem::rename(temporary, path, error);
  if (error) {
    std::filesystem::remove(temporary, error);
    return "cannot rename " + temporary + " to " + path;
  }
  return "";
}

}  // namespace

std::string TrajectoryLibraryCacheDir(const std::string& configured) {
  if (configured == "off") return "";
  if (!configured.empty()) return configured;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg != nullptr && xdg[0] == '/') {
    return std::string(xdg) + "/cairn";
  }
  if (const char* home = std::getenv("HOME"); home != nullptr && home[0] == '/') {
    return std::string(home) + "/.cache/cairn";
  }
  return "";
}

std::string TrajectoryLibraryCacheFile(const nav::TrajectoryLibraryOptions& options) {
  char name[96];
  std::snprintf(name, sizeof(name), "trajectory_library_v%u_%016" PRIx64 ".zst",
                static_cast<unsigned>(nav::TrajectoryLibrary::kFormatVersion),
                nav::TrajectoryLibrary::Fingerprint(options));
  return name;
}

CachedLibrary LoadOrBuildTrajectoryLibrary(const nav::TrajectoryLibraryOptions& options,
                                           const std::string& cache_dir) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  CachedLibrary result;
  const std::string path = cache_dir.empty() ? "" : cache_dir + "/" + TrajectoryLibraryCacheFile(options);
  std::string refused;
  if (!path.empty() && std::filesystem::exists(path)) {
    const auto t0 = std::chrono::steady_clock::now();
    if (auto library = LoadFile(path, options, &why)) {
      result.library = std::move(library);
      result.loaded = true;
      result.how = "loaded from " + path + " in " + Ms(MsSince(t0));
      return result;
    }
    refused = why;
  }
  const auto t0 = std::chrono::steady_clock::now();
  result.library = std::make_shared<const nav::TrajectoryLibrary>(options);
  result.how = "built in " + Ms(MsSince(t0));
  if (path.empty()) {
    result.how +=
        "; not cached: no cache folder (local_planner.library_cache_dir is off, or neither "
        "XDG_CACHE_HOME nor HOME is set)";
    return result;
  }
  const std::string not_saved = SaveFile(*result.library, cache_dir, path);
  result.cache_failed = !not_saved.empty() || !refused.empty();
  if (!not_saved.empty()) {
    result.how += "; not cached (local_planner.library_cache_dir '" + cache_dir + "'): " + not_saved;
    if (!refused.empty()) result.how += "; " + path + " was refused (" + refused + ")";
  } else if (!refused.empty()) {
    result.how += "; " + path + " was refused (" + refused + ") and replaced";
  } else {
    result.how += ", cached in " + path;
  }
  return result;
}

}  // namespace cairn::agent
