// The uniform selector: every row held equally often, only rows held, nothing from an empty store.
#include "replay/selectors/uniform.h"

#include <gtest/gtest.h>

#include <map>

#include "replay/shard.h"
#include "replay/test_rows.h"

namespace coins {
namespace {

using testing::MakeRun;

ReplayOptions Options(int64_t capacity) {
  ReplayOptions o;
  o.capacity = capacity;
  o.capacity_mb = 16;
  return o;
}

TEST(UniformSelector, PicksEveryRowEquallyOften) {
  Shard shard(0, Options(1024));
  for (uint64_t s = 0; s < 3; ++s) ASSERT_EQ(shard.Receive(*MakeRun(s, 0, 9, float(10 * s))), Shard::Outcome::kStored);
  const ChunkStore& store = shard.store();
  ASSERT_EQ(store.rows(), 30);
  UniformSelector selector(store);
  std::mt19937_64 rng(7);
  std::map<uint64_t, int> seen;  // global row -> picks
  for (int i = 0; i < 30000; ++i) {
    Pick p;
    ASSERT_EQ(selector.Select(&rng, &p), Selected::kRow);
    ASSERT_LT(p.chunk, store.chunks());
    ASSERT_LT(p.row, store.chunk(p.chunk).n_rows);
    EXPECT_DOUBLE_EQ(p.prob, 1.0 / 30);
    seen[store.chunk(p.chunk).row_base + p.row]++;
  }
  // context rows are picked too: the sampler redraws them
  ASSERT_EQ(seen.size(), 30u);
  for (const auto& [row, n] : seen) EXPECT_NEAR(n, 1000, 120) << "row " << row;
}

TEST(UniformSelector, PicksOnlyRowsStillHeld) {
  Shard shard(0, Options(1024));
  // 1024 transitions at most: the first batches leave
  for (uint64_t s = 0; s < 15; ++s)
    ASSERT_EQ(shard.Receive(*MakeRun(s, 0, 99, float(100 * s))), Shard::Outcome::kStored);
  const ChunkStore& store = shard.store();
  ASSERT_GT(store.first_row(), 0u);
  UniformSelector selector(store);
  std::mt19937_64 rng(8);
  uint64_t lowest = ~uint64_t(0), highest = 0;
  for (int i = 0; i < 20000; ++i) {
    Pick p;
    ASSERT_EQ(selector.Select(&rng, &p), Selected::kRow);
    const uint64_t row = store.chunk(p.chunk).row_base + p.row;
    lowest = std::min(lowest, row);
    highest = std::max(highest, row);
  }
  EXPECT_EQ(lowest, store.first_row());
  EXPECT_EQ(highest, store.end_row() - 1);
}

TEST(UniformSelector, AnEmptyStoreIsEmpty) {
  ChunkStore store(1024, 16 << 20);
  UniformSelector selector(store);
  std::mt19937_64 rng(9);
  Pick p;
  EXPECT_EQ(selector.Select(&rng, &p), Selected::kEmpty);
}

}  // namespace
}  // namespace coins
