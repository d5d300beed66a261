// The level selector: every pick a transition of the mask's levels, uniformly, with its
// probability; nothing when the mask's levels hold no transition.
#include "replay/selectors/level.h"

#include <gtest/gtest.h>

#include <map>

#include "replay/shard.h"
#include "replay/test_rows.h"

namespace coins {
namespace {

using testing::MakeRun;

TEST(LevelSelector, PicksTransitionsOfTheMasksLevelsUniformly) {
  ReplayOptions o;
  o.capacity = 1024;
  o.capacity_mb = 16;
  Shard shard(0, o);
  ASSERT_EQ(shard.Receive(*MakeRun(0, 0, 80, 0)), Shard::Outcome::kStored);
  ASSERT_EQ(shard.Receive(*MakeRun(1, 2, 4, 1000)), Shard::Outcome::kStored);
  ASSERT_EQ(shard.Receive(*MakeRun(2, 3, 6, 2000)), Shard::Outcome::kStored);
  const ChunkStore& store = shard.store();
  const uint32_t mask = (1u << 2) | (1u << 3);
  LevelSelector selector(store, shard.levels(), mask);
  std::mt19937_64 rng(6);
  std::map<float, int> seen;  // state -> picks
  std::vector<float> state(1);
  for (int i = 0; i < 20000; ++i) {
    Pick p;
    ASSERT_EQ(selector.Select(&rng, &p), Selected::kRow);
    ASSERT_FALSE(store.flags(p.chunk)[p.row] & msg::ROW_SEGMENT_START);
    ASSERT_TRUE(mask >> store.skill_levels(p.chunk)[p.row] & 1u);
    EXPECT_DOUBLE_EQ(p.prob, 0.1);
    store.DecodeRow(p.chunk, p.row, state.data());
    seen[state[0]]++;
  }
  ASSERT_EQ(seen.size(), 10u);
  for (const auto& [s, n] : seen) EXPECT_NEAR(n, 2000, 200) << "state " << s;
  LevelSelector none(store, shard.levels(), 1u << 5);
  Pick p;
  EXPECT_EQ(none.Select(&rng, &p), Selected::kEmpty);
}

}  // namespace
}  // namespace coins
