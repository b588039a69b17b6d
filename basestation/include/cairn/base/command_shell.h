// The basestation's command language, shared by the interactive REPL, scripts read from stdin or a file,
// and the one-shot form `cairn_base --base-id opA -- <command>`.
#pragma once

#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "cairn/base/fleet_client.h"

namespace cairn::base {

/// Exit codes of a command (and of cairn_base).
enum ExitCode : int { kOk = 0, kRefused = 1, kUsage = 2 };

/// Executes one command line against a fleet client and prints the outcome (text, or one JSON object per
/// line with `json`). Commands: robots, status, request-control, release, mode, goto, path, plan, teleop,
/// stop, wait, sleep, map, snapshot, stairs, help (see Help()).
class CommandShell {
 public:
  CommandShell(FleetClient& client, bool json, std::ostream& out);

  /// Runs `line` ("" and "# comment" do nothing). @return kOk, kRefused (the robot refused, timed out or
  /// failed; its reason is printed) or kUsage (malformed command: the message names the argument and value).
  int Execute(const std::string& line);

  /// Prints events not yet shown (a new staircase), once each. Execute() calls it before and after each
  /// command; an interactive loop also calls it while idle.
  void PrintEvents();

  /// Help text listing every command.
  static std::string Help();
  /// Command names (for completion).
  static const std::vector<std::string>& CommandNames();

 private:
  int Run(const std::string& line);
  int Map(const std::vector<std::string>& args);
  int Snapshot(const std::vector<std::string>& args);
  int Stairs();
  int Robots();
  int Status(const std::vector<std::string>& args);
  int Control(const std::vector<std::string>& args, bool request);
  int Mode(const std::vector<std::string>& args);
  int Goto(const std::vector<std::string>& args);
  int Teleop(const std::vector<std::string>& args);
  int Wait(const std::vector<std::string>& args);
  int Path(const std::vector<std::string>& args);
  int Plan(const std::vector<std::string>& args);
  // Waits for the last goal of `robot` to arrive or fail, printing progress (distance left, ETA) every
  // 2 s; `command` names the output lines. Returns the exit code.
  int WaitArrived(const std::string& command, const std::string& robot, double timeout_s);
  int Sleep(const std::vector<std::string>& args);
  int Report(const std::string& command, const std::string& robot, const CommandOutcome& outcome);
  int UsageError(const std::string& command, const std::string& message);

  FleetClient& client_;
  bool json_;
  std::ostream& out_;
  core::SteadyTime created_;
  std::map<std::string, uint32_t> last_goal_id_;  // per robot, the last waypoint this shell sent
};

}  // namespace cairn::base
