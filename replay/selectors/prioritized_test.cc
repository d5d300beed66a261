// The prioritised selector: draws in proportion to priority^alpha, slots mapped back to rows
// after the ring wraps, nothing from zero mass; and the importance weights.
#include "replay/selectors/prioritized.h"

#include <gtest/gtest.h>

#include <map>

#include "replay/shard.h"
#include "replay/test_rows.h"

namespace coins {
namespace {

using testing::MakeRun;

ReplayOptions Options(double alpha) {
  ReplayOptions o;
  o.capacity = 1024;
  o.capacity_mb = 16;
  o.priority_exponent = alpha;
  return o;
}

TEST(PrioritizedSelector, DrawsInProportionToPriorityToTheAlpha) {
  Shard shard(0, Options(0.5));
  ASSERT_EQ(shard.Receive(*MakeRun(0, 0, 4, 0)), Shard::Outcome::kStored);  // rows 1 .. 4 are transitions
  // masses 1, 2, 3, 4 after the exponent 0.5
  for (uint64_t row = 1; row <= 4; ++row) shard.priorities().SetPriority(row, double(row * row));
  PrioritizedSelector selector(shard.store(), shard.priorities());
  std::mt19937_64 rng(3);
  std::map<uint32_t, int> seen;
  for (int i = 0; i < 40000; ++i) {
    Pick p;
    ASSERT_EQ(selector.Select(&rng, &p), Selected::kRow);
    EXPECT_NEAR(p.prob, p.row / 10.0, 1e-12);
    seen[p.row]++;
  }
  EXPECT_EQ(seen.count(0), 0u);  // the context row has no mass
  for (uint32_t row = 1; row <= 4; ++row) EXPECT_NEAR(seen[row], 4000 * row, 250) << "row " << row;
}

TEST(PrioritizedSelector, MapsSlotsBackToRowsAfterTheRingWraps) {
  Shard shard(0, Options(1.0));
  // 46 batches of 100 rows: more rows than the 4096 slots, so slot numbers wrap
  for (uint64_t s = 0; s < 46; ++s)
    ASSERT_EQ(shard.Receive(*MakeRun(s, 0, 99, float(100 * s))), Shard::Outcome::kStored);
  const ChunkStore& store = shard.store();
  const Priorities& prio = shard.priorities();
  ASSERT_GT(store.end_row(), uint64_t(prio.priority_tree().size()));
  // the newest transition holds almost all the mass; its slot is below the oldest row's slot
  const uint64_t hot = store.end_row() - 1;
  ASSERT_LT(prio.Slot(hot), prio.Slot(store.first_row()));
  for (uint64_t row = store.first_row(); row < store.end_row(); ++row)
    shard.priorities().SetPriority(row, row == hot ? 1e9 : 1e-9);
  PrioritizedSelector selector(store, prio);
  std::mt19937_64 rng(4);
  for (int i = 0; i < 100; ++i) {
    Pick p;
    ASSERT_EQ(selector.Select(&rng, &p), Selected::kRow);
    std::vector<float> state(1);
    store.DecodeRow(p.chunk, p.row, state.data());
    EXPECT_EQ(store.chunk(p.chunk).row_base + p.row, hot);
    EXPECT_EQ(state[0], 4599.0f);
  }
}

TEST(PrioritizedSelector, ZeroMassIsEmpty) {
  Shard shard(0, Options(1.0));
  ASSERT_EQ(shard.Receive(*MakeRun(0, 0, 4, 0)), Shard::Outcome::kStored);
  for (uint64_t row = 1; row <= 4; ++row) shard.priorities().SetPriority(row, 0.0);
  PrioritizedSelector selector(shard.store(), shard.priorities());
  std::mt19937_64 rng(5);
  Pick p;
  EXPECT_EQ(selector.Select(&rng, &p), Selected::kEmpty);
}

// a rare level (4 rows among 400) drawn by priority among its own rows only, with the
// probability relative to the level's mass; evicted and unprioritised rows leave with their mass
TEST(PrioritizedLevelSelector, DrawsARareLevelByPriorityAmongItsOwnRows) {
  Shard shard(0, Options(0.5));
  ASSERT_EQ(shard.Receive(*MakeRun(0, 1, 200, 0)), Shard::Outcome::kStored);     // rows 1 .. 200: level 1
  ASSERT_EQ(shard.Receive(*MakeRun(1, 2, 4, 1000)), Shard::Outcome::kStored);    // rows 202 .. 205: level 2
  ASSERT_EQ(shard.Receive(*MakeRun(2, 1, 200, 2000)), Shard::Outcome::kStored);  // level 1 again
  const ChunkStore& store = shard.store();
  // level 2's masses 1, 2, 3, 4 after the exponent; level 1's rows far heavier
  for (uint64_t row = 202; row <= 205; ++row) shard.priorities().SetPriority(row, double((row - 201) * (row - 201)));
  for (uint64_t row = 1; row <= 200; ++row) shard.priorities().SetPriority(row, 1e6);
  EXPECT_NEAR(shard.priorities().LevelMass(1u << 2), 10.0, 1e-9);
  PrioritizedLevelSelector selector(store, shard.priorities(), 1u << 2);
  std::mt19937_64 rng(7);
  std::map<float, int> seen;  // state -> picks
  std::vector<float> state(1);
  for (int i = 0; i < 40000; ++i) {
    Pick p;
    ASSERT_EQ(selector.Select(&rng, &p), Selected::kRow);
    ASSERT_EQ(store.skill_levels(p.chunk)[p.row], 2);
    store.DecodeRow(p.chunk, p.row, state.data());
    const double k = state[0] - 1000.0;  // 1 .. 4
    EXPECT_NEAR(p.prob, k / 10.0, 1e-9);
    seen[state[0]]++;
  }
  ASSERT_EQ(seen.size(), 4u);
  for (const auto& [s, n] : seen) EXPECT_NEAR(n, 4000 * (s - 1000), 250) << "state " << s;
  // levels 1 and 2 together: level 1 holds almost all the mass
  PrioritizedLevelSelector both(store, shard.priorities(), (1u << 1) | (1u << 2));
  int level2 = 0;
  for (int i = 0; i < 2000; ++i) {
    Pick p;
    ASSERT_EQ(both.Select(&rng, &p), Selected::kRow);
    level2 += store.skill_levels(p.chunk)[p.row] == 2;
  }
  EXPECT_LE(level2, 2);
  Pick p;
  EXPECT_EQ(PrioritizedLevelSelector(store, shard.priorities(), 1u << 3).Select(&rng, &p), Selected::kEmpty);
}

TEST(PrioritizedLevelSelector, ALevelsMassLeavesWithItsEvictedRows) {
  Shard shard(0, Options(1.0));
  ASSERT_EQ(shard.Receive(*MakeRun(0, 2, 99, 0)), Shard::Outcome::kStored);
  EXPECT_NEAR(shard.priorities().LevelMass(1u << 2), 99.0, 1e-9) << "new rows: the largest priority, 1";
  // 45 more batches of level 1 push the ring past 4096 slots: level 2's rows are evicted
  for (uint64_t s = 1; s < 46; ++s)
    ASSERT_EQ(shard.Receive(*MakeRun(s, 1, 99, float(100 * s))), Shard::Outcome::kStored);
  ASSERT_GT(shard.store().first_row(), 100u);
  EXPECT_NEAR(shard.priorities().LevelMass(1u << 2), 0.0, 1e-9);
  EXPECT_NEAR(shard.priorities().LevelMass(1u << 1), double(shard.store().transitions()), 1e-6);
  std::mt19937_64 rng(8);
  Pick p;
  EXPECT_EQ(PrioritizedLevelSelector(shard.store(), shard.priorities(), 1u << 2).Select(&rng, &p), Selected::kEmpty);
  PrioritizedLevelSelector level1(shard.store(), shard.priorities(), 1u << 1);
  for (int i = 0; i < 1000; ++i) {
    ASSERT_EQ(level1.Select(&rng, &p), Selected::kRow);
    const uint64_t row = shard.store().chunk(p.chunk).row_base + p.row;
    ASSERT_GE(row, shard.store().first_row());
    ASSERT_EQ(shard.store().skill_levels(p.chunk)[p.row], 1);
  }
}

TEST(ImportanceWeights, AreNormalisedByTheBatchMaximum) {
  const std::vector<double> probs = {0.5, 0.25, 0.125};
  std::vector<float> w(3);
  // (4 p)^-1 = 0.5, 1, 2; the largest is 2
  ImportanceWeights(probs, 4.0, 1.0, w);
  EXPECT_FLOAT_EQ(w[0], 0.25f);
  EXPECT_FLOAT_EQ(w[1], 0.5f);
  EXPECT_FLOAT_EQ(w[2], 1.0f);
  // beta 0: no correction
  ImportanceWeights(probs, 4.0, 0.0, w);
  for (float x : w) EXPECT_FLOAT_EQ(x, 1.0f);
  // beta 0.5: sqrt of the ratios
  ImportanceWeights(probs, 4.0, 0.5, w);
  EXPECT_FLOAT_EQ(w[0], 0.5f);
  EXPECT_FLOAT_EQ(w[1], float(std::sqrt(0.5)));
}

}  // namespace
}  // namespace coins
