// Copyright Cairn authors.
//
// PCD point cloud loading. The only translation unit of Cairn that includes PCL headers (they are slow to
// compile); keep it that way.
#include <pcl/io/pcd_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <exception>
#include <fstream>
#include <functional>
#include <limits>
#include <set>
#include <sstream>
#include <vector>

#include "world_loaders.h"

namespace cairn::sim::internal {
namespace {

// A header value that must be a whole number >= 0 ("12"; not "-5", "1e9", "12x" or one past int64).
bool ParseCount(const std::string& text, std::int64_t* value) {
  if (text.empty() || text.size() > 18 || !std::all_of(text.begin(), text.end(), [](char c) {
        return std::isdigit(static_cast<unsigned char>(c));
      })) {
    return false;
  }
  *value = std::stoll(text);
  return true;
}

std::string Bytes(double bytes) {
  std::ostringstream out;
  out.precision(3);
  if (bytes >= 1e9) {
    out << bytes / 1e9 << " GB";
  } else if (bytes >= 1e6) {
    out << bytes / 1e6 << " MB";
  } else {
    out << static_cast<std::int64_t>(bytes) << " bytes";
  }
  return out.str();
}

// LZF (PCD's binary_compressed) turns 3 bytes into at most 264: a file cannot hold more than this many bytes
// per compressed byte.
constexpr double kMaxLzfRatio = 88.0;

// PCL's header reader does not stop at the DATA line: it reads on while the lines are empty, comments (after
// trimming) or start with a header keyword (a prefix match), and a keyword line there changes the header it
// uses. Data whose first line starts with one (binary bytes spelling "FIELDS..."; found by fuzzing, a heap
// use-after-free inside PCL 1.13's reader) is refused through `fail`. `in` is at the first byte after the
// DATA line.
template <typename Fail>
void CheckNoHeaderAfterData(std::istream& in, const Fail& fail) {
  static const char* const kKeywords[] = {"FIELDS", "COLUMNS", "SIZE",   "TYPE", "COUNT",
                                          "WIDTH",  "HEIGHT",  "POINTS", "DATA", "VIEWPOINT"};
  for (std::string line; std::getline(in, line);) {
    if (line.empty()) continue;
    std::istringstream tokens(line);
    std::string first;
    if (!(tokens >> first)) return;  // blank: PCL's header ends here
    if (first[0] == '#' || first.rfind("VERSION", 0) == 0) continue;
    for (const char* keyword : kKeywords) {
      if (first.rfind(keyword, 0) == 0) {
        std::string shown = first.substr(0, 20);
        for (char& c : shown) c = std::isprint(static_cast<unsigned char>(c)) ? c : '?';
        fail("the data after the DATA line starts with '" + shown + "', which PCL would read as a " +
             keyword + " header line");
      }
    }
    return;
  }
}

// A PCD header's lines as read, before they are checked against one another.
struct PcdHeader {
  std::vector<std::string> fields, sizes, types, counts;
  std::int64_t width = -1, height = -1, points = -1;  // -1: no such line
};

using PcdFail = std::function<void(const std::string&)>;  // throws WorldError

// Bytes and values of one point, from the fields' SIZE, TYPE and COUNT (each checked, naming the field).
std::pair<std::int64_t, std::int64_t> PcdPointLayout(PcdHeader* h, const PcdFail& fail) {
  if (h->fields.empty()) fail("no FIELDS line");
  const std::set<std::string> names(h->fields.begin(), h->fields.end());
  if (!names.count("x") || !names.count("y") || !names.count("z")) fail("FIELDS lacks x, y or z");
  if (h->counts.empty()) h->counts.assign(h->fields.size(), "1");
  for (const auto& [name, list] : {std::make_pair("SIZE", &h->sizes), std::make_pair("TYPE", &h->types),
                                   std::make_pair("COUNT", &h->counts)}) {
    if (list->size() != h->fields.size()) {
      fail(std::string(name) + " has " + std::to_string(list->size()) + " values for " +
           std::to_string(h->fields.size()) + " FIELDS");
    }
  }
  std::int64_t point_bytes = 0;
  std::int64_t values_per_point = 0;
  for (std::size_t f = 0; f < h->fields.size(); ++f) {
    const std::string& field = h->fields[f];
    const std::string& size = h->sizes[f];
    const std::string& type = h->types[f];
    if (size != "1" && size != "2" && size != "4" && size != "8") {
      fail("SIZE '" + size + "' of field '" + field + "' is not 1, 2, 4 or 8");
    }
    if (type != "I" && type != "U" && type != "F") {
      fail("TYPE '" + type.substr(0, 8) + "' of field '" + field + "' is not I, U or F");
    }
    if (type == "F" && size != "4" && size != "8") {
      fail("field '" + field + "' is TYPE F with SIZE " + size + " (a float has 4 or 8 bytes)");
    }
    std::int64_t count = 0;
    if (!ParseCount(h->counts[f], &count) || count < 1 || count > 1000000) {
      fail("COUNT '" + h->counts[f].substr(0, 20) + "' of field '" + field + "' is not in [1, 1000000]");
    }
    point_bytes += count * std::stoll(size);
    values_per_point += count;
  }
  return {point_bytes, values_per_point};
}

// Checks the header's fields and point count, then that the data after the header (from `in`'s position,
// the line after DATA) holds what they declare for data `kind`.
void CheckPcdLayout(PcdHeader header, const std::string& kind, std::ifstream& in, const PcdFail& fail) {
  const auto [point_bytes, values_per_point] = PcdPointLayout(&header, fail);
  const std::int64_t width = header.width;
  const std::int64_t height = header.height;
  std::int64_t points = header.points;
  if (width < 0) fail("no WIDTH line");
  if (height < 0) fail("no HEIGHT line");
  if (points < 0) points = width * height;  // optional in the format
  if (width > 0 && height > std::numeric_limits<std::int64_t>::max() / width)
    fail("WIDTH x HEIGHT overflows");
  if (points != width * height) {
    fail("POINTS " + std::to_string(points) + " is not WIDTH x HEIGHT = " + std::to_string(width) + " x " +
         std::to_string(height));
  }
  // What the data after the header must hold at least.
  const std::streamoff data_begin = in.tellg();
  CheckNoHeaderAfterData(in, fail);
  in.clear();
  in.seekg(0, std::ios::end);
  const double data_bytes = static_cast<double>(in.tellg() - data_begin);
  double need = 0.0;
  std::string what;
  if (kind == "binary") {
    need = static_cast<double>(points) * static_cast<double>(point_bytes);
    what =
        std::to_string(points) + " points of " + std::to_string(point_bytes) + " bytes (" + Bytes(need) + ")";
  } else if (kind == "ascii") {
    need = static_cast<double>(points) * static_cast<double>(values_per_point) * 2.0;  // "0 " per value
    what = std::to_string(points) + " points of " + std::to_string(values_per_point) + " values (" +
           Bytes(need) + " of text at least)";
  } else {
    in.seekg(data_begin);
    std::uint32_t sizes_le[2] = {0, 0};  // compressed, uncompressed
    in.read(reinterpret_cast<char*>(sizes_le), sizeof(sizes_le));
    if (!in) fail("binary_compressed data without its two sizes");
    const double uncompressed = static_cast<double>(points) * static_cast<double>(point_bytes);
    if (static_cast<double>(sizes_le[1]) != uncompressed) {
      fail("binary_compressed data of " + std::to_string(sizes_le[1]) + " bytes uncompressed, but POINTS " +
           std::to_string(points) + " of " + std::to_string(point_bytes) + " bytes make " +
           Bytes(uncompressed));
    }
    need = 8.0 + std::max(static_cast<double>(sizes_le[0]), uncompressed / kMaxLzfRatio);
    what = std::to_string(points) + " points of " + std::to_string(point_bytes) + " bytes (" +
           Bytes(uncompressed) + ", at least " + Bytes(need) + " compressed)";
  }
  if (need > data_bytes) {
    fail("the header declares " + what + " but the file holds " + Bytes(data_bytes) + " after it");
  }
}

// Checks the PCD header (format: https://pointclouds.org/documentation/tutorials/pcd_file_format.html)
// before PCL reads the file, and that the data it declares fits in the file: PCL 1.13's PCDReader
// dereferences missing fields of a file without a header and crashes, sizes the cloud from POINTS before
// reading any data (a 215-byte file declaring 2e9 points made it allocate 23.5 GB), and reports a bad TYPE or
// a negative POINTS as a generic failure. Throws WorldError naming the header field and its value.
void CheckPcdHeader(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const auto fail = [&path](const std::string& why) {
    throw WorldError("world file '" + path + "' is not a valid PCD file (" + why + ")");
  };
  PcdHeader header;
  std::set<std::string> keys_seen;
  std::string line;
  for (int n = 0; n < 64 && std::getline(in, line); ++n) {
    if (line.empty()) continue;  // PCL skips empty lines only: one of blanks (or a lone '\r') ends its header
    if (line.find_first_not_of(" \t\r") == std::string::npos) {
      fail("line " + std::to_string(n + 1) +
           " is blank (spaces or a carriage return) before the DATA line: PCL's "
           "reader stops at it");  // found by fuzzing: PCL 1.13 then read a missing field (SEGV)
    }
    if (line.back() == '\r') line.pop_back();
    if (line[0] == '#') continue;
    std::istringstream tokens(line);
    std::string key;
    tokens >> key;
    std::vector<std::string> values;
    for (std::string v; tokens >> v;) values.push_back(v);
    // PCL acts on every header line as it reads it (a POINTS line sizes the cloud at once): a key given twice
    // would be checked here by its last value and used by PCL with its first (found by fuzzing: POINTS 2e9,
    // then POINTS 50, made PCL allocate 48 GB).
    if (!keys_seen.insert(key).second) fail(key.substr(0, 20) + " appears twice in the header");
    const auto one_count = [&](std::int64_t* out) {
      if (values.size() != 1 || !ParseCount(values[0], out)) {
        fail(key + " '" + (values.empty() ? "" : values[0].substr(0, 20)) +
             (values.size() > 1 ? " ..." : "") + "' is not a whole number >= 0");
      }
    };
    if (key == "FIELDS") {
      header.fields = values;
    } else if (key == "SIZE") {
      header.sizes = values;
    } else if (key == "TYPE") {
      header.types = values;
    } else if (key == "COUNT") {
      header.counts = values;
    } else if (key == "WIDTH") {
      one_count(&header.width);
    } else if (key == "HEIGHT") {
      one_count(&header.height);
    } else if (key == "POINTS") {
      one_count(&header.points);
    } else if (key == "DATA") {
      const std::string kind = values.empty() ? "" : values[0];
      if (kind != "ascii" && kind != "binary" && kind != "binary_compressed") {
        fail("DATA '" + kind + "' is not ascii, binary or binary_compressed");
      }
      CheckPcdLayout(header, kind, in, fail);
      return;
    } else if (key != "VERSION" && key != "VIEWPOINT") {
      fail("unexpected header line '" + line.substr(0, 40) + "'");
    }
  }
  fail("no DATA line in the header");
}

}  // namespace

World LoadPcdFile(const std::string& path, const WorldLoadOptions& options, WorldLoadReport* report) {
  CheckReadableFile(path);
  CheckPcdHeader(path);
  pcl::PointCloud<pcl::PointXYZ> cloud;
  int rc = -1;
  try {
    pcl::PCDReader reader;
    rc = reader.read(path, cloud);
  } catch (const std::exception& e) {
    throw WorldError("world file '" + path + "' is not a valid PCD file: " + e.what());
  }
  if (rc < 0) {
    throw WorldError("world file '" + path +
                     "' is not a valid PCD file (bad header, or corrupt or truncated data)");
  }
  report->points_total = static_cast<std::int64_t>(cloud.size());
  std::vector<Eigen::Vector3d> points;
  points.reserve(cloud.size());
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const pcl::PointXYZ& q : cloud.points) {
    const Eigen::Vector3d p(q.x, q.y, q.z);
    if (!p.allFinite()) {
      ++report->points_dropped_non_finite;
      continue;
    }
    points.push_back(p);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  if (points.empty()) {
    std::ostringstream msg;
    msg << "world file '" << path << "' is an empty map: no finite point (" << report->points_total
        << " points, " << report->points_dropped_non_finite << " dropped as NaN/inf)";
    throw WorldError(msg.str());
  }
  const double res = options.pcd_resolution_m;
  // A point on a voxel face belongs to the voxel above it, so the grid must reach past `hi`.
  World world = MakeGridCovering(path, "PCD file '" + path + "'", lo,
                                 hi + Eigen::Vector3d::Constant(0.5 * res), res, options.max_voxels);
  PointCounts counts;
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3d q = (p - world.p_W_min()) / res;
    Eigen::Vector3i index(static_cast<int>(std::floor(q.x())), static_cast<int>(std::floor(q.y())),
                          static_cast<int>(std::floor(q.z())));
    index = index.cwiseMax(0).cwiseMin(world.dims() - Eigen::Vector3i::Ones());  // Rounding at the faces.
    world.SetOccupied(index);
    int& n = counts[world.LinearIndex(index)];
    n = std::min(n + 1, 1 << 20);
  }
  CleanUpScannedWorld(&world, options, &counts, report);
  return world;
}

}  // namespace cairn::sim::internal
