// Reusable per-search arrays for the A* searches (astar.cpp, multilevel.cpp). A search over the robot's map
// needs arrays the size of the map (millions of entries): allocating and zeroing them per plan costs more
// than the search, and on a robot the page faults and unmappings of those allocations stall every other
// thread of the process (the control loop's wakes came up to 1 s late while plans ran on workers). A pool
// keeps a few of them across searches and threads; a search leases one, resets only what it touched, and
// gives it back.
#pragma once

#include <memory>
#include <mutex>
#include <utility>
#include <vector>

namespace cairn::nav::internal {

/// A pool of `Scratch` objects shared by every thread. Lease() hands one out (a new one when the pool is
/// empty); the lease returns it on destruction, keeping at most kKept of them.
template <class Scratch>
class ScratchPool {
 public:
  static constexpr std::size_t kKept = 4;

  class Lease {
   public:
    Lease(ScratchPool* pool, std::unique_ptr<Scratch> scratch) : pool_(pool), scratch_(std::move(scratch)) {}
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    ~Lease() { pool_->Return(std::move(scratch_)); }
    Scratch& operator*() { return *scratch_; }
    Scratch* operator->() { return scratch_.get(); }

   private:
    ScratchPool* pool_;
    std::unique_ptr<Scratch> scratch_;
  };

  Lease Take() {
    std::unique_ptr<Scratch> scratch;
    {
      std::lock_guard<std::mutex> guard(mutex_);
      if (!free_.empty()) {
        scratch = std::move(free_.back());
        free_.pop_back();
      }
    }
    if (!scratch) scratch = std::make_unique<Scratch>();
    return Lease(this, std::move(scratch));
  }

 private:
  void Return(std::unique_ptr<Scratch> scratch) {
    std::lock_guard<std::mutex> guard(mutex_);
    if (free_.size() < kKept) free_.push_back(std::move(scratch));
  }

  std::mutex mutex_;
  std::vector<std::unique_ptr<Scratch>> free_;
};

}  // namespace cairn::nav::internal
