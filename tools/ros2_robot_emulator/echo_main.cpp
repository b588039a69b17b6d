// Copyright Cairn authors.
//
// cairn_ros2_echo: a ROS 2 subscriber on Eclipse Cyclone DDS that prints every sample of the topics it is
// given as one line of JSON, like `ros2 topic echo`. With the robot emulator it is the implementation that is
// not ours which Cairn is tested against, so it uses no Cairn code and no Fast DDS: Cyclone DDS's C API, the
// types idlc generates from idl/ros2/ros2_msgs.idl, and the emulator's loopback-only DDS node (dds_node.h).
//
// QoS. DDS matches a reader only with writers that offer at least what it requests: a TRANSIENT_LOCAL reader
// ignores VOLATILE writers and a RELIABLE reader ignores BEST_EFFORT ones (Cyclone DDS reports "requested
// incompatible QoS"). So by default (--reliability auto, --durability auto) every topic gets three readers,
// in order of preference: reliable + transient local, reliable + volatile, best effort + volatile. Each
// writer is read through the first of them it matches (the others' copies of its samples are dropped, by
// the sample's publication handle): latched samples from transient-local writers, reliable delivery from
// reliable writers, and best-effort writers still heard. --reliability/--durability pin the QoS instead.
#include <signal.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "cli_values.h"
#include "dds_node.h"
#include "echo_json.h"

namespace ros2_emulator {
namespace {

constexpr const char* kName = "cairn_ros2_echo";
constexpr std::int32_t kReaderDepth = 100;  // KEEP_LAST history of every reader, samples
constexpr double kPollPeriod_s = 0.1;       // the longest wait between two looks at the stop flag

std::atomic<bool> g_stop_requested{false};

extern "C" void OnStopSignal(int /*signal*/) { g_stop_requested = true; }

enum class Reliability { kAuto, kReliable, kBestEffort };
enum class Durability { kAuto, kTransientLocal, kVolatile };

/// One TOPIC:TYPE argument, resolved.
struct TopicSpec {
  std::string ros_name;  // absolute, e.g. "/tf"
  std::string dds_name;  // e.g. "rt/tf"
  const EchoType* type = nullptr;
};

struct EchoOptions {
  bool help = false;
  std::uint32_t domain_id = 0;   // --domain (ROS_DOMAIN_ID when unset, else 0)
  std::string interface_name;    // --interface ("" = loopback only)
  std::uint64_t count = 0;       // --count: exit after this many samples in total; 0 = unlimited
  std::uint64_t count_each = 0;  // --count-each: exit once every topic has this many; 0 = off
  double timeout_s = 30.0;       // --timeout-s: exit after this long; 0 = never
  Reliability reliability = Reliability::kAuto;
  Durability durability = Durability::kAuto;
  std::vector<TopicSpec> topics;
};

std::string Usage() {
  return R"(cairn_ros2_echo: prints ROS 2 messages as JSON lines, like `ros2 topic echo`, on Eclipse Cyclone
DDS (loopback only: 127.0.0.1, no multicast). Run it in a private network namespace (tests/netns_run.sh).

Usage: cairn_ros2_echo [flags] TOPIC:TYPE [TOPIC:TYPE ...]
  TOPIC                 a ROS 2 topic name, e.g. /tf (the DDS topic rt/tf)
  TYPE                  tf2_msgs/TFMessage, nav_msgs/Path, sensor_msgs/PointCloud2, nav_msgs/Odometry,
                        geometry_msgs/Twist, visualization_msgs/MarkerArray (Humble's Marker) or
                        sensor_msgs/CompressedImage (pkg/msg/Type is accepted too)
  --domain N            DDS domain id 0..232 (default: ROS_DOMAIN_ID, else 0)
  --interface NAME      speak DDS on this network interface only, with multicast discovery there
                        (default: loopback only)
  --count K             exit after K samples in total (default: no limit)
  --count-each K        exit once every topic has had K samples (default: off)
  --timeout-s T         exit after T seconds from READY, 0 = never (default 30)
  --reliability R       auto (default), reliable or best_effort
  --durability D        auto (default), transient_local or volatile
                        auto: each writer is read with the strictest QoS it matches (reliable before best
                        effort, transient local before volatile), so latched samples arrive and every writer
                        is heard; a fixed value ignores writers that offer less (stderr says so)
  --help                this text
Every reader keeps the last 100 samples. Prints READY on stdout once all readers exist, then one JSON object
a line per sample: {"topic":"/tf","type":"tf2_msgs/TFMessage",...}; stamps are sec.nanosec, exact.
Exit codes: 0 after --count/--count-each, --timeout-s, SIGINT or SIGTERM; 1 on a DDS failure or when stdout
closes; 2 on a bad flag or argument.
)";
}

TopicSpec ParseTopicSpec(const std::string& argument) {
  const std::size_t colon = argument.find(':');
  if (colon == std::string::npos) {
    throw UsageError(Quote(argument) + " is not TOPIC:TYPE (e.g. /tf:tf2_msgs/TFMessage) nor a flag");
  }
  TopicSpec spec;
  spec.dds_name = RosTopicToDds(Quote(argument) + ":", argument.substr(0, colon));
  spec.ros_name = "/" + spec.dds_name.substr(3);  // "rt/tf" -> "/tf"
  const std::string type_name = argument.substr(colon + 1);
  spec.type = FindEchoType(type_name);
  if (spec.type == nullptr) {
    throw UsageError(Quote(argument) + ": unknown type " + Quote(type_name) + " (known: " + EchoTypeNames() +
                     ")");
  }
  return spec;
}

EchoOptions ParseOptions(int argc, const char* const* argv, const char* ros_domain_id_env) {
  EchoOptions options;
  if (ros_domain_id_env != nullptr && *ros_domain_id_env != '\0') {
    options.domain_id = ParseDomain("ROS_DOMAIN_ID", ros_domain_id_env);
  }
  for (int i = 1; i < argc; ++i) {
    const std::string argument = argv[i];
    if (argument == "--help" || argument == "-h") {
      options.help = true;
      return options;
    }
    if (argument.rfind('-', 0) != 0) {
      TopicSpec spec = ParseTopicSpec(argument);
      for (const TopicSpec& other : options.topics) {
        if (other.dds_name == spec.dds_name) {
          throw UsageError(Quote(argument) + ": topic " + spec.ros_name + " is already given");
        }
      }
      options.topics.push_back(std::move(spec));
      continue;
    }
    static const char* const kValueFlags[] = {"--domain",      "--count",      "--count-each", "--timeout-s",
                                              "--reliability", "--durability", "--interface"};
    if (std::find(std::begin(kValueFlags), std::end(kValueFlags), argument) == std::end(kValueFlags)) {
      throw UsageError("unknown flag " + Quote(argument) + " (see --help)");
    }
    if (i + 1 >= argc) throw UsageError(argument + " needs a value (see --help)");
    const std::string value = argv[++i];
    if (argument == "--domain") {
      options.domain_id = ParseDomain("--domain", value);
    } else if (argument == "--interface") {
      options.interface_name = ParseInterfaceName(argument, value);
    } else if (argument == "--count" || argument == "--count-each") {
      const std::optional<unsigned long long> count = ToUnsigned(value, UINT64_MAX);
      if (!count || *count == 0) throw UsageError(argument + " " + Quote(value) + " must be an integer >= 1");
      (argument == "--count" ? options.count : options.count_each) = *count;
    } else if (argument == "--timeout-s") {
      const std::optional<double> timeout_s = ToDouble(value);
      if (!timeout_s || *timeout_s < 0.0) {
        throw UsageError("--timeout-s " + Quote(value) + " must be a number of seconds >= 0 (0 = never)");
      }
      options.timeout_s = *timeout_s;
    } else if (argument == "--reliability") {
      if (value == "auto") {
        options.reliability = Reliability::kAuto;
      } else if (value == "reliable") {
        options.reliability = Reliability::kReliable;
      } else if (value == "best_effort") {
        options.reliability = Reliability::kBestEffort;
      } else {
        throw UsageError("--reliability " + Quote(value) + " must be auto, reliable or best_effort");
      }
    } else if (argument == "--durability") {
      if (value == "auto") {
        options.durability = Durability::kAuto;
      } else if (value == "transient_local") {
        options.durability = Durability::kTransientLocal;
      } else if (value == "volatile") {
        options.durability = Durability::kVolatile;
      } else {
        throw UsageError("--durability " + Quote(value) + " must be auto, transient_local or volatile");
      }
    }
  }
  if (options.topics.empty()) {
    throw UsageError("no TOPIC:TYPE given (e.g. /tf:tf2_msgs/TFMessage; see --help)");
  }
  return options;
}

/// The QoS of a topic's readers, in order of preference (see the top of this file).
std::vector<EndpointQos> ReaderQos(Reliability reliability, Durability durability) {
  std::vector<EndpointQos> readers;
  for (const bool reliable : {true, false}) {
    if (reliability != Reliability::kAuto && reliable != (reliability == Reliability::kReliable)) continue;
    for (const bool transient_local : {true, false}) {
      if (durability != Durability::kAuto && transient_local != (durability == Durability::kTransientLocal)) {
        continue;
      }
      // Both automatic: no best-effort transient-local reader; ROS 2's latching writers are reliable.
      if (reliability == Reliability::kAuto && durability == Durability::kAuto && !reliable &&
          transient_local) {
        continue;
      }
      readers.push_back({reliable, transient_local, kReaderDepth});
    }
  }
  return readers;
}

std::string QosName(const EndpointQos& qos) {
  return std::string(qos.reliable ? "reliable" : "best_effort") + " " +
         (qos.transient_local ? "transient_local" : "volatile");
}

std::string PolicyName(std::uint32_t policy_id) {
  switch (policy_id) {
    case DDS_RELIABILITY_QOS_POLICY_ID:
      return "reliability";
    case DDS_DURABILITY_QOS_POLICY_ID:
      return "durability";
    default:
      return "policy id " + std::to_string(policy_id);
  }
}

/// A topic's readers and what has come through them.
struct TopicReaders {
  TopicSpec spec;
  std::vector<EndpointQos> qos;                                   // per reader, in order of preference
  std::vector<dds_entity_t> readers;                              // same order
  std::map<dds_instance_handle_t, std::size_t> reader_of_writer;  // by publication handle
  std::uint64_t samples = 0;                                      // printed
  std::uint32_t incompatible_writers = 0;                         // as last reported
};

/// True if `writer` is matched with `reader` now.
bool Matched(dds_entity_t reader, dds_instance_handle_t writer) {
  std::vector<dds_instance_handle_t> handles(16);
  for (;;) {
    const dds_return_t n = dds_get_matched_publications(reader, handles.data(), handles.size());
    if (n < 0) return false;
    if (static_cast<std::size_t>(n) <= handles.size()) {
      return std::find(handles.begin(), handles.begin() + n, writer) != handles.begin() + n;
    }
    handles.resize(static_cast<std::size_t>(n));
  }
}

/// The index of the reader through which samples of `writer` are printed: the first reader (in preference
/// order) it is matched with, decided when its first sample is seen (here, through reader `seen_by`).
/// Cyclone matches a newly discovered writer with the topic's readers one after the other; a sample arriving
/// in between reaches only the readers matched so far, and is lost here if a stricter reader is matched by
/// the time it is taken (a window of microseconds, at discovery only).
std::size_t ReaderOfWriter(TopicReaders& topic, dds_instance_handle_t writer, std::size_t seen_by) {
  const auto known = topic.reader_of_writer.find(writer);
  if (known != topic.reader_of_writer.end()) {
    // A stricter reader can only deliver a writer it matched (late, in a race with the first sample).
    known->second = std::min(known->second, seen_by);
    return known->second;
  }
  std::size_t chosen = seen_by;
  for (std::size_t k = 0; k < seen_by; ++k) {
    if (Matched(topic.readers[k], writer)) {
      chosen = k;
      break;
    }
  }
  topic.reader_of_writer[writer] = chosen;
  std::fprintf(stderr, "%s: %s: a writer, read as %s\n", kName, topic.spec.ros_name.c_str(),
               QosName(topic.qos[chosen]).c_str());
  return chosen;
}

/// Reports writers that not even the topic's least demanding reader can match.
void ReportIncompatibleWriters(TopicReaders& topic) {
  dds_requested_incompatible_qos_status_t status{};
  if (dds_get_requested_incompatible_qos_status(topic.readers.back(), &status) < 0) return;
  if (status.total_count == topic.incompatible_writers) return;
  topic.incompatible_writers = status.total_count;
  std::fprintf(stderr,
               "%s: %s: a writer's QoS is incompatible with this reader's (%s; reader %s): not read. "
               "--reliability auto --durability auto read every writer\n",
               kName, topic.spec.ros_name.c_str(), PolicyName(status.last_policy_id).c_str(),
               QosName(topic.qos.back()).c_str());
}

double MonotonicNow_s() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<double>(now.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec);
}

class Echo {
 public:
  explicit Echo(const EchoOptions& options)
      : options_(options), node_(options.domain_id, options.interface_name) {
    for (const TopicSpec& spec : options.topics) {
      TopicReaders topic;
      topic.spec = spec;
      topic.qos = ReaderQos(options.reliability, options.durability);
      for (const EndpointQos& qos : topic.qos) {
        topic.readers.push_back(node_.CreateReader(spec.dds_name, *spec.type->descriptor, qos));
      }
      topics_.push_back(std::move(topic));
    }
    // One waitset over a read condition per reader (children of the participant, deleted with it).
    const dds_entity_t participant = dds_get_participant(topics_.front().readers.front());
    waitset_ = dds_create_waitset(participant);
    if (waitset_ < 0) throw DdsError(std::string("creating a waitset failed: ") + dds_strretcode(waitset_));
    for (const TopicReaders& topic : topics_) {
      for (const dds_entity_t reader : topic.readers) {
        const dds_entity_t condition = dds_create_readcondition(reader, DDS_ANY_STATE);
        const dds_return_t rc = condition < 0 ? condition : dds_waitset_attach(waitset_, condition, 0);
        if (rc < 0) {
          throw DdsError("attaching a read condition on " + topic.spec.dds_name +
                         " failed: " + dds_strretcode(rc));
        }
      }
    }
  }

  /// Prints samples until a stop condition; returns the exit code.
  int Run() {
    const double start_s = MonotonicNow_s();
    for (;;) {
      if (g_stop_requested) {
        Summary("stopped by a signal");
        return 0;
      }
      double wait_s = kPollPeriod_s;
      if (options_.timeout_s > 0.0) {
        const double remaining_s = start_s + options_.timeout_s - MonotonicNow_s();
        if (remaining_s <= 0.0) {
          Summary("--timeout-s reached");
          return 0;
        }
        wait_s = std::min(wait_s, remaining_s);
      }
      dds_waitset_wait(waitset_, nullptr, 0, static_cast<dds_duration_t>(wait_s * 1e9));
      for (TopicReaders& topic : topics_) {
        ReportIncompatibleWriters(topic);
        if (!TakeAndPrint(topic)) return 1;
        if (Done()) {
          Summary(options_.count > 0 && total_ >= options_.count ? "--count reached"
                                                                 : "--count-each reached");
          return 0;
        }
      }
    }
  }

 private:
  bool Done() const {
    if (options_.count > 0 && total_ >= options_.count) return true;
    if (options_.count_each == 0) return false;
    return std::all_of(topics_.begin(), topics_.end(),
                       [&](const TopicReaders& topic) { return topic.samples >= options_.count_each; });
  }

  /// Takes everything waiting on the topic's readers, stricter readers first, and prints the samples each
  /// writer's chosen reader delivered (until a count is reached). False if stdout failed.
  bool TakeAndPrint(TopicReaders& topic) {
    constexpr std::size_t kMaxSamples = 16;
    for (std::size_t k = 0; k < topic.readers.size(); ++k) {
      for (;;) {
        void* samples[kMaxSamples] = {nullptr};  // nullptr: Cyclone lends its own buffers
        dds_sample_info_t infos[kMaxSamples];
        const dds_return_t n = dds_take(topic.readers[k], samples, infos, kMaxSamples, kMaxSamples);
        if (n <= 0) break;
        bool output_ok = true;
        for (dds_return_t i = 0; i < n && output_ok; ++i) {
          if (!infos[i].valid_data || Done()) continue;
          if (ReaderOfWriter(topic, infos[i].publication_handle, k) != k) continue;  // read through another
          const std::string line = SampleToJson(topic.spec.ros_name, *topic.spec.type, samples[i]) + "\n";
          output_ok =
              std::fwrite(line.data(), 1, line.size(), stdout) == line.size() && std::fflush(stdout) == 0;
          ++topic.samples;
          ++total_;
        }
        dds_return_loan(topic.readers[k], samples, n);
        if (!output_ok) {
          std::fprintf(stderr, "%s: writing to stdout failed: %s\n", kName, std::strerror(errno));
          return false;
        }
        if (static_cast<std::size_t>(n) < kMaxSamples) break;
      }
    }
    return true;
  }

  void Summary(const char* why) const {
    std::string counts;
    for (const TopicReaders& topic : topics_) {
      counts += (counts.empty() ? "" : ", ") + topic.spec.ros_name + " " + std::to_string(topic.samples);
    }
    std::fprintf(stderr, "%s: %s: %llu samples (%s)\n", kName, why, static_cast<unsigned long long>(total_),
                 counts.c_str());
  }

  EchoOptions options_;
  DdsNode node_;
  std::vector<TopicReaders> topics_;
  dds_entity_t waitset_ = 0;
  std::uint64_t total_ = 0;
};

}  // namespace
}  // namespace ros2_emulator

int main(int argc, char** argv) {
  using namespace ros2_emulator;
  EchoOptions options;
  try {
    options = ParseOptions(argc, argv, std::getenv("ROS_DOMAIN_ID"));
  } catch (const UsageError& e) {
    std::fprintf(stderr, "%s: %s\n", kName, e.what());
    return 2;
  }
  if (options.help) {
    std::fputs(Usage().c_str(), stdout);
    return 0;
  }

  // SIGINT/SIGTERM only raise a flag (seen within 0.1 s); a closed stdout is an error, not a signal.
  struct sigaction action {};
  action.sa_handler = OnStopSignal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  signal(SIGPIPE, SIG_IGN);

  try {
    Echo echo(options);
    std::string topics;
    for (const TopicSpec& spec : options.topics) {
      topics += (topics.empty() ? "" : " ") + spec.dds_name + " (" + spec.type->ros_name + ")";
    }
    std::fprintf(stderr, "%s: domain %u, %s\n", kName, options.domain_id, topics.c_str());
    std::fputs("READY\n", stdout);
    std::fflush(stdout);
    return echo.Run();
  } catch (const DdsError& e) {
    std::fprintf(stderr, "%s: %s\n", kName, e.what());
    return 1;
  }
}
