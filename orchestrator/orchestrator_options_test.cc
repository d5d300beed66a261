// OrchestratorOptions through the config loader, the config fingerprint, and EpochCutter.
#include <gtest/gtest.h>

#include "common/checkpoint.h"
#include "orchestrator/config_values.h"
#include "orchestrator/epoch_cutter.h"
#include "orchestrator/orchestrator_options.h"

namespace coins {
namespace {

// loads YAML text into the orchestrator section and validates; the error message or ""
std::string Load(const std::string& yaml, OrchestratorOptions* o = nullptr) {
  OrchestratorOptions local;
  OrchestratorOptions& opts = o ? *o : local;
  ConfigLoader loader({ConfigSection::Of("orchestrator", opts)});
  Status s = loader.LoadText(yaml, "test");
  if (s.ok()) s = loader.Validate();
  return s.message();
}

TEST(OrchestratorOptions, DefaultsAreValidAndFollowThePaper) {
  OrchestratorOptions o;
  EXPECT_EQ(Load("orchestrator: {}", &o), "");
  EXPECT_EQ(o.eps_si, 3.0);
  EXPECT_EQ(o.n_complete_goals, 3'000);
  EXPECT_EQ(o.primitive_n_complete_goals, 1'000);
  EXPECT_EQ(o.success_tolerance, 0.01);
  EXPECT_EQ(o.detect_every_steps, 10'000);
  EXPECT_EQ(o.detect_budget_steps, 50'000);
}

TEST(OrchestratorOptions, ValuesAreRead) {
  OrchestratorOptions o;
  EXPECT_EQ(Load("orchestrator: {eps_si: 4.5, skill_max_steps: 90000, task_tolerance: 2}", &o), "");
  EXPECT_EQ(o.eps_si, 4.5);
  EXPECT_EQ(o.skill_max_steps, 90'000);
  EXPECT_EQ(o.task_tolerance, 2.0);
}

TEST(OrchestratorOptions, InvalidValuesAreRefusedNamingTheKey) {
  struct Case {
    std::string yaml, key;
  };
  for (const Case& c : std::vector<Case>{
           {"orchestrator: {detect_every_steps: 0}", "orchestrator.detect_every_steps"},
           {"orchestrator: {success_tolerance: 2}", "orchestrator.success_tolerance"},
           {"orchestrator: {skill_steps_per_update: 0}", "orchestrator.skill_steps_per_update"},
           {"orchestrator: {eps_si: .nan}", "orchestrator.eps_si"},
           {"orchestrator: {detect_every_steps: 300000}",
            "detect_every_steps (300000) must not exceed detect_budget_steps"},
           {"orchestrator: {n_complete_goals: 0}", "orchestrator.n_complete_goals"},
           {"orchestrator: {primitive_n_complete_goals: -3}", "orchestrator.primitive_n_complete_goals"},
           {"orchestrator: {skill_learning_starts: 500000}",
            "skill_learning_starts (500000) must be below skill_max_steps"},
           {"orchestrator: {task_min_steps: 2000000}", "task_min_steps (2000000) must not exceed task_max_steps"},
           {"orchestrator: {task_learning_starts: 1000000}", "task_learning_starts"},
           {"orchestrator: {checkpoint_timeout_s: 600}",
            "checkpoint_timeout_s (600) must not exceed checkpoint_period_s"},
           {"orchestrator: {n_complete: 5}", "unknown key 'orchestrator.n_complete'"},
       }) {
    std::string err = Load(c.yaml);
    EXPECT_NE(err.find(c.key), std::string::npos) << c.yaml << " -> " << err;
  }
}

TEST(ConfigValues, FingerprintLeavesOutOperationalKeys) {
  ConfigValues all = {{"dds.domain", "3"},          {"run.dir", "runs/x"},        {"run.steps", "100"},
                      {"run.actors", "2"},          {"run.env", "breakout"},      {"learner.status_period_s", "1"},
                      {"orchestrator.eps_si", "3"}, {"replay.snapshot_dir", "x"}, {"run.shards", "2"}};
  ConfigValues fp = ChainFingerprint(all);
  EXPECT_EQ(fp, (ConfigValues{{"orchestrator.eps_si", "3"}, {"run.env", "breakout"}, {"run.shards", "2"}}));
  EXPECT_EQ(HashConfig(fp), HashConfig(ChainFingerprint(all)));
  ConfigValues other = fp;
  other["run.shards"] = "4";
  EXPECT_NE(HashConfig(fp), HashConfig(other));
  EXPECT_EQ(FirstDifference(other, fp, "runs/x/config.yaml"), "run.shards is 4 here, 2 in runs/x/config.yaml");
  EXPECT_EQ(FirstDifference(fp, fp, "x"), "");
}

using Clock = EpochCutter::Clock;
using std::chrono::seconds;

TEST(EpochCutter, CutsEveryPeriodAndCompletesWhenEveryAckIsIn) {
  Clock::time_point t0{};
  EpochCutter cut(2, seconds(10), seconds(5), 0, t0);
  EXPECT_FALSE(cut.Due(t0 + seconds(9)));
  auto e = cut.Due(t0 + seconds(10));
  ASSERT_TRUE(e);
  EXPECT_EQ(*e, 1u);
  EXPECT_FALSE(cut.Due(t0 + seconds(11)));  // one pending at a time
  const uint64_t id = CheckpointCommandId(1);
  std::string missing;
  EpochAcks acks;
  acks.shards[0] = id;
  EXPECT_EQ(cut.Check(t0 + seconds(11), acks, &missing), EpochCutter::Outcome::kPending);
  EXPECT_EQ(missing, "replay-1, learner");
  acks.shards[1] = id + 5;  // a later checkpoint covers this one
  acks.learner = id;
  EXPECT_EQ(cut.Check(t0 + seconds(12), acks, &missing), EpochCutter::Outcome::kComplete);
  EXPECT_FALSE(cut.pending());
  EXPECT_FALSE(cut.Due(t0 + seconds(19)));
  EXPECT_EQ(cut.Due(t0 + seconds(20)).value_or(0), 2u);
}

TEST(EpochCutter, APhaseChangeCutsAtOnceAndAMissingAckIsAbandonedNotWaitedFor) {
  Clock::time_point t0{};
  EpochCutter cut(1, seconds(100), seconds(5), 7, t0);  // resumed after epoch 7
  cut.RequestCut();
  EXPECT_EQ(cut.Due(t0 + seconds(1)).value_or(0), 8u);
  EXPECT_FALSE(cut.ShouldResend(t0 + seconds(1)));
  EXPECT_TRUE(cut.ShouldResend(t0 + seconds(2)));
  std::string missing;
  EpochAcks acks;
  acks.shards[0] = CheckpointCommandId(8);
  EXPECT_EQ(cut.Check(t0 + seconds(6), acks, &missing), EpochCutter::Outcome::kAbandoned);
  EXPECT_EQ(missing, "learner");
  // retried at the next period with a new number
  EXPECT_FALSE(cut.Due(t0 + seconds(50)));
  EXPECT_EQ(cut.Due(t0 + seconds(101)).value_or(0), 9u);
}

TEST(Checkpoint, CommandIdsAreAboveTimeBasedIdsAndMapBackToTheEpoch) {
  EXPECT_GT(CheckpointCommandId(1), uint64_t(4'000'000'000'000'000'000ULL));
  EXPECT_EQ(CheckpointEpochOf(CheckpointCommandId(42)), 42u);
  EXPECT_EQ(CheckpointEpochOf(12345), 0u);
}

}  // namespace
}  // namespace coins
