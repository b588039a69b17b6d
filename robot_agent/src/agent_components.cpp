#include "cairn/agent/agent_components.h"

#include <malloc.h>
#include <spdlog/spdlog.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>
#include <thread>

#include "cairn/agent/modes/mode_manager.h"
#include "cairn/core/shutdown.h"

namespace cairn::agent {

FaultInjection ParseFaultInjection(const std::string& text) {
  const std::string flag = "--inject-fault \"" + text + "\"";
  const auto first = text.find(':');
  const auto second = first == std::string::npos ? std::string::npos : text.find(':', first + 1);
  if (second == std::string::npos)
    throw std::invalid_argument(flag + ": expected COMPONENT:throw|hang|stuck:AFTER_S");
  FaultInjection f;
  f.component = text.substr(0, first);
  const std::string kind = text.substr(first + 1, second - first - 1);
  const std::string after = text.substr(second + 1);
  const std::vector<std::string>& names = AgentComponentNames();
  if (std::find(names.begin(), names.end(), f.component) == names.end()) {
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    throw std::invalid_argument(flag + ": no component \"" + f.component + "\" (the components are " + list +
                                ")");
  }
  if (kind == "throw") {
    f.kind = FaultInjection::Kind::kThrow;
  } else if (kind == "hang" || kind == "stuck") {
    f.kind = kind == "hang" ? FaultInjection::Kind::kHang : FaultInjection::Kind::kStuck;
    if (f.component != "platform" && f.component != "perception" && f.component != "planning") {
      throw std::invalid_argument(
          flag + (kind == "hang" ? ": a hang of " : ": stuck work in ") + f.component +
          " would hang the control cycle, which cannot be restarted within the process "
          "(hang platform, perception or planning)");
    }
  } else {
    throw std::invalid_argument(flag + ": kind \"" + kind + "\" is not throw, hang or stuck");
  }
  std::size_t used = 0;
  double seconds = -1.0;
  try {
    seconds = std::stod(after, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (after.empty() || used != after.size() || !std::isfinite(seconds) || seconds < 0) {
    throw std::invalid_argument(flag + ": AFTER_S \"" + after + "\" is not a number of seconds >= 0");
  }
  f.after_s = seconds;
  return f;
}

FaultInjector::FaultInjector(std::vector<FaultInjection> faults, core::SteadyTime start) : start_(start) {
  for (auto& f : faults) {
    auto p = std::make_unique<Pending>();
    p->fault = std::move(f);
    faults_.push_back(std::move(p));
  }
}

void FaultInjector::Check(const std::string& component) {
  for (auto& p : faults_) {
    if (p->fault.component != component || p->fired.load()) continue;
    if (core::SecondsBetween(start_, core::SteadyClock::now()) < p->fault.after_s) continue;
    if (p->fired.exchange(true)) continue;
    if (p->fault.kind == FaultInjection::Kind::kThrow) {
      spdlog::warn("{}: injected fault: throwing (--inject-fault)", component);
      throw std::runtime_error("injected fault (--inject-fault " + component + ":throw)");
    }
    if (p->fault.kind == FaultInjection::Kind::kStuck) {
      spdlog::warn("{}: injected fault: stuck for good, even at shutdown (--inject-fault)", component);
      while (true) std::this_thread::sleep_for(std::chrono::seconds(1));
    }
    spdlog::warn("{}: injected fault: hanging until the process ends (--inject-fault)", component);
    while (!core::WaitForShutdown(std::chrono::milliseconds(1000))) {
    }
  }
}

std::uint64_t ProcessRssBytes() {
  std::ifstream statm("/proc/self/statm");
  std::uint64_t size_pages = 0, resident_pages = 0;
  if (!(statm >> size_pages >> resident_pages)) return 0;
  return resident_pages * static_cast<std::uint64_t>(sysconf(_SC_PAGESIZE));
}

bool ReturnLargeBlocksWhenFreed(std::size_t threshold_bytes) {
  return mallopt(M_MMAP_THRESHOLD, static_cast<int>(std::min<std::size_t>(threshold_bytes, 32u << 20))) == 1;
}

double ProcessCpuSeconds() {
  timespec ts{};
  if (clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts) != 0) return 0.0;
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace cairn::agent
