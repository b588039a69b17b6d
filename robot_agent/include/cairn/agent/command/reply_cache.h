// De-duplication of command retries in the command interface (Sriganesh et al. 2024, § Command Interface).
// A basestation resends a command until it hears the reply; the robot must apply it once and answer every
// copy. A command is identified by the DDS writer that sent it (participant GUID prefix + entity id) and the
// writer's request id: a retry from the same process hits the cache, a command from any other process (a
// restarted basestation, a one-shot CLI call with the same base id, which counts its ids from 1 again)
// never does, so it always runs.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>
#include <tuple>
#include <utility>

namespace cairn::agent {

/// Identity of one command: the sending writer (core::WriterIdOf), the command kind, the writer's request id.
struct CommandKey {
  std::string writer_id;
  uint32_t kind = 0;
  uint32_t request_id = 0;

  bool operator==(const CommandKey& o) const {
    return std::tie(writer_id, kind, request_id) == std::tie(o.writer_id, o.kind, o.request_id);
  }
};

/// The last `capacity` replies, oldest dropped first. Not thread-safe (the agent calls it under its lock).
template <class Reply>
class ReplyCache {
 public:
  /// `capacity`: replies kept, >= 1 (a retry older than that many later commands runs again).
  explicit ReplyCache(std::size_t capacity) : capacity_(capacity < 1 ? 1 : capacity) {}

  /// The reply already given to `key`, or nullptr when this command was never answered (or fell out).
  const Reply* Find(const CommandKey& key) const {
    for (const auto& [k, reply] : replies_) {
      if (k == key) return &reply;
    }
    return nullptr;
  }

  /// Remembers the reply given to `key`.
  void Insert(CommandKey key, Reply reply) {
    replies_.emplace_back(std::move(key), std::move(reply));
    if (replies_.size() > capacity_) replies_.pop_front();
  }

  std::size_t size() const { return replies_.size(); }

 private:
  std::size_t capacity_;
  std::deque<std::pair<CommandKey, Reply>> replies_;
};

}  // namespace cairn::agent
