#include "common/env_steps.h"

#include <gtest/gtest.h>

namespace coins {
namespace {

TEST(EnvStepCount, RestartsAndResumesCountEveryStepOnce) {
  EnvStepCount count;
  // a fresh actor, restarted from 0 (a new incarnation): its steps add up
  count.Report(0, 100, /*incarnation=*/11, /*first_step=*/0);
  count.Report(0, 200, 11, 0);
  count.Report(0, 50, 12, 0);
  EXPECT_EQ(count.total(), 250u);
  EXPECT_EQ(count.last(0), 50u);

  // a resumed actor counts on from its share of the run's steps: that share is the run's
  count.Report(1, 5000, 21, 5000);
  EXPECT_EQ(count.total(), 5250u);
  count.Report(1, 6000, 21, 5000);
  // restarted from a count read before its last report arrived (5800 < 6000): the steps from
  // 5800 to 6000 are not counted twice, and none are lost
  count.Report(1, 5800, 22, 5800);
  EXPECT_EQ(count.total(), 250u + 6000u);
  count.Report(1, 5900, 22, 5800);
  EXPECT_EQ(count.total(), 250u + 6100u);
  // a late report of the replaced incarnation changes nothing
  count.Report(1, 6000, 21, 5000);
  EXPECT_EQ(count.total(), 250u + 6100u);
  // restarted from the count it reached: it simply counts on
  count.Report(1, 5900, 23, 5900);
  count.Report(1, 7000, 23, 5900);
  EXPECT_EQ(count.total(), 250u + 7200u);
  EXPECT_EQ(count.last(1), 7000u);
  // a new incarnation whose first report is already past the old count, from a stale first step
  count.Report(1, 7500, 24, 6800);
  EXPECT_EQ(count.total(), 250u + 7200u + (7500u - 6800u));

  // reports without an incarnation (0) keep the rule "a count that goes back restarted from 0"
  count.Report(2, 40);
  count.Report(2, 10);
  EXPECT_EQ(count.last(2), 10u);
  EXPECT_EQ(count.total(), 250u + 7900u + 50u);
}

TEST(EnvStepCount, ActorSharesAddUpToTheRunsSteps) {
  EXPECT_EQ(ActorShare(10, 0, 3), 4u);
  EXPECT_EQ(ActorShare(10, 1, 3), 3u);
  EXPECT_EQ(ActorShare(10, 2, 3), 3u);
  EXPECT_EQ(ActorShare(7, 0, 1), 7u);
}

}  // namespace
}  // namespace coins
