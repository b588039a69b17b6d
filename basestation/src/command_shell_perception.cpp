// The command shell's map, camera, staircase and path commands (see command_shell.h).
#include <fstream>

#include "cairn/base/command_shell.h"
#include "cairn/base/operator_text.h"
#include "cairn/perception/jpeg.h"
#include "cairn/perception/png.h"
#include "command_table.h"
#include "shell_util.h"

namespace cairn::base {

namespace msgs = cairn_msgs;
using nlohmann::json;
using shell::Dump;
using shell::Fixed;
using shell::ParseNumber;
using shell::PointsJson;
using shell::PointsText;
using shell::StaircaseJson;

int CommandShell::Map(const std::vector<std::string>& args) {
  const std::string& target = args[0];
  const std::string& path = args[2];
  if (target != "fleet" && RefuseUnknown("map", target)) return kRefused;
  if (path.size() < 4 || path.substr(path.size() - 3) != ".bt") {
    return UsageError("map", "FILE '" + path + "' must end in .bt (OctoMap binary)");
  }
  const MapSaveResult r = client_.perception().SaveMap(target, path, /*sync_timeout_s=*/10.0);
  if (json_) {
    json j = {{"command", "map"},
              {"target", target},
              {"ok", r.ok},
              {"result", r.ok ? outcome::kAccepted : outcome::kFailed},
              {"file", path}};
    if (r.ok) {
      j["voxels"] = r.voxels;
      j["occupied"] = r.occupied;
      j["resolution_m"] = r.resolution_m;
    } else {
      j["reason"] = r.error;
    }
    out_ << Dump(j) << std::endl;
  } else if (r.ok) {
    out_ << "map " << target << ": " << r.voxels << " voxels (" << r.occupied << " occupied) at "
         << Fixed(r.resolution_m, 2) << " m saved to " << path << std::endl;
  } else {
    out_ << "map " << target << ": " << outcome::kFailed << ": " << r.error << std::endl;
  }
  return r.ok ? kOk : kRefused;
}

int CommandShell::Snapshot(const std::vector<std::string>& args) {
  const std::string& robot = args[0];
  const std::string& path = args[1];
  if (RefuseUnknown("snapshot", robot)) return kRefused;
  auto ends_with = [&](const std::string& suffix) {
    return path.size() > suffix.size() &&
           path.compare(path.size() - suffix.size(), suffix.size(), suffix) == 0;
  };
  const bool png = ends_with(".png") || ends_with(".PNG");
  if (!png && !ends_with(".jpg") && !ends_with(".jpeg") && !ends_with(".JPG") && !ends_with(".JPEG")) {
    return UsageError("snapshot", "FILE '" + path + "' must end in .jpg, .jpeg (the camera's JPEG) or .png");
  }
  double timeout_s = 5.0;
  std::string error;
  if (args.size() == 3 &&
      (!ParseNumber(args[2], "TIMEOUT_S", &timeout_s, &error) || timeout_s <= 0 || timeout_s > 600)) {
    return UsageError("snapshot", error.empty() ? "TIMEOUT_S '" + args[2] + "' must be in (0, 600]" : error);
  }
  // The next frame, so that the picture is from now, not from whenever the last one arrived.
  const auto latest = client_.perception().LatestFrame(robot);
  const auto view = client_.perception().WaitForFrame(robot, latest ? latest->frames_received : 0, timeout_s);
  auto fail = [&](const std::string& reason) {
    CommandOutcome o;
    o.result = outcome::kFailed;
    o.reason = reason;
    return Report("snapshot", robot, o);
  };
  if (!view) {
    return fail("no camera frame from robot " + robot + " within " + Fixed(timeout_s, 1) +
                " s (unknown robot, camera off, or frames dropped on a saturated link)");
  }
  std::vector<std::uint8_t> data = view->frame.data();
  if (png) {
    try {
      data = perception::EncodeGrayPng(perception::DecodeGrayJpeg(data));
    } catch (const perception::JpegError& e) {
      return fail("frame " + std::to_string(view->frame.seq()) + " cannot be converted to PNG: " + e.what());
    }
  }
  std::ofstream file(path, std::ios::binary);
  file.write(reinterpret_cast<const char*>(data.data()), static_cast<std::streamsize>(data.size()));
  file.close();
  if (!file) return fail("cannot write '" + path + "'");
  const auto& p = view->frame.pose_MC().position();
  if (json_) {
    out_ << Dump(json{{"command", "snapshot"},
                      {"robot", robot},
                      {"ok", true},
                      {"result", outcome::kAccepted},
                      {"file", path},
                      {"format", png ? "png" : "jpeg"},
                      {"bytes", data.size()},
                      {"width_px", view->frame.width_px()},
                      {"height_px", view->frame.height_px()},
                      {"seq", view->frame.seq()},
                      {"frames_missed", view->frames_missed},
                      {"x_m", p.x_m()},
                      {"y_m", p.y_m()},
                      {"z_m", p.z_m()}})
         << std::endl;
  } else {
    out_ << "snapshot " << robot << ": frame " << view->frame.seq() << ", " << view->frame.width_px() << "x"
         << view->frame.height_px() << (png ? " PNG, " : " JPEG, ") << data.size() << " bytes, camera at ("
         << Fixed(p.x_m(), 2) << ", " << Fixed(p.y_m(), 2) << ", " << Fixed(p.z_m(), 2) << ") saved to "
         << path << std::endl;
  }
  return kOk;
}

int CommandShell::Stairs() {
  const auto entries = client_.perception().Staircases();
  if (json_) {
    json list = json::array();
    for (const auto& e : entries) list.push_back(StaircaseJson(e));
    out_ << Dump(json{
                {"command", "stairs"}, {"ok", true}, {"result", outcome::kAccepted}, {"staircases", list}})
         << std::endl;
    return kOk;
  }
  if (entries.empty()) {
    out_ << "stairs: none found" << std::endl;
    return kOk;
  }
  for (const auto& e : entries) {
    out_ << "staircase " << e.id << ": " << DescribeStaircase(e) << ", confidence "
         << Fixed(e.staircase.confidence, 2) << std::endl;
  }
  return kOk;
}

int CommandShell::Path(const std::vector<std::string>& args) {
  const std::string& robot = args[0];
  if (RefuseUnknown("path", robot)) return kRefused;
  // The path is latched: a fresh basestation receives it shortly after discovery. After this shell's own
  // goto, wait for that goal's path.
  const uint32_t goal_id = last_goal_id_.count(robot) ? last_goal_id_[robot] : 0;
  auto view = client_.WaitUntil(robot, 3.0, [goal_id](const RobotView& v) {
    return v.global_path.has_value() && (goal_id == 0 || v.global_path->goal_id() == goal_id ||
                                         (v.state && v.state->nav_goal_id() == goal_id &&
                                          v.state->nav_status() != msgs::NAV_STATUS_ACTIVE));
  });
  if (!view) view = client_.Robot(robot);
  if (view && !view->global_path) view.reset();
  if (!view) {
    CommandOutcome o;
    o.result = outcome::kRefused;
    o.reason = client_.Robot(robot) ? "robot " + robot + " has published no global path"
                                    : client_.UnknownRobotReason(robot);
    return Report("path", robot, o);
  }
  const auto& p = *view->global_path;
  if (json_) {
    out_ << Dump(json{{"command", "path"},
                      {"robot", robot},
                      {"ok", true},
                      {"result", outcome::kAccepted},
                      {"goal_id", p.goal_id()},
                      {"platform", p.platform()},
                      {"frame_id", p.frame_id()},
                      {"length_m", p.length_m()},
                      {"map_version", p.map_version()},
                      {"replans", p.replans()},
                      {"path", PointsJson(p.path_M())}})
         << std::endl;
    return kOk;
  }
  if (p.path_M().empty()) {
    out_ << "path " << robot << ": none (no active goal)" << std::endl;
    return kOk;
  }
  out_ << "path " << robot << ": goal " << ShortId(p.goal_id()) << ", " << Fixed(p.length_m(), 1) << " m, "
       << p.path_M().size() << " waypoints (frame " << p.frame_id() << ", platform " << p.platform()
       << ", map version " << p.map_version() << ", " << p.replans() << " replans)" << std::endl
       << PointsText(p.path_M());
  return kOk;
}

int CommandShell::Plan(const std::vector<std::string>& args) {
  const std::string usage = UsageOf("plan");
  std::vector<std::string> positional;
  std::string platform, from;
  for (std::size_t i = 0; i < args.size(); ++i) {
    if ((args[i] == "--from" || args[i] == "--platform") && i + 1 < args.size()) {
      (args[i] == "--from" ? from : platform) = args[i + 1];
      ++i;
    } else if (args[i].rfind("--", 0) == 0) {
      return UsageError("plan", "unknown or incomplete option '" + args[i] + "'; " + usage);
    } else {
      positional.push_back(args[i]);
    }
  }
  if (positional.size() < 2) return UsageError("plan", usage);
  const std::string& robot = positional[0];
  if (RefuseUnknown("plan", robot)) return kRefused;
  double gx = 0, gy = 0, sx = 0, sy = 0;
  std::string error;
  std::size_t used = 0;
  if (!ParsePoint(positional, 1, &gx, &gy, &used, &error)) return UsageError("plan", error);
  if (1 + used != positional.size()) return UsageError("plan", usage);
  if (!from.empty()) {
    if (!ParsePoint({from}, 0, &sx, &sy, &used, &error)) return UsageError("plan", "--from: " + error);
  } else {
    const auto view = client_.WaitUntil(robot, 3.0, [](const RobotView& v) { return v.state.has_value(); });
    if (!view) {
      CommandOutcome o;
      o.result = outcome::kRefused;
      o.reason = "no state from robot '" + robot + "' to plan from (give --from X,Y)" +
                 DidYouMeanText(robot, client_.RobotIds());
      return Report("plan", robot, o);
    }
    sx = view->state->pose_MB().position().x_m();
    sy = view->state->pose_MB().position().y_m();
  }
  const PathAnswer a = client_.RequestPath(robot, platform, sx, sy, gx, gy);
  if (json_) {
    json j = {{"command", "plan"},  {"robot", robot},     {"ok", a.ok},
              {"result", a.result}, {"reason", a.reason}, {"round_trip_ms", a.round_trip_ms}};
    if (a.result == outcome::kAccepted || a.result == outcome::kRefused) {
      j["status"] = a.response.status();
      j["length_m"] = a.response.length_m();
      j["planning_time_s"] = a.response.planning_time_s();
      j["map_version"] = a.response.map_version();
      j["path"] = PointsJson(a.response.path_M());
    }
    out_ << Dump(j) << std::endl;
  } else if (a.ok) {
    out_ << "plan " << robot << ": path " << Fixed(a.response.length_m(), 1) << " m, "
         << a.response.path_M().size() << " waypoints, planned in "
         << Fixed(a.response.planning_time_s() * 1000.0, 1) << " ms (map version " << a.response.map_version()
         << ")" << std::endl
         << PointsText(a.response.path_M());
  } else {
    out_ << "plan " << robot << ": " << a.result << ": " << a.reason << std::endl;
  }
  return a.ok ? kOk : kRefused;
}

}  // namespace cairn::base
