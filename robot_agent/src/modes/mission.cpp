#include "cairn/agent/modes/mission.h"

#include <array>
#include <stdexcept>
#include <utility>

#include "cairn/core/range_check.h"
#include "cairn/fleet/robot_status.h"

namespace cairn::agent {

using core::InRange;

bool MissionOptions::IsValid(std::string* why) const {
  return InRange("mission.resume_within_s", resume_within_s, 0, 3600, true, why) &&
         InRange("mission.retry_every_s", retry_every_s, 0, 60, true, why);
}

std::string FailedCondition(const std::string& failure) {
  static const std::string kNoLonger = " no longer allowed: ";
  const std::size_t after = failure.find(kNoLonger);
  return after == std::string::npos ? failure : failure.substr(after + kNoLonger.size());
}

bool IsTransientFailure(const std::string& failure) {
  // The condition is the first word of the tree's failure (after a re-check's prefix).
  const std::string condition_text = FailedCondition(failure);
  const std::string condition = condition_text.substr(0, condition_text.find(':'));
  static const std::array<const char*, 4> kTransient = {"IsComponentUp", "IsLocalized", "IsMappingHealthy",
                                                        "IsLocalPlannerHealthy"};
  for (const char* name : kTransient) {
    if (condition == name) return true;
  }
  return false;
}

const char* ToString(PausedMission::Kind kind) {
  switch (kind) {
    case PausedMission::Kind::kWaypoint:
      return fleet::mission_kind::kWaypoint;
    case PausedMission::Kind::kExplore:
      return fleet::mission_kind::kExplore;
    case PausedMission::Kind::kConvoy:
      return fleet::mission_kind::kConvoy;
  }
  return fleet::mission_kind::kWaypoint;
}

MissionKeeper::MissionKeeper(const MissionOptions& options) : options_(options) {
  if (std::string why; !options_.IsValid(&why)) throw std::invalid_argument(why);
}

void MissionKeeper::Pause(PausedMission mission) {
  paused_ = std::move(mission);
  last_try_s_ = paused_->since_s;  // the condition has just failed: the first retry after retry_every_s
}

std::optional<PausedMission> MissionKeeper::Take() {
  std::optional<PausedMission> taken = std::move(paused_);
  paused_.reset();
  return taken;
}

void MissionKeeper::Release(double now_s) {
  if (!paused_) return;
  paused_->held = false;
  paused_->since_s = now_s;  // the time to resume counts from the yield's end
  last_try_s_ = -1e300;      // at once
}

void MissionKeeper::SetReason(const std::string& reason) {
  if (paused_) paused_->reason = reason;
}

MissionKeeper::Due MissionKeeper::Check(double now_s) const {
  if (!paused_) return Due::kNothing;
  if (paused_->held) return Due::kWait;
  if (now_s - paused_->since_s > options_.resume_within_s) return Due::kExpired;
  return now_s - last_try_s_ >= options_.retry_every_s ? Due::kTry : Due::kWait;
}

}  // namespace cairn::agent
