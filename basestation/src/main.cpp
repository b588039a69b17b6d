// cairn_base: one operator's basestation. Interactive REPL on a terminal, line-by-line commands otherwise,
// or one command after `--`. See --help.
#include <poll.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <optional>

#include <CLI/CLI.hpp>
#include <editline/readline.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "cairn/base/command_shell.h"
#include "cairn/base/fleet_client.h"
#include "cairn/core/dds.h"
#include "cairn/core/shutdown.h"

namespace {

// Interactive session state for libedit's callback interface (the handler has no user pointer).
struct Interactive {
  std::optional<std::string> pending;  // a complete line, run outside the line handler
  bool done = false;
};
Interactive g_interactive;

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

// Reads lines from a terminal with history (libedit) until Ctrl-D, "quit", or SIGINT/SIGTERM. Input is polled
// so that Ctrl-C ends the session at once instead of after the next Enter.
int RunInteractive(cairn::base::CommandShell& shell, cairn::base::FleetClient& client, const std::string& base_id) {
  const char* home = std::getenv("HOME");
  const std::string history = std::string(home ? home : ".") + "/.cairn_base_history";
  read_history(history.c_str());
  std::cout << "cairn_base " << base_id << ": type help for commands, quit or Ctrl-D to leave." << std::endl;
  const std::string prompt = base_id + "> ";
  int last = cairn::base::kOk;
  rl_callback_handler_install(prompt.c_str(), OnLine);
  while (!g_interactive.done && !cairn::core::ShutdownRequested()) {
    pollfd input{STDIN_FILENO, POLLIN, 0};
    if (poll(&input, 1, 100) > 0) rl_callback_read_char();
    if (!g_interactive.pending && client.perception().HasEvents() &&
        (rl_line_buffer == nullptr || rl_line_buffer[0] == '\0')) {
      // Events (a new staircase) between commands, while nothing is typed: print them above a new prompt.
      rl_callback_handler_remove();
      shell.PrintEvents();
      rl_callback_handler_install(prompt.c_str(), OnLine);
    }
    if (g_interactive.pending) {
      // Without the handler installed the output is not interleaved with a redrawn prompt.
      rl_callback_handler_remove();
      last = shell.Execute(*g_interactive.pending);
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

}  // namespace

int main(int argc, char** argv) {
  cairn::core::InstallShutdownHandler();
  // Logs go to stderr: stdout carries command output (cairn_base) and the READY line (cairn_agent).
  spdlog::set_default_logger(spdlog::stderr_color_mt("cairn"));
  cairn::base::FleetClientOptions options;
  std::string domain_text = "0", script;
  bool json = false, keep_going = false, no_joystick = false;
  std::vector<std::string> command;

  CLI::App app{"cairn_base: a Cairn basestation. Commands come from the terminal (REPL), from stdin line by "
               "line, from --script FILE, or as one command after --.\n\n" +
               cairn::base::CommandShell::Help()};
  app.add_option("--base-id", options.base_id, "basestation id, unique in the fleet ([A-Za-z0-9_-]{1,64})")
      ->required();
  app.add_option("--domain", domain_text, "DDS domain id, 0..232")->capture_default_str();
  app.add_flag("--json", json, "print one JSON object per command");
  app.add_option("--script", script, "run the commands of FILE, stop at the first failure");
  app.add_flag("--keep-going", keep_going, "with a script or stdin: run every line even after a failure");
  app.add_option("--dds-profiles", options.dds_profiles_file, "Fast DDS XML profiles file (default: shipped "
                                                              "loopback-only config/dds_profiles.xml)");
  app.add_option("--command-timeout", options.command_timeout_s, "seconds to wait for a robot's answer")
      ->capture_default_str();
  app.add_flag("--no-joystick", no_joystick,
               "do not advertise a joystick: robots then refuse smart_joystick mode from this basestation");
  app.add_option("command", command, "one command to run, after --");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  try {
    options.domain_id = cairn::core::ParseDomainId(domain_text);
    if (no_joystick) options.capabilities.clear();
    if (!(options.command_timeout_s > 0 && options.command_timeout_s <= 60)) {
      throw std::invalid_argument("--command-timeout " + std::to_string(options.command_timeout_s) +
                                  " must be in (0, 60]");
    }
    std::ifstream script_file;
    if (!script.empty()) {
      script_file.open(script);
      if (!script_file) throw std::invalid_argument("--script '" + script + "' cannot be read");
    }
    cairn::base::FleetClient client(options);
    cairn::base::CommandShell shell(client, json, std::cout);
    if (!command.empty()) {
      std::string line;
      for (const auto& word : command) line += (line.empty() ? "" : " ") + word;
      return shell.Execute(line);
    }
    if (!script.empty()) return RunScript(shell, script_file, keep_going);
    if (isatty(STDIN_FILENO)) return RunInteractive(shell, client, options.base_id);
    return RunScript(shell, std::cin, /*keep_going=*/true);
  } catch (const std::exception& e) {
    spdlog::error("cairn_base {}: {}", options.base_id, e.what());
    return cairn::base::kUsage;
  }
}
