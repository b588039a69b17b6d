// The console's commands in one table: each command's name, usage, help text, argument count and what its
// words complete to. The shell's dispatch checks argument counts against it, its usage errors, `help`, `help
// R`, tab completion and "did you mean" all read it, so that a command is described in one place.
#pragma once

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace cairn::base {

/// What a command's first argument names (for completion).
enum class FirstArgument {
  kNone,          ///< not a robot (or no argument)
  kRobot,         ///< a robot id
  kRobotOrAll,    ///< a robot id or "all"
  kRobotOrFleet,  ///< a robot id or "fleet"
  kRobots,        ///< every word is a robot id (request-control r1 r2, convoy r1 r2 r3)
};

/// One console command.
struct CommandSpec {
  std::string name;   ///< e.g. "goto"
  std::string usage;  ///< the synopsis, name first: "goto R POINT [TOL] [--z Z_M] [--wait [TIMEOUT_S]]"
  std::string help;   ///< what it does, one paragraph (help wraps it)
  /// Argument counts (words after the name) outside [min_args, max_args] are refused with the usage before
  /// the command runs; commands that parse options check the rest themselves.
  std::size_t min_args = 0;
  std::size_t max_args = std::numeric_limits<std::size_t>::max();
  FirstArgument first = FirstArgument::kNone;
  bool place_second = false;  ///< the second word is a point: completes to place names
};

/// Every command, in the order help lists them.
const std::vector<CommandSpec>& CommandTable();

/// The command named `name`, or nullptr.
const CommandSpec* FindCommand(const std::string& name);

/// The options `spec` takes, as its synopsis names them ("--wait", "--z", ...), in order.
std::vector<std::string> OptionsOf(const CommandSpec& spec);

/// "usage: " and the command's synopsis; throws std::logic_error for a name not in the table (a bug).
std::string UsageOf(const std::string& name);

/// The words of a command line as the console splits them: at whitespace, up to a word starting with '#' (a
/// comment). "" and "# note" have none.
std::vector<std::string> SplitCommandLine(const std::string& line);

/// The `help` text: every command's synopsis and help, wrapped to `width` columns, then the outcomes.
std::string CommandHelp(std::size_t width = 104);

}  // namespace cairn::base
