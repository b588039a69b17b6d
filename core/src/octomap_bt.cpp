#include "cairn/core/octomap_bt.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

namespace cairn::core {
namespace {

constexpr int kTreeDepth = kOctomapTreeDepth;
constexpr char kBtFirstLine[] = "# Octomap OcTree binary file";
constexpr char kOtFirstLine[] = "# Octomap OcTree file";

}  // namespace

std::int64_t CountBtNodes(const char* data, std::size_t size, std::string* error) {
  error->clear();
  if (size == 0) return 0;
  // pending[d]: inner nodes at depth d whose child codes are still to be read.
  std::array<int, kTreeDepth + 1> pending{};
  std::int64_t nodes = 1;  // The root.
  std::size_t pos = 0;
  int depth = 0;  // Depth of the node whose codes are read next.
  pending[0] = 1;
  while (true) {
    while (depth >= 0 && pending[depth] == 0) --depth;
    if (depth < 0) break;
    --pending[depth];
    if (pos + 2 > size) {
      *error = "truncated: the node data ends at byte " + std::to_string(size) + " inside the tree";
      return -1;
    }
    const unsigned codes = static_cast<unsigned char>(data[pos]) |
                           (static_cast<unsigned>(static_cast<unsigned char>(data[pos + 1])) << 8);
    pos += 2;
    int inner = 0;
    for (int i = 0; i < 8; ++i) {
      const unsigned c = (codes >> (2 * i)) & 3u;
      if (c != 0) ++nodes;
      if (c == 3) ++inner;
    }
    if (codes == 0 && depth > 0) {
      *error = "corrupt: an inner node at depth " + std::to_string(depth) + " has no children (byte " +
               std::to_string(pos - 2) + ")";
      return -1;
    }
    if (inner > 0 && depth + 1 >= kTreeDepth) {
      *error = "corrupt: inner nodes below the finest depth " + std::to_string(kTreeDepth) + " (byte " +
               std::to_string(pos - 2) + ")";
      return -1;
    }
    if (inner > 0) {
      pending[depth + 1] += inner;
      ++depth;
    }
  }
  if (pos != size) {
    *error = "corrupt: " + std::to_string(size - pos) + " bytes follow the end of the node data";
    return -1;
  }
  return nodes;
}

std::int64_t CountOtNodes(const char* data, std::size_t size, std::string* error) {
  error->clear();
  if (size == 0) return 0;                               // OctoMap writes no node data for an empty tree
  constexpr std::size_t kNodeBytes = sizeof(float) + 1;  // OcTreeNode's value, then its child bits
  // pending[d]: nodes at depth d still to be read (OctoMap writes a node, then its children, depth first).
  std::array<int, kTreeDepth + 1> pending{};
  std::int64_t nodes = 0;
  std::size_t pos = 0;
  int depth = 0;  // Depth of the node read next.
  pending[0] = 1;
  while (true) {
    while (depth >= 0 && pending[depth] == 0) --depth;
    if (depth < 0) break;
    --pending[depth];
    if (pos + kNodeBytes > size) {
      *error = "truncated: the node data ends at byte " + std::to_string(size) + " inside the tree";
      return -1;
    }
    const unsigned children = static_cast<unsigned char>(data[pos + sizeof(float)]);
    pos += kNodeBytes;
    ++nodes;
    if (children == 0) continue;
    if (depth + 1 > kTreeDepth) {
      *error = "corrupt: nodes below the finest depth " + std::to_string(kTreeDepth) + " (byte " +
               std::to_string(pos - 1) + ")";
      return -1;
    }
    int count = 0;
    for (int i = 0; i < 8; ++i) count += (children >> i) & 1u;
    pending[depth + 1] += count;
    ++depth;
  }
  if (pos != size) {
    *error = "corrupt: " + std::to_string(size - pos) + " bytes follow the end of the node data";
    return -1;
  }
  return nodes;
}

std::string OtFileHeader(std::size_t num_nodes, double resolution_m) {
  std::string h = kOtFirstLine;
  h += "\n# (feel free to add / change comments, but leave the first line as it is!)\n#\n";
  h += "id OcTree\nsize " + std::to_string(num_nodes) + "\nres " + ShortestDecimal(resolution_m) + "\ndata\n";
  return h;
}

std::string ShortestDecimal(double value) {
  for (int precision = 6; precision <= 17; ++precision) {
    std::ostringstream s;
    s.precision(precision);
    s << value;
    if (std::strtod(s.str().c_str(), nullptr) == value) return s.str();
  }
  return std::to_string(value);
}

std::string BtFileHeader(std::size_t num_nodes, double resolution_m) {
  std::string h = kBtFirstLine;
  h += "\n# (feel free to add / change comments, but leave the first line as it is!)\n#\n";
  h += "id OcTree\nsize " + std::to_string(num_nodes) + "\nres " + ShortestDecimal(resolution_m) + "\ndata\n";
  return h;
}

namespace {

enum class Format { kBinary, kFull };

// The header's lines, one at a time: each without its '\n' (and '\r'), at most 1024 bytes.
class HeaderLines {
 public:
  explicit HeaderLines(const std::string& bytes) : bytes_(bytes) {}
  // The next line; false at the end of the file.
  bool Next(std::string* line) {
    if (pos_ >= bytes_.size()) return false;
    std::size_t eol = bytes_.find('\n', pos_);
    if (eol == std::string::npos || eol - pos_ > 1024) eol = std::min(bytes_.size(), pos_ + 1024);
    *line = bytes_.substr(pos_, eol - pos_);
    pos_ = std::min(bytes_.size(), eol + 1);  // a last line without '\n' ends the file (found by fuzzing)
    if (!line->empty() && line->back() == '\r') line->pop_back();
    return true;
  }
  // Where the next line starts (after the header: the node stream).
  std::size_t pos() const { return pos_; }

 private:
  const std::string& bytes_;
  std::size_t pos_ = 0;
};

// Throws unless `line` is the first line of the format (naming the other format when it is that one's).
void CheckFirstLine(const std::string& line, const std::string& where, bool binary) {
  const std::string first_line = binary ? kBtFirstLine : kOtFirstLine;
  // "# Octomap OcTree file" is a prefix of neither form's other first line, so the order of the checks
  // matters only for the message.
  if (line.rfind(first_line, 0) == 0) return;
  if (binary && line.rfind(kOtFirstLine, 0) == 0) {
    throw std::invalid_argument(where + " is an OctoMap full (.ot) file, not a binary (.bt) file");
  }
  if (!binary && line.rfind(kBtFirstLine, 0) == 0) {
    throw std::invalid_argument(where + " is an OctoMap binary (.bt) file, not a full (.ot) file");
  }
  const char* kind = binary ? "an OctoMap binary (.bt) file" : "an OctoMap full (.ot) file";
  throw std::invalid_argument(where + " is not " + kind + ": its first line is not '" + first_line + "'");
}

struct OctomapHeader {
  std::int64_t size = 0;  // nodes
  double resolution_m = 0.0;
};

// The header's lines after the first, up to and including 'data': id OcTree, size and res, each checked.
OctomapHeader ReadHeader(HeaderLines* lines, const std::string& where) {
  std::string id;
  std::optional<std::int64_t> size;
  std::optional<double> res;
  bool data_found = false;
  std::string line;
  for (int n = 0; n < 256 && !data_found; ++n) {
    if (!lines->Next(&line)) break;
    std::istringstream s(line);
    std::string keyword;
    if (!(s >> keyword) || keyword[0] == '#') continue;
    std::string value;
    s >> value;
    std::string rest;
    if (keyword == "data" && value.empty()) {
      data_found = true;
    } else if (keyword == "id" && !value.empty() && !(s >> rest)) {
      id = value;
    } else if (keyword == "size" && !value.empty() && !(s >> rest) &&
               value.find_first_not_of("0123456789") == std::string::npos && value.size() <= 10) {
      size = std::stoll(value);
    } else if (keyword == "res" && !value.empty() && !(s >> rest)) {
      char* parse_end = nullptr;
      const double r = std::strtod(value.c_str(), &parse_end);
      if (parse_end == nullptr || *parse_end != '\0') {
        throw std::invalid_argument(where + " has an invalid resolution '" + value + "' in its header");
      }
      res = r;
    } else {
      throw std::invalid_argument(where + " has an invalid header line '" + line.substr(0, 80) + "'");
    }
  }
  if (!data_found)
    throw std::invalid_argument(where + " is truncated or corrupt: its header has no 'data' line");
  if (id != "OcTree") {
    throw std::invalid_argument(where + " holds an OctoMap tree of type '" + id +
                                "'; only 'OcTree' is supported");
  }
  if (!size || *size > std::numeric_limits<std::uint32_t>::max()) {
    throw std::invalid_argument(where + " has no valid 'size' in its header");
  }
  if (!res) throw std::invalid_argument(where + " has no 'res' (resolution) in its header");
  if (!std::isfinite(*res) || *res <= 0.0) {
    throw std::invalid_argument(where + " has an invalid resolution " + std::to_string(*res) +
                                " in its header");
  }
  return {*size, *res};
}

// The header of a .bt or .ot file (they differ in their first line only) and the node stream after it, walked
// by the format's counter.
BtFile ParseOctomapFile(const std::string& bytes, const std::string& where, Format format) {
  const bool binary = format == Format::kBinary;
  if (bytes.empty()) throw std::invalid_argument(where + " is empty");
  HeaderLines lines(bytes);
  std::string line;
  lines.Next(&line);
  CheckFirstLine(line, where, binary);
  const OctomapHeader header = ReadHeader(&lines, where);
  BtFile contents;
  contents.resolution_m = header.resolution_m;
  contents.data = bytes.substr(lines.pos());
  std::string error;
  contents.num_nodes = binary ? CountBtNodes(contents.data.data(), contents.data.size(), &error)
                              : CountOtNodes(contents.data.data(), contents.data.size(), &error);
  if (!error.empty()) throw std::invalid_argument(where + " is " + error);
  if (contents.num_nodes != header.size) {
    throw std::invalid_argument(where + " is corrupt or truncated: its header says " +
                                std::to_string(header.size) + " nodes but its data holds " +
                                std::to_string(contents.num_nodes));
  }
  return contents;
}

}  // namespace

BtFile ParseBtFile(const std::string& bytes, const std::string& where) {
  return ParseOctomapFile(bytes, where, Format::kBinary);
}

BtFile ParseOtFile(const std::string& bytes, const std::string& where) {
  return ParseOctomapFile(bytes, where, Format::kFull);
}

}  // namespace cairn::core
