// cairn_base: one operator's basestation. Interactive REPL on a terminal, line-by-line commands otherwise,
// or one command after `--`. See --help.
#include <editline/readline.h>
#include <poll.h>
#include <signal.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <termios.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <thread>

#include "cairn/base/command_shell.h"
#include "cairn/base/fleet_client.h"
#include "cairn/base/gui_bridge.h"
#include "cairn/base/ros2_fleet_bridge.h"
#include "cairn/core/dds.h"
#include "cairn/core/link_cli.h"
#include "cairn/core/shutdown.h"

namespace {

// Interactive session state for libedit's callback interface (the handler has no user pointer).
struct Interactive {
  std::optional<std::string> pending;  // a complete line, run outside the line handler
  bool done = false;
  cairn::base::CommandShell* shell = nullptr;  // for completion
};
Interactive g_interactive;

// Ctrl-C in the REPL: cancels the running wait, or clears the line being typed. It never ends the session
// (quit or Ctrl-D do); SIGTERM still does.
std::atomic<bool> g_interrupt{false};
void OnInterrupt() { g_interrupt.store(true); }

void OnLine(char* raw) {
  if (raw == nullptr) {  // Ctrl-D
    g_interactive.done = true;
    return;
  }
  std::string line(raw);
  std::free(raw);
  if (line == "quit" || line == "exit") {
    g_interactive.done = true;
    return;
  }
  if (line.find_first_not_of(" \t") == std::string::npos) return;
  add_history(line.c_str());
  g_interactive.pending = std::move(line);
}

// Completion of commands, robot ids, modes and places (Tab).
char* CompletionGenerator(const char* text, int state) {
  static std::vector<std::string> matches;
  static std::size_t next = 0;
  if (state == 0) {
    std::istringstream words(std::string(rl_line_buffer, static_cast<std::size_t>(std::max(0, rl_point))));
    std::vector<std::string> before;
    for (std::string w; words >> w;) before.push_back(w);
    const std::string prefix(text);
    if (!before.empty() && !prefix.empty() && before.back() == prefix) before.pop_back();
    matches =
        g_interactive.shell ? g_interactive.shell->Complete(before, prefix) : std::vector<std::string>{};
    next = 0;
  }
  if (next >= matches.size()) return nullptr;
  return strdup(matches[next++].c_str());
}

char** Complete(const char* text, int, int) {
  rl_attempted_completion_over = 1;  // no file-name completion
  return rl_completion_matches(text, CompletionGenerator);
}

// Terminal in non-canonical, no-echo mode while a command runs, so that `watch` sees a single key press at
// once; Ctrl-C still raises SIGINT. Restored on scope exit.
class KeysWhileRunning {
 public:
  KeysWhileRunning() : active_(tcgetattr(STDIN_FILENO, &saved_) == 0) {
    if (!active_) return;
    termios raw = saved_;
    raw.c_lflag &= static_cast<tcflag_t>(~(ICANON | ECHO));
    raw.c_cc[VMIN] = 0;
    raw.c_cc[VTIME] = 0;
    tcsetattr(STDIN_FILENO, TCSANOW, &raw);
  }
  ~KeysWhileRunning() {
    if (active_) tcsetattr(STDIN_FILENO, TCSANOW, &saved_);
  }
  KeysWhileRunning(const KeysWhileRunning&) = delete;
  KeysWhileRunning& operator=(const KeysWhileRunning&) = delete;

 private:
  termios saved_{};
  bool active_;
};

bool KeyPressed() {
  pollfd input{STDIN_FILENO, POLLIN, 0};
  if (poll(&input, 1, 0) <= 0) return false;
  char keys[64];
  const bool pressed = read(STDIN_FILENO, keys, sizeof(keys)) > 0;
  // The rest of a multi-byte key (an arrow's escape sequence) must not reach the next prompt.
  while (poll(&input, 1, 20) > 0 && read(STDIN_FILENO, keys, sizeof(keys)) > 0) {
  }
  return pressed;
}

// Prints events above the line being typed, then has libedit redraw its prompt and line (its buffer is
// untouched: the handler stays installed).
void PrintEventsKeepingLine(cairn::base::CommandShell& shell) {
  std::cout << "\r\033[K" << std::flush;
  shell.PrintEvents();
  rl_forced_update_display();
}

// Reads lines from a terminal with history (libedit) until Ctrl-D, "quit", or SIGTERM. Input is polled so
// that events print while nothing is being run, above the line being typed.
int RunInteractive(cairn::base::CommandShell& shell, cairn::base::FleetClient& client,
                   const std::string& base_id) {
  // Before anything initializes libedit (read_history does): it must not install signal handlers, which
  // would run on any thread, DDS ones included. Ctrl-C is ours (cancel a wait, clear the line).
  rl_catch_signals = 0;
  const char* home = std::getenv("HOME");
  const std::string history = std::string(home ? home : ".") + "/.cairn_base_history";
  read_history(history.c_str());
  cairn::core::SetInterruptHandler(OnInterrupt);
  std::cout
      << "cairn_base " << base_id
      << ": type help for commands, Tab to complete, Ctrl-C to cancel a wait or clear the line, quit or "
         "Ctrl-D to leave (robots keep running)."
      << std::endl;
  const std::string prompt = base_id + "> ";
  int last = cairn::base::kOk;
  g_interactive.shell = &shell;
  rl_attempted_completion_function = Complete;
  rl_completion_append_character = ' ';
  rl_callback_handler_install(prompt.c_str(), OnLine);
  while (!g_interactive.done && !cairn::core::ShutdownRequested()) {
    pollfd input{STDIN_FILENO, POLLIN, 0};
    if (poll(&input, 1, 100) > 0) rl_callback_read_char();
    if (g_interrupt.exchange(false)) {  // Ctrl-C at the prompt: drop the line being typed
      rl_callback_handler_remove();
      std::cout << "^C" << std::endl;
      rl_callback_handler_install(prompt.c_str(), OnLine);
    }
    if (!g_interactive.pending && client.HasEvents()) PrintEventsKeepingLine(shell);
    if (g_interactive.pending) {
      // Without the handler installed the output is not interleaved with a redrawn prompt.
      rl_callback_handler_remove();
      try {
        KeysWhileRunning keys;
        last = shell.Execute(*g_interactive.pending);
      } catch (const std::exception& e) {  // a command's failure never ends the operator's session
        std::cout << "error: " << e.what() << std::endl;
        last = cairn::base::kRefused;
      }
      g_interrupt.store(false);
      g_interactive.pending.reset();
      rl_callback_handler_install(prompt.c_str(), OnLine);
    }
  }
  rl_callback_handler_remove();
  std::cout << std::endl;
  write_history(history.c_str());
  return last;
}

// Runs every line of `in`; the exit code is the first failure's (scripts stop at the first failure).
int RunScript(cairn::base::CommandShell& shell, std::istream& in, bool keep_going) {
  std::string line;
  int first_failure = cairn::base::kOk;
  while (!cairn::core::ShutdownRequested() && std::getline(in, line)) {
    if (line == "quit" || line == "exit") break;
    const int code = shell.Execute(line);
    if (code != cairn::base::kOk && first_failure == cairn::base::kOk) {
      first_failure = code;
      if (!keep_going) break;
    }
  }
  return first_failure;
}

// Runs the lines of a pipe or file on stdin (not a terminal) as they arrive, every one (--keep-going is
// implied: a controlling program reads each result), and prints events while it waits for the next line:
// reading with std::getline left them until the next command, seconds late. Ends at EOF, "quit"/"exit", or
// shutdown; the exit code is the first failure's.
int RunPiped(cairn::base::CommandShell& shell, cairn::base::FleetClient& client) {
  constexpr int kPollMs = 50;  // events print within this of their arrival here
  std::string buffer;
  int first_failure = cairn::base::kOk;
  bool eof = false;
  while (!cairn::core::ShutdownRequested()) {
    std::size_t newline = buffer.find('\n');
    if (newline == std::string::npos && eof) {
      if (buffer.empty()) break;
      newline = buffer.size();  // a last line without a newline
      buffer += '\n';
    }
    if (newline != std::string::npos) {
      std::string line = buffer.substr(0, newline);
      buffer.erase(0, newline + 1);
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line == "quit" || line == "exit") break;
      const int code = shell.Execute(line);
      if (code != cairn::base::kOk && first_failure == cairn::base::kOk) first_failure = code;
      continue;
    }
    pollfd input{STDIN_FILENO, POLLIN, 0};
    if (poll(&input, 1, kPollMs) > 0) {
      char chunk[4096];
      const ssize_t n = read(STDIN_FILENO, chunk, sizeof(chunk));
      if (n > 0) {
        buffer.append(chunk, static_cast<std::size_t>(n));
      } else if (n == 0 || (errno != EINTR && errno != EAGAIN)) {
        eof = true;
      }
    }
    if (client.HasEvents()) shell.PrintEvents();
  }
  return first_failure;
}

// The web app built by ./cairn build: BUILD/web, the executable being BUILD/basestation/cairn_base.
std::string DefaultWebRoot(const char* argv0) {
  std::error_code ec;
  std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) exe = std::filesystem::absolute(argv0, ec);
  return (exe.parent_path().parent_path() / "web").string();
}

// How long a basestation on a lan or radio link waits for robots it has not seen before it calls one unknown
// (FleetClientOptions::discovery_s; 1.5 s on loopback).
constexpr double kNetworkDiscoveryS = 5.0;
// How long a robot's state (10 Hz) may be silent before a basestation on a lan or radio link shows it lost:
// 8 state periods, so a cut link or a dead robot shows within 1 s while 5 % random loss (8 losses in a row:
// p = 4e-11) never does (bench/fleet_join.sh). On loopback the default stays 3 s: one machine's robots are
// seen to go by their liveliness (1 s lease) and their participants leaving.
constexpr double kNetworkLostAfterS = 0.8;

// The command line's values, before they are checked.
struct BaseCommandLine {
  cairn::base::FleetClientOptions options;
  cairn::base::ShellOptions shell_options;
  std::string domain_text = "0", script, listen = "127.0.0.1:8080", gui_root, ros2_domain_text;
  bool keep_going = false, no_joystick = false, gui = false;
  std::vector<std::string> command;
  double discovery_wait_s = 0, lost_after_s = 0;
  double gui_map_kBps = cairn::base::GuiOptions{}.map_budget_kBps;
};

// cairn_base's flags, read into `cl`.
void AddFlags(CLI::App& app, BaseCommandLine* cl) {
  app.add_option("--base-id", cl->options.base_id,
                 "basestation id, unique in the fleet ([A-Za-z0-9_-]{1,64})")
      ->required();
  app.add_option("--domain", cl->domain_text, "DDS domain id, 0..232")->capture_default_str();
  app.add_flag("--json", cl->shell_options.json,
               "print one JSON object per command, progress line and event");
  app.add_option("--script", cl->script, "run the commands of FILE, stop at the first failure");
  app.add_flag("--keep-going", cl->keep_going, "with a script or stdin: run every line even after a failure");
  cairn::core::AddLinkFlags(app, &cl->options.link);
  cairn::core::AddSecureFlag(app, &cl->options.security);
  app.add_option("--dds-profiles", cl->options.dds_profiles_file,
                 "Fast DDS XML profiles file (default: shipped "
                 "loopback-only config/dds_profiles.xml)");
  app.add_option("--command-timeout", cl->options.command_timeout_s, "seconds to wait for a robot's answer")
      ->capture_default_str();
  app.add_option(
      "--discovery-wait", cl->discovery_wait_s,
      "after this basestation starts, a command to a robot it has not seen yet waits this long for it "
      "before refusing it as unknown, seconds (default 5 on lan and radio links, 1.5 on loopback)");
  app.add_option(
      "--lost-after", cl->lost_after_s,
      "show a robot lost when its state (10 Hz) has been silent this long, seconds (default 0.8 on lan "
      "and radio links, 3 on loopback)");
  app.add_flag("--no-joystick", cl->no_joystick,
               "do not advertise a joystick: robots then refuse smart_joystick mode from this basestation");
  app.add_option("--places", cl->shell_options.places_file,
                 "named places file (YAML), read at start and written by `place add`");
  app.add_option("--proximity-m", cl->options.events.proximity_m,
                 "event when two robots are closer than this, metres (centre to centre)")
      ->capture_default_str();
  app.add_flag(
      "--gui", cl->gui,
      "also serve the operator GUI (web app and Foxglove WebSocket protocol) on --listen; the console "
      "keeps working beside it");
  app.add_option("--listen", cl->listen,
                 "with --gui: ADDR:PORT to serve on (any address other than loopback only "
                 "when given)")
      ->capture_default_str();
  app.add_option("--gui-root", cl->gui_root,
                 "with --gui: the built web app (default: web/ beside the build's "
                 "basestation/ directory)");
  app.add_option(
         "--gui-map-kBps", cl->gui_map_kBps,
         "with --gui: the fleet map's share of the link to each GUI client, kB/s (changed map columns wait "
         "when it is spent)")
      ->capture_default_str();
  app.add_option("--ros2-domain", cl->ros2_domain_text,
                 "also publish the fleet for ROS 2 tools (RViz2: config/rviz/cairn.rviz) on ROS 2 domain N, "
                 "0..232: /tf map -> ROBOT/base_link, /ROBOT/path, /cairn/fleet_map");
  app.add_option("command", cl->command, "one command to run, after --");
}

// The fleet client's options checked and completed from the flags (domain, link, discovery wait, lost after,
// joystick, command timeout, proximity). @throws std::invalid_argument naming the flag and the value.
void CheckFleetOptions(const CLI::App& app, BaseCommandLine* cl) {
  cairn::base::FleetClientOptions& options = cl->options;
  options.domain_id = cairn::core::ParseDomainId(cl->domain_text);
  cairn::core::CheckLinkOptions(options.link);
  cairn::core::CheckSecureFlag(options.base_id, &options.security);
  // Across hosts a lost announcement or endpoint message waits for the next one: 5 % loss took a fresh
  // basestation past 1.5 s to know a robot (cairn_networks_test), so a robot it has not seen yet is given
  // longer before a command to it is refused as unknown.
  if (cairn::core::IsNamedNetworkLink(options.link)) {
    options.discovery_s = kNetworkDiscoveryS;
    options.lost_after_s = kNetworkLostAfterS;
  }
  if (app.count("--discovery-wait") > 0) {
    if (!(cl->discovery_wait_s > 0 && cl->discovery_wait_s <= 60)) {
      throw std::invalid_argument("--discovery-wait " + std::to_string(cl->discovery_wait_s) +
                                  " must be in (0, 60] s");
    }
    options.discovery_s = cl->discovery_wait_s;
  }
  if (app.count("--lost-after") > 0) {
    if (!(cl->lost_after_s >= 0.2 && cl->lost_after_s <= 60)) {
      throw std::invalid_argument("--lost-after " + std::to_string(cl->lost_after_s) +
                                  " must be in [0.2, 60] s");
    }
    options.lost_after_s = cl->lost_after_s;
  }
  if (cl->no_joystick) options.capabilities.clear();
  if (!(options.command_timeout_s > 0 && options.command_timeout_s <= 60)) {
    throw std::invalid_argument("--command-timeout " + std::to_string(options.command_timeout_s) +
                                " must be in (0, 60]");
  }
  if (!(options.events.proximity_m > 0 && options.events.proximity_m <= 100)) {
    throw std::invalid_argument("--proximity-m " + std::to_string(options.events.proximity_m) +
                                " must be in (0, 100]");
  }
  options.events.proximity_clear_m =
      std::max(options.events.proximity_clear_m, options.events.proximity_m + 1.0);
}

// The GUI's options from the flags (--gui, --listen, --gui-root, --gui-map-kBps); `argv0` finds the web app
// beside the build. @throws std::invalid_argument naming the flag and the value.
cairn::base::GuiOptions GuiOptionsFrom(const CLI::App& app, const BaseCommandLine& cl, const char* argv0) {
  cairn::base::GuiOptions gui_options;
  if (cl.gui) {
    cairn::base::ParseListenAddress(cl.listen, &gui_options.server.address, &gui_options.server.port);
    gui_options.server.web_root = cl.gui_root.empty() ? DefaultWebRoot(argv0) : cl.gui_root;
    gui_options.places_file = cl.shell_options.places_file;
    gui_options.map_budget_kBps = cl.gui_map_kBps;
    std::string why;
    if (!gui_options.IsValid(&why)) {
      throw std::invalid_argument("--gui-map-kBps " + std::to_string(cl.gui_map_kBps) + ": " + why);
    }
  } else if (app.count("--listen") > 0 || app.count("--gui-root") > 0 || app.count("--gui-map-kBps") > 0) {
    throw std::invalid_argument("--listen, --gui-root and --gui-map-kBps need --gui");
  }
  return gui_options;
}

}  // namespace

int main(int argc, char** argv) {
  cairn::core::InstallShutdownHandler();
  // Logs go to stderr: stdout carries command output (cairn_base) and the READY line (cairn_agent).
  spdlog::set_default_logger(spdlog::stderr_color_mt("cairn"));
  BaseCommandLine cl;
  cairn::base::FleetClientOptions& options = cl.options;
  cairn::base::ShellOptions& shell_options = cl.shell_options;
  CLI::App app{
      "cairn_base: a Cairn basestation. Commands come from the terminal (REPL), from stdin line by "
      "line, from --script FILE, or as one command after --.\n\n" +
      cairn::base::CommandShell::Help()};
  AddFlags(app, &cl);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  try {
    CheckFleetOptions(app, &cl);
    std::ifstream script_file;
    if (!cl.script.empty()) {
      // A folder opens as a stream that reads nothing: it ran no command and exited 0.
      if (std::filesystem::is_directory(cl.script))
        throw std::invalid_argument("--script '" + cl.script + "' is a folder, not a file");
      script_file.open(cl.script);
      if (!script_file) throw std::invalid_argument("--script '" + cl.script + "' cannot be read");
    }
    const bool interactive = cl.command.empty() && cl.script.empty() && isatty(STDIN_FILENO);
    if (interactive) {
      spdlog::set_level(spdlog::level::warn);  // the terminal is the operator's: only what needs attention
      shell_options.key_pressed = KeyPressed;
      shell_options.cancel = &g_interrupt;
    }
    const cairn::base::GuiOptions gui_options = GuiOptionsFrom(app, cl, argv[0]);
    cairn::base::Ros2FleetOptions ros2_options;
    if (!cl.ros2_domain_text.empty()) {
      ros2_options.domain_id = cairn::core::ParseDomainId(cl.ros2_domain_text, "--ros2-domain");
      if (!options.dds_profiles_file.empty()) ros2_options.profiles_file = options.dds_profiles_file;
    }
    cairn::base::FleetClient client(options);
    std::unique_ptr<cairn::base::Ros2FleetBridge> ros2_bridge;
    if (!cl.ros2_domain_text.empty()) {
      ros2_bridge = std::make_unique<cairn::base::Ros2FleetBridge>(client, ros2_options);
      spdlog::info("cairn_base {}: publishing the fleet for ROS 2 tools on ROS 2 domain {}", options.base_id,
                   ros2_options.domain_id);
    }
    std::unique_ptr<cairn::base::GuiBridge> gui_bridge;
    if (cl.gui) {
      gui_bridge = std::make_unique<cairn::base::GuiBridge>(client, gui_options);
      // The URL on stdout's first line: scripts and the demo read it from there.
      std::cout << "GUI " << gui_bridge->url() << std::endl;
    }
    cairn::base::CommandShell shell(client, shell_options, std::cout);
    if (!cl.command.empty()) {
      std::string line;
      for (const auto& word : cl.command) line += (line.empty() ? "" : " ") + word;
      return shell.Execute(line);
    }
    if (!cl.script.empty()) return RunScript(shell, script_file, cl.keep_going);
    if (interactive) return RunInteractive(shell, client, options.base_id);
    const int code = RunPiped(shell, client);
    // A GUI or a ROS 2 publisher outlives the end of stdin (cairn_base --gui </dev/null): it serves until
    // SIGINT or SIGTERM.
    if (gui_bridge)
      spdlog::info("cairn_base {}: stdin ended; the GUI serves {} until SIGINT or SIGTERM", options.base_id,
                   gui_bridge->url());
    if (ros2_bridge)
      spdlog::info("cairn_base {}: stdin ended; the fleet is published for ROS 2 until SIGINT or SIGTERM",
                   options.base_id);
    while ((gui_bridge || ros2_bridge) && !cairn::core::ShutdownRequested())
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    return code;
  } catch (const std::exception& e) {
    spdlog::error("cairn_base {}: {}", options.base_id, e.what());
    return cairn::base::kUsage;
  }
}
