// The basestation's command language, shared by the interactive REPL, scripts read from stdin or a file,
// and the one-shot form `cairn_base --base-id opA -- <command>`.
#pragma once

#include <atomic>
#include <functional>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "cairn/base/fleet.h"
#include "cairn/base/places.h"

namespace cairn::base {

/// Exit codes of a command (and of cairn_base): accepted 0; refused, failed, timed out, cancelled 1;
/// invalid input 2.
enum ExitCode : int { kOk = 0, kRefused = 1, kUsage = 2 };

/// How the shell prints and what it may use.
struct ShellOptions {
  bool json = false;        ///< one JSON object per line (results, progress, events)
  std::string places_file;  ///< named places (Places); "" = places live only in this session
  /// Interactive terminal hooks (nullptr in scripts): true once a key was pressed (ends `watch`); the key is
  /// consumed.
  std::function<bool()> key_pressed;
  /// Set (e.g. by SIGINT in the REPL) to cancel the running wait, teleop or watch; the shell clears it.
  std::atomic<bool>* cancel = nullptr;
  /// Print the fleet's events (taken from the client) around commands and during waits; false for a second
  /// shell on the same client (the GUI's), which must not take the console's events.
  bool print_events = true;
};

/// Executes one command line against a fleet client and prints the outcome (text, or one JSON object per
/// line). Outcomes use one vocabulary (operator_text.h): accepted, refused, failed, timed out, invalid, and
/// cancelled (the operator's Ctrl-C). Commands: see Help().
class CommandShell {
 public:
  /// @throws std::invalid_argument when the places file is malformed (names file, place and field).
  CommandShell(Fleet& client, ShellOptions options, std::ostream& out);
  /// The minimal form: no places file, no terminal hooks.
  CommandShell(Fleet& client, bool json, std::ostream& out);

  /// Runs `line` ("" and "# comment" do nothing). @return kOk, kRefused (refused, failed, timed out or
  /// cancelled; the reason is printed) or kUsage (malformed command: the message names the argument and
  /// value, with "did you mean" for commands and robot ids).
  int Execute(const std::string& line);
  /// Runs a command given as its words, the name first (as SplitCommandLine splits a line; a structured
  /// command from the GUI): nothing is split or joined again. Same results as Execute(line).
  int Execute(const std::vector<std::string>& words);

  /// Prints events not yet shown (arrivals, failures, losses, locks, stops, staircases, proximity), once
  /// each. Execute() calls it before and after each command and during waits; an interactive loop also
  /// calls it while idle.
  void PrintEvents();

  /// Help text listing every command.
  static std::string Help();
  /// Command names (for completion and "did you mean").
  static const std::vector<std::string>& CommandNames();
  /// Completions of the word being typed, given the words before it (robot ids, modes, places, options).
  std::vector<std::string> Complete(const std::vector<std::string>& words_before,
                                    const std::string& prefix) const;

 private:
  int Run(const std::vector<std::string>& words);
  int Map(const std::vector<std::string>& args);
  int Snapshot(const std::vector<std::string>& args);
  int Stairs();
  int Robots();
  int Links(const std::vector<std::string>& args);
  int Watch(const std::vector<std::string>& args);
  int Events(const std::vector<std::string>& args);
  int Status(const std::vector<std::string>& args);
  int Health(const std::vector<std::string>& args);
  int Restart(const std::vector<std::string>& args);
  int HelpFor(const std::string& robot);
  int Control(const std::vector<std::string>& args, bool request);
  // grant | deny | handover R BASE: the holder's answer to BASE's request, or a handover unasked.
  int AnswerControl(const std::string& command, const std::string& robot, const std::string& to_base_id);
  int Mode(const std::vector<std::string>& args);
  // goto R POINT ... and home R [POINT] ... (`command`): a waypoint goal, the robot's start by default for
  // home.
  int Goto(const std::string& command, const std::vector<std::string>& args);
  int ResumeGoal(const std::vector<std::string>& args);
  // explore R [--region X0,Y0,X1,Y1] [--z-range Z0,Z1] [--wait [TIMEOUT_S]] (command_shell_explore.cpp).
  int Explore(const std::vector<std::string>& args);
  // Waits until exploration `task_id` of `robot` ends, printing its progress every 5 s: accepted when
  // complete, failed when it failed or was stopped (or the robot is lost), timed out.
  int WaitExplored(const std::string& robot, uint32_t task_id, double timeout_s);
  // frontiers R: explored area, frontier count, current target, targets reached and given up.
  int Frontiers(const std::vector<std::string>& args);
  // convoy LEADER R1 R2 ..., convoy-stop [LEADER], peel R POINT [TOL] (command_shell_convoy.cpp).
  int Convoy(const std::vector<std::string>& args);
  int ConvoyStop(const std::vector<std::string>& all_args);
  int Peel(const std::vector<std::string>& args);
  // yield R [for A]: R gets out of A's way (A: by default the robot whose route passes R); waits up to 5 s
  // for R's answer (its yield_state).
  int Yield(const std::vector<std::string>& args);
  // "" when this basestation holds every robot of `robots` (waits up to 3 s for a state from each), else
  // why not, naming the first robot it does not hold.
  std::string RefuseUnlessHeld(const std::string& command, const std::vector<std::string>& robots);
  // Sends follower i `ahead[i]` (empty: leave the convoy), all at once; their answers in order.
  std::vector<CommandOutcome> SendConvoys(const std::vector<std::string>& followers,
                                          const std::vector<std::vector<std::string>>& ahead);
  // The convoy followers the fleet's states show (of `leader`'s convoy; "": every one): id, robots ahead.
  std::vector<std::pair<std::string, std::vector<std::string>>> ConvoyFollowers(const std::string& leader);
  int Stop(const std::vector<std::string>& args);
  int Teleop(const std::vector<std::string>& args);
  int Wait(const std::vector<std::string>& args);
  int Path(const std::vector<std::string>& args);
  int Plan(const std::vector<std::string>& args);
  int Place(const std::vector<std::string>& args);
  int ListPlaces();
  // Waits for the last goal of `robot` to arrive or fail, printing progress (distance left, ETA) every
  // 2 s and events as they come; `command` names the output lines. Returns the exit code.
  int WaitArrived(const std::string& command, const std::string& robot, double timeout_s);
  // While `robot` drives goal `goal_id` (0: any): its distance left, ETA, local planner and replans, one line
  // (a JSON progress line with --json).
  void PrintGoalProgress(const std::string& command, const std::string& robot, uint32_t goal_id);
  int Sleep(const std::vector<std::string>& args);
  int Report(const std::string& command, const std::string& robot, const CommandOutcome& outcome,
             const std::string& notice = "");
  // The answers of one command sent to several robots: a line per robot (text), or one JSON object for
  // `label` with a "robots" list; a single robot's is Report()'s unless `always_list`. kOk when all were
  // accepted (none: failed).
  int ReportEach(const std::string& command, const std::string& label, const std::vector<std::string>& robots,
                 const std::vector<CommandOutcome>& outcomes, bool always_list = false);
  int UsageError(const std::string& command, const std::string& message);
  // The robots table (`robots`, `watch`).
  void PrintRobotsTable();
  // Reads a point: "X Y", "X,Y" or a place name from args[first...]; sets *used to the words consumed.
  // false with *error naming the argument on failure.
  bool ParsePoint(const std::vector<std::string>& args, std::size_t first, double* x_m, double* y_m,
                  std::size_t* used, std::string* error);
  bool Cancelled();
  // Reports `command` refused and returns true when `robot` is unknown (refused at once after discovery).
  bool RefuseUnknown(const std::string& command, const std::string& robot);
  // The view of `robot` with a state received after this shell's last answer from it (waits up to 0.5 s),
  // so that what it shows follows from the commands just sent.
  std::optional<RobotView> FreshView(const std::string& robot);

  Fleet& client_;
  ShellOptions options_;
  bool json_;
  std::ostream& out_;
  Places places_;
  std::map<std::string, uint32_t> last_goal_id_;         // per robot, the last waypoint this shell sent
  std::map<std::string, core::SteadyTime> last_answer_;  // per robot, when it last answered this shell
};

}  // namespace cairn::base
