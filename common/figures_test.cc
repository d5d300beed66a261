// The summary statistics reports and tables share: median, and mean with the population's or the
// sample's standard deviation.
#include "common/figures.h"

#include <cmath>

#include <gtest/gtest.h>

namespace coins {
namespace {

TEST(FiguresStats, MeanSdPopulationAndSample) {
  const std::vector<double> xs{1.0, 2.0, 3.0, 6.0};
  const MeanAndSd pop = MeanSd(xs);
  EXPECT_DOUBLE_EQ(pop.mean, 3.0);
  EXPECT_DOUBLE_EQ(pop.sd, std::sqrt(14.0 / 4.0));  // squared deviations 4 + 1 + 0 + 9
  const MeanAndSd sample = MeanSd(xs, /*sample=*/true);
  EXPECT_DOUBLE_EQ(sample.mean, 3.0);
  EXPECT_DOUBLE_EQ(sample.sd, std::sqrt(14.0 / 3.0));
  EXPECT_DOUBLE_EQ(MeanSd({5.0}, true).sd, 0.0) << "one value has no sample spread";
  EXPECT_DOUBLE_EQ(MeanSd({}).mean, 0.0);
  EXPECT_DOUBLE_EQ(Median({3.0, 1.0, 2.0, 10.0}), 2.5);
}

}  // namespace
}  // namespace coins
