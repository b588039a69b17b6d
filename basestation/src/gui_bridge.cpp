// The GUI's server side: FleetClient -> Foxglove WebSocket channels, services -> CommandShell (gui_bridge.h).
#include "cairn/base/gui_bridge.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>
#include <unordered_map>

#include "cairn/base/operator_text.h"
#include "cairn/core/time.h"
#include "cairn/fleet/robot_status.h"
#include "command_table.h"
#include "gui_command.h"
#include "shell_util.h"

namespace cairn::base {
namespace {

using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr int kChunkVoxels = 20;  // a /fleet_map entity covers 20 x 20 coarse voxels (4 x 4 m at 0.2 m)

std::uint64_t NowNs() {
  const core::WallStamp now = core::WallNow();
  return static_cast<std::uint64_t>(now.sec) * 1000000000ULL + now.nanosec;
}

json Stamp(std::uint64_t ns) { return {{"sec", ns / 1000000000ULL}, {"nsec", ns % 1000000000ULL}}; }

using shell::YawOf;

json Vec3(double x, double y, double z) { return {{"x", x}, {"y", y}, {"z", z}}; }
json Color(double r, double g, double b, double a = 1.0) { return {{"r", r}, {"g", g}, {"b", b}, {"a", a}}; }
json PoseJson(double x, double y, double z, double yaw) {
  return {{"position", Vec3(x, y, z)},
          {"orientation", {{"x", 0.0}, {"y", 0.0}, {"z", std::sin(yaw / 2)}, {"w", std::cos(yaw / 2)}}}};
}

// An empty foxglove.SceneEntity with every field the schema names.
json Entity(const std::string& id, std::uint64_t ns) {
  return {{"timestamp", Stamp(ns)},     {"frame_id", "map"},      {"id", id},
          {"lifetime", Stamp(0)},       {"frame_locked", false},  {"metadata", json::array()},
          {"arrows", json::array()},    {"cubes", json::array()}, {"spheres", json::array()},
          {"cylinders", json::array()}, {"lines", json::array()}, {"triangles", json::array()},
          {"texts", json::array()},     {"models", json::array()}};
}

json Cube(double x, double y, double z, double yaw, double sx, double sy, double sz, const json& color) {
  return {{"pose", PoseJson(x, y, z, yaw)}, {"size", Vec3(sx, sy, sz)}, {"color", color}};
}

json LineStrip(const std::vector<std::array<double, 3>>& points, double thickness, const json& color) {
  json pts = json::array();
  for (const auto& p : points) pts.push_back(Vec3(p[0], p[1], p[2]));
  return {{"type", 0},
          {"pose", PoseJson(0, 0, 0, 0)},
          {"thickness", thickness},
          {"scale_invariant", false},
          {"points", pts},
          {"color", color},
          {"colors", json::array()},
          {"indices", json::array()}};
}

json Deletion(const std::string& id, std::uint64_t ns) {
  return {{"timestamp", Stamp(ns)}, {"type", 0}, {"id", id}};
}

// Height colour of a map voxel (a blue-green-yellow-red ramp over [-1, 7] m), as "r,g,b" in [0, 1].
void HeightColor(double z, double* r, double* g, double* b) {
  const double t = std::clamp((z + 1.0) / 8.0, 0.0, 1.0);
  *r = std::clamp(1.5 * t - 0.25, 0.0, 1.0) * 0.9 + 0.1;
  *g = std::clamp(1.0 - std::abs(2.0 * t - 1.0) * 0.8, 0.0, 1.0) * 0.85 + 0.1;
  *b = std::clamp(1.0 - 1.6 * t, 0.0, 1.0) * 0.8 + 0.15;
}

// Foxglove's schemas written by the web build (build.mjs): {"foxglove.SceneUpdate": {...}, ...}.
json LoadSchemas(const std::string& web_root) {
  const std::string path = web_root + "/foxglove-schemas.json";
  std::ifstream in(path);
  if (!in) {
    throw std::invalid_argument("the GUI's schema file '" + path +
                                "' cannot be read (build the web app: ./cairn build)");
  }
  json j;
  try {
    in >> j;
  } catch (const std::exception& e) {
    throw std::invalid_argument("the GUI's schema file '" + path + "' is not JSON: " + e.what());
  }
  for (const char* name :
       {"foxglove.SceneUpdate", "foxglove.FrameTransforms", "foxglove.CompressedImage", "foxglove.Log"}) {
    if (!j.contains(name)) throw std::invalid_argument("the GUI's schema file '" + path + "' has no " + name);
  }
  return j;
}

// cairn's own JSON schemas.
const char* kFleetStateSchema =
    R"json({"title":"cairn.FleetState","description":"The fleet as one basestation sees it, with the actions valid now for it","type":"object","properties":{
"timestamp":{"type":"object","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}},
"base_id":{"type":"string","description":"this basestation"},
"robots":{"type":"array","items":{"type":"object","properties":{
"id":{"type":"string"},"platform":{"type":"string"},"online":{"type":"boolean"},"lost_reason":{"type":"string"},
"color":{"type":"string","description":"the robot's colour in every view, #rrggbb"},
"heard_s_ago":{"type":"number","description":"seconds since its last state"},
"link":{"type":"object","description":"its link as this basestation sees it (cairn_base links)","properties":{
"class":{"type":"string"},"budget_kbps":{"type":"number"},"rtt_ms":{"type":"number","description":"last link-probe round trip, -1 none yet"},
"rtt_max_ms":{"type":"number"},"probe_wait_s":{"type":"number"},"loss_pct":{"type":"number","description":"state samples lost over 10 s"},
"state_lost":{"type":"integer"},"state_received":{"type":"integer"},"sent_kbps":{"type":"number"},"over_budget":{"type":"boolean"},
"usage":{"type":"array","items":{"type":"object","properties":{"topic_class":{"type":"string"},"sent_kbps":{"type":"number"},"sent_bytes":{"type":"integer"}}}}}},
"mode":{"type":"string"},"holder":{"type":"string","description":"basestation holding the control lock, empty when free"},
"holder_alive":{"type":"boolean"},"you_hold":{"type":"boolean"},
"nav_status":{"type":"string","enum":["none","active","arrived","failed","paused"]},"nav_reason":{"type":"string"},"nav_goal_id":{"type":"integer"},
"goal":{"type":"object","properties":{"x_m":{"type":"number"},"y_m":{"type":"number"},"z_m":{"type":"number"}}},
"distance_left_m":{"type":"number"},"eta_s":{"type":"number"},"local_planner_status":{"type":"string"},
"pose":{"type":"object","properties":{"x_m":{"type":"number"},"y_m":{"type":"number"},"z_m":{"type":"number"},"yaw_rad":{"type":"number"}}},
"speed_mps":{"type":"number"},"in_contact":{"type":"boolean"},
"valid_actions":{"type":"array","items":{"type":"string"},"description":"what this basestation may send now, as the CLI's help R"},
"valid_modes":{"type":"array","items":{"type":"string"}},"goal_acceptable":{"type":"boolean"},
"max_speed_mps":{"type":"number"},"max_reverse_speed_mps":{"type":"number"},"max_yaw_rate_radps":{"type":"number"},
"camera_age_s":{"type":"number","description":"age of its latest camera frame, -1 = none"},
"control_period_max_ms":{"type":"number"},
"components":{"type":"array","description":"its agent's components as its health monitor judges them (cairn_base health R)","items":{"type":"object","properties":{"name":{"type":"string"},"state":{"type":"string","enum":["active","down","inactive","unconfigured"]},"loop_rate_hz":{"type":"number"},"target_rate_hz":{"type":"number"},"cpu_percent":{"type":"number"},"restarts":{"type":"integer"},"restart_in_s":{"type":"number"},"last_error":{"type":"string"},"degraded":{"type":"boolean"}}}},
"exploration":{"type":"object","description":"the robot's exploration (as status --json): state, reason, task_id, explored_m2, frontiers, reachable_frontiers, targets_reached, targets_failed, peers, peer_seen_m2, target {x_m, y_m, z_m} when it has one"},"convoy":{"type":"object","description":"a convoy follower's record (as status --json): state (none|following|holding|lost|blocked), ahead (the robots ahead, nearest first, the leader last), reason, gap_m when known"},"yield":{"type":"object","description":"get-out-of-the-way: state ('' | moving_aside | aside | returning | refused as the robot asked; asking | blocked as the robot asking), peer (the other robot), reason, for (the robot whose route passes this one now: yield offers to let it pass; '' = none)"},
"state_stamp":{"type":"object","description":"the robot's stamp of its latest state (wall clock)","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}},
"received_stamp":{"type":"object","description":"when this basestation received that state (wall clock)","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}}}}}}})json";

const char* kCommandRequestSchema =
    R"json({"title":"cairn.CommandRequest","description":"One cairn_base command (see cairn_base --help): structured, {\"name\":\"goto\",\"robot\":\"r1\",\"args\":[12,4],\"options\":{\"z\":1.2}}, or a console line, {\"command\":\"goto r1 12 4 --z 1.2\"}","type":"object","oneOf":[{"properties":{"name":{"type":"string"},"robot":{"type":"string"},"args":{"type":"array","items":{"type":["string","number"]}},"options":{"type":"object","additionalProperties":{"type":["string","number","boolean"]}}},"required":["name"],"additionalProperties":false},{"properties":{"command":{"type":"string"}},"required":["command"],"additionalProperties":false}]})json";

const char* kCommandTableSchema =
    R"json({"title":"cairn.CommandTable","description":"cairn_base's commands, as its console's help lists them (sent once to each subscriber): name, usage (synopsis), help, min_args and max_args (words after the name; max_args -1: no bound)","type":"object","properties":{"commands":{"type":"array","items":{"type":"object","properties":{"name":{"type":"string"},"usage":{"type":"string"},"help":{"type":"string"},"min_args":{"type":"integer"},"max_args":{"type":"integer"}},"required":["name","usage","help","min_args","max_args"]}}},"required":["commands"]})json";

// The command table as /cairn/commands carries it.
std::string CommandTableJson() {
  json commands = json::array();
  for (const CommandSpec& spec : CommandTable()) {
    const bool unbounded = spec.max_args == std::numeric_limits<std::size_t>::max();
    commands.push_back({{"name", spec.name},
                        {"usage", spec.usage},
                        {"help", spec.help},
                        {"min_args", spec.min_args},
                        {"max_args", unbounded ? json(-1) : json(spec.max_args)}});
  }
  return json{{"commands", commands}}.dump();
}

const char* kCommandResponseSchema =
    R"json({"title":"cairn.CommandResponse","description":"The CLI's --json result of the command: command, robot, ok, result (accepted|refused|failed|timed out|invalid), reason, holder, mode, valid_actions, ...","type":"object","properties":{"ok":{"type":"boolean"},"result":{"type":"string"},"reason":{"type":"string"},"exit_code":{"type":"integer"},"lines":{"type":"array","items":{"type":"object"}}}})json";

int LogLevel(const std::string& kind) {
  if (kind == "goal_abandoned" || kind == "lost" || kind == "lock_taken" || kind == "exploration_stopped" ||
      kind == "mission_paused" || kind == "control_requested")
    return 3;  // WARNING
  if (kind == "stopped" || kind == "component_failed" || kind == "component_restart_failed" ||
      kind == "component_escalated")
    return 3;
  // A staircase the operator may have relied on is gone.
  if (kind == "staircase_removed") return 3;
  return 2;  // INFO
}

// Robot colours: distinct on the dark 3D view and beside each other; no red (STOP, warnings). The first ones
// stand out from the map's blue-to-green height colours; the blues and greens come last.
constexpr std::array<std::uint32_t, RobotPalette::kSize> kRobotColors = {
    0xff9f1c,  // orange
    0xff70a6,  // pink
    0xffd60a,  // yellow
    0xc77dff,  // purple
    0xe8e8e8,  // white
    0xa3e048,  // lime
    0xc8a27a,  // tan
    0x4e9bff,  // blue
    0x3ddc97,  // green
    0x2ec4d6,  // cyan
};

}  // namespace

int RobotPalette::SlotOf(const std::string& robot_id) {
  const auto known = slots_.find(robot_id);
  if (known != slots_.end()) return known->second;
  // The preferred slot: the trailing number (r1 -> 0), else an FNV-1a hash of the name.
  std::size_t digits = robot_id.size();
  while (digits > 0 && std::isdigit(static_cast<unsigned char>(robot_id[digits - 1])) != 0) --digits;
  int preferred = 0;
  if (digits < robot_id.size() && robot_id.size() - digits <= 6) {
    preferred = (std::stoi(robot_id.substr(digits)) + RobotPalette::kSize - 1) % RobotPalette::kSize;
  } else {
    std::uint32_t hash = 2166136261U;
    for (const char c : robot_id) hash = (hash ^ static_cast<unsigned char>(c)) * 16777619U;
    preferred = static_cast<int>(hash % RobotPalette::kSize);
  }
  // Taken by another robot: the next free one (all taken, the eleventh robot shares its preferred slot).
  std::array<bool, RobotPalette::kSize> taken{};
  for (const auto& [id, slot] : slots_) taken[static_cast<std::size_t>(slot)] = true;
  int slot = preferred;
  for (int k = 0; k < RobotPalette::kSize; ++k) {
    const int candidate = (preferred + k) % RobotPalette::kSize;
    if (!taken[static_cast<std::size_t>(candidate)]) {
      slot = candidate;
      break;
    }
  }
  slots_.emplace(robot_id, slot);
  return slot;
}

std::string RobotPalette::ColorOf(const std::string& robot_id) {
  char text[8];
  std::snprintf(text, sizeof(text), "#%06x", kRobotColors[static_cast<std::size_t>(SlotOf(robot_id))]);
  return text;
}

void RobotPalette::RgbOf(const std::string& robot_id, double* r, double* g, double* b) {
  const std::uint32_t c = kRobotColors[static_cast<std::size_t>(SlotOf(robot_id))];
  *r = ((c >> 16) & 0xff) / 255.0;
  *g = ((c >> 8) & 0xff) / 255.0;
  *b = (c & 0xff) / 255.0;
}

void ModeColor(const std::string& mode, double* r, double* g, double* b) {
  if (mode == "idle") {
    *r = 0.62, *g = 0.64, *b = 0.68;
  } else if (mode == "manual") {
    *r = 0.96, *g = 0.55, *b = 0.15;
  } else if (mode == "smart_joystick") {
    *r = 0.64, *g = 0.38, *b = 0.92;
  } else if (mode == "waypoint") {
    *r = 0.2, *g = 0.55, *b = 0.98;
  } else {
    *r = 0.15, *g = 0.72, *b = 0.65;
  }
}

bool GuiOptions::IsValid(std::string* why) const {
  auto bad = [why](const std::string& text) {
    if (why != nullptr) *why = text;
    return false;
  };
  if (!(state_rate_hz > 0 && state_rate_hz <= 50))
    return bad("GuiOptions::state_rate_hz " + std::to_string(state_rate_hz) + " must be in (0, 50]");
  if (!(map_period_s >= 0.1 && map_period_s <= 60))
    return bad("GuiOptions::map_period_s " + std::to_string(map_period_s) + " must be in [0.1, 60]");
  if (!(map_budget_kBps >= 1 && map_budget_kBps <= 1e6))
    return bad("GuiOptions::map_budget_kBps " + std::to_string(map_budget_kBps) + " must be in [1, 1e6]");
  if (!(map_resend_s >= 0 && map_resend_s <= 600))
    return bad("GuiOptions::map_resend_s " + std::to_string(map_resend_s) + " must be in [0, 600]");
  if (!(trail_s >= 0 && trail_s <= 3600))
    return bad("GuiOptions::trail_s " + std::to_string(trail_s) + " must be in [0, 3600]");
  return true;
}

class GuiBridge::Impl {
 public:
  Impl(FleetClient& client, const GuiOptions& options) : client_(client), options_(options) {
    std::string why;
    if (!options.IsValid(&why)) throw std::invalid_argument(why);
    if (options.server.web_root.empty())
      throw std::invalid_argument("the GUI needs a web root (--gui-root DIR)");
    const json schemas = LoadSchemas(options.server.web_root);
    FoxgloveServer::Handlers handlers;
    handlers.on_subscribe = [this](FoxgloveServer::ClientId c, std::uint32_t channel) {
      OnSubscribe(c, channel);
    };
    handlers.on_client_message = [this](FoxgloveServer::ClientId c, const std::string& topic,
                                        const std::string& encoding, const std::string& payload) {
      OnClientMessage(c, topic, encoding, payload);
    };
    handlers.on_service_call = [this](FoxgloveServer::ClientId, std::uint32_t service,
                                      const std::string& request, FoxgloveServer::Responder respond) {
      OnServiceCall(service, request, std::move(respond));
    };
    FoxgloveServerOptions server_options = options.server;
    server_options.name = "cairn_base " + client.base_id();
    server_ = std::make_unique<FoxgloveServer>(server_options, std::move(handlers));
    auto channel = [&](const std::string& topic, const std::string& schema_name, const std::string& schema) {
      ChannelSpec spec;
      spec.topic = topic;
      spec.schema_name = schema_name;
      spec.schema = schema;
      return server_->AddChannel(spec);
    };
    scene_schema_ = schemas["foxglove.SceneUpdate"].dump();
    image_schema_ = schemas["foxglove.CompressedImage"].dump();
    fleet_ = channel("/fleet", "cairn.FleetState", kFleetStateSchema);
    tf_ = channel("/tf", "foxglove.FrameTransforms", schemas["foxglove.FrameTransforms"].dump());
    robots_ = channel("/robots", "foxglove.SceneUpdate", scene_schema_);
    paths_ = channel("/paths", "foxglove.SceneUpdate", scene_schema_);
    stairs_ = channel("/staircases", "foxglove.SceneUpdate", scene_schema_);
    places_ = channel("/places", "foxglove.SceneUpdate", scene_schema_);
    map_ = channel("/fleet_map", "foxglove.SceneUpdate", scene_schema_);
    events_ = channel("/events", "foxglove.Log", schemas["foxglove.Log"].dump());
    command_table_ = channel("/cairn/commands", "cairn.CommandTable", kCommandTableSchema);
    ServiceSpec command;
    command.name = "/cairn/command";
    command.type = "cairn.Command";
    command.request_schema_name = "cairn.CommandRequest";
    command.request_schema = kCommandRequestSchema;
    command.response_schema_name = "cairn.CommandResponse";
    command.response_schema = kCommandResponseSchema;
    command_service_ = server_->AddService(command);
    // Every event the FleetClient still keeps, also those from before the GUI started (a staircase found
    // while the basestation was starting); the console prints its own, the shell below prints none.
    ShellOptions shell_options;
    shell_options.json = true;
    shell_options.places_file = options.places_file;
    shell_options.print_events = false;
    shell_ = std::make_unique<CommandShell>(client_, shell_options, shell_out_);
    publisher_ = std::thread([this] { PublishLoop(); });
    commander_ = std::thread([this] { CommandLoop(); });
  }

  ~Impl() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    if (publisher_.joinable()) publisher_.join();
    if (commander_.joinable()) commander_.join();
    server_.reset();
  }

  std::string url() const { return server_->url(); }

  GuiStats Stats() const {
    std::lock_guard<std::mutex> lock(mutex_);
    GuiStats s = stats_;
    s.server = server_->Stats();
    return s;
  }

 private:
  struct Snapshot {  // what a new subscriber must be sent
    FoxgloveServer::ClientId client;
    std::uint32_t channel;
  };

  void OnSubscribe(FoxgloveServer::ClientId client, std::uint32_t channel) {
    // The others refresh at 10 Hz; /events sends a new subscriber the events it missed (ReplayEvents), and
    // /cairn/commands the command table (it never changes).
    if (channel != map_ && channel != stairs_ && channel != paths_ && channel != events_ &&
        channel != command_table_ && channel != places_) {
      return;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    snapshots_.push_back({client, channel});
  }

  void OnServiceCall(std::uint32_t service, const std::string& request, FoxgloveServer::Responder respond) {
    if (service != command_service_) {
      respond(false, "unknown service " + std::to_string(service));
      return;
    }
    std::vector<std::string> words;
    try {
      words = CommandRequestWords(json::parse(request));
    } catch (const std::exception& e) {
      respond(false, e.what());
      return;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    commands_.emplace_back(std::move(words), std::move(respond));
    cv_.notify_all();
  }

  // Commands run one at a time on their own thread, as the CLI runs the same words (its --json output is the
  // answer).
  void CommandLoop() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!stop_) {
      cv_.wait(lock, [this] { return stop_ || !commands_.empty(); });
      if (stop_) break;
      auto [words, respond] = std::move(commands_.front());
      commands_.pop_front();
      lock.unlock();
      json answer = RunCommand(words);
      respond(true, answer.dump());
      lock.lock();
      ++stats_.commands;
    }
  }

  // The answer to one command: the last JSON line the shell printed, with every line and the exit code.
  json RunCommand(const std::vector<std::string>& words) {
    const std::string first = words.empty() ? "" : words.front();
    const bool waits = std::find(words.begin(), words.end(), "--wait") != words.end();
    if (first == "teleop" || first == "watch" || first == "wait" || first == "sleep" || waits) {
      // The GUI drives with /cairn/teleop and follows progress on /fleet: nothing here may hold the queue.
      return {{"command", first},
              {"ok", false},
              {"result", outcome::kInvalid},
              {"exit_code", kUsage},
              {"reason",
               "'" + first + (waits ? " --wait" : "") +
                   "' is for the CLI: the GUI streams teleop on /cairn/teleop and shows progress on /fleet"}};
    }
    int code = kUsage;
    shell_out_.str("");
    try {
      code = shell_->Execute(words);
    } catch (const std::exception& e) {
      shell_out_ << json{{"command", first},
                         {"ok", false},
                         {"result", outcome::kFailed},
                         {"reason", e.what()}}
                        .dump()
                 << "\n";
    }
    json lines = json::array();
    std::istringstream out(shell_out_.str());
    for (std::string text; std::getline(out, text);) {
      try {
        lines.push_back(json::parse(text));
      } catch (const std::exception&) {
        lines.push_back({{"text", text}});
      }
    }
    json answer = lines.empty() ? json{{"ok", code == kOk}} : lines.back();
    answer["lines"] = lines;
    answer["exit_code"] = code;
    if (!answer.contains("ok")) answer["ok"] = code == kOk;
    return answer;
  }

  void OnClientMessage(FoxgloveServer::ClientId, const std::string& topic, const std::string& encoding,
                       const std::string& payload) {
    if (topic != "/cairn/teleop") return;
    double vx = 0, wz = 0, vy = 0;
    std::string robot;
    try {
      if (encoding != "json") throw std::invalid_argument("encoding '" + encoding + "' is not json");
      const json j = json::parse(payload);
      robot = j.at("robot_id").get<std::string>();
      vx = j.at("linear_x_mps").get<double>();
      wz = j.at("angular_z_radps").get<double>();
      vy = j.value("linear_y_mps", 0.0);
      if (!std::isfinite(vx) || !std::isfinite(wz) || !std::isfinite(vy))
        throw std::invalid_argument("a speed is not finite");
    } catch (const std::exception& e) {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.teleop_rejected;
      spdlog::warn("GUI teleop message dropped: {}", e.what());
      return;
    }
    const auto view = client_.Robot(robot);
    if (!view || view->lost) {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.teleop_rejected;
      return;
    }
    // The robot's limits, as the CLI's teleop command applies them.
    if (view->max_speed_mps > 0) vx = std::clamp(vx, -view->max_reverse_speed_mps, view->max_speed_mps);
    if (view->max_speed_mps > 0) vy = std::clamp(vy, -view->max_speed_mps, view->max_speed_mps);
    if (view->max_yaw_rate_radps > 0)
      wz = std::clamp(wz, -view->max_yaw_rate_radps, view->max_yaw_rate_radps);
    if (client_.PublishTeleop(robot, vx, wz, vy)) {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.teleop_messages;
    }
  }

  void PublishLoop() {
    const auto period = std::chrono::duration<double>(1.0 / options_.state_rate_hz);
    auto next = Clock::now();
    int tick = 0;
    std::unique_lock<std::mutex> lock(mutex_);
    while (!stop_) {
      std::vector<Snapshot> snapshots;
      snapshots.swap(snapshots_);
      lock.unlock();
      try {
        const std::uint64_t ns = NowNs();
        const std::vector<RobotView> robots = client_.Robots();
        PublishState(robots, ns);
        if (tick % std::max(1, static_cast<int>(std::lround(options_.state_rate_hz / 2))) == 0)
          PublishPaths(robots, ns, {});
        PublishCameras(robots, ns);
        PublishEvents(ns);
        PublishStairs(ns, {});
        if (tick % std::max(1, static_cast<int>(std::lround(options_.state_rate_hz * 2))) == 0)
          PublishPlaces(ns, {});
        const double since_map = std::chrono::duration<double>(Clock::now() - last_map_).count();
        if (since_map >= options_.map_period_s) {
          PublishMap(ns, {});
          last_map_ = Clock::now();
        }
        for (const Snapshot& s : snapshots) {
          if (s.channel == map_) PublishMap(ns, s.client);
          if (s.channel == stairs_) PublishStairs(ns, s.client);
          if (s.channel == paths_) PublishPaths(robots, ns, s.client);
          if (s.channel == places_) PublishPlaces(ns, s.client);
          if (s.channel == events_) ReplayEvents(ns, s.client);
          if (s.channel == command_table_) server_->SendTo(s.client, command_table_, ns, CommandTableJson());
        }
      } catch (const std::exception& e) {
        spdlog::warn("GUI publisher: {}", e.what());
      }
      ++tick;
      next += std::chrono::duration_cast<Clock::duration>(period);
      lock.lock();
      cv_.wait_until(lock, next, [this] { return stop_ || !snapshots_.empty(); });
      if (Clock::now() > next + std::chrono::seconds(1)) next = Clock::now();
    }
  }

  void PublishState(const std::vector<RobotView>& robots, std::uint64_t ns) {
    json fleet = {{"timestamp", Stamp(ns)}, {"base_id", client_.base_id()}, {"robots", json::array()}};
    json tf = {{"transforms", json::array()}};
    json scene = {{"deletions", json::array()}, {"entities", json::array()}};
    const auto now = core::SteadyClock::now();
    for (const RobotView& v : robots) {
      json r = {
          {"id", v.robot_id}, {"platform", v.platform}, {"online", !v.lost}, {"lost_reason", v.lost_reason}};
      r["color"] = palette_.ColorOf(v.robot_id);
      r["heard_s_ago"] = v.state ? core::SecondsBetween(v.state_received, now) : -1.0;
      r["link"] = shell::LinkFieldsJson(v.link);
      r["link"]["class"] = v.link.link;
      r["valid_actions"] = ValidActions(v, client_.base_id());
      r["max_speed_mps"] = v.max_speed_mps;
      r["max_reverse_speed_mps"] = v.max_reverse_speed_mps;
      r["max_yaw_rate_radps"] = v.max_yaw_rate_radps;
      r["valid_modes"] = v.tree ? v.tree->valid_modes() : std::vector<std::string>{};
      r["goal_acceptable"] = v.tree ? v.tree->goal_acceptable() : false;
      const auto frame = client_.perception().LatestFrame(v.robot_id);
      r["camera_age_s"] = frame ? core::SecondsBetween(frame->received, now) : -1.0;
      r["components"] = ComponentsJson(v);
      if (v.state) {
        const cairn_msgs::RobotState& s = *v.state;
        const auto& p = s.pose_MB().position();
        const double yaw = YawOf(s.pose_MB().orientation());
        r["mode"] = s.mode();
        r["holder"] = s.holder_id();
        r["holder_alive"] = s.holder_alive();
        r["you_hold"] = s.holder_id() == client_.base_id();
        // A basestation waiting for the holder's answer (grant or deny), and the last answer or handover.
        r["control_request"] = {{"from", s.control_requester_id()}, {"left_s", s.control_request_left_s()}};
        r["handover"] = {{"count", s.handovers()}, {"outcome", s.handover_outcome()}};
        r["nav_status"] = fleet::NavStatusWord(s.nav_status());
        r["nav_reason"] = s.nav_reason();
        r["nav_goal_id"] = s.nav_goal_id();
        r["goal"] = {
            {"x_m", s.nav_goal_M().x_m()}, {"y_m", s.nav_goal_M().y_m()}, {"z_m", s.nav_goal_M().z_m()}};
        r["distance_left_m"] = s.nav_distance_left_m();
        r["eta_s"] = s.nav_eta_s();
        r["local_planner_status"] = s.local_planner_status();
        r["pose"] = {{"x_m", p.x_m()}, {"y_m", p.y_m()}, {"z_m", p.z_m()}, {"yaw_rad", yaw}};
        r["speed_mps"] = s.twist_B().linear_x_mps();
        r["in_contact"] = s.in_contact();
        r["control_period_max_ms"] = s.control_period_max_ms();
        r["exploration"] = ExplorationJson(s);
        r["convoy"] = ConvoyJson(s);
        r["yield"] = {{"state", s.yield_state()},
                      {"peer", s.yield_peer_id()},
                      {"reason", s.yield_reason()},
                      {"for", RobotWhoseRoutePasses(robots, v, 1.5)}};
        const std::uint64_t state_ns = s.stamp().sec() < 0
                                           ? 0
                                           : static_cast<std::uint64_t>(s.stamp().sec()) * 1000000000ULL +
                                                 std::min<std::uint64_t>(s.stamp().nanosec(), 999999999ULL);
        const double received_ago_s = core::SecondsBetween(v.state_received, now);
        r["state_stamp"] = Stamp(state_ns);
        r["received_stamp"] =
            Stamp(ns - std::min<std::uint64_t>(
                           ns, static_cast<std::uint64_t>(std::max(0.0, received_ago_s) * 1e9)));
        // The pose at the time the robot stamped it (a peer's stamp in the future or far past: ours).
        const bool stamp_plausible =
            state_ns > 0 && state_ns <= ns + 1000000000ULL && ns - std::min(ns, state_ns) < 3600000000000ULL;
        tf["transforms"].push_back(RobotTransform(v.robot_id, s, stamp_plausible ? state_ns : ns));
        json e = RobotEntity(v, s, ns);
        scene["entities"].push_back(e);
        UpdateTrail(v.robot_id, p.x_m(), p.y_m(), p.z_m());
      } else {
        r["mode"] = "";
        r["holder"] = "";
        r["you_hold"] = false;
        r["nav_status"] = "none";
      }
      fleet["robots"].push_back(r);
    }
    server_->Publish(fleet_, ns, fleet.dump());
    if (!tf["transforms"].empty()) server_->Publish(tf_, ns, tf.dump());
    server_->Publish(robots_, ns, scene.dump());
  }

  // The robot's agent's components as its health monitor judges them (Health tab).
  static json ComponentsJson(const RobotView& v) {
    json components = json::array();
    if (!v.health) return components;
    for (const auto& c : v.health->components()) {
      components.push_back({{"name", c.name()},
                            {"state", c.state()},
                            {"loop_rate_hz", c.loop_rate_hz()},
                            {"target_rate_hz", c.target_rate_hz()},
                            {"cpu_percent", c.cpu_percent()},
                            {"restarts", c.restarts()},
                            {"restart_in_s", c.restart_in_s()},
                            {"last_error", c.last_error()},
                            {"degraded", c.degraded()}});
    }
    return components;
  }

  // map -> the robot's base, stamped `stamp_ns` (/tf).
  static json RobotTransform(const std::string& robot_id, const cairn_msgs::RobotState& s,
                             std::uint64_t stamp_ns) {
    const auto& p = s.pose_MB().position();
    return {{"timestamp", Stamp(stamp_ns)},
            {"parent_frame_id", "map"},
            {"child_frame_id", robot_id},
            {"translation", Vec3(p.x_m(), p.y_m(), p.z_m())},
            {"rotation",
             {{"x", s.pose_MB().orientation().x()},
              {"y", s.pose_MB().orientation().y()},
              {"z", s.pose_MB().orientation().z()},
              {"w", s.pose_MB().orientation().w()}}}};
  }

  // The robot's body in the 3D view: a box in the robot's colour, a heading arrow and a label.
  json RobotEntity(const RobotView& v, const cairn_msgs::RobotState& s, std::uint64_t ns) {
    const auto& p = s.pose_MB().position();
    const double yaw = YawOf(s.pose_MB().orientation());
    double cr = 0, cg = 0, cb = 0;
    palette_.RgbOf(v.robot_id, &cr, &cg, &cb);
    const double alpha = v.lost ? 0.35 : 1.0;
    json e = Entity("robot/" + v.robot_id, ns);
    e["cubes"].push_back(
        Cube(p.x_m(), p.y_m(), p.z_m() + 0.2, yaw, 0.7, 0.5, 0.35, Color(cr, cg, cb, alpha)));
    e["arrows"].push_back({{"pose", PoseJson(p.x_m(), p.y_m(), p.z_m() + 0.45, yaw)},
                           {"shaft_length", 0.45},
                           {"shaft_diameter", 0.06},
                           {"head_length", 0.2},
                           {"head_diameter", 0.16},
                           {"color", Color(1, 1, 1, alpha)}});
    const std::string holder = s.holder_id().empty() ? "free" : "held by " + s.holder_id();
    e["texts"].push_back(
        {{"pose", PoseJson(p.x_m(), p.y_m(), p.z_m() + 0.9, 0)},
         {"billboard", true},
         {"font_size", 14.0},
         {"scale_invariant", true},
         {"color", Color(1, 1, 1, 1)},
         {"text", v.robot_id + " · " + s.mode() + " · " + holder + (v.lost ? " · LOST" : "")}});
    e["metadata"].push_back({{"key", "holder"}, {"value", s.holder_id()}});
    e["metadata"].push_back({{"key", "mode"}, {"value", s.mode()}});
    return e;
  }

  void UpdateTrail(const std::string& id, double x, double y, double z) {
    auto& trail = trails_[id];
    const auto now = Clock::now();
    if (trail.empty() || std::hypot(trail.back().p[0] - x, trail.back().p[1] - y) > 0.2)
      trail.push_back({{x, y, z + 0.05}, now});
    while (!trail.empty() && std::chrono::duration<double>(now - trail.front().t).count() > options_.trail_s)
      trail.pop_front();
  }

  // Global paths, local plans, goals, exploration targets and trails: changed ones to every subscriber, or
  // all to `only`.
  void PublishPaths(const std::vector<RobotView>& robots, std::uint64_t ns,
                    std::optional<FoxgloveServer::ClientId> only) {
    json scene = {{"deletions", json::array()}, {"entities", json::array()}};
    for (const RobotView& v : robots) {
      if (!v.state) continue;
      json e = Entity("path/" + v.robot_id, ns);
      const auto& s = *v.state;
      // Everything of one robot in its colour: the path solid and thick (seen at overview zoom), the local
      // plan lighter, the trail faint.
      double cr = 0, cg = 0, cb = 0;
      palette_.RgbOf(v.robot_id, &cr, &cg, &cb);
      if (v.global_path && s.nav_status() == cairn_msgs::NAV_STATUS_ACTIVE &&
          !v.global_path->path_M().empty()) {
        std::vector<std::array<double, 3>> pts;
        for (const auto& p : v.global_path->path_M()) pts.push_back({p.x_m(), p.y_m(), p.z_m() + 0.1});
        e["lines"].push_back(LineStrip(pts, 0.15, Color(cr, cg, cb, 0.95)));
        const auto& g = s.nav_goal_M();
        e["spheres"].push_back({{"pose", PoseJson(g.x_m(), g.y_m(), g.z_m() + 0.15, 0)},
                                {"size", Vec3(0.3, 0.3, 0.3)},
                                {"color", Color(cr, cg, cb, 0.95)}});
      }
      if (s.explore_has_target() && s.explore_state() == fleet::explore_state::kExploring) {
        // The frontier the robot explores toward: a sphere on a 1 m post.
        const auto& t = s.explore_target_M();
        e["lines"].push_back(LineStrip({{t.x_m(), t.y_m(), t.z_m()}, {t.x_m(), t.y_m(), t.z_m() + 1.0}}, 0.08,
                                       Color(cr, cg, cb, 0.9)));
        e["spheres"].push_back({{"pose", PoseJson(t.x_m(), t.y_m(), t.z_m() + 1.0, 0)},
                                {"size", Vec3(0.35, 0.35, 0.35)},
                                {"color", Color(cr, cg, cb, 0.95)}});
      }
      if (v.local_plan && !v.local_plan->chosen_path_B().empty()) {
        const auto& lp = *v.local_plan;
        const double yaw = YawOf(lp.pose_MB().orientation());
        const auto& o = lp.pose_MB().position();
        std::vector<std::array<double, 3>> pts;
        for (const auto& p : lp.chosen_path_B()) {
          pts.push_back({o.x_m() + std::cos(yaw) * p.x_m() - std::sin(yaw) * p.y_m(),
                         o.y_m() + std::sin(yaw) * p.x_m() + std::cos(yaw) * p.y_m(), o.z_m() + 0.12});
        }
        e["lines"].push_back(LineStrip(pts, 0.08, Color(0.5 + cr / 2, 0.5 + cg / 2, 0.5 + cb / 2, 0.9)));
      }
      const auto trail = trails_.find(v.robot_id);
      if (trail != trails_.end() && trail->second.size() >= 2) {
        std::vector<std::array<double, 3>> pts;
        for (const auto& t : trail->second) pts.push_back(t.p);
        e["lines"].push_back(LineStrip(pts, 0.05, Color(cr, cg, cb, 0.45)));
      }
      const std::string text = e["lines"].dump() + e["spheres"].dump();
      if (!only) {
        auto& last = last_paths_[v.robot_id];
        if (last == text) continue;
        last = text;
      }
      scene["entities"].push_back(e);
    }
    if (scene["entities"].empty()) return;
    Send(paths_, ns, scene.dump(), only);
  }

  // To every subscriber of `channel`, or to `only` (a new subscriber's snapshot).
  void Send(std::uint32_t channel, std::uint64_t ns, const std::string& payload,
            std::optional<FoxgloveServer::ClientId> only) {
    if (only) {
      server_->SendTo(*only, channel, ns, payload);
    } else {
      server_->Publish(channel, ns, payload);
    }
  }

  void PublishCameras(const std::vector<RobotView>& robots, std::uint64_t ns) {
    for (const RobotView& v : robots) {
      auto channel = cameras_.find(v.robot_id);
      if (channel == cameras_.end()) {
        ChannelSpec spec;
        spec.topic = "/" + v.robot_id + "/camera";
        spec.schema_name = "foxglove.CompressedImage";
        spec.schema = image_schema_;
        channel = cameras_.emplace(v.robot_id, Camera{server_->AddChannel(spec), 0}).first;
      }
      const auto frame = client_.perception().LatestFrame(v.robot_id);
      if (!frame || frame->frames_received == channel->second.frames_sent) continue;
      channel->second.frames_sent = frame->frames_received;
      if (!server_->HasSubscribers(channel->second.id)) continue;
      const auto& data = frame->frame.data();
      const json image = {
          {"timestamp", {{"sec", frame->frame.stamp().sec()}, {"nsec", frame->frame.stamp().nanosec()}}},
          {"frame_id", v.robot_id + "/camera"},
          {"data", Base64(data)},
          {"format", frame->frame.format()}};
      server_->Publish(channel->second.id, ns, image.dump());
    }
  }

  static std::string Base64(const std::vector<std::uint8_t>& bytes) {
    static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((bytes.size() + 2) / 3 * 4);
    for (std::size_t i = 0; i < bytes.size(); i += 3) {
      const std::uint32_t n = (static_cast<std::uint32_t>(bytes[i]) << 16) |
                              (i + 1 < bytes.size() ? static_cast<std::uint32_t>(bytes[i + 1]) << 8 : 0) |
                              (i + 2 < bytes.size() ? static_cast<std::uint32_t>(bytes[i + 2]) : 0);
      out.push_back(k[(n >> 18) & 63]);
      out.push_back(k[(n >> 12) & 63]);
      out.push_back(i + 1 < bytes.size() ? k[(n >> 6) & 63] : '=');
      out.push_back(i + 2 < bytes.size() ? k[n & 63] : '=');
    }
    return out;
  }

  // An operator event as a foxglove.Log stamped with the event's own time.
  static std::string LogPayload(const OperatorEvent& e) {
    const auto t = std::chrono::duration_cast<std::chrono::nanoseconds>(e.time.time_since_epoch()).count();
    return json{{"timestamp", Stamp(static_cast<std::uint64_t>(t))},
                {"level", LogLevel(e.kind)},
                {"message", e.message},
                {"name", e.kind + (e.robot_id.empty() ? "" : "/" + e.robot_id)},
                {"file", ""},
                {"line", 0}}
        .dump();
  }

  void PublishEvents(std::uint64_t ns) {
    for (const OperatorEvent& e : client_.EventsSince(&event_cursor_))
      server_->Publish(events_, ns, LogPayload(e));
  }

  // The events the FleetClient keeps that went out before, each with its own time, to a new /events
  // subscriber (a GUI opened late still lists the staircases found and robots lost before it). One it also
  // got live is sent twice: the Cairn GUI drops it (same time, name and message).
  void ReplayEvents(std::uint64_t ns, FoxgloveServer::ClientId client) {
    for (const OperatorEvent& e : client_.RecentEvents()) {
      if (e.seq <= event_cursor_) server_->SendTo(client, events_, ns, LogPayload(e));
    }
  }

  // The named places (the places file, which other consoles also write): a post and its name each, every
  // two seconds when the file changed, or all to `only`. A file that cannot be read keeps the last ones.
  void PublishPlaces(std::uint64_t ns, std::optional<FoxgloveServer::ClientId> only) {
    if (options_.places_file.empty()) return;
    // Read again only when the file changed (or for a new subscriber, who gets all of them).
    std::error_code no_file;
    const auto written = std::filesystem::last_write_time(options_.places_file, no_file);
    if (!only && !no_file && places_read_ && written == places_written_) return;
    std::vector<Place> places;
    try {
      places = Places::Load(options_.places_file).All();
    } catch (const std::exception& e) {
      if (places_error_ != e.what()) spdlog::warn("GUI: places not updated: {}", e.what());
      places_error_ = e.what();
      return;
    }
    places_error_.clear();
    if (!only) {  // what every subscriber was sent (a new subscriber's read must not hide a change from the
                  // rest)
      places_read_ = !no_file;
      places_written_ = written;
    }
    json scene = {{"deletions", json::array()}, {"entities", json::array()}};
    std::set<std::string> names;
    for (const Place& place : places) {
      names.insert(place.name);
      json e = Entity("place/" + place.name, ns);
      e["lines"].push_back(
          LineStrip({{place.x_m, place.y_m, place.z_m}, {place.x_m, place.y_m, place.z_m + 1.5}}, 0.04,
                    Color(0.85, 0.88, 0.92, 0.7)));
      e["texts"].push_back({{"pose", PoseJson(place.x_m, place.y_m, place.z_m + 1.6, 0)},
                            {"billboard", true},
                            {"font_size", 12.0},
                            {"scale_invariant", true},
                            {"color", Color(0.85, 0.88, 0.92, 1)},
                            {"text", place.name}});
      scene["entities"].push_back(e);
    }
    // What changed is the places themselves (the entities also carry this period's time stamp).
    std::string text;
    for (const Place& place : places)
      text += place.name + " " + std::to_string(place.x_m) + " " + std::to_string(place.y_m) + " " +
              std::to_string(place.z_m) + "\n";
    if (!only) {
      if (text == places_sent_) return;
      for (const std::string& name : places_shown_)
        if (names.count(name) == 0) scene["deletions"].push_back(Deletion("place/" + name, ns));
      places_sent_ = text;
      places_shown_ = names;
    }
    if (scene["entities"].empty() && scene["deletions"].empty()) return;
    Send(places_, ns, scene.dump(), only);
  }

  void PublishStairs(std::uint64_t ns, std::optional<FoxgloveServer::ClientId> only) {
    const auto entries = client_.perception().Staircases();
    json scene = {{"deletions", json::array()}, {"entities", json::array()}};
    for (const auto& entry : entries) {
      const perception::Staircase& st = entry.staircase;
      json e = Entity("stairs/" + std::to_string(entry.id), ns);
      const double c = std::cos(st.yaw_rad), s = std::sin(st.yaw_rad);
      for (int k = 1; k <= st.num_steps; ++k) {
        // Step k: a block from the floor to k rises, one run deep, centred across the width.
        const double along = (k - 0.5) * st.run_m;
        const double h = k * st.rise_m;
        e["cubes"].push_back(Cube(st.p_W_first_step.x() + c * along, st.p_W_first_step.y() + s * along,
                                  st.p_W_first_step.z() + h / 2, st.yaw_rad, st.run_m, st.width_m, h,
                                  Color(1.0, 0.78, 0.1, 0.55)));
      }
      std::string sources;
      for (const auto& src : entry.sources) sources += (sources.empty() ? "" : ", ") + src;
      e["texts"].push_back({{"pose", PoseJson(st.p_W_first_step.x(), st.p_W_first_step.y(),
                                              st.p_W_first_step.z() + st.num_steps * st.rise_m + 0.5, 0)},
                            {"billboard", true},
                            {"font_size", 12.0},
                            {"scale_invariant", true},
                            {"color", Color(1.0, 0.85, 0.3, 1)},
                            {"text", "staircase " + std::to_string(entry.id) + ": " +
                                         std::to_string(st.num_steps) + " steps (seen by " + sources + ")"}});
      scene["entities"].push_back(e);
    }
    if (only) {
      if (!entries.empty()) Send(stairs_, ns, scene.dump(), only);
      return;
    }
    // A staircase merged into another or removed: its id is retired, its steps go from every view.
    std::set<int> shown;
    for (const auto& entry : entries) shown.insert(entry.id);
    for (const int id : stairs_shown_) {
      if (shown.count(id) == 0) scene["deletions"].push_back(Deletion("stairs/" + std::to_string(id), ns));
    }
    stairs_shown_ = std::move(shown);
    std::string text = scene.dump();
    if (text == last_stairs_) return;
    last_stairs_ = text;
    Send(stairs_, ns, text, only);
  }

  // The fleet map's occupied voxels by 4 x 4 m column: changed columns to every subscriber, or every column
  // to `only` (a new subscriber).
  void PublishMap(std::uint64_t ns, std::optional<FoxgloveServer::ClientId> only) {
    const double res = client_.perception().MapResolution();
    if (!(res > 0)) return;
    if (only) {
      SendAllColumns(ns, *only);
    } else {
      PublishChangedColumns(MapColumns(res), ns);
    }
  }

  // The occupied voxels as scene cubes (JSON, coloured by height), by column.
  std::map<std::pair<int, int>, std::string> MapColumns(double res) const {
    std::map<std::pair<int, int>, std::string> chunks;
    for (const perception::CoarseVoxel& v : client_.perception().MapVoxels()) {
      if (v.state != perception::CoarseState::kOccupied) continue;
      const std::pair<int, int> key{FloorDiv(v.ix, kChunkVoxels), FloorDiv(v.iy, kChunkVoxels)};
      std::string& cubes = chunks[key];
      double r = 0, g = 0, b = 0;
      const double x = (v.ix + 0.5) * res, y = (v.iy + 0.5) * res, z = (v.iz + 0.5) * res;
      HeightColor(z, &r, &g, &b);
      char buf[256];
      std::snprintf(
          buf, sizeof(buf),
          "%s{\"pose\":{\"position\":{\"x\":%.2f,\"y\":%.2f,\"z\":%.2f},\"orientation\":{\"x\":0,\"y\":0,"
          "\"z\":0,\"w\":1}},\"size\":{\"x\":%.3f,\"y\":%.3f,\"z\":%.3f},\"color\":{\"r\":%.2f,\"g\":%.2f,"
          "\"b\":%.2f,\"a\":1}}",
          cubes.empty() ? "" : ",", x, y, z, res, res, res, r, g, b);
      cubes += buf;
    }
    return chunks;
  }

  void PublishChangedColumns(const std::map<std::pair<int, int>, std::string>& chunks, std::uint64_t ns) {
    // The link budget (GuiOptions::map_budget_kBps): a token bucket filled at the budget, holding at most
    // two seconds of it. Columns never sent go first (new ground shows at once), then changed ones, least
    // recently sent first, each at most every map_resend_s: a map that keeps changing as robots drive costs
    // the budget, not every change; what waits goes out at a later period.
    const auto now = Clock::now();
    const double budget_Bps = options_.map_budget_kBps * 1000.0;
    const double dt = map_tokens_at_ == Clock::time_point{}
                          ? 2.0
                          : std::chrono::duration<double>(now - map_tokens_at_).count();
    map_tokens_at_ = now;
    map_tokens_ = std::min(2.0 * budget_Bps, map_tokens_ + dt * budget_Bps);
    // Each changed column with when it was last sent (never: the epoch, so it sorts first).
    struct Changed {
      std::pair<int, int> key;
      const std::string* cubes;
      Clock::time_point sent_at;
    };
    std::vector<Changed> changed;
    for (const auto& [key, cubes] : chunks) {
      const auto sent = map_sent_.find(key);
      if (sent == map_sent_.end()) {
        changed.push_back({key, &cubes, Clock::time_point{}});
      } else if (sent->second.cubes != cubes &&
                 std::chrono::duration<double>(now - sent->second.sent_at).count() >= options_.map_resend_s) {
        changed.push_back({key, &cubes, sent->second.sent_at});
      }
    }
    std::stable_sort(changed.begin(), changed.end(),
                     [](const Changed& a, const Changed& b) { return a.sent_at < b.sent_at; });
    std::vector<std::string> entities, deletions;
    for (const Changed& c : changed) {
      if (map_tokens_ <= 0) {
        std::lock_guard<std::mutex> lock(mutex_);
        stats_.map_chunks_deferred += 1;
        continue;
      }
      entities.push_back(ChunkEntity(c.key, *c.cubes, ns));
      map_tokens_ -= static_cast<double>(entities.back().size());
      map_sent_[c.key] = {*c.cubes, now};
    }
    for (auto it = map_sent_.begin(); it != map_sent_.end();) {
      if (chunks.count(it->first)) {
        ++it;
        continue;
      }
      deletions.push_back(Deletion(ChunkId(it->first), ns).dump());
      it = map_sent_.erase(it);
    }
    // At most ~64 columns per message so that no single frame grows past a few MB.
    for (std::size_t i = 0; i < std::max<std::size_t>(entities.size(), deletions.empty() ? 0 : 1); i += 64) {
      std::string msg = "{\"deletions\":[";
      if (i == 0) msg += Join(deletions);
      msg += "],\"entities\":[";
      const std::size_t end = std::min(entities.size(), i + 64);
      msg += Join(std::vector<std::string>(
          entities.begin() + static_cast<std::ptrdiff_t>(std::min(i, entities.size())),
          entities.begin() + static_cast<std::ptrdiff_t>(end)));
      msg += "]}";
      server_->Publish(map_, ns, msg);
      std::lock_guard<std::mutex> lock(mutex_);
      stats_.map_chunks_sent += end - std::min(i, end);
    }
  }

  // Every column sent so far, to a new subscriber.
  void SendAllColumns(std::uint64_t ns, FoxgloveServer::ClientId only) {
    std::vector<std::string> entities;
    for (const auto& [key, sent] : map_sent_) entities.push_back(ChunkEntity(key, sent.cubes, ns));
    for (std::size_t i = 0; i < entities.size(); i += 64) {
      const std::size_t end = std::min(entities.size(), i + 64);
      server_->SendTo(
          only, map_, ns,
          "{\"deletions\":[],\"entities\":[" +
              Join(std::vector<std::string>(entities.begin() + static_cast<std::ptrdiff_t>(i),
                                            entities.begin() + static_cast<std::ptrdiff_t>(end))) +
              "]}");
    }
  }

  static int FloorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
  static std::string ChunkId(const std::pair<int, int>& key) {
    return "map/" + std::to_string(key.first) + "/" + std::to_string(key.second);
  }
  static std::string ChunkEntity(const std::pair<int, int>& key, const std::string& cubes, std::uint64_t ns) {
    json e = Entity(ChunkId(key), ns);
    e.erase("cubes");
    std::string text = e.dump();
    text.pop_back();  // '}'
    return text + ",\"cubes\":[" + cubes + "]}";
  }
  static std::string Join(const std::vector<std::string>& parts) {
    std::string out;
    for (const std::string& p : parts) out += (out.empty() ? "" : ",") + p;
    return out;
  }

  struct TrailPoint {
    std::array<double, 3> p;
    Clock::time_point t;
  };
  struct Camera {
    std::uint32_t id = 0;
    std::uint64_t frames_sent = 0;
  };

  FleetClient& client_;
  GuiOptions options_;
  std::unique_ptr<FoxgloveServer> server_;
  std::string scene_schema_, image_schema_;
  std::uint32_t fleet_ = 0, tf_ = 0, robots_ = 0, paths_ = 0, stairs_ = 0, map_ = 0, events_ = 0;
  std::uint32_t places_ = 0;
  std::uint32_t command_table_ = 0;
  std::uint32_t command_service_ = 0;
  std::ostringstream shell_out_;
  std::unique_ptr<CommandShell> shell_;
  // Publisher thread only.
  std::map<std::string, Camera> cameras_;
  std::map<std::string, std::deque<TrailPoint>> trails_;
  std::map<std::string, std::string> last_paths_;
  std::string last_stairs_;
  RobotPalette palette_;
  std::string places_sent_;             // the places as last sent to every subscriber
  std::set<std::string> places_shown_;  // their names
  std::string places_error_;            // why the file was last unreadable (warned once)
  bool places_read_ = false;            // places_written_ is the file's time when it was last read
  std::filesystem::file_time_type places_written_;
  std::set<int> stairs_shown_;  // fleet staircase ids last sent to every subscriber
  struct SentColumn {
    std::string cubes;  // the column's cubes as last sent
    Clock::time_point sent_at;
  };
  std::map<std::pair<int, int>, SentColumn> map_sent_;
  double map_tokens_ = 0;  // bytes the map may send now (token bucket)
  Clock::time_point map_tokens_at_{};
  Clock::time_point last_map_{};
  std::uint64_t event_cursor_ = 0;
  // Shared.
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::vector<Snapshot> snapshots_;
  std::deque<std::pair<std::vector<std::string>, FoxgloveServer::Responder>> commands_;
  GuiStats stats_;
  std::thread publisher_;
  std::thread commander_;
};

GuiBridge::GuiBridge(FleetClient& client, const GuiOptions& options)
    : impl_(std::make_unique<Impl>(client, options)) {}
GuiBridge::~GuiBridge() = default;
std::string GuiBridge::url() const { return impl_->url(); }
GuiStats GuiBridge::Stats() const { return impl_->Stats(); }

}  // namespace cairn::base
