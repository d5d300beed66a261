// The level index: draws are exactly uniform over the transitions of the asked levels, and
// follow insertions and evictions.
#include "replay/level_index.h"

#include <gtest/gtest.h>

#include <map>

#include "replay/shard.h"
#include "replay/test_rows.h"

namespace coins {
namespace {

using testing::MakeRun;

TEST(LevelIndex, DrawsUniformlyAmongTheAskedLevels) {
  ReplayOptions o;
  o.capacity = 1024;
  o.capacity_mb = 16;
  Shard shard(0, o);
  ASSERT_EQ(shard.Receive(*MakeRun(0, 0, 90, 0)), Shard::Outcome::kStored);
  ASSERT_EQ(shard.Receive(*MakeRun(1, 3, 5, 1000)), Shard::Outcome::kStored);
  ASSERT_EQ(shard.Receive(*MakeRun(2, 2, 30, 2000)), Shard::Outcome::kStored);
  ASSERT_EQ(shard.Receive(*MakeRun(3, 3, 5, 3000)), Shard::Outcome::kStored);
  const LevelIndex& index = shard.levels();
  EXPECT_EQ(index.Count(1u << 0), 90u);
  EXPECT_EQ(index.Count(1u << 3), 10u);
  EXPECT_EQ(index.Count((1u << 2) | (1u << 3)), 40u);

  // level 3 is 10 rows in 125: every draw is one of them, each about equally often
  std::mt19937_64 rng(1);
  std::map<float, int> seen;
  const ChunkStore& store = shard.store();
  std::vector<float> state(1);
  for (int i = 0; i < 20000; ++i) {
    size_t c;
    uint32_t r;
    ASSERT_TRUE(index.Draw(store, 1u << 3, &rng, &c, &r));
    ASSERT_EQ(store.skill_levels(c)[r], 3);
    ASSERT_FALSE(store.flags(c)[r] & msg::ROW_SEGMENT_START);
    store.DecodeRow(c, r, state.data());
    seen[state[0]]++;
  }
  ASSERT_EQ(seen.size(), 10u);
  for (const auto& [s, n] : seen) EXPECT_NEAR(n, 2000, 200) << "row with state " << s;
  size_t c;
  uint32_t r;
  EXPECT_FALSE(index.Draw(store, 1u << 5, &rng, &c, &r));
}

TEST(LevelIndex, FollowsEvictions) {
  ReplayOptions o;
  o.capacity = 1024;
  o.capacity_mb = 16;
  Shard shard(0, o);
  // 1024 transitions at most: the first level-3 batch leaves when the level-0 ones arrive
  ASSERT_EQ(shard.Receive(*MakeRun(0, 3, 20, 0)), Shard::Outcome::kStored);
  for (uint64_t s = 1; s <= 11; ++s)
    ASSERT_EQ(shard.Receive(*MakeRun(s, 0, 100, float(100 * s))), Shard::Outcome::kStored);
  EXPECT_EQ(shard.levels().Count(1u << 3), 0u);
  EXPECT_EQ(shard.levels().Count(1u << 0), uint64_t(shard.store().transitions()));
  std::mt19937_64 rng(2);
  size_t c;
  uint32_t r;
  EXPECT_FALSE(shard.levels().Draw(shard.store(), 1u << 3, &rng, &c, &r));
  for (int i = 0; i < 1000; ++i) {
    ASSERT_TRUE(shard.levels().Draw(shard.store(), 1u << 0, &rng, &c, &r));
    ASSERT_LT(c, shard.store().chunks());
  }
}

}  // namespace
}  // namespace coins
