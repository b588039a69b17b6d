#include "cairn/agent/command/reply_cache.h"

#include <gtest/gtest.h>

namespace cairn::agent {
namespace {

TEST(ReplyCache, ARetryFromTheSameWriterHitsAnyOtherWriterMisses) {
  ReplyCache<std::string> cache(4);
  const CommandKey first{"01.0f.aa.aa.00.00.00.01.00.00.00.01.00.00.01.03", 2, 1};
  cache.Insert(first, "denied: outside the map");
  ASSERT_NE(cache.Find(first), nullptr);
  EXPECT_EQ(*cache.Find(first), "denied: outside the map");
  // A new process with the same base id numbers its requests from 1 again.
  const CommandKey new_process{"01.0f.aa.aa.00.00.00.02.00.00.00.01.00.00.01.03", 2, 1};
  EXPECT_EQ(cache.Find(new_process), nullptr);
  EXPECT_EQ(cache.Find(CommandKey{first.writer_id, 3, 1}), nullptr) << "another kind";
  EXPECT_EQ(cache.Find(CommandKey{first.writer_id, 2, 2}), nullptr) << "another request";
}

TEST(ReplyCache, DropsTheOldestBeyondCapacity) {
  ReplyCache<int> cache(2);
  cache.Insert({"w", 0, 1}, 1);
  cache.Insert({"w", 0, 2}, 2);
  cache.Insert({"w", 0, 3}, 3);
  EXPECT_EQ(cache.size(), 2u);
  EXPECT_EQ(cache.Find({"w", 0, 1}), nullptr);
  ASSERT_NE(cache.Find({"w", 0, 3}), nullptr);
  EXPECT_EQ(*cache.Find({"w", 0, 3}), 3);
}

}  // namespace
}  // namespace cairn::agent
