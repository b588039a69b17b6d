// cairn_agent: one process per robot. See --help.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <iterator>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cairn/agent/agent_components.h"
#include "cairn/agent/journal.h"
#include "cairn/agent/modes/mode_manager.h"
#include "cairn/agent/robot_agent.h"
#include "cairn/agent/supervisor.h"
#include "cairn/core/config.h"
#include "cairn/core/dds.h"
#include "cairn/core/link_cli.h"
#include "cairn/core/shutdown.h"
#include "cairn/ros2/ros2_platform.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/platform_profile.h"
#include "cairn/sim/simulated_platform.h"

// With --map-save, how long a SIGINT/SIGTERM's shutdown may take before the process is ended (the map is
// written at exit; without it, core::kDefaultShutdownDeadline).
constexpr std::chrono::seconds kMapSaveShutdownDeadline{10};

namespace {

// --print-tree-nodes-model and --update-tree-nodes-model need no other option (not even --robot-id): the exit
// status when one of them is given, else nothing.
std::optional<int> HandleTreeNodesModelFlags(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--print-tree-nodes-model") {
      std::cout << cairn::agent::ModeManager::TreeNodesModel() << std::endl;
      return 0;
    }
    if (arg != "--update-tree-nodes-model") continue;
    if (i + 1 >= argc) {
      std::cerr << "--update-tree-nodes-model needs a mode tree file (FILE.xml)" << std::endl;
      return 2;
    }
    const std::string path = argv[i + 1];
    try {
      std::ifstream in(path);
      if (!in) throw std::runtime_error("cannot read mode tree file '" + path + "'");
      const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      const std::string updated = cairn::agent::ModeManager::WithTreeNodesModel(text);
      std::ofstream out(path + ".tmp");
      out << updated;
      out.close();
      if (!out || std::rename((path + ".tmp").c_str(), path.c_str()) != 0) {
        throw std::runtime_error("cannot write mode tree file '" + path + "'");
      }
      std::cout << path << ": <TreeNodesModel> " << (updated == text ? "already up to date" : "updated")
                << std::endl;
      return 0;
    } catch (const std::exception& e) {
      std::cerr << "cairn_agent: " << e.what() << std::endl;
      return 2;
    }
  }
  return std::nullopt;
}

// --supervise: this process runs the agent (the same command line without --supervise) as its child and
// starts it again with --resume when it crashes. Returns the exit status.
int Supervise(const cairn::agent::AgentOptions& options, int argc, char** argv) {
  if (options.journal_dir.empty()) {
    spdlog::error(
        "cairn_agent {}: --supervise needs --journal DIR (a restarted robot reads its last state "
        "there)",
        options.robot_id);
    return 2;
  }
  std::vector<std::string> child;
  child.emplace_back("/proc/self/exe");
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) != "--supervise") child.emplace_back(argv[i]);
  }
  char self[4096];
  const ssize_t n = readlink("/proc/self/exe", self, sizeof(self) - 1);
  if (n > 0) child[0] = std::string(self, static_cast<std::size_t>(n));
  return cairn::agent::SuperviseAgent(child, options.robot_id);
}

// --resume: the journal's last known safe state into `options->resumed` (none: a fresh start).
void ReadJournalToResume(cairn::agent::AgentOptions* options) {
  try {
    options->resumed = cairn::agent::ReadJournal(options->journal_dir, options->robot_id);
  } catch (const std::invalid_argument& e) {
    // A robot that cannot read its journal still comes up, idle and free, rather than not at all; the bad
    // file is kept beside it for a look.
    spdlog::error("cairn_agent {}: {}; starting without it (kept as journal.json.bad)", options->robot_id,
                  e.what());
    const std::string file = cairn::agent::JournalFile(options->journal_dir);
    std::rename(file.c_str(), (file + ".bad").c_str());
  }
  if (!options->resumed)
    spdlog::info("cairn_agent {}: no journal in {}: a fresh start", options->robot_id, options->journal_dir);
}

// The platform driver behind the seam core::PlatformIO (docs/PLATFORM.md): the simulator (`driver` "sim"), or
// the robot's own ROS 2 stack ("ros2", on ROS 2 domain `ros2_domain_text`).
// @throws std::invalid_argument for another driver or a bad domain or config.
std::shared_ptr<cairn::core::PlatformIO> MakePlatform(const std::string& driver,
                                                      const cairn::agent::AgentOptions& options,
                                                      const std::string& config_file,
                                                      const std::string& ros2_domain_text) {
  if (driver == "ros2") {
    cairn::ros2::Ros2PlatformOptions ros2;
    ros2.domain_id = cairn::core::ParseDomainId(ros2_domain_text, "--ros2-domain (or ROS_DOMAIN_ID)");
    ros2.limits = options.navigation.platform.limits;
    ros2.footprint_radius_m = options.navigation.platform.footprint_radius_m;
    if (!options.dds_profiles_file.empty()) ros2.profiles_file = options.dds_profiles_file;
    if (!config_file.empty()) ros2.LoadConfigFile(config_file);
    return std::make_shared<cairn::ros2::Ros2Platform>(ros2);
  }
  if (driver == "sim") {
    cairn::sim::SimulatedPlatformOptions sim;
    sim.world = options.world;
    sim.pcd_resolution_m = options.pcd_resolution_m;
    sim.start_W = options.start_W;
    if (options.resumed) {
      // The simulator stands in for a robot that stayed where it stopped: it starts at the journal's pose
      // (the pose estimate, so within the SLAM drift of where the robot was).
      sim.start_W =
          cairn::core::PlanarPose{options.resumed->x_m, options.resumed->y_m, options.resumed->yaw_rad};
    }
    sim.start_slot = options.start_slot;
    sim.start_key = options.robot_id;
    cairn::sim::ApplyPlatformProfile(options.navigation.platform, &sim);
    if (!config_file.empty()) sim.LoadConfigFile(config_file);
    return std::make_shared<cairn::sim::SimulatedPlatform>(sim);
  }
  throw std::invalid_argument("--driver '" + driver + "' is neither sim nor ros2");
}

// The command line's values, before they are checked.
struct AgentCommandLine {
  cairn::agent::AgentOptions options;
  std::string start_text, domain_text = "0", config_file, platform = "wheeled", driver = "sim";
  // The robot's own ROS 2 domain: ROS_DOMAIN_ID as ROS 2 itself reads it, else 0.
  std::string ros2_domain_text = std::getenv("ROS_DOMAIN_ID") ? std::getenv("ROS_DOMAIN_ID") : "0";
  bool resume = false, supervise = false;
};

// cairn_agent's flags, read into `cl`.
void AddFlags(CLI::App& app, AgentCommandLine* cl) {
  std::string worlds;
  for (const auto& name : cairn::sim::BuiltinWorldNames()) worlds += (worlds.empty() ? "" : ", ") + name;
  app.add_option("--robot-id", cl->options.robot_id, "robot id, unique in the fleet ([A-Za-z0-9_-]{1,64})")
      ->required();
  app.add_option("--world", cl->options.world,
                 "world: builtin:NAME (" + worlds + "), an OctoMap .bt file or a .pcd point cloud")
      ->capture_default_str();
  app.add_option("--start", cl->start_text,
                 "start pose X,Y[,YAW] in metres/radians, frame map, or slot:K for the "
                 "K-th free start of the world (default: chosen from the robot id)");
  app.add_option("--platform", cl->platform, "wheeled | legged (limits, step height, local planner headings)")
      ->capture_default_str();
  app.add_option("--domain", cl->domain_text, "DDS domain id, 0..232")->capture_default_str();
  app.add_option("--driver", cl->driver,
                 "platform driver: sim (the simulator, --world) | ros2 (the robot's ROS 2 topics: "
                 "config section "
                 "ros2, docs/PLATFORM.md)")
      ->capture_default_str();
  app.add_option("--ros2-domain", cl->ros2_domain_text,
                 "with --driver ros2: the robot's ROS 2 domain id, 0..232 (default: ROS_DOMAIN_ID, else 0)")
      ->capture_default_str();
  app.add_option("--config", cl->config_file, "YAML config file (see config/agent.yaml)");
  app.add_option("--pcd-resolution", cl->options.pcd_resolution_m, "voxel size for .pcd worlds, metres")
      ->capture_default_str();
  cairn::core::AddLinkFlags(app, &cl->options.link);
  cairn::core::AddSecureFlag(app, &cl->options.security);
  app.add_option("--dds-profiles", cl->options.dds_profiles_file,
                 "Fast DDS XML profiles file (default: shipped "
                 "loopback-only config/dds_profiles.xml)");
  app.add_option("--map-save", cl->options.map_save_path,
                 "save the robot's map (OctoMap .bt, full resolution, SLAM frame) to this file at exit");
  app.add_option("--journal", cl->options.journal_dir,
                 "keep the robot's last known safe state in folder DIR (lock holder, mode, goal, pose, a map "
                 "snapshot), written atomically whenever it changes");
  app.add_flag(
      "--resume", cl->resume,
      "with --journal: start from the journal (idle, the lock back with its holder, the map reloaded, "
      "the old goal offered as resume-goal, never resumed by itself); a fresh start when there is none");
  app.add_flag("--supervise", cl->supervise,
               "with --journal: run the agent as a child process and start it again with --resume when it "
               "crashes (back-off 1-30 s)");
  app.add_option("--journal-map-every", cl->options.journal_map_every_s,
                 "with --journal: seconds between map snapshots")
      ->capture_default_str();
  app.add_option(
      "--inject-fault", cl->options.inject_faults,
      "test hook: make COMPONENT throw, or hang, AFTER_S seconds after start "
      "(COMPONENT:throw|hang|stuck:AFTER_S; repeatable); the health monitor restarts it; stuck work "
      "does not stop even at shutdown");
  app.add_option("--mode-tree", cl->options.mode_tree_file, "mode tree XML (default: config/mode_tree.xml)");
  app.add_flag(
      "--print-tree-nodes-model",
      "print the mode tree's <TreeNodesModel> (Groot2) for the nodes this agent registers, and exit");
  app.add_option("--update-tree-nodes-model",
                 "rewrite the <TreeNodesModel> of mode tree FILE.xml in place (so "
                 "Groot2 opens it with this agent's nodes), and exit");
}

// The values checked and completed (start, journal, platform, config file, link budget, --map-save), into
// cl->options. @throws std::invalid_argument naming the flag or field and the value.
void CheckCommandLine(AgentCommandLine* cl) {
  cairn::agent::AgentOptions& options = cl->options;
  options.domain_id = cairn::core::ParseDomainId(cl->domain_text);
  cairn::core::CheckLinkOptions(options.link);
  cairn::core::CheckSecureFlag(options.robot_id, &options.security);
  if (!cl->start_text.empty()) cairn::agent::ParseStart(cl->start_text, &options);
  if (cl->resume && options.journal_dir.empty()) throw std::invalid_argument("--resume needs --journal DIR");
  for (const std::string& fault : options.inject_faults) cairn::agent::ParseFaultInjection(fault);
  if (cl->resume) ReadJournalToResume(&options);
  options.SetPlatform(cl->platform);
  if (!cl->config_file.empty()) options.LoadConfigFile(cl->config_file);
  const std::string budget = options.ApplyLinkBudget();
  if (!budget.empty())
    spdlog::info("cairn_agent {}: radio link of {} kbit/s: {}", options.robot_id, options.link.link_kbps,
                 budget);
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  if (!options.map_save_path.empty()) {
    // Written at exit: a missing folder found only then lost the map and exited 0.
    if (const std::string fault = cairn::core::CheckOutputFile("--map-save", options.map_save_path);
        !fault.empty()) {
      throw std::invalid_argument(fault);
    }
    // Writing a large map takes seconds: a signal's shutdown waits longer for it before ending the process.
    cairn::core::SetShutdownDeadline(kMapSaveShutdownDeadline);
  }
  options.supervised = std::getenv("CAIRN_SUPERVISED") != nullptr;
}

}  // namespace

int main(int argc, char** argv) {
  cairn::core::InstallShutdownHandler();
  cairn::agent::ReturnLargeBlocksWhenFreed();  // a grown map's old grids go back to the system
  // Logs go to stderr: stdout carries command output (cairn_base) and the READY line (cairn_agent).
  spdlog::set_default_logger(spdlog::stderr_color_mt("cairn"));
  AgentCommandLine cl;
  cairn::agent::AgentOptions& options = cl.options;
  CLI::App app{
      "cairn_agent: one Cairn robot (command interface, mode tree, mux, navigation, perception) on "
      "Fast DDS, driving the simulated platform (--world) or a robot's own ROS 2 stack (--driver ros2)."};
  AddFlags(app, &cl);
  if (const std::optional<int> status = HandleTreeNodesModelFlags(argc, argv)) return *status;
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  if (cl.supervise) return Supervise(options, argc, argv);

  try {
    CheckCommandLine(&cl);
    const std::shared_ptr<cairn::core::PlatformIO> platform_io =
        MakePlatform(cl.driver, options, cl.config_file, cl.ros2_domain_text);
    cairn::agent::RobotAgent agent(options, platform_io);
    // READY once the components run: a command that needs one is refused before then.
    agent.Run([&options] { std::cout << "READY " << options.robot_id << std::endl; });
    if (agent.restart_requested()) {
      // A component's work did not stop and may still use the agent's state: no destructor runs.
      spdlog::error("cairn_agent {}: exiting for a restart by the supervisor", options.robot_id);
      spdlog::default_logger()->flush();
      std::cout.flush();
      std::_Exit(cairn::agent::RobotAgent::kRestartExitStatus);
    }
  } catch (const std::exception& e) {
    spdlog::error("cairn_agent {}: {}", options.robot_id, e.what());
    return 2;
  }
  return 0;
}
