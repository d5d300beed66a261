// The weighted selector: uniform until a weight is set, then in proportion to the weights;
// nothing when every weight is 0.
#include "replay/selectors/weighted.h"

#include <gtest/gtest.h>

#include <map>

#include "replay/shard.h"
#include "replay/test_rows.h"

namespace coins {
namespace {

using testing::MakeRun;

struct Fixture {
  ReplayOptions options = [] {
    ReplayOptions o;
    o.capacity = 1024;
    o.capacity_mb = 16;
    return o;
  }();
  Shard shard{0, options};
  Fixture() { EXPECT_EQ(shard.Receive(*MakeRun(0, 0, 4, 0)), Shard::Outcome::kStored); }  // rows 1 .. 4
  std::map<uint32_t, int> Draw(int n, uint64_t seed) {
    WeightedSelector selector(shard.store(), shard.priorities());
    std::mt19937_64 rng(seed);
    std::map<uint32_t, int> seen;
    for (int i = 0; i < n; ++i) {
      Pick p;
      EXPECT_EQ(selector.Select(&rng, &p), Selected::kRow);
      seen[p.row]++;
    }
    return seen;
  }
};

TEST(WeightedSelector, IsUniformUntilAWeightIsSet) {
  Fixture f;
  ASSERT_FALSE(f.shard.priorities().has_weights());
  auto seen = f.Draw(25000, 1);
  ASSERT_EQ(seen.size(), 5u);  // the context row too: the sampler redraws it
  for (const auto& [row, n] : seen) EXPECT_NEAR(n, 5000, 300) << "row " << row;
}

TEST(WeightedSelector, DrawsInProportionToTheWeights) {
  Fixture f;
  const double weights[] = {0, 1, 0, 3};
  for (uint64_t row = 1; row <= 4; ++row) f.shard.priorities().SetWeight(row, weights[row - 1]);
  auto seen = f.Draw(20000, 2);
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_NEAR(seen[2], 5000, 250);
  EXPECT_NEAR(seen[4], 15000, 250);
}

TEST(WeightedSelector, AllZeroWeightsAreEmpty) {
  Fixture f;
  for (uint64_t row = 1; row <= 4; ++row) f.shard.priorities().SetWeight(row, 0.0);
  WeightedSelector selector(f.shard.store(), f.shard.priorities());
  std::mt19937_64 rng(3);
  Pick p;
  EXPECT_EQ(selector.Select(&rng, &p), Selected::kEmpty);
}

}  // namespace
}  // namespace coins
