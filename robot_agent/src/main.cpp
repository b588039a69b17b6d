// cairn_agent: one process per robot. See --help.
#include <iostream>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "cairn/agent/robot_agent.h"
#include "cairn/core/dds.h"
#include "cairn/core/shutdown.h"
#include "cairn/sim/builtin_worlds.h"

int main(int argc, char** argv) {
  cairn::core::InstallShutdownHandler();
  // Logs go to stderr: stdout carries command output (cairn_base) and the READY line (cairn_agent).
  spdlog::set_default_logger(spdlog::stderr_color_mt("cairn"));
  cairn::agent::AgentOptions options;
  std::string start_text, domain_text = "0", config_file, platform = "wheeled";
  std::string worlds;
  for (const auto& name : cairn::sim::BuiltinWorldNames()) worlds += (worlds.empty() ? "" : ", ") + name;

  CLI::App app{"cairn_agent: one Cairn robot (command interface, mode tree, mux, navigation, simulated "
               "platform) on Fast DDS."};
  app.add_option("--robot-id", options.robot_id, "robot id, unique in the fleet ([A-Za-z0-9_-]{1,64})")
      ->required();
  app.add_option("--world", options.world,
                 "world: builtin:NAME (" + worlds + "), an OctoMap .bt file or a .pcd point cloud")
      ->capture_default_str();
  app.add_option("--start", start_text, "start pose X,Y[,YAW] in metres/radians, frame map, or slot:K for the "
                                        "K-th free start of the world (default: chosen from the robot id)");
  app.add_option("--platform", platform, "wheeled | legged (limits, step height, local planner headings)")
      ->capture_default_str();
  app.add_option("--domain", domain_text, "DDS domain id, 0..232")->capture_default_str();
  app.add_option("--config", config_file, "YAML config file (see config/agent.yaml)");
  app.add_option("--pcd-resolution", options.pcd_resolution_m, "voxel size for .pcd worlds, metres")
      ->capture_default_str();
  app.add_option("--dds-profiles", options.dds_profiles_file, "Fast DDS XML profiles file (default: shipped "
                                                              "loopback-only config/dds_profiles.xml)");
  app.add_option("--map-save", options.map_save_path,
                 "save the robot's map (OctoMap .bt, full resolution, SLAM frame) to this file at exit");
  app.add_option("--mode-tree", options.mode_tree_file, "mode tree XML (default: config/mode_tree.xml)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  try {
    options.domain_id = cairn::core::ParseDomainId(domain_text);
    if (!start_text.empty()) cairn::agent::ParseStart(start_text, &options);
    options.SetPlatform(platform);
    if (!config_file.empty()) options.LoadConfigFile(config_file);
    std::string why;
    if (!options.IsValid(&why)) throw std::invalid_argument(why);
    cairn::agent::RobotAgent agent(options);
    std::cout << "READY " << options.robot_id << std::endl;
    agent.Run();
  } catch (const std::exception& e) {
    spdlog::error("cairn_agent {}: {}", options.robot_id, e.what());
    return 2;
  }
  return 0;
}
