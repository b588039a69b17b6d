#include "cairn/agent/journal.h"

#include <fcntl.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "cairn/core/peer_input.h"

namespace cairn::agent {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

constexpr int kVersion = 1;
constexpr const char* kMapFile = "map.bt";
constexpr double kPoseStepM = 0.25;
constexpr double kPoseStepRad = 0.2;
constexpr double kPoseRefreshS = 5.0;

double SteadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// fsync of a file or folder; false when it cannot be opened or synced.
bool Sync(const std::string& path, bool folder) {
  const int fd = ::open(path.c_str(), folder ? (O_RDONLY | O_DIRECTORY) : O_RDONLY);
  if (fd < 0) return false;
  const bool ok = ::fsync(fd) == 0;
  ::close(fd);
  return ok;
}

json ToJson(const JournalEntry& e) {
  json j = {{"version", kVersion},
            {"robot_id", e.robot_id},
            {"holder_id", e.holder_id},
            {"mode", e.mode},
            {"pose_M", {{"x_m", e.x_m}, {"y_m", e.y_m}, {"z_m", e.z_m}, {"yaw_rad", e.yaw_rad}}},
            {"map_file", e.map_file}};
  if (e.has_goal) {
    j["goal"] = {{"goal_id", e.goal_id},
                 {"x_m", e.goal_x_m},
                 {"y_m", e.goal_y_m},
                 {"z_m", std::isnan(e.goal_z_m) ? json(nullptr) : json(e.goal_z_m)},
                 {"tolerance_m", e.goal_tolerance_m}};
  } else {
    j["goal"] = nullptr;
  }
  return j;
}

// The finite number at `key` of `object` (named `where` in errors), within +-limit.
double Number(const json& object, const std::string& key, const std::string& where, double limit = 1e6) {
  if (!object.contains(key) || !object[key].is_number()) {
    throw std::invalid_argument(where + "." + key + " is missing or not a number");
  }
  const double v = object[key].get<double>();
  if (!std::isfinite(v) || std::abs(v) > limit) {
    throw std::invalid_argument(where + "." + key + " = " + std::to_string(v) + " must be finite, within +-" +
                                std::to_string(limit));
  }
  return v;
}

std::string Text(const json& object, const std::string& key) {
  if (!object.contains(key) || !object[key].is_string()) {
    throw std::invalid_argument(key + " is missing or not a string");
  }
  return object[key].get<std::string>();
}

}  // namespace

bool JournalEntry::SameStateAs(const JournalEntry& o) const {
  const auto same = [](double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); };
  return robot_id == o.robot_id && holder_id == o.holder_id && mode == o.mode && has_goal == o.has_goal &&
         goal_id == o.goal_id && goal_x_m == o.goal_x_m && goal_y_m == o.goal_y_m &&
         same(goal_z_m, o.goal_z_m) && goal_tolerance_m == o.goal_tolerance_m && map_file == o.map_file;
}

std::string JournalFile(const std::string& dir) { return (fs::path(dir) / "journal.json").string(); }

std::optional<JournalEntry> ReadJournal(const std::string& dir, const std::string& robot_id) {
  const std::string path = JournalFile(dir);
  std::error_code ec;
  if (!fs::exists(path, ec)) return std::nullopt;
  try {
    std::ifstream in(path);
    if (!in) throw std::invalid_argument("it cannot be read");
    const json j = json::parse(in);  // throws json::parse_error naming the byte
    if (!j.is_object()) throw std::invalid_argument("it is not a JSON object");
    if (!j.contains("version") || j["version"] != kVersion) {
      throw std::invalid_argument("version " +
                                  (j.contains("version") ? j["version"].dump() : std::string("missing")) +
                                  " is not " + std::to_string(kVersion));
    }
    JournalEntry e;
    e.robot_id = Text(j, "robot_id");
    if (e.robot_id != robot_id) {
      throw std::invalid_argument("it is robot '" + e.robot_id.substr(0, 64) + "''s, not " + robot_id + "'s");
    }
    e.holder_id = Text(j, "holder_id");
    if (!e.holder_id.empty()) {
      if (const std::string why = core::CheckId("holder_id", e.holder_id); !why.empty()) {
        throw std::invalid_argument(why);
      }
    }
    e.mode = Text(j, "mode");
    if (e.mode.size() > 64) throw std::invalid_argument("mode is longer than 64 characters");
    if (!j.contains("pose_M") || !j["pose_M"].is_object()) throw std::invalid_argument("pose_M is missing");
    e.x_m = Number(j["pose_M"], "x_m", "pose_M");
    e.y_m = Number(j["pose_M"], "y_m", "pose_M");
    e.z_m = Number(j["pose_M"], "z_m", "pose_M");
    e.yaw_rad = Number(j["pose_M"], "yaw_rad", "pose_M", 10.0);
    if (j.contains("goal") && j["goal"].is_object()) {
      const json& g = j["goal"];
      e.has_goal = true;
      e.goal_id = static_cast<uint32_t>(Number(g, "goal_id", "goal", 4294967295.0));
      e.goal_x_m = Number(g, "x_m", "goal");
      e.goal_y_m = Number(g, "y_m", "goal");
      e.goal_z_m = g.contains("z_m") && g["z_m"].is_null() ? std::nan("") : Number(g, "z_m", "goal");
      e.goal_tolerance_m = Number(g, "tolerance_m", "goal", 1e3);
    } else if (j.contains("goal") && !j["goal"].is_null()) {
      throw std::invalid_argument("goal is neither null nor an object");
    }
    e.map_file = Text(j, "map_file");
    if (!e.map_file.empty()) {
      if (e.map_file != kMapFile)
        throw std::invalid_argument("map_file '" + e.map_file + "' is not " + kMapFile);
      if (!fs::is_regular_file(fs::path(dir) / e.map_file, ec)) {
        throw std::invalid_argument("map_file '" + e.map_file + "' does not exist in " + dir);
      }
    }
    return e;
  } catch (const json::exception& e) {
    throw std::invalid_argument("journal " + path + ": " + e.what());
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("journal " + path + ": " + e.what());
  }
}

JournalWriter::JournalWriter(std::string dir, double map_every_s,
                             std::function<void(const std::string&)> save_map)
    : dir_(std::move(dir)), map_every_s_(map_every_s), save_map_(std::move(save_map)) {
  if (save_map_ && !(map_every_s_ > 0 && std::isfinite(map_every_s_))) {
    throw std::invalid_argument("--journal-map-every " + std::to_string(map_every_s_) + " must be > 0 s");
  }
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (!fs::is_directory(dir_, ec)) throw std::invalid_argument("--journal '" + dir_ + "' cannot be created");
  const std::string probe = (fs::path(dir_) / ".write_test").string();
  if (!std::ofstream(probe)) throw std::invalid_argument("--journal '" + dir_ + "' is not writable");
  fs::remove(probe, ec);
  thread_ = std::thread([this] { Loop(); });
}

JournalWriter::~JournalWriter() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

void JournalWriter::Submit(const JournalEntry& entry) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    pending_ = entry;
  }
  cv_.notify_all();
}

int JournalWriter::writes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return writes_;
}

void JournalWriter::Loop() {
  double next_map_s = SteadySeconds() + (save_map_ ? map_every_s_ : 0.0);
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    cv_.wait_for(lock, std::chrono::milliseconds(200), [this] { return stop_ || pending_.has_value(); });
    const bool stopping = stop_;
    std::optional<JournalEntry> entry = std::move(pending_);
    pending_.reset();
    lock.unlock();
    if (save_map_ && SteadySeconds() >= next_map_s && !stopping) {
      const std::string path = (fs::path(dir_) / kMapFile).string();
      try {
        save_map_(path);
        if (!Sync(path, false)) spdlog::warn("journal: cannot fsync {}", path);
        map_file_ = kMapFile;
        if (!entry && written_) entry = *written_;  // refer to the snapshot now
      } catch (const std::exception& e) {
        spdlog::error("journal: map snapshot to {} failed: {}", path, e.what());
      }
      next_map_s = SteadySeconds() + map_every_s_;
    }
    if (entry) {
      entry->map_file = map_file_;
      WriteEntry(std::move(*entry));
    }
    lock.lock();
    if (stopping) return;
  }
}

void JournalWriter::WriteEntry(JournalEntry entry) {
  const double now_s = SteadySeconds();
  if (written_ && entry.SameStateAs(*written_)) {
    const double moved_m = std::hypot(entry.x_m - written_->x_m, entry.y_m - written_->y_m);
    const double turned_rad = std::abs(std::remainder(entry.yaw_rad - written_->yaw_rad, 2 * M_PI));
    const bool pose_changed = moved_m > 0.01 || turned_rad > 0.01;
    if (moved_m <= kPoseStepM && turned_rad <= kPoseStepRad &&
        (!pose_changed || now_s - written_at_s_ < kPoseRefreshS)) {
      return;
    }
  }
  const std::string path = JournalFile(dir_);
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << ToJson(entry).dump(2) << '\n';
    out.close();
    if (!out) {
      spdlog::error("journal: cannot write {}", tmp);
      return;
    }
  }
  if (!Sync(tmp, false) || std::rename(tmp.c_str(), path.c_str()) != 0 || !Sync(dir_, true)) {
    spdlog::error("journal: cannot replace {} atomically", path);
    return;
  }
  written_ = std::move(entry);
  written_at_s_ = now_s;
  std::lock_guard<std::mutex> lock(mutex_);
  ++writes_;
}

}  // namespace cairn::agent
