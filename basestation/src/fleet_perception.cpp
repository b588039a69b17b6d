#include "cairn/base/fleet_perception.h"

#include <spdlog/spdlog.h>

#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "cairn/core/dds.h"
#include "cairn/core/peer_input.h"
#include "cairn/msgs/stamp.h"
#include "cairn_msgsPubSubTypes.h"

namespace cairn::base {

namespace msgs = cairn_msgs;
using core::SteadyClock;

namespace {

constexpr double kSyncRequestPeriodS = 1.0;           // at most one snapshot request per robot per second
constexpr std::size_t kMaxStaircaseInstances = 4096;  // (robot, staircase) reports kept from peers
constexpr std::size_t kMaxStaircaseEvents = 1000;     // untaken events kept; the oldest go first

// Farthest a map coordinate from a robot may be from the map's origin, metres: beyond any site (a staircase
// at x = 1e300 was announced to every operator).
constexpr double kMaxMapCoordinateM = 1e5;

// A robot's detection, checked: false and the fault (the field and its value, the rule) if a field is not
// finite or out of its physical range. The robot id is checked by the caller.
bool ToStaircase(const msgs::StaircaseDetection& m, perception::Staircase* s, std::string* why) {
  const auto in_range = [why](const char* field, double value, double lo, double hi, bool lo_open) {
    if (std::isfinite(value) && (lo_open ? value > lo : value >= lo) && value <= hi) return true;
    std::ostringstream out;
    out << field << " = " << value << " is not in " << (lo_open ? "(" : "[") << lo << ", " << hi << "]";
    *why = out.str();
    return false;
  };
  const auto& p = m.p_M_first_step();
  if (!in_range("p_M_first_step.x_m", p.x_m(), -kMaxMapCoordinateM, kMaxMapCoordinateM, false) ||
      !in_range("p_M_first_step.y_m", p.y_m(), -kMaxMapCoordinateM, kMaxMapCoordinateM, false) ||
      !in_range("p_M_first_step.z_m", p.z_m(), -kMaxMapCoordinateM, kMaxMapCoordinateM, false) ||
      !in_range("yaw_rad", m.yaw_rad(), -10.0, 10.0, false) ||
      !in_range("rise_m", m.rise_m(), 0.0, 1.0, true) || !in_range("run_m", m.run_m(), 0.0, 2.0, true) ||
      !in_range("width_m", m.width_m(), 0.0, 20.0, true) ||
      !in_range("num_steps", m.num_steps(), 1, 500, false) ||
      !in_range("confidence", m.confidence(), 0.0, 1.0, false)) {
    return false;
  }
  s->p_W_first_step = {p.x_m(), p.y_m(), p.z_m()};
  s->yaw_rad = m.yaw_rad();
  s->rise_m = m.rise_m();
  s->run_m = m.run_m();
  s->width_m = m.width_m();
  s->num_steps = m.num_steps();
  s->confidence = m.confidence();
  s->support_points = static_cast<int>(std::min<uint32_t>(m.detections(), 1000000));
  return true;
}

}  // namespace

bool StaircaseFromMessage(const msgs::StaircaseDetection& m, perception::Staircase* staircase,
                          std::string* why) {
  *why = core::CheckId("robot id", m.robot_id());
  return why->empty() && ToStaircase(m, staircase, why);
}

std::string DescribeStaircase(const perception::StaircaseRegistry::Entry& entry) {
  const perception::Staircase& s = entry.staircase;
  char text[256];
  std::snprintf(text, sizeof(text),
                "%d steps at (%.2f, %.2f, %.2f) heading %.0f deg, rise %.3f m, run %.3f m, width %.2f m",
                s.num_steps, s.p_W_first_step.x(), s.p_W_first_step.y(), s.p_W_first_step.z(),
                s.yaw_rad * 180.0 / M_PI, s.rise_m, s.run_m, s.width_m);
  std::string sources;
  for (const auto& source : entry.sources) sources += (sources.empty() ? "" : ", ") + source;
  return std::string(text) + ", seen by " + sources;
}

FleetEvent StaircaseEvent(const StaircaseChange& change) {
  FleetEvent event;
  event.staircase = change.staircase;
  const std::string id = std::to_string(change.staircase.id);
  switch (change.kind) {
    case StaircaseChange::Kind::kNew:
      event.kind = "staircase";
      event.message = "new staircase " + id + ": " + DescribeStaircase(change.staircase);
      break;
    case StaircaseChange::Kind::kMerged:
      event.kind = "staircase_merged";
      event.merged_id = change.merged_id;
      event.message = "staircase " + std::to_string(change.merged_id) + " merged into staircase " + id +
                      " (same flight): " + DescribeStaircase(change.staircase);
      break;
    case StaircaseChange::Kind::kRemoved:
      event.kind = "staircase_removed";
      event.reason = change.reason;
      event.message = "staircase " + id + " removed: " + change.reason + " (was " +
                      DescribeStaircase(change.staircase) + ")";
      break;
  }
  return event;
}

class FleetPerception::Impl {
 public:
  Impl(core::Participant& participant, const std::string& base_id)
      : base_id_(base_id), security_(participant.options().security) {
    sync_writer_ = std::make_unique<core::Writer<msgs::MapSyncRequestPubSubType>>(
        participant, "cairn/map_sync_request", "cairn.command");
    map_reader_ = std::make_unique<core::Reader<msgs::MapUpdatePubSubType>>(
        participant, "cairn/map_update", "cairn.map",
        [this](const msgs::MapUpdate& m, const eprosima::fastdds::dds::SampleInfo& info) {
          if (FromRobot("cairn/map_update", m.robot_id(), info)) OnMap(m);
        });
    camera_reader_ = std::make_unique<core::Reader<msgs::CompressedImagePubSubType>>(
        participant, "cairn/camera", "cairn.camera",
        [this](const msgs::CompressedImage& m, const eprosima::fastdds::dds::SampleInfo& info) {
          if (FromRobot("cairn/camera", m.robot_id(), info)) OnCamera(m);
        });
    staircase_reader_ = std::make_unique<core::Reader<msgs::StaircaseDetectionPubSubType>>(
        participant, "cairn/staircase", "cairn.latched",
        [this](const msgs::StaircaseDetection& m, const eprosima::fastdds::dds::SampleInfo& info) {
          if (FromRobot("cairn/staircase", m.robot_id(), info)) OnStaircase(m);
        });
    // Requests can be lost before discovery completes (the command QoS is volatile) and a robot at rest sends
    // no deltas that would reveal the gap: keep asking, once a second, until every seen robot's map is whole.
    sync_thread_ = std::thread([this] {
      std::unique_lock<std::mutex> lock(mutex_);
      while (!stop_) {
        cv_.wait_for(lock, std::chrono::seconds(1));
        if (stop_) break;
        const std::set<std::string> robots = seen_robots_;
        lock.unlock();
        for (const auto& robot : robots) {
          if (!HasBase(robot)) MaybeRequestSync(robot);
        }
        lock.lock();
      }
    });
  }

  ~Impl() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    sync_thread_.join();
    map_reader_.reset();
    camera_reader_.reset();
    staircase_reader_.reset();
  }

  void OnMap(const msgs::MapUpdate& m) {
    perception::MapUpdate update;
    update.robot_id = m.robot_id();
    update.kind = m.kind() == 1 ? perception::MapUpdateKind::kSnapshot : perception::MapUpdateKind::kDelta;
    update.seq = m.seq();
    update.base_seq = m.base_seq();
    update.snapshot_id = m.snapshot_id();
    update.chunk_index = m.chunk_index();
    update.chunk_count = m.chunk_count();
    update.resolution_m = m.resolution_m();
    update.data = m.data();
    std::string error;
    // Wire-level checks FleetMap cannot see (it only gets the decoded enum and the payload): logged drops.
    if (m.kind() > 1) {
      spdlog::warn("map update from {} dropped: kind {} is neither DELTA (0) nor SNAPSHOT (1)", m.robot_id(),
                   static_cast<int>(m.kind()));
      return;
    }
    if (m.encoding() != "cairn-coarse-zstd-v1") {
      spdlog::warn("map update from {} dropped: encoding '{}' is not cairn-coarse-zstd-v1", m.robot_id(),
                   m.encoding());
      return;
    }
    if (!map_.Apply(m.robot_id(), update, &error)) {
      spdlog::warn("map update from {} (seq {}, kind {}) dropped: {}", m.robot_id(), m.seq(),
                   static_cast<int>(m.kind()), error);
    }
    if (map_.NeedsSnapshot(m.robot_id())) MaybeRequestSync(m.robot_id());
    cv_.notify_all();
  }

  void MaybeRequestSync(const std::string& robot_id) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const auto now = SteadyClock::now();
      auto it = last_sync_request_.find(robot_id);
      if (it != last_sync_request_.end() && core::SecondsBetween(it->second, now) < kSyncRequestPeriodS)
        return;
      last_sync_request_[robot_id] = now;
    }
    msgs::MapSyncRequest request;
    request.robot_id(robot_id);
    request.requester_id(base_id_);
    request.stamp(cairn::msgs::WallStampNow());
    sync_writer_->Write(request);
    spdlog::info("basestation {}: asked {} for a map snapshot", base_id_, robot_id);
  }

  // True for a robot seen announcing a map (OnRobotSeen).
  bool SendsMap(const std::string& robot_id) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return seen_robots_.count(robot_id) > 0;
  }

  bool HasBase(const std::string& robot_id) const {
    perception::RobotMapStats stats;
    return map_.GetRobotStats(robot_id, &stats) && stats.has_base && !stats.needs_snapshot;
  }

  void OnCamera(const msgs::CompressedImage& m) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      CameraView& view = frames_[m.robot_id()];
      if (view.frames_received > 0 && m.seq() > view.frame.seq() + 1) {
        view.frames_missed += m.seq() - view.frame.seq() - 1;
      }
      view.frame = m;
      view.received = SteadyClock::now();
      ++view.frames_received;
    }
    cv_.notify_all();
  }

  void OnStaircase(const msgs::StaircaseDetection& m) {
    perception::Staircase staircase;
    std::string why;
    if (!StaircaseFromMessage(m, &staircase, &why)) {
      std::uint64_t suppressed = 0;
      if (warnings_.Allow("staircase", core::SteadyClock::now(), &suppressed)) {
        spdlog::warn(
            "staircase {} from {} dropped: {}{}", m.staircase_id(),
            m.robot_id().substr(0, core::kMaxIdLength), why,
            suppressed > 0 ? " (and " + std::to_string(suppressed) + " more since the last warning)" : "");
      }
      return;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    // Each fleet staircase keeps its id as robots refine it; new ones, merges and removals are told once.
    std::string refused;
    for (const StaircaseChange& change :
         staircases_.Report(m.robot_id(), m.staircase_id(), staircase, &refused)) {
      FleetEvent event = StaircaseEvent(change);
      spdlog::info("basestation {}: {}", base_id_, event.message);
      events_.push_back(std::move(event));
      if (events_.size() > kMaxStaircaseEvents) events_.pop_front();
    }
    std::uint64_t suppressed = 0;
    if (!refused.empty() && warnings_.Allow("staircases kept", core::SteadyClock::now(), &suppressed)) {
      spdlog::warn(
          "staircase {} from {} dropped: {}{}", m.staircase_id(), m.robot_id(), refused,
          suppressed > 0 ? " (and " + std::to_string(suppressed) + " more since the last warning)" : "");
    }
  }

  const std::string base_id_;
  const core::SecurityOptions security_;
  core::WarningLimiter forged_warnings_;
  // Under DDS Security: true when the writer of `info` holds the certificate of `robot_id`, the robot the
  // message is about; else it is dropped (a robot's certificate publishing another robot's map, camera or
  // staircases) and logged at most every 5 s per topic. Always true without security.
  bool FromRobot(const char* topic, const std::string& robot_id,
                 const eprosima::fastdds::dds::SampleInfo& info) {
    if (core::SentUnder(security_, info, robot_id)) return true;
    std::uint64_t suppressed = 0;
    if (forged_warnings_.Allow(topic, core::SteadyClock::now(), &suppressed)) {
      spdlog::warn(
          "basestation {}: a forged message dropped: {}: robot id '{}' not sent under its certificate "
          "(participant {}){}",
          base_id_, topic, robot_id.substr(0, 64), core::ParticipantIdOf(info.publication_handle),
          suppressed > 0 ? " (and " + std::to_string(suppressed) + " more since the last warning)" : "");
    }
    return false;
  }
  perception::FleetMap map_;  // thread-safe
  mutable std::mutex mutex_;
  mutable std::condition_variable cv_;
  std::map<std::string, core::SteadyTime> last_sync_request_;
  std::map<std::string, CameraView> frames_;
  core::WarningLimiter warnings_;  // bad staircase messages from peers
  FleetStaircases staircases_{FleetStaircasesOptions{{}, kMaxStaircaseInstances}};
  std::deque<FleetEvent> events_;      // not yet taken, at most kMaxStaircaseEvents
  std::set<std::string> seen_robots_;  // robots seen announcing a map
  bool stop_ = false;
  std::thread sync_thread_;

  std::unique_ptr<core::Writer<msgs::MapSyncRequestPubSubType>> sync_writer_;
  std::unique_ptr<core::Reader<msgs::MapUpdatePubSubType>> map_reader_;
  std::unique_ptr<core::Reader<msgs::CompressedImagePubSubType>> camera_reader_;
  std::unique_ptr<core::Reader<msgs::StaircaseDetectionPubSubType>> staircase_reader_;
};

FleetPerception::FleetPerception(core::Participant& participant, const std::string& base_id)
    : impl_(std::make_unique<Impl>(participant, base_id)) {}
FleetPerception::~FleetPerception() = default;

void FleetPerception::OnRobotSeen(const std::string& robot_id, double map_resolution_m) {
  {
    std::lock_guard<std::mutex> lock(impl_->mutex_);
    if (!(map_resolution_m > 0)) {  // none to sync (a robot may restart with perception off)
      impl_->seen_robots_.erase(robot_id);
      return;
    }
    impl_->seen_robots_.insert(robot_id);
  }
  // A robot's agent info arrives once per session: a restarted robot numbers its deltas from 1 again, so its
  // stream starts afresh (the voxels stay until the new session overwrites them).
  impl_->map_.ResetRobot(robot_id);
  impl_->MaybeRequestSync(robot_id);
}

void FleetPerception::OnRobotBack(const std::string& robot_id) {
  if (!impl_->SendsMap(robot_id)) return;
  impl_->map_.ResetRobot(robot_id);
  impl_->MaybeRequestSync(robot_id);
}

void FleetPerception::SyncIfIncomplete(const std::string& robot_id) {
  if (impl_->SendsMap(robot_id) && !impl_->HasBase(robot_id)) impl_->MaybeRequestSync(robot_id);
}

bool FleetPerception::WaitForMapSync(const std::string& robot_id, double timeout_s) {
  const auto deadline = SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                                                 std::chrono::duration<double>(timeout_s));
  while (!impl_->HasBase(robot_id)) {
    impl_->MaybeRequestSync(robot_id);
    std::unique_lock<std::mutex> lock(impl_->mutex_);
    if (impl_->cv_.wait_until(lock,
                              std::min(deadline, SteadyClock::now() + std::chrono::milliseconds(100))) ==
            std::cv_status::timeout &&
        SteadyClock::now() >= deadline) {
      return impl_->HasBase(robot_id);
    }
  }
  return true;
}

MapSaveResult FleetPerception::SaveMap(const std::string& target, const std::string& path,
                                       double sync_timeout_s) {
  MapSaveResult result;
  const bool fleet = target == "fleet";
  std::vector<std::string> robots = impl_->map_.Robots();
  if (!fleet && std::find(robots.begin(), robots.end(), target) == robots.end()) {
    // Nothing from it yet: ask (it may have joined before any change), then wait.
    impl_->MaybeRequestSync(target);
  }
  if (fleet) {
    for (const auto& robot : robots) {
      if (!WaitForMapSync(robot, sync_timeout_s)) {
        result.error = "the map of robot " + robot + " is incomplete (snapshot not received within " +
                       std::to_string(sync_timeout_s).substr(0, 4) + " s)";
        return result;
      }
    }
  } else if (!WaitForMapSync(target, sync_timeout_s)) {
    result.error = "no complete map of robot " + target + " within " +
                   std::to_string(sync_timeout_s).substr(0, 4) +
                   " s (unknown robot, or its snapshot has not arrived)";
    return result;
  }
  const std::vector<perception::CoarseVoxel> voxels = impl_->map_.Voxels(fleet ? "" : target);
  if (voxels.empty()) {
    result.error = std::string("the ") + (fleet ? "fleet map" : "map of robot " + target) + " is empty";
    return result;
  }
  std::string error;
  if (!impl_->map_.SaveBt(path, fleet ? "" : target, &error)) {
    result.error = error;
    return result;
  }
  result.ok = true;
  result.voxels = voxels.size();
  for (const auto& v : voxels) result.occupied += v.state == perception::CoarseState::kOccupied;
  result.resolution_m = impl_->map_.resolution_m();
  return result;
}

std::optional<CameraView> FleetPerception::LatestFrame(const std::string& robot_id) const {
  std::lock_guard<std::mutex> lock(impl_->mutex_);
  auto it = impl_->frames_.find(robot_id);
  if (it == impl_->frames_.end()) return std::nullopt;
  return it->second;
}

std::optional<CameraView> FleetPerception::WaitForFrame(const std::string& robot_id,
                                                        std::uint64_t after_received,
                                                        double timeout_s) const {
  std::unique_lock<std::mutex> lock(impl_->mutex_);
  std::optional<CameraView> found;
  impl_->cv_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] {
    auto it = impl_->frames_.find(robot_id);
    if (it == impl_->frames_.end() || it->second.frames_received <= after_received) return false;
    found = it->second;
    return true;
  });
  return found;
}

std::vector<perception::StaircaseRegistry::Entry> FleetPerception::Staircases() const {
  std::lock_guard<std::mutex> lock(impl_->mutex_);
  return impl_->staircases_.Entries();
}

std::vector<FleetEvent> FleetPerception::TakeEvents() {
  std::lock_guard<std::mutex> lock(impl_->mutex_);
  std::vector<FleetEvent> events(impl_->events_.begin(), impl_->events_.end());
  impl_->events_.clear();
  return events;
}

perception::FleetMapStats FleetPerception::MapStats() const { return impl_->map_.Stats(); }
std::vector<perception::CoarseVoxel> FleetPerception::MapVoxels() const { return impl_->map_.Voxels(); }
double FleetPerception::MapResolution() const { return impl_->map_.resolution_m(); }

bool FleetPerception::RobotMapStats(const std::string& robot_id, perception::RobotMapStats* out) const {
  return impl_->map_.GetRobotStats(robot_id, out);
}

}  // namespace cairn::base
