// The learner's detect job: how much replay it samples and what a failed round leaves behind.
#include <gtest/gtest.h>

#include "learner/local_run.h"

namespace coins {
namespace {

LocalRunOptions SmallDetector() {
  LocalRunOptions o;
  o.actors = 2;
  o.shards = 1;
  o.seed = 5;
  o.actor.batch_rows = 256;
  o.replay.capacity = 100000;
  o.replay.capacity_mb = 32;
  o.learner.detector.passive_steps = o.learner.detector.passive_hard_steps = 50;
  o.learner.detector.active_steps = 50;
  return o;
}

msg::ChainCommand Detect(uint64_t seq, uint64_t step_base, std::vector<std::string> targets) {
  msg::ChainCommand c;
  c.schema_version(msg::CHAIN_COMMAND_SCHEMA);
  c.seq(seq);
  c.job("detect");
  c.phase("detecting");
  c.source("Action");
  c.targets(targets);
  c.round(1);
  c.step_base(step_base);
  return c;
}

msg::ChainCommand Collect(uint64_t step_base) {
  msg::ChainCommand c = Detect(1, step_base, {});
  c.job("idle");
  c.phase("collecting");
  return c;
}

// actors reach a detect point within a second, faster than their periodic step reports: the
// round still samples everything collected up to the command's step_base (before: the learner's
// stale count of 0 sized the sample at 2 rows, and a target with no held-out row failed the round)
TEST(DetectJob, SamplesWhatWasCollectedEvenWhenTheLearnersStepCountLags) {
  auto made = LocalRun::Create(SmallDetector());
  ASSERT_TRUE(made.ok()) << made.status().message();
  LocalRun& r = **made;
  ASSERT_TRUE(r.Command(Collect(4000)).ok());
  ASSERT_TRUE(r.StepActors(100000).ok());
  ASSERT_EQ(r.env_steps(), 4000u);
  ASSERT_TRUE(r.Command(Detect(2, 4000, {"Paddle", "Ball", "Block"})).ok());
  auto worked = r.LearnerWork(1, /*counted_steps=*/0);
  ASSERT_TRUE(worked.ok()) << worked.status().message();
  ASSERT_EQ(r.scores().size(), 1u);
  for (const auto& s : r.scores()[0].scores()) {
    // held out: about 0.2 of the ~3,500 distinct rows that 8,000 draws from 4,000 find
    EXPECT_GT(s.transitions(), 500u) << s.target();
    EXPECT_LT(s.transitions(), 1000u) << s.target();
  }
}

// a round that fails is reported once and not run again for the same command: the learner stays
// free for the orchestrator's next command instead of repeating a long round
TEST(DetectJob, AFailedRoundIsNotRunAgainForTheSameCommand) {
  auto made = LocalRun::Create(SmallDetector());
  ASSERT_TRUE(made.ok()) << made.status().message();
  LocalRun& r = **made;
  ASSERT_TRUE(r.Command(Collect(2000)).ok());
  ASSERT_TRUE(r.StepActors(100000).ok());
  ASSERT_TRUE(r.Command(Detect(2, 2000, {"Paddle", "Bat"})).ok());
  auto failed = r.LearnerWork(1);
  ASSERT_FALSE(failed.ok());
  EXPECT_NE(failed.status().message().find("Bat"), std::string::npos) << failed.status().message();
  EXPECT_EQ(r.learner().status().state(), "failed");
  auto again = r.LearnerWork(1);
  ASSERT_TRUE(again.ok()) << "the failed round ran again: " << again.status().message();
  EXPECT_EQ(*again, 0);
  EXPECT_TRUE(r.scores().empty());
  // the next round is run
  ASSERT_TRUE(r.Command(Detect(3, 2000, {"Paddle"})).ok());
  auto next = r.LearnerWork(1);
  ASSERT_TRUE(next.ok()) << next.status().message();
  EXPECT_EQ(r.scores().size(), 1u);
}

// a detect round holds Work for the whole training of its models: the progress tick is called
// all through it (every 64 Adam steps), so the learner process keeps its status, checkpoint
// acknowledgements and heartbeat going (before: nothing for the whole round)
TEST(DetectJob, TheProgressTickRunsAllThroughTheModelsTraining) {
  LocalRunOptions o = SmallDetector();
  o.learner.detector.passive_steps = o.learner.detector.passive_hard_steps = 256;
  o.learner.detector.active_steps = 512;
  auto made = LocalRun::Create(o);
  ASSERT_TRUE(made.ok()) << made.status().message();
  LocalRun& r = **made;
  ASSERT_TRUE(r.Command(Collect(2000)).ok());
  ASSERT_TRUE(r.StepActors(100000).ok());
  int ticks = 0, during_detect = 0;
  r.learner().SetProgressTick([&] {
    ++ticks;
    during_detect += r.learner().status().job() == "detect";
  });
  ASSERT_TRUE(r.Command(Detect(2, 2000, {"Paddle"})).ok());
  auto worked = r.LearnerWork(1);
  ASSERT_TRUE(worked.ok()) << worked.status().message();
  ASSERT_EQ(r.scores().size(), 1u);
  // 256 + 256 + 512 Adam steps: 16 checks inside the training alone
  EXPECT_GE(ticks, 16);
  EXPECT_EQ(during_detect, ticks) << "the status says what the learner is doing while it ticks";
}

}  // namespace
}  // namespace coins
