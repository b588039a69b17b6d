#include "command_table.h"

#include <cctype>
#include <sstream>
#include <stdexcept>

namespace cairn::base {
namespace {

constexpr std::size_t kAny = std::numeric_limits<std::size_t>::max();

// Appends the words of `text` to `out`, the first at column `column`, wrapping at `width` columns onto lines
// indented by `indent`.
void AppendWrapped(const std::string& text, std::size_t column, std::size_t indent, std::size_t width,
                   std::string* out) {
  bool first_on_line = true;
  std::istringstream words(text);
  for (std::string word; words >> word;) {
    if (!first_on_line && column + 1 + word.size() > width) {
      *out += "\n" + std::string(indent, ' ');
      column = indent;
      first_on_line = true;
    }
    if (!first_on_line) {
      *out += ' ';
      ++column;
    }
    *out += word;
    column += word.size();
    first_on_line = false;
  }
}

}  // namespace

std::vector<std::string> SplitCommandLine(const std::string& line) {
  std::vector<std::string> words;
  std::istringstream in(line);
  for (std::string word; in >> word;) {
    if (word[0] == '#') break;
    words.push_back(word);
  }
  return words;
}

const std::vector<CommandSpec>& CommandTable() {
  // One data table, kept whole on purpose (one entry per command, in help order): splitting it would scatter
  // what the table exists to keep in one place. Help text is a paragraph: CommandHelp wraps it. Argument
  // counts are words after the name.
  static const std::vector<CommandSpec> kTable = {
      {"robots", "robots",
       "the fleet: mode, holder, goal status, distance left, ETA, last heard, last refusal", 0, 0,
       FirstArgument::kNone, false},
      {"watch", "watch [PERIOD_S] [--count N]",
       "the robots table refreshed in place until a key is pressed (in scripts: N times, default 1)", 0, kAny,
       FirstArgument::kNone, false},
      {"status", "status R", "R at a glance: pose, control, goal, refusal, valid actions", 1, 1,
       FirstArgument::kRobot, false},
      {"links", "links [R]",
       "each robot's link: class and budget, last heard, probe round trip, state samples lost, what it sends "
       "per topic class; warns when a robot sends more than its budget or stops answering",
       0, 1, FirstArgument::kRobot, false},
      {"help", "help [R]", "this text; help R: what you may do with R now, and how", 0, 1,
       FirstArgument::kRobot, false},
      {"health", "health R",
       "R's software components: state, loop rate against its target, CPU, memory, restarts, last error (a "
       "failed part restarts by itself, alone, with a growing back-off)",
       1, 1, FirstArgument::kRobot, false},
      {"restart", "restart R COMPONENT", "restart one component of R now (the lock holder's only)", 2, 2,
       FirstArgument::kRobot, false},
      {"request-control", "request-control R [R2 ...]",
       "ask for R's control lock; when another basestation holds it, its operator is asked to grant or deny "
       "it and you are told the answer (a request left unanswered expires)",
       1, kAny, FirstArgument::kRobots, false},
      {"release", "release R [R2 ...]", "give R's control lock back (the robot stops)", 1, kAny,
       FirstArgument::kRobots, false},
      {"grant", "grant R BASE",
       "hand R's control lock to basestation BASE, which asked for it (R keeps its "
       "mode and goal)",
       2, 2, FirstArgument::kRobot, false},
      {"deny", "deny R BASE", "refuse basestation BASE's request for R's control lock", 2, 2,
       FirstArgument::kRobot, false},
      {"handover", "handover R BASE",
       "hand R's control lock to basestation BASE unasked (R keeps its mode and goal; BASE must be running)",
       2, 2, FirstArgument::kRobot, false},
      {"mode", "mode R MODE", "switch R to idle | manual | smart_joystick (waypoint: use goto)", 2, 2,
       FirstArgument::kRobot, false},
      {"goto", "goto R POINT [TOL] [--z Z_M] [--wait [TIMEOUT_S]]",
       "drive R to POINT (on the level nearest Z_M, default the robot's); --wait prints progress (distance "
       "left, ETA) until it arrives or fails (default 600 s; a robot lost for 5 s, or whose process exited, "
       "fails it)",
       1, kAny, FirstArgument::kRobot, true},
      {"resume-goal", "resume-goal R [--wait [TIMEOUT_S]]",
       "drive R again to the goal it was driving when it crashed (a robot restarted with --resume offers it, "
       "never resumes it)",
       1, kAny, FirstArgument::kRobot, false},
      {"explore",
       "explore R [R2 ...] [--region X0,Y0,X1,Y1] [--z-range Z0,Z1] [--home-after-silence S] "
       "[--wait [TIMEOUT_S]]",
       "R explores by itself (frontiers of its own map, in the region and height band when given) until no "
       "reachable frontier is left, then goes idle; --home-after-silence: it drives back to its start when "
       "it hears no basestation for S s; --wait prints progress until it ends (default 3600 s)",
       1, kAny, FirstArgument::kRobot, false},
      {"frontiers", "frontiers R", "R's exploration: explored area, frontiers, current target", 1, 1,
       FirstArgument::kRobot, false},
      {"convoy", "convoy LEADER R1 [R2 ...]",
       "R1 follows LEADER, R2 follows R1, ... on the path each robot ahead drove, at the configured spacing "
       "(this basestation must hold every lock); drive the leader as usual (goto, teleop, smart_joystick)",
       2, kAny, FirstArgument::kRobots, false},
      {"convoy-stop", "convoy-stop [LEADER] [--stop-leader]",
       "the followers (of LEADER's convoy, or of every convoy) go idle; the leader drives on unless "
       "--stop-leader (an operator stop)",
       0, 2, FirstArgument::kRobot, false},
      {"peel", "peel R POINT [TOL]",
       "follower R leaves its convoy for POINT; the robots behind it close up behind the robot ahead of it",
       1, kAny, FirstArgument::kRobot, true},
      {"yield", "yield R [for A]",
       "R gets out of A's way (A: the robot whose route passes R): it drives to the nearest spot on its own "
       "map that clears A's route, waits until A has passed and comes back; refused (with the reason) in "
       "manual control or a mode outside its policy",
       1, kAny, FirstArgument::kRobot, false},
      {"home", "home R [POINT] [--z Z_M] [--wait [TIMEOUT_S]]",
       "R drives back to where it started (or to POINT) on its own map, from any mode; --wait as goto's", 1,
       kAny, FirstArgument::kRobot, true},
      {"path", "path R", "the global path R is following (waypoints, length)", 1, 1, FirstArgument::kRobot,
       false},
      {"plan", "plan R POINT [--from POINT] [--platform P]",
       "ask R's global planner for a path (from R's pose, for R's platform by default); prints the path or "
       "the reason",
       1, kAny, FirstArgument::kRobot, true},
      {"teleop", "teleop R VX_MPS WZ_RADPS DURATION_S [VY_MPS]",
       "drive R for DURATION_S, then stop sending: manual mode unless R is in smart_joystick, where the "
       "twist is the direction the local planner follows; speeds beyond R's limits are clamped, with a "
       "notice",
       4, 5, FirstArgument::kRobot, false},
      {"stop", "stop R [R2 ...]|all",
       "stop now: zero twist, mode idle, goal cancelled; from any basestation, without the control lock (the "
       "lock stays)",
       1, kAny, FirstArgument::kRobotOrAll, false},
      {"wait", "wait R arrived|idle|mode=M|online|lost [TIMEOUT_S]",
       "block until R reaches that state (default 60 s)", 2, 3, FirstArgument::kRobot, false},
      {"events", "events [N]", "the last N events (default 20)", 0, 1, FirstArgument::kNone, false},
      {"place", "place add NAME POINT [Z] | place remove NAME", "name a point (saved to the --places file)",
       1, kAny, FirstArgument::kNone, false},
      {"places", "places", "the named places", 0, 0, FirstArgument::kNone, false},
      {"map", "map R|fleet --save FILE.bt",
       "save R's coarse map (or the fleet map merged from every robot) as an OctoMap .bt; asks for a "
       "snapshot first if it is incomplete",
       3, 3, FirstArgument::kRobotOrFleet, false},
      {"snapshot", "snapshot R FILE.jpg|FILE.png [TIMEOUT_S]", "save R's next camera frame (default 5 s)", 2,
       3, FirstArgument::kRobot, false},
      {"stairs", "stairs", "staircases found by the fleet (merged across robots)", 0, 0, FirstArgument::kNone,
       false},
      {"sleep", "sleep S", "pause a script for S seconds", 1, 1, FirstArgument::kNone, false},
  };
  return kTable;
}

const CommandSpec* FindCommand(const std::string& name) {
  for (const CommandSpec& spec : CommandTable()) {
    if (spec.name == name) return &spec;
  }
  return nullptr;
}

std::vector<std::string> OptionsOf(const CommandSpec& spec) {
  std::vector<std::string> options;
  for (std::size_t at = spec.usage.find("--"); at != std::string::npos; at = spec.usage.find("--", at + 2)) {
    std::size_t end = at + 2;
    while (end < spec.usage.size() &&
           (std::islower(static_cast<unsigned char>(spec.usage[end])) != 0 || spec.usage[end] == '-')) {
      ++end;
    }
    options.push_back(spec.usage.substr(at, end - at));
  }
  return options;
}

std::string UsageOf(const std::string& name) {
  const CommandSpec* spec = FindCommand(name);
  if (spec == nullptr) throw std::logic_error("UsageOf: no command '" + name + "' in the table");
  return "usage: " + spec->usage;
}

std::string CommandHelp(std::size_t width) {
  constexpr std::size_t kHelpColumn = 38;  // where help text starts: "  " + a 34-column synopsis + 2 spaces
  std::string out = "commands (R: a robot id; a point is X Y, X,Y or a place name, metres, frame map):\n";
  for (const CommandSpec& spec : CommandTable()) {
    out += "  " + spec.usage;
    std::size_t column = 2 + spec.usage.size();
    if (column + 2 <= kHelpColumn) {
      out += std::string(kHelpColumn - column, ' ');
      column = kHelpColumn;
    } else if (column + 2 + 20 <= width) {
      out += "  ";
      column += 2;
    } else {
      out += "\n" + std::string(kHelpColumn, ' ');
      column = kHelpColumn;
    }
    AppendWrapped(spec.help, column, kHelpColumn, width, &out);
    out += "\n";
  }
  out +=
      "Outcomes: accepted, refused, failed, timed out, invalid (a malformed command), cancelled (Ctrl-C).\n"
      "Refusals say why and what is valid now; a refused, failed, timed-out or cancelled command exits 1,\n"
      "an invalid one 2. Events (robots joining, arrivals, failures, losses, robots leaving or over their "
      "link\nbudget, locks, stops, staircases, robots close to each other) print as they happen.";
  return out;
}

}  // namespace cairn::base
