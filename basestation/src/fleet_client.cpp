#include "cairn/base/fleet_client.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <deque>
#include <iterator>
#include <set>
#include <thread>

#include "cairn/base/operator_text.h"
#include "cairn/core/dds.h"
#include "cairn/core/peer_input.h"
#include "cairn/fleet/robot_status.h"
#include "cairn/msgs/robot_state.h"
#include "cairn/msgs/stamp.h"
#include "cairn_msgsPubSubTypes.h"

namespace cairn::base {

namespace msgs = cairn_msgs;
using core::SteadyClock;

namespace {

// Identifies one command to one robot, to match its acknowledgement.
std::string ResponseKey(const std::string& robot_id, msgs::CommandKind kind, uint32_t request_id) {
  return robot_id + "/" + std::to_string(kind) + "/" + std::to_string(request_id);
}

}  // namespace

class FleetClient::Impl {
 public:
  explicit Impl(const FleetClientOptions& options) : options_(CheckedOptions(options)) {
    events_.detector = FleetEventDetector(options.events);
    MakeParticipant();
    // Announced on cairn/base_info, which only robots read; robots announce on cairn/agent_info.
    info_writer_ = std::make_unique<core::Writer<msgs::AgentInfoPubSubType>>(*participant_, "cairn/base_info",
                                                                             "cairn.latched");
    perception_ = std::make_unique<FleetPerception>(*participant_, options.base_id);
    if (!options.security.enabled()) {
      // The shared command topics, matched before the first command needs them.
      for (const CommandKind& kind : kCommandKinds) kind.make(*this, "");
      CommandWriter<msgs::TeleopTwistPubSubType>("cairn/teleop", "", "cairn.teleop");
      CommandWriter<msgs::PathRequestPubSubType>("cairn/path_request", "");
    }
    readers_.response = std::make_unique<core::Reader<msgs::CommandResponsePubSubType>>(
        *participant_, "cairn/command_response", "cairn.command",
        [this](const msgs::CommandResponse& m, const eprosima::fastdds::dds::SampleInfo& info) {
          if (FromRobot("cairn/command_response", m.robot_id(), info)) OnResponse(m);
        });
    MakeStateReaders();
    MakeLinkProbe();
    MakeViewReaders();
    MakeInfoReader();
    Announce(0);
    monitor_.thread = std::thread([this] { MonitorLoop(); });
  }

  // `options`, or std::invalid_argument naming the field and its value.
  static const FleetClientOptions& CheckedOptions(const FleetClientOptions& options) {
    if (const std::string fault = core::CheckId("--base-id", options.base_id); !fault.empty()) {
      throw std::invalid_argument(fault);
    }
    std::string why;
    if (!options.events.IsValid(&why)) throw std::invalid_argument("events: " + why);
    if (!(options.discovery_s > 0 && options.discovery_s <= 60)) {
      throw std::invalid_argument("discovery_s = " + std::to_string(options.discovery_s) +
                                  " must be in (0, 60]");
    }
    if (options.events_kept < 1 || options.events_kept > 100000) {
      throw std::invalid_argument("events_kept = " + std::to_string(options.events_kept) +
                                  " must be in [1, 100000]");
    }
    return options;
  }

  void MakeParticipant() {
    const FleetClientOptions& options = options_;
    core::ParticipantOptions p;
    p.domain_id = options.domain_id;
    if (!options.dds_profiles_file.empty()) p.profiles_file = options.dds_profiles_file;
    p.link = options.link;
    p.name = "cairn_base/" + options.base_id;
    // Fast DDS's discovery thread must not wait for mutex_: the monitor loop applies what it collects.
    p.on_participant_gone = [this](const std::string& participant, bool dropped) {
      std::lock_guard<std::mutex> guard(departures_.mutex);
      departures_.gone.emplace_back(participant, dropped);
    };
    if (options.security.enabled()) {
      // Under DDS Security each robot has command topics of its own, and this base makes writers only for the
      // robots its permissions give it (core::CommandTopicFor), on first use; an observer makes none.
      p.security = options.security;
      commandable_ = options.security.CommandableRobots();
    }
    participant_ = std::make_unique<core::Participant>(p);
  }

  // A robot's whole state (reliable, latched), its pose stream and its components' health.
  void MakeStateReaders() {
    // A robot's whole state (on change, at least once a second; reliable, latched) and its 10 Hz pose stream,
    // applied to the last whole state (idl/cairn_msgs.idl RobotPose). Either keeps the robot from being lost;
    // the gaps in the pose stream's sequence numbers are the link's losses.
    readers_.state = std::make_unique<core::Reader<msgs::RobotStatePubSubType>>(
        *participant_, "cairn/robot_state", "cairn.latched",
        [this](const msgs::RobotState& m, const eprosima::fastdds::dds::SampleInfo& info) {
          if (!FromRobot("cairn/robot_state", m.robot_id(), info)) return;
          const auto now = SteadyClock::now();
          WarnOfUnknownWords(m, now);
          std::vector<ClassUsage> usage;
          for (const msgs::LinkClassUsage& u : m.link_usage()) {
            usage.push_back({u.topic_class(), u.sent_kbps(), u.sent_bytes()});
          }
          Update(m.robot_id(), [&](RobotView& v) {
            cairn::msgs::ApplyWholeState(m, &v.state);
            if (!v.first_state) v.first_state = m;
            // The process sending it, for "left" when that participant goes: its agent info, which says the
            // same, may not have matched yet (a basestation just started, a lossy link).
            views_.participant_of_robot[m.robot_id()] = core::ParticipantIdOf(info.publication_handle);
            v.platform = m.platform();
            v.state_received = now;
            v.whole_state_received = now;
            if (!usage.empty()) probing_.links.OnUsage(m.robot_id(), std::move(usage));  // once a second
          });
        });
    readers_.pose = std::make_unique<core::Reader<msgs::RobotPosePubSubType>>(
        *participant_, "cairn/robot_pose", "cairn.state",
        [this](const msgs::RobotPose& m, const eprosima::fastdds::dds::SampleInfo& info) {
          if (!FromRobot("cairn/robot_pose", m.robot_id(), info)) return;
          const auto now = SteadyClock::now();
          Update(m.robot_id(), [&](RobotView& v) {
            if (v.state) cairn::msgs::MergePose(m, &*v.state);  // else its whole state is on the way
            v.state_received = now;
            probing_.links.OnState(
                m.robot_id(), core::WriterIdOf(info.publication_handle),
                static_cast<std::uint64_t>(info.sample_identity.sequence_number().to64long()), now);
          });
        });
    // Component health: kept with the robot's view (the robot must be known by its state or agent info); it
    // does not keep a robot from being shown lost.
    readers_.health = std::make_unique<core::Reader<msgs::AgentHealthPubSubType>>(
        *participant_, "cairn/health", "cairn.latched",
        [this](const msgs::AgentHealth& m, const eprosima::fastdds::dds::SampleInfo& info) {
          if (!FromRobot("cairn/health", m.robot_id(), info)) return;
          {
            std::lock_guard<std::mutex> lock(mutex_);
            auto it = views_.robots.find(m.robot_id());
            if (it == views_.robots.end()) return;
            it->second.health = m;
          }
          cv_.notify_all();
        });
  }

  // This base's link probes and the robots' echoes (round trips: LinkMonitor).
  void MakeLinkProbe() {
    probe_writer_ = std::make_unique<core::Writer<msgs::PingPongPubSubType>>(
        *participant_, "cairn/link_probe", "cairn.command");
    readers_.probe_reply = std::make_unique<core::Reader<msgs::PingPongPubSubType>>(
        *participant_, "cairn/link_probe_reply", "cairn.command",
        [this](const msgs::PingPong& m, const auto&) {
          if (m.base_id() != options_.base_id || m.body() != participant_->participant_id())
            return;  // another base's probe
          const auto now = SteadyClock::now();
          std::lock_guard<std::mutex> lock(mutex_);
          if (views_.robots.count(m.robot_id()) == 0) return;  // announces itself first
          probing_.links.OnProbeReply(m.robot_id(), m.request_id(), now);
        });
    readers_.path_response = std::make_unique<core::Reader<msgs::PathResponsePubSubType>>(
        *participant_, "cairn/path_response", "cairn.command",
        [this](const msgs::PathResponse& m, const auto&) {
          // Answers to another process with this base id (same request ids) are not ours.
          if (m.requester_id() != options_.base_id ||
              m.requester_participant() != participant_->participant_id())
            return;
          {
            std::lock_guard<std::mutex> lock(mutex_);
            if (awaited_.paths.count(m.request_id()) == 0) return;  // a late duplicate of an answered request
            awaited_.path_answers[m.request_id()] = m;
          }
          cv_.notify_all();
        });
  }

  // What a robot shows: its global path, local plan and mode tree, kept with its view.
  void MakeViewReaders() {
    readers_.global_path = std::make_unique<core::Reader<msgs::GlobalPathPubSubType>>(
        *participant_, "cairn/global_path", "cairn.latched",
        [this](const msgs::GlobalPath& m, const eprosima::fastdds::dds::SampleInfo& info) {
          if (FromRobot("cairn/global_path", m.robot_id(), info))
            Update(m.robot_id(), [&](RobotView& v) { v.global_path = m; });
        });
    readers_.local_plan = std::make_unique<core::Reader<msgs::LocalPlanPubSubType>>(
        *participant_, "cairn/local_plan", "cairn.state",
        [this](const msgs::LocalPlan& m, const eprosima::fastdds::dds::SampleInfo& info) {
          if (FromRobot("cairn/local_plan", m.robot_id(), info))
            Update(m.robot_id(), [&](RobotView& v) { v.local_plan = m; });
        });
    readers_.tree = std::make_unique<core::Reader<msgs::BehaviorTreeStatePubSubType>>(
        *participant_, "cairn/bt_state", "cairn.latched",
        [this](const msgs::BehaviorTreeState& m, const eprosima::fastdds::dds::SampleInfo& info) {
          if (FromRobot("cairn/bt_state", m.robot_id(), info))
            Update(m.robot_id(), [&](RobotView& v) { v.tree = m; });
        });
  }

  // Robots' announcements (platform, capabilities, limits, link) and their writers' liveliness.
  void MakeInfoReader() {
    readers_.info = std::make_unique<core::Reader<msgs::AgentInfoPubSubType>>(
        *participant_, "cairn/agent_info", "cairn.latched",
        [this](const msgs::AgentInfo& m, const eprosima::fastdds::dds::SampleInfo& info) {
          if (m.kind() != msgs::AGENT_KIND_ROBOT || !FromRobot("cairn/agent_info", m.agent_id(), info))
            return;
          {
            std::lock_guard<std::mutex> lock(mutex_);
            views_.by_writer[info.publication_handle] = m.agent_id();
            views_.current_writer[m.agent_id()] = info.publication_handle;
            views_.participant_of_robot[m.agent_id()] = core::ParticipantIdOf(info.publication_handle);
          }
          Update(m.agent_id(), [&](RobotView& v) {
            v.platform = m.platform();
            v.capabilities = m.capabilities();
            v.sensors = m.sensors();
            v.map_resolution_m =
                std::isfinite(m.map_resolution_m()) ? std::max(0.0, m.map_resolution_m()) : 0.0;
            v.version = m.version();
            v.announced = true;
            probing_.links.OnInfo(m.agent_id(), m.link(), m.link_kbps());
            v.max_speed_mps = std::isfinite(m.max_speed_mps()) ? std::max(0.0, m.max_speed_mps()) : 0.0;
            v.max_reverse_speed_mps =
                std::isfinite(m.max_reverse_speed_mps()) ? std::max(0.0, m.max_reverse_speed_mps()) : 0.0;
            v.max_yaw_rate_radps =
                std::isfinite(m.max_yaw_rate_radps()) ? std::max(0.0, m.max_yaw_rate_radps()) : 0.0;
            v.footprint_radius_m = std::isfinite(m.footprint_radius_m()) && m.footprint_radius_m() <= 5.0
                                       ? std::max(0.0, m.footprint_radius_m())
                                       : 0.0;
          });
          // How long the announcement took to arrive, by the robot's wall clock against ours (a figure of
          // discovery when the clocks are synchronized; the fleet join test reads it).
          const double age_s =
              cairn::msgs::WallSeconds(cairn::msgs::WallStampNow()) - cairn::msgs::WallSeconds(m.stamp());
          spdlog::info("basestation {}: {} announced itself on link {} ({:.3f} s ago by its clock)",
                       options_.base_id, m.agent_id(), m.link().empty() ? "?" : m.link(), age_s);
          perception_->OnRobotSeen(m.agent_id(), m.map_resolution_m());
        },
        [this](const eprosima::fastdds::dds::LivelinessChangedStatus& status) { OnLiveliness(status); });
  }

  ~Impl() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      monitor_.stop = true;
    }
    cv_.notify_all();
    if (monitor_.thread.joinable()) monitor_.thread.join();
    readers_ = Readers{};
    perception_.reset();  // after readers_.info, whose callback uses it
  }

  // Publishes this basestation's AgentInfo with the number of robots it hears (robots size their share of a
  // radio by it). Called without mutex_ held.
  void Announce(int robots_heard) {
    msgs::AgentInfo info;
    info.agent_id(options_.base_id);
    info.kind(msgs::AGENT_KIND_BASESTATION);
    info.platform("basestation");
    info.capabilities(options_.capabilities);
    info.version("0.1.0");
    info.stamp(cairn::msgs::WallStampNow());
    info.link(options_.link.link);
    info.link_kbps(core::StatedBudgetKbps(options_.link));
    info.robots_heard(static_cast<std::uint16_t>(std::min(robots_heard, 65535)));
    info_writer_->Write(info);
  }

  // Applies `change` to the view of `robot_id` (creating it), marks it seen and wakes waiters.
  void Update(const std::string& robot_id, const std::function<void(RobotView&)>& change) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      RobotView& v = views_.robots[robot_id];
      v.robot_id = robot_id;
      change(v);
      v.last_seen = SteadyClock::now();
      v.lost = false;
      v.left = false;
      v.lost_reason.clear();
    }
    cv_.notify_all();
  }

  void OnLiveliness(const eprosima::fastdds::dds::LivelinessChangedStatus& status) {
    if (status.alive_count_change == 0 && status.not_alive_count_change < 0) {
      std::lock_guard<std::mutex> lock(mutex_);
      views_.by_writer.erase(status.last_publication_handle);  // a lapsed writer unmatched: gone for good
      return;
    }
    if (!core::IsLivelinessLoss(status)) return;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      auto it = views_.by_writer.find(status.last_publication_handle);
      if (it == views_.by_writer.end()) return;
      const std::string robot_id = it->second;
      // Unmatched while alive (alive -1, not_alive 0): that process is gone for good.
      if (status.not_alive_count_change == 0) views_.by_writer.erase(it);
      // An old process of a robot that has restarted (a new writer announces its id) does not make it lost.
      auto current = views_.current_writer.find(robot_id);
      if (current == views_.current_writer.end() || !(current->second == status.last_publication_handle))
        return;
      auto robot = views_.robots.find(robot_id);
      if (robot == views_.robots.end()) return;
      robot->second.lost = true;
      robot->second.lost_reason = "liveliness lost";
    }
    cv_.notify_all();
  }

  void OnResponse(const msgs::CommandResponse& m) {
    // Replies to another process with this base id (it numbers its requests from 1 too) are not ours.
    if (m.base_id() != options_.base_id || m.requester_participant() != participant_->participant_id())
      return;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const std::string key = ResponseKey(m.robot_id(), m.kind(), m.request_id());
      if (awaited_.commands.count(key) == 0) return;  // a replayed answer to a request already answered
      awaited_.answers[key] = m;
    }
    cv_.notify_all();
  }

  // Robots whose process left cleanly (participant removed, not dropped) since the last call: shown "left".
  // A participant removed after its lease had expired here is not a process that exited: it is a process
  // that stalled (SIGSTOP, a frozen machine) and, running again, replaces its participant (core::Participant
  // re-creates one after a stall); its robot stays lost until its new participant is heard.
  void ApplyGoneParticipants() {
    std::vector<std::pair<std::string, bool>> gone;
    {
      std::lock_guard<std::mutex> guard(departures_.mutex);
      gone.swap(departures_.gone);
    }
    const auto now = SteadyClock::now();
    for (auto it = departures_.dropped_at.begin(); it != departures_.dropped_at.end();) {
      it = core::SecondsBetween(it->second, now) > kDroppedKeptS ? departures_.dropped_at.erase(it)
                                                                 : std::next(it);
    }
    for (const auto& [participant, dropped] : gone) {
      const bool stalled = !dropped && departures_.dropped_at.count(participant) > 0;
      if (dropped) departures_.dropped_at[participant] = now;
      for (auto& [robot_id, robot_participant] : views_.participant_of_robot) {
        if (robot_participant != participant) continue;
        RobotView& v = views_.robots[robot_id];
        v.lost = true;
        v.left = !dropped && !stalled;
        v.lost_reason = dropped   ? "its participant's lease expired"
                        : stalled ? "its process stalled past its lease and is replacing its participant"
                                  : "its process exited";
      }
    }
  }

  // Applies staleness and the link monitor's view to a copy of a view.
  RobotView WithStaleness(RobotView v, core::SteadyTime now) const {
    v.link = probing_.links.View(v.robot_id, now);
    if (!v.lost && v.state && core::SecondsBetween(v.last_seen, now) > options_.lost_after_s) {
      v.lost = true;
      v.lost_reason = fmt::format("no state for {:.1f} s", core::SecondsBetween(v.last_seen, now));
    }
    return v;
  }

  // Sends with `send(request_id)` every command_retry_s until `answered()` holds (checked under mutex_) or
  // command_timeout_s passes. Returns false on timeout (and sets *reason). The lock is held on return.
  bool SendUntil(const std::string& robot_id, uint32_t request_id, const std::function<bool(uint32_t)>& send,
                 const std::function<bool()>& answered, std::unique_lock<std::mutex>* lock,
                 std::string* reason) {
    const auto deadline = SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                                                   std::chrono::duration<double>(options_.command_timeout_s));
    const auto retry = std::chrono::duration_cast<SteadyClock::duration>(
        std::chrono::duration<double>(options_.command_retry_s));
    while (true) {
      lock->unlock();
      send(request_id);
      lock->lock();
      const auto resend_at = std::min(deadline, SteadyClock::now() + retry);
      if (cv_.wait_until(*lock, resend_at, answered)) return true;
      if (SteadyClock::now() >= deadline) {
        *reason = "robot " + robot_id + " did not acknowledge within " +
                  std::to_string(options_.command_timeout_s).substr(0, 4) + " s";
        return false;
      }
    }
  }

  // Sends a command until the robot answers or the timeout passes (robots de-duplicate).
  // `require_live`: refuse a robot that is unknown or lost instead of sending (every command but stop, which
  // is sent at once whatever this basestation believes: a robot that looks lost on a congested link may
  // still hear it).
  CommandOutcome Call(const std::string& robot_id, msgs::CommandKind kind,
                      const std::function<bool(uint32_t)>& send, bool require_live = true) {
    CommandOutcome outcome;
    outcome.request_id = sequences_.request_id++;
    // No robot can have such an id (robots check theirs at start), and one longer than a DDS key holds would
    // not even serialize (found by fuzzing: `stop` with a 370-character id).
    if (std::string why = core::CheckId("robot id", robot_id); !why.empty()) {
      outcome.result = outcome::kInvalid;
      outcome.reason = std::move(why);
      return outcome;
    }
    if (std::string why = NotPermittedReason(robot_id, kind == msgs::COMMAND_KIND_STOP); !why.empty()) {
      outcome.result = outcome::kRefused;
      outcome.reason = std::move(why);
      return outcome;
    }
    if (require_live && !WaitForRobot(robot_id, options_.command_timeout_s)) {
      outcome.result = outcome::kRefused;
      outcome.reason = UnknownRobotReason(robot_id);
      return outcome;
    }
    const std::string key = ResponseKey(robot_id, kind, outcome.request_id);
    const auto start = SteadyClock::now();
    {
      std::lock_guard<std::mutex> guard(mutex_);
      awaited_.commands.insert(key);
    }
    if (require_live) {
      WaitForCommandPath(robot_id, options_.command_timeout_s);
    } else {
      // A stop goes out at once; when this basestation has only just found a live robot (its endpoints still
      // being matched: seconds under DDS Security on a loaded machine), the time to answer counts from the
      // match, not from before it, when nothing could be heard. A lost or unknown robot is not waited for.
      // The robot de-duplicates the repeats.
      send(outcome.request_id);
      if (SeenLive(robot_id)) WaitForCommandPath(robot_id, options_.command_timeout_s);
    }
    std::unique_lock<std::mutex> lock(mutex_);
    const bool answered = SendUntil(
        robot_id, outcome.request_id, send, [&] { return awaited_.answers.count(key) > 0; }, &lock,
        &outcome.reason);
    awaited_.commands.erase(key);
    if (!answered) {
      outcome.result = outcome::kTimedOut;
      return outcome;
    }
    const msgs::CommandResponse r = awaited_.answers[key];
    awaited_.answers.erase(key);
    outcome.round_trip_ms = std::chrono::duration<double, std::milli>(SteadyClock::now() - start).count();
    outcome.ok = r.result() == msgs::COMMAND_RESULT_ACCEPTED;
    outcome.result = outcome.ok ? outcome::kAccepted : outcome::kRefused;
    const OperatorReason why = ExplainReason(robot_id, r.reason());
    outcome.reason = why.text;
    outcome.robot_reason = r.reason();
    outcome.condition = r.result() == msgs::COMMAND_RESULT_DISCARDED ? "lock" : why.condition;
    outcome.holder_id = r.holder_id();
    outcome.mode = r.mode();
    outcome.goal_id = r.goal_id();
    outcome.answered = true;
    outcome.valid_modes = r.valid_modes();
    outcome.goal_acceptable = r.goal_acceptable();
    return outcome;
  }

  // Watches the fleet at 10 Hz: staleness and proximity change without a message, so polling it is.
  void MonitorLoop() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (std::uint64_t tick = 0; !monitor_.stop; ++tick) {
      if (tick % 10 == 0) {  // the link probe, every second
        const std::uint32_t probe_id = ++probing_.last_id;
        probing_.links.OnProbeSent(probe_id, SteadyClock::now());
        lock.unlock();
        msgs::PingPong probe;
        probe.request_id(probe_id);
        probe.base_id(options_.base_id);
        probe.body(participant_->participant_id());
        probe_writer_->Write(probe);
        lock.lock();
      }
      ApplyGoneParticipants();
      std::vector<RobotView> views;
      const auto now = SteadyClock::now();
      for (const auto& [id, view] : views_.robots) views.push_back(WithStaleness(view, now));
      std::vector<OperatorEvent> events = events_.detector.Observe(views);
      const int robots_heard = static_cast<int>(
          std::count_if(views.begin(), views.end(), [](const RobotView& v) { return v.state && !v.lost; }));
      lock.unlock();
      if (robots_heard != probing_.announced_robots_heard) {
        probing_.announced_robots_heard = robots_heard;
        Announce(robots_heard);
      }
      // A robot back from lost may have sent map deltas this basestation never got (a cut link unmatches the
      // writers, and volatile samples are not replayed): its map here starts again from a snapshot, asked for
      // until one completes.
      for (const OperatorEvent& e : events) {
        if (e.kind == "back") perception_->OnRobotBack(e.robot_id);
      }
      for (const RobotView& v : views) {
        if (v.announced && !v.lost) perception_->SyncIfIncomplete(v.robot_id);
      }
      MakeCommandWritersFor(views);
      for (const FleetEvent& f : perception_->TakeEvents()) {
        OperatorEvent e;
        e.kind = f.kind;
        e.message = f.message;
        e.reason = f.reason;
        e.staircase = f.staircase;
        e.merged_staircase_id = f.merged_id;
        events.push_back(e);
      }
      lock.lock();
      for (auto& e : events) {
        e.seq = ++events_.seq;
        events_.pending.push_back(e);
        events_.recent.push_back(std::move(e));
        if (events_.recent.size() > options_.events_kept) events_.recent.pop_front();
        if (events_.pending.size() > options_.events_kept) events_.pending.pop_front();
      }
      if (!events.empty()) cv_.notify_all();
      cv_.wait_for(lock, std::chrono::milliseconds(100), [this] { return monitor_.stop; });
    }
  }

  // True when this basestation has heard `robot_id` and does not hold it lost at `now`; mutex_ held.
  bool LiveLocked(const std::string& robot_id, core::SteadyTime now) const {
    auto it = views_.robots.find(robot_id);
    return it != views_.robots.end() && !WithStaleness(it->second, now).lost;
  }
  // LiveLocked() now, without waiting.
  bool SeenLive(const std::string& robot_id) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return LiveLocked(robot_id, SteadyClock::now());
  }

  // Waits for `robot_id` to be known and alive: a robot not heard of yet until discovery_s has passed since
  // this client started (a fresh basestation on a lossy link may need longer than a command's timeout to
  // discover it; once that has passed, an unknown robot, a typo, is refused at once), a lost one up to
  // `timeout_s`.
  bool WaitForRobot(const std::string& robot_id, double timeout_s) const {
    std::unique_lock<std::mutex> lock(mutex_);
    const auto discovered_by = created_ + std::chrono::duration_cast<SteadyClock::duration>(
                                              std::chrono::duration<double>(options_.discovery_s));
    const auto deadline = SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                                                   std::chrono::duration<double>(timeout_s));
    while (true) {
      const auto now = SteadyClock::now();
      if (LiveLocked(robot_id, now)) return true;
      const auto until = views_.robots.count(robot_id) == 0 ? discovered_by : deadline;
      if (now >= until) return false;
      cv_.wait_until(lock, std::min(until, now + std::chrono::milliseconds(100)));
    }
  }

  // Waits up to `timeout_s` until the robot's command readers have matched this basestation's command writers
  // (endpoint discovery done both ways is what lets it hear a command). Seeing a robot's state does not mean
  // that yet: on a lossy link a lost endpoint announcement is repaired only at Fast DDS's next heartbeat (1
  // s), and a command sent before the match is never delivered (volatile). Returns whether they matched; the
  // command is sent either way.
  // The writer of command topic `topic` for `robot_id` (core::CommandTopicFor: one shared by every robot
  // without DDS Security), made on first use. @throws core::DdsError when it cannot be made.
  template <class PubSubT>
  core::Writer<PubSubT>& CommandWriter(const std::string& topic, const std::string& robot_id,
                                       const std::string& qos_class = "cairn.command") {
    const std::string name = core::CommandTopicFor(topic, robot_id, commandable_.has_value());
    std::lock_guard<std::mutex> lock(command_writers_.mutex);
    std::shared_ptr<void>& writer = command_writers_.by_topic[name];
    if (!writer) writer = std::make_shared<core::Writer<PubSubT>>(*participant_, name, qos_class);
    return *std::static_pointer_cast<core::Writer<PubSubT>>(writer);
  }

  // One kind of command: makes (or finds) its writer for a robot and tells whether it matched a process.
  struct CommandKind {
    bool e_stop = false;  // stop: any commander may send it to any robot
    std::function<void(Impl&, const std::string& robot_id)> make;
    std::function<bool(Impl&, const std::string& robot_id, const std::string& participant,
                       SteadyClock::time_point deadline)>
        matched;
  };
  template <class PubSubT>
  static CommandKind Kind(const char* topic, const char* qos_class = "cairn.command") {
    return {
        std::string(topic) == "cairn/stop_request",
        [=](Impl& impl, const std::string& robot) { impl.CommandWriter<PubSubT>(topic, robot, qos_class); },
        [=](Impl& impl, const std::string& robot, const std::string& participant,
            SteadyClock::time_point deadline) {
          return impl.CommandWriter<PubSubT>(topic, robot, qos_class).WaitMatchedWith(participant, deadline);
        }};
  }
  // The commands whose writers a command waits for (WaitForCommandPath).
  static const std::vector<CommandKind> kCommandKinds;

  // Under DDS Security: true when the writer of `info` holds the certificate of `robot_id`, the robot the
  // message is about; else it is dropped (a robot's certificate publishing another robot's state, path or
  // answers) and logged at most every 5 s per topic, naming both. Always true without security.
  bool FromRobot(const char* topic, const std::string& robot_id,
                 const eprosima::fastdds::dds::SampleInfo& info) {
    if (core::SentUnder(options_.security, info, robot_id)) return true;
    std::uint64_t suppressed = 0;
    if (forged_warnings_.Allow(topic, SteadyClock::now(), &suppressed)) {
      const std::string participant = core::ParticipantIdOf(info.publication_handle);
      const std::string real = participant_->CertifiedIdOf(participant);
      spdlog::warn(
          "basestation {}: a forged message dropped: {}: robot id '{}' sent under the certificate of {} "
          "(participant {}){}",
          options_.base_id, topic, robot_id.substr(0, 64),
          real.empty() ? "another identity" : "'" + real + "'", participant,
          suppressed > 0 ? " (and " + std::to_string(suppressed) + " more since the last warning)" : "");
    }
    return false;
  }
  core::WarningLimiter forged_warnings_;

  // A state word this basestation does not know (fleet/robot_status.h: a newer robot, or a broken one) is
  // shown as the robot said it, and logged at most every 5 s per robot, naming the field and the value.
  void WarnOfUnknownWords(const msgs::RobotState& m, core::SteadyTime now) {
    const std::string why = fleet::CheckStateWords(m);
    std::uint64_t suppressed = 0;
    if (why.empty() || !word_warnings_.Allow(m.robot_id(), now, &suppressed)) return;
    spdlog::warn(
        "basestation {}: robot '{}' reports a state this basestation does not know: {}{}", options_.base_id,
        m.robot_id().substr(0, 64), why,
        suppressed > 0 ? " (and " + std::to_string(suppressed) + " more since the last warning)" : "");
  }
  core::WarningLimiter word_warnings_;

  // False for an observer under DDS Security (no robot to command).
  bool MayCommandAny() const { return !commandable_ || !commandable_->empty(); }

  // "" when this base may command `robot_id` (always without DDS Security), else why not. A commander may
  // send any robot an `e_stop`.
  std::string NotPermittedReason(const std::string& robot_id, bool e_stop = false) const {
    if (!commandable_ || (e_stop && MayCommandAny())) return "";
    for (const std::string& robot : *commandable_) {
      if (robot == "*" || robot == robot_id) return "";
    }
    std::string given;
    for (const std::string& robot : *commandable_) given += (given.empty() ? "" : ", ") + robot;
    return "basestation " + options_.base_id + " may not command " + robot_id +
           " under DDS Security: its permissions (" + options_.security.File("permissions.xml", true) +
           ") give it " + (given.empty() ? std::string("no robot (an observer)") : given);
  }

  // Under DDS Security each robot's command topics are its own (core::CommandTopicFor). Their writers are
  // made once the robot has announced itself, not at the first command: a command, an e-stop above all, then
  // finds its writer made and matched instead of waiting for secure endpoint discovery. Only the commands
  // this basestation may send that robot (the e-stop alone for another commander's robot); none for an
  // observer.
  void MakeCommandWritersFor(const std::vector<RobotView>& views) {
    if (!commandable_) return;  // without security the shared writers are made at start
    for (const RobotView& v : views) {
      if (!v.announced || monitor_.writers_made.count(v.robot_id) > 0) continue;
      monitor_.writers_made.insert(v.robot_id);
      const bool all = NotPermittedReason(v.robot_id).empty();
      const bool e_stop = NotPermittedReason(v.robot_id, true).empty();
      for (const CommandKind& kind : kCommandKinds) {
        if (!all && !(kind.e_stop && e_stop)) continue;
        try {
          kind.make(*this, v.robot_id);
        } catch (const core::DdsError& e) {
          spdlog::warn(
              "basestation {}: a command writer for robot {} not made ahead ({}): made at its first command",
              options_.base_id, v.robot_id, e.what());
        }
      }
    }
  }

  // Waits until the robot's readers matched this base's writers of the commands it may send that robot.
  bool WaitForCommandPath(const std::string& robot_id, double timeout_s) {
    const auto deadline = SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                                                   std::chrono::duration<double>(timeout_s));
    std::string participant;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      auto it = views_.participant_of_robot.find(robot_id);
      if (it != views_.participant_of_robot.end()) participant = it->second;
    }
    if (participant.empty()) return false;  // known by state only (no agent info yet): nothing to wait on
    const bool e_stop_only = !NotPermittedReason(robot_id).empty();
    for (const CommandKind& kind : kCommandKinds) {
      if (e_stop_only && !kind.e_stop) continue;
      if (!kind.matched(*this, robot_id, participant, deadline)) return false;
    }
    return true;
  }

  std::string UnknownRobotReason(const std::string& robot_id) const {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = views_.robots.find(robot_id);
    if (it != views_.robots.end()) {
      return "robot " + robot_id + " is lost (" + WithStaleness(it->second, SteadyClock::now()).lost_reason +
             ")";
    }
    std::string known;
    std::vector<std::string> ids;
    for (const auto& [id, view] : views_.robots) {
      known += (known.empty() ? "" : ", ") + id;
      ids.push_back(id);
    }
    return "unknown robot '" + robot_id + "'" + DidYouMeanText(robot_id, ids) +
           " (known: " + (known.empty() ? "none" : known) + ")";
  }

  FleetClientOptions options_;
  const core::SteadyTime created_ = SteadyClock::now();
  mutable std::mutex mutex_;
  // The operator's events (under mutex_): detected from the views, pending for the next poll, the recent ones
  // kept, and the last event's number.
  struct Events {
    FleetEventDetector detector;
    std::deque<OperatorEvent> pending;
    std::deque<OperatorEvent> recent;
    std::uint64_t seq = 0;
  } events_;
  // The monitor thread (events, probes, announcements, departures) and its stop flag (under mutex_).
  struct Monitor {
    bool stop = false;
    std::thread thread;
    // Under DDS Security: the robots whose command writers the monitor made (monitor thread only).
    std::set<std::string> writers_made;
  } monitor_;
  mutable std::condition_variable cv_;
  // The robots as this basestation sees them (under mutex_): each robot's view, and which agent-info writer
  // and process (ParticipantIdOf) speak for it.
  struct Views {
    std::map<std::string, RobotView> robots;
    std::map<eprosima::fastrtps::rtps::InstanceHandle_t, std::string> by_writer;
    std::map<std::string, eprosima::fastrtps::rtps::InstanceHandle_t> current_writer;  // newest agent info
    std::map<std::string, std::string> participant_of_robot;  // robot id -> its newest process
  } views_;
  // The links' round-trip probes (under mutex_) and what the last announcement said.
  struct Probing {
    LinkMonitor links;
    std::uint32_t last_id = 0;
    int announced_robots_heard = 0;  // MonitorLoop only: the robots_heard of the last Announce
  } probing_;
  // Processes that left: those Fast DDS's discovery thread reported (under `mutex`, taken there: never
  // mutex_), and those whose lease expired here, and when (under mutex_): one removed later stalled, it did
  // not exit. Kept kDroppedKeptS: a robot cut off longer and then shut down cleanly is shown lost rather than
  // left.
  struct Departures {
    std::mutex mutex;
    std::vector<std::pair<std::string, bool>> gone;  // (participant, dropped)
    std::map<std::string, core::SteadyTime> dropped_at;
  } departures_;
  static constexpr double kDroppedKeptS = 600.0;
  // Commands and path requests sent and not yet answered, and their answers (under mutex_).
  struct Awaited {
    std::set<std::string> commands;                        // ResponseKey()s
    std::map<std::string, msgs::CommandResponse> answers;  // answers to `commands` only
    std::set<uint32_t> paths;                              // path request ids
    std::map<uint32_t, msgs::PathResponse> path_answers;   // answers to `paths` only
  } awaited_;
  // The next command request id and teleop sequence number.
  struct Sequences {
    std::atomic<uint32_t> request_id{1};
    std::atomic<uint64_t> teleop{0};
  } sequences_;

  std::unique_ptr<core::Participant> participant_;
  std::unique_ptr<core::Writer<msgs::AgentInfoPubSubType>> info_writer_;
  std::unique_ptr<FleetPerception> perception_;
  // The command writers, by topic name (core::Writer<...>), made on first use.
  struct CommandWriters {
    std::mutex mutex;
    std::map<std::string, std::shared_ptr<void>> by_topic;
  } command_writers_;
  std::unique_ptr<core::Writer<msgs::PingPongPubSubType>> probe_writer_;
  // Yield requests' writers, one per topic (under DDS Security one per robot), made by the first SendYield to
  // it, and the next request's id.
  struct YieldWriters {
    std::mutex mutex;  // guards the two below
    std::map<std::string, std::unique_ptr<core::Writer<msgs::YieldRequestPubSubType>>> by_topic;
    std::uint32_t next_id = 1;
  } yield_;
  // Under DDS Security: the robots this base may command ("*": all; empty: an observer). Unset without it.
  std::optional<std::vector<std::string>> commandable_;
  // What the robots publish and this base reads (reset first: no callback runs while the rest goes).
  struct Readers {
    std::unique_ptr<core::Reader<msgs::PingPongPubSubType>> probe_reply;
    std::unique_ptr<core::Reader<msgs::CommandResponsePubSubType>> response;
    std::unique_ptr<core::Reader<msgs::PathResponsePubSubType>> path_response;
    std::unique_ptr<core::Reader<msgs::GlobalPathPubSubType>> global_path;
    std::unique_ptr<core::Reader<msgs::LocalPlanPubSubType>> local_plan;
    std::unique_ptr<core::Reader<msgs::RobotStatePubSubType>> state;
    std::unique_ptr<core::Reader<msgs::RobotPosePubSubType>> pose;
    std::unique_ptr<core::Reader<msgs::AgentHealthPubSubType>> health;
    std::unique_ptr<core::Reader<msgs::BehaviorTreeStatePubSubType>> tree;
    std::unique_ptr<core::Reader<msgs::AgentInfoPubSubType>> info;
  } readers_;
};

const std::vector<FleetClient::Impl::CommandKind> FleetClient::Impl::kCommandKinds = {
    Kind<msgs::ControlRequestPubSubType>("cairn/control_request"),
    Kind<msgs::ModeRequestPubSubType>("cairn/mode_request"),
    Kind<msgs::WaypointGoalPubSubType>("cairn/waypoint_goal"),
    Kind<msgs::ExploreRequestPubSubType>("cairn/explore_request"),
    Kind<msgs::HomeRequestPubSubType>("cairn/home_request"),
    Kind<msgs::StopRequestPubSubType>("cairn/stop_request"),
    Kind<msgs::RestartRequestPubSubType>("cairn/restart_request"),
    Kind<msgs::ConvoyRequestPubSubType>("cairn/convoy_request")};

FleetClient::FleetClient(const FleetClientOptions& options) : impl_(std::make_unique<Impl>(options)) {}
FleetClient::~FleetClient() = default;

const std::string& FleetClient::base_id() const { return impl_->options_.base_id; }

std::string FleetClient::participant_id() const { return impl_->participant_->participant_id(); }

FleetPerception& FleetClient::perception() { return *impl_->perception_; }

std::vector<OperatorEvent> FleetClient::TakeEvents() {
  std::lock_guard<std::mutex> lock(impl_->mutex_);
  std::vector<OperatorEvent> events(impl_->events_.pending.begin(), impl_->events_.pending.end());
  impl_->events_.pending.clear();
  return events;
}

bool FleetClient::HasEvents() const {
  std::lock_guard<std::mutex> lock(impl_->mutex_);
  return !impl_->events_.pending.empty();
}

std::vector<OperatorEvent> FleetClient::RecentEvents() const {
  std::lock_guard<std::mutex> lock(impl_->mutex_);
  return {impl_->events_.recent.begin(), impl_->events_.recent.end()};
}

std::vector<OperatorEvent> FleetClient::EventsSince(std::uint64_t* cursor) const {
  std::lock_guard<std::mutex> lock(impl_->mutex_);
  std::vector<OperatorEvent> events;
  for (const OperatorEvent& e : impl_->events_.recent) {
    if (e.seq > *cursor) events.push_back(e);
  }
  *cursor = std::max(*cursor, impl_->events_.seq);
  return events;
}

bool FleetClient::Knows(const std::string& robot_id) const {
  std::unique_lock<std::mutex> lock(impl_->mutex_);
  const auto discovered_by =
      impl_->created_ + std::chrono::duration_cast<SteadyClock::duration>(
                            std::chrono::duration<double>(impl_->options_.discovery_s));
  impl_->cv_.wait_until(lock, discovered_by, [&] { return impl_->views_.robots.count(robot_id) > 0; });
  return impl_->views_.robots.count(robot_id) > 0;
}

core::SteadyTime FleetClient::started() const { return impl_->created_; }

core::SteadyTime FleetClient::discovery_end() const {
  return impl_->created_ + std::chrono::duration_cast<SteadyClock::duration>(
                               std::chrono::duration<double>(impl_->options_.discovery_s));
}

std::string FleetClient::UnknownRobotReason(const std::string& robot_id) const {
  return impl_->UnknownRobotReason(robot_id);
}

std::vector<std::string> FleetClient::RobotIds() const {
  std::lock_guard<std::mutex> lock(impl_->mutex_);
  std::vector<std::string> ids;
  for (const auto& [id, view] : impl_->views_.robots) ids.push_back(id);
  return ids;
}

std::vector<RobotView> FleetClient::Robots() const {
  std::lock_guard<std::mutex> lock(impl_->mutex_);
  std::vector<RobotView> views;
  const auto now = SteadyClock::now();
  for (const auto& [id, view] : impl_->views_.robots) views.push_back(impl_->WithStaleness(view, now));
  return views;
}

std::optional<RobotView> FleetClient::Robot(const std::string& robot_id) const {
  std::lock_guard<std::mutex> lock(impl_->mutex_);
  auto it = impl_->views_.robots.find(robot_id);
  if (it == impl_->views_.robots.end()) return std::nullopt;
  return impl_->WithStaleness(it->second, SteadyClock::now());
}

bool FleetClient::WaitForRobot(const std::string& robot_id, double timeout_s) const {
  return impl_->WaitForRobot(robot_id, timeout_s);
}

std::optional<RobotView> FleetClient::WaitUntil(
    const std::string& robot_id, double timeout_s,
    const std::function<bool(const RobotView&)>& predicate) const {
  std::unique_lock<std::mutex> lock(impl_->mutex_);
  const auto deadline = SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                                                 std::chrono::duration<double>(timeout_s));
  std::optional<RobotView> match;
  auto check = [&] {
    auto it = impl_->views_.robots.find(robot_id);
    if (it == impl_->views_.robots.end()) return false;
    RobotView v = impl_->WithStaleness(it->second, SteadyClock::now());
    if (!predicate(v)) return false;
    match = std::move(v);
    return true;
  };
  // Staleness changes without an update, so re-check at least every 100 ms.
  while (!check()) {
    if (SteadyClock::now() >= deadline) return std::nullopt;
    impl_->cv_.wait_until(lock, std::min(deadline, SteadyClock::now() + std::chrono::milliseconds(100)));
  }
  return match;
}

CommandOutcome FleetClient::SendControl(const std::string& robot_id, msgs::CommandKind kind,
                                        msgs::ControlAction action, const std::string& target_base_id) {
  return impl_->Call(robot_id, kind, [&](uint32_t id) {
    msgs::ControlRequest m;
    m.robot_id(robot_id);
    m.base_id(base_id());
    m.request_id(id);
    m.action(action);
    m.target_base_id(target_base_id);
    return impl_->CommandWriter<msgs::ControlRequestPubSubType>("cairn/control_request", robot_id).Write(m);
  });
}

CommandOutcome FleetClient::RequestControl(const std::string& robot_id) {
  return SendControl(robot_id, msgs::COMMAND_KIND_CONTROL_REQUEST, msgs::CONTROL_ACTION_REQUEST);
}

CommandOutcome FleetClient::ReleaseControl(const std::string& robot_id) {
  return SendControl(robot_id, msgs::COMMAND_KIND_CONTROL_RELEASE, msgs::CONTROL_ACTION_RELEASE);
}

CommandOutcome FleetClient::HandOverControl(const std::string& robot_id, const std::string& to_base_id) {
  return SendControl(robot_id, msgs::COMMAND_KIND_CONTROL_HANDOVER, msgs::CONTROL_ACTION_HANDOVER,
                     to_base_id);
}

CommandOutcome FleetClient::DenyControl(const std::string& robot_id, const std::string& to_base_id) {
  return SendControl(robot_id, msgs::COMMAND_KIND_CONTROL_DENY, msgs::CONTROL_ACTION_DENY, to_base_id);
}

CommandOutcome FleetClient::Restart(const std::string& robot_id, const std::string& component) {
  return impl_->Call(robot_id, msgs::COMMAND_KIND_RESTART, [&](uint32_t id) {
    msgs::RestartRequest m;
    m.robot_id(robot_id);
    m.base_id(base_id());
    m.request_id(id);
    m.component_name(component);
    return impl_->CommandWriter<msgs::RestartRequestPubSubType>("cairn/restart_request", robot_id).Write(m);
  });
}

CommandOutcome FleetClient::RequestMode(const std::string& robot_id, const std::string& mode) {
  return impl_->Call(robot_id, msgs::COMMAND_KIND_MODE, [&](uint32_t id) {
    msgs::ModeRequest m;
    m.robot_id(robot_id);
    m.base_id(base_id());
    m.request_id(id);
    m.mode(mode);
    return impl_->CommandWriter<msgs::ModeRequestPubSubType>("cairn/mode_request", robot_id).Write(m);
  });
}

CommandOutcome FleetClient::SendWaypoint(const std::string& robot_id, double x_m, double y_m,
                                         double tolerance_m, double z_m) {
  return impl_->Call(robot_id, msgs::COMMAND_KIND_WAYPOINT, [&](uint32_t id) {
    msgs::WaypointGoal m;
    m.robot_id(robot_id);
    m.base_id(base_id());
    m.request_id(id);
    m.frame_id("map");
    m.x_m(x_m);
    m.y_m(y_m);
    m.tolerance_m(tolerance_m);
    m.z_m(z_m);
    return impl_->CommandWriter<msgs::WaypointGoalPubSubType>("cairn/waypoint_goal", robot_id).Write(m);
  });
}

CommandOutcome FleetClient::SendExplore(const std::string& robot_id,
                                        const std::optional<Eigen::AlignedBox2d>& region_M, double min_z_m,
                                        double max_z_m, double home_after_silence_s) {
  return impl_->Call(robot_id, msgs::COMMAND_KIND_EXPLORE, [&](uint32_t id) {
    msgs::ExploreRequest m;
    m.robot_id(robot_id);
    m.base_id(base_id());
    m.request_id(id);
    m.frame_id("map");
    m.has_region(region_M.has_value());
    if (region_M) {
      m.region_min_x_m(region_M->min().x());
      m.region_min_y_m(region_M->min().y());
      m.region_max_x_m(region_M->max().x());
      m.region_max_y_m(region_M->max().y());
    }
    m.min_z_m(min_z_m);
    m.max_z_m(max_z_m);
    m.home_after_silence_s(home_after_silence_s);
    return impl_->CommandWriter<msgs::ExploreRequestPubSubType>("cairn/explore_request", robot_id).Write(m);
  });
}

CommandOutcome FleetClient::SendConvoy(const std::string& robot_id,
                                       const std::vector<std::string>& ahead_ids) {
  return impl_->Call(robot_id, msgs::COMMAND_KIND_CONVOY, [&](uint32_t id) {
    msgs::ConvoyRequest m;
    m.robot_id(robot_id);
    m.base_id(base_id());
    m.request_id(id);
    m.action(ahead_ids.empty() ? msgs::CONVOY_ACTION_STOP : msgs::CONVOY_ACTION_FOLLOW);
    m.ahead_ids(ahead_ids);
    return impl_->CommandWriter<msgs::ConvoyRequestPubSubType>("cairn/convoy_request", robot_id).Write(m);
  });
}

std::string FleetClient::SendYield(const std::string& robot_id, const std::string& passing_id,
                                   double passing_radius_m,
                                   const std::vector<Eigen::Vector2d>& keep_clear_M) {
  if (std::string why = impl_->NotPermittedReason(robot_id); !why.empty()) return why;
  std::lock_guard<std::mutex> lock(impl_->yield_.mutex);
  // Under DDS Security on the robot's own command topic (only its commanders may write it), else on the topic
  // robots ask one another on. A new writer's first sample would reach only the readers already matched: give
  // discovery a moment.
  const std::string topic =
      core::CommandTopicFor("cairn/yield_request", robot_id, impl_->options_.security.enabled());
  std::unique_ptr<core::Writer<msgs::YieldRequestPubSubType>>& writer = impl_->yield_.by_topic[topic];
  if (!writer) {
    try {
      writer = std::make_unique<core::Writer<msgs::YieldRequestPubSubType>>(*impl_->participant_, topic,
                                                                            "cairn.command");
    } catch (const core::DdsError& e) {
      // Keys made before operators' yield requests had the robot's own topic lack it: make them again.
      return std::string("the yield request cannot be sent: ") + e.what();
    }
    writer->WaitForMatched(1, std::chrono::milliseconds(1500));
  }
  msgs::YieldRequest m;
  m.robot_id(robot_id);
  m.sender_id(base_id());
  m.request_id(impl_->yield_.next_id++);
  m.action(msgs::YIELD_ACTION_ASK);
  m.passing_id(passing_id);
  m.passing_radius_m(static_cast<float>(passing_radius_m));
  for (const Eigen::Vector2d& p : keep_clear_M) {
    msgs::PeerPathPoint q;
    q.x_m(static_cast<float>(p.x()));
    q.y_m(static_cast<float>(p.y()));
    m.keep_clear_M().push_back(q);
  }
  return writer->Write(m) ? "" : "the yield request could not be sent (DDS history full)";
}

CommandOutcome FleetClient::SendHome(const std::string& robot_id,
                                     const std::optional<Eigen::Vector3d>& point_M) {
  return impl_->Call(robot_id, msgs::COMMAND_KIND_HOME, [&](uint32_t id) {
    msgs::HomeRequest m;
    m.robot_id(robot_id);
    m.base_id(base_id());
    m.request_id(id);
    m.frame_id("map");
    m.has_point(point_M.has_value());
    if (point_M) {
      m.x_m(point_M->x());
      m.y_m(point_M->y());
      m.z_m(point_M->z());
    }
    return impl_->CommandWriter<msgs::HomeRequestPubSubType>("cairn/home_request", robot_id).Write(m);
  });
}

CommandOutcome FleetClient::Stop(const std::string& robot_id) {
  return impl_->Call(
      robot_id, msgs::COMMAND_KIND_STOP,
      [&](uint32_t id) {
        msgs::StopRequest m;
        m.robot_id(robot_id);
        m.base_id(base_id());
        m.request_id(id);
        return impl_->CommandWriter<msgs::StopRequestPubSubType>("cairn/stop_request", robot_id).Write(m);
      },
      /*require_live=*/false);
}

bool FleetClient::PublishTeleop(const std::string& robot_id, double linear_x_mps, double angular_z_radps,
                                double linear_y_mps) {
  if (!impl_->NotPermittedReason(robot_id).empty()) return false;
  msgs::TeleopTwist m;
  m.robot_id(robot_id);
  m.base_id(base_id());
  m.sequence_number(++impl_->sequences_.teleop);
  m.stamp(cairn::msgs::WallStampNow());
  m.twist().linear_x_mps(linear_x_mps);
  m.twist().linear_y_mps(linear_y_mps);
  m.twist().angular_z_radps(angular_z_radps);
  return impl_->CommandWriter<msgs::TeleopTwistPubSubType>("cairn/teleop", robot_id, "cairn.teleop").Write(m);
}

PathAnswer FleetClient::RequestPath(const std::string& robot_id, const std::string& platform,
                                    double start_x_m, double start_y_m, double goal_x_m, double goal_y_m) {
  PathAnswer answer;
  const uint32_t request_id = impl_->sequences_.request_id++;
  if (std::string why = impl_->NotPermittedReason(robot_id); !why.empty()) {
    answer.result = outcome::kRefused;
    answer.reason = std::move(why);
    return answer;
  }
  if (!impl_->WaitForRobot(robot_id, impl_->options_.command_timeout_s)) {
    answer.result = outcome::kRefused;
    answer.reason = impl_->UnknownRobotReason(robot_id);
    return answer;
  }
  const auto start = SteadyClock::now();
  std::unique_lock<std::mutex> lock(impl_->mutex_);
  auto send = [&](uint32_t id) {
    msgs::PathRequest m;
    m.request_id(id);
    m.requester_id(base_id());
    m.robot_id(robot_id);
    m.platform(platform);
    m.frame_id("map");
    m.start_M().x_m(start_x_m);
    m.start_M().y_m(start_y_m);
    m.goal_M().x_m(goal_x_m);
    m.goal_M().y_m(goal_y_m);
    return impl_->CommandWriter<msgs::PathRequestPubSubType>("cairn/path_request", robot_id).Write(m);
  };
  impl_->awaited_.paths.insert(request_id);
  const bool answered = impl_->SendUntil(
      robot_id, request_id, send, [&] { return impl_->awaited_.path_answers.count(request_id) > 0; }, &lock,
      &answer.reason);
  impl_->awaited_.paths.erase(request_id);
  if (!answered) {
    answer.result = outcome::kTimedOut;
    return answer;
  }
  answer.response = impl_->awaited_.path_answers[request_id];
  impl_->awaited_.path_answers.erase(request_id);
  answer.round_trip_ms = std::chrono::duration<double, std::milli>(SteadyClock::now() - start).count();
  answer.ok = answer.response.success();
  answer.result = answer.ok ? outcome::kAccepted : outcome::kRefused;
  answer.reason = answer.response.reason();
  return answer;
}

}  // namespace cairn::base
