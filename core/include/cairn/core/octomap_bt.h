// OctoMap files, binary (.bt) and full (.ot), read without OctoMap: the header and the node stream are
// checked before any tree is built (OctoMap's own readers recurse once per node, trust the header, and do not
// stop at the end of the data). Shared by the robot's map (perception::OccupancyMap::LoadBt) and the
// simulator's worlds (sim::LoadWorld). DDS-free (cairn_types).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace cairn::core {

/// Finest depth of an OctoMap OcTree (keys of 16 bits per axis).
inline constexpr int kOctomapTreeDepth = 16;

/// A parsed, validated .bt or .ot file.
struct BtFile {
  double resolution_m = 0.0;   ///< leaf edge at the finest depth, metres, finite and > 0
  std::int64_t num_nodes = 0;  ///< nodes in the stream, equal to the header's size
  /// The node stream, depth first: .bt, two bytes of child codes per inner node; .ot, per node its value (a
  /// 4-byte float, log-odds) and a byte of child bits.
  std::string data;
};

/// Parses and validates the bytes of a .bt file: the first line, the header (id OcTree, size, res, data; at
/// most 256 lines of at most 1024 characters), and the node stream walked iteratively (at most 16 levels, no
/// inner node without children, no byte after its end, as many nodes as the header says). `where` names the
/// file in errors (e.g. "map file '/x/m.bt'"). The resolution is only checked to be finite and > 0; callers
/// apply their own range.
/// @throws std::invalid_argument "<where> is ..." naming the fault (an .ot file, a missing or bad header
///         field, truncated or corrupt data with the byte offset).
BtFile ParseBtFile(const std::string& bytes, const std::string& where);

/// Parses and validates the bytes of an OctoMap full (.ot) file of an OcTree, as ParseBtFile does a .bt: the
/// first line ("# Octomap OcTree file"), the same header, and the node stream walked iteratively
/// (CountOtNodes). Other tree types (ColorOcTree, ...) are refused, naming the type.
/// @throws std::invalid_argument "<where> is ..." naming the fault (a .bt file, a header field, truncated or
///         corrupt data).
BtFile ParseOtFile(const std::string& bytes, const std::string& where);

/// Walks an OctoMap full (.ot) node stream of an OcTree (`data`, `size` bytes; per node a 4-byte value and a
/// byte whose bit i says child i follows, depth first, at most 16 levels) without building it, iteratively.
/// @return its number of nodes with *error empty; -1 with the fault in *error (truncated, too deep, bytes
///         after its end). An empty stream has 0 nodes.
std::int64_t CountOtNodes(const char* data, std::size_t size, std::string* error);

/// The header OctoMap's AbstractOcTree::write() writes for an OcTree of `num_nodes` nodes at `resolution_m`;
/// followed by an .ot node stream, it is a file AbstractOcTree::read() reads.
std::string OtFileHeader(std::size_t num_nodes, double resolution_m);

/// Walks an OctoMap binary node stream (`data`, `size` bytes) without building it (depth first, two bytes of
/// child codes per inner node, at most 16 levels, iteratively) and returns its number of nodes with *error
/// empty; -1 with the fault in *error (truncated, too deep, an inner node without children, bytes after its
/// end) otherwise. An empty stream has 0 nodes.
std::int64_t CountBtNodes(const char* data, std::size_t size, std::string* error);

/// The shortest decimal text of `value` that reads back exactly ("0.1" for 0.1), as OctoMap writes a
/// resolution.
std::string ShortestDecimal(double value);

/// The header OctoMap's writeBinaryConst() writes for `num_nodes` nodes at `resolution_m` (shortest exact
/// decimal, "0.1" for 0.1); followed by a node stream, it is a .bt file OctoMap reads.
std::string BtFileHeader(std::size_t num_nodes, double resolution_m);

}  // namespace cairn::core
