// ChainMachine with scripted scores, skill counts and evaluations (no DDS, no files).
#include "orchestrator/chain_machine.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <set>

#include "orchestrator/chain_store.h"

namespace coins::chain {
namespace {

envs::EnvSpec BreakoutLikeSpec() {
  envs::EnvSpec spec;
  spec.name = "breakout-like";
  auto factor = [](std::string name, int instances, bool multi) {
    envs::FactorSpec f;
    f.name = std::move(name);
    f.features = 2;
    f.instances = instances;
    f.multi_instance = multi;
    return f;
  };
  for (auto f : {factor("Action", 1, false), factor("Paddle", 1, false), factor("Ball", 1, false),
                 factor("Block", 5, true), factor("Done", 1, false), factor("Reward", 1, false)})
    spec.factors.push_back(f);
  return spec;
}

OrchestratorOptions SmallOptions() {
  OrchestratorOptions o;
  o.detect_every_steps = 1000;
  o.detect_budget_steps = 3000;
  o.n_complete_goals = 20;
  o.primitive_n_complete_goals = 20;
  o.success_tolerance = 0.01;
  o.success_window_goals = 10;
  o.skill_min_goals = 40;
  o.skill_max_steps = 50'000;
  o.skill_learning_starts = 100;
  o.skill_steps_per_update = 4;
  o.task_min_steps = 2000;
  o.task_max_steps = 100'000;
  o.task_n_complete_steps = 3000;
  o.task_tolerance = 1.0;
  o.task_learning_starts = 500;
  o.task_steps_per_update = 2;
  return o;
}

Score MakeScore(const std::string& source, const std::string& target, double sc, bool eligible = true) {
  Score s;
  s.source = source;
  s.target = target;
  s.score = sc;
  s.eligible = eligible;
  s.pass = sc > 3.0;
  s.interactions = 12;
  s.goal_interactions = 60;
  s.mask = {1.0f, 0.0f};
  s.goal_kind = "continuous";
  s.goal_set = {-1.0f, 1.0f};
  return s;
}

ScoresReport Answer(const ChainMachine& m, std::vector<Score> scores) {
  ScoresReport r;
  r.command_seq = m.command().seq;
  r.round = m.command().round;
  r.source = m.command().source;
  r.scores = std::move(scores);
  return r;
}

LearnerReport Eval(const ChainMachine& m, uint64_t at, double mean) {
  LearnerReport r;
  r.command_seq = m.command().seq;
  r.job = "train-task";
  r.state = "running";
  r.eval_env_steps = at;
  r.eval_return_mean = mean;
  r.eval_return_sd = 1.0;
  r.eval_episodes = 20;
  return r;
}

struct Chain {
  ChainMachine m{BreakoutLikeSpec(), SmallOptions()};
};

// drives a fresh chain to training-skill with Action->Paddle accepted at 1000 env steps
void AcceptPaddle(ChainMachine& m) {
  ASSERT_TRUE(m.OnEnvSteps(1000));
  ASSERT_TRUE(m.OnScores(Answer(m, {MakeScore("Action", "Paddle", 6.0), MakeScore("Action", "Ball", 1.0)})));
  ASSERT_EQ(m.state().phase, Phase::kTrainingSkill);
}

// feeds one window of 10 goals of level `level` with `reached` successes, at env steps `at`
void Window(ChainMachine& m, int level, uint64_t at, uint64_t reached, uint64_t* started, uint64_t* got) {
  m.OnEnvSteps(at);
  *started += 10;
  *got += reached;
  m.OnSkillCounts(level, *started, *got);
}

TEST(ChainMachine, FreshChainCollectsRandomActionData) {
  Chain c;
  Command cmd = c.m.command();
  EXPECT_EQ(cmd.seq, 1u);
  EXPECT_EQ(cmd.phase, "collecting");
  EXPECT_EQ(cmd.job, "idle");
  EXPECT_EQ(cmd.source, "Action");
  EXPECT_EQ(cmd.acting_level, 0);
  EXPECT_EQ(cmd.step_base, 1000u);
  EXPECT_EQ(cmd.steps_per_update, 0.0);
  EXPECT_EQ(cmd.step_limit, 0u);
  EXPECT_EQ(c.m.Targets(), (std::vector<std::string>{"Paddle", "Ball", "Block"}));
}

TEST(ChainMachine, DetectsAtTheDetectPointWithEveryUncontrolledTarget) {
  Chain c;
  EXPECT_FALSE(c.m.OnEnvSteps(999));
  EXPECT_TRUE(c.m.OnEnvSteps(1000));
  Command cmd = c.m.command();
  EXPECT_EQ(cmd.seq, 2u);
  EXPECT_EQ(cmd.phase, "detecting");
  EXPECT_EQ(cmd.job, "detect");
  EXPECT_EQ(cmd.round, 1u);
  EXPECT_EQ(cmd.targets, (std::vector<std::string>{"Paddle", "Ball", "Block"}));
  EXPECT_EQ(cmd.step_base, 1000u);  // actors wait while the round is scored
  EXPECT_EQ(cmd.steps_per_update, 0.0);
  EXPECT_FALSE(c.m.OnEnvSteps(5000));  // more steps change nothing while detecting
  EXPECT_EQ(c.m.command().seq, 2u);
}

TEST(ChainMachine, AcceptsTheArgmaxOfEligiblePassingScores) {
  Chain c;
  c.m.OnEnvSteps(1000);
  // Block scores highest but is a multi-instance class (even when marked eligible); Ball is
  // higher than Paddle but not eligible
  ASSERT_TRUE(c.m.OnScores(Answer(c.m, {MakeScore("Action", "Ball", 8.0, false), MakeScore("Action", "Paddle", 4.5),
                                        MakeScore("Action", "Block", 9.0, true), MakeScore("Action", "Reward", 9.5)})));
  Command cmd = c.m.command();
  EXPECT_EQ(cmd.phase, "training-skill");
  EXPECT_EQ(cmd.job, "train-skill");
  ASSERT_EQ(cmd.links.size(), 1u);
  EXPECT_EQ(cmd.links[0].source, "Action");
  EXPECT_EQ(cmd.links[0].target, "Paddle");
  EXPECT_EQ(cmd.links[0].score, 4.5);
  EXPECT_EQ(cmd.links[0].mask, (std::vector<float>{1.0f, 0.0f}));
  EXPECT_EQ(cmd.acting_level, 1);
  EXPECT_EQ(cmd.step_base, 1000u + 100u);  // phase start + skill_learning_starts
  EXPECT_EQ(cmd.steps_per_update, 4.0);
  EXPECT_EQ(cmd.step_limit, 1000u + 50'000u);  // phase start + skill budget
  EXPECT_EQ(c.m.state().links[0].accepted_at_steps, 1000u);
  EXPECT_EQ(c.m.state().last_scores.size(), 4u);
  EXPECT_NE(c.m.state().note.find("Action->Paddle accepted in round 1: Sc_I 4.50 > eps_SI 3 (12 detections; mask and "
                                  "goal set from 60)"),
            std::string::npos)
      << c.m.state().note;
}

TEST(ChainMachine, PicksTheHighestOfSeveralPassingTargets) {
  Chain c;
  c.m.OnEnvSteps(1000);
  ASSERT_TRUE(c.m.OnScores(Answer(c.m, {MakeScore("Action", "Paddle", 4.0), MakeScore("Action", "Ball", 5.0)})));
  EXPECT_EQ(c.m.command().links.at(0).target, "Ball");
}

TEST(ChainMachine, ScoreAtTheThresholdDoesNotPass) {
  Chain c;
  c.m.OnEnvSteps(1000);
  ASSERT_TRUE(c.m.OnScores(Answer(c.m, {MakeScore("Action", "Paddle", 3.0), MakeScore("Action", "Ball", NAN)})));
  EXPECT_EQ(c.m.state().phase, Phase::kCollecting);
  EXPECT_TRUE(c.m.state().links.empty());
}

TEST(ChainMachine, BelowThresholdCollectsOneMoreIncrementWhileTheBudgetLasts) {
  Chain c;  // budget 3000, increments of 1000: rounds at 1000, 2000, 3000
  for (uint64_t point : {1000u, 2000u, 3000u}) {
    ASSERT_TRUE(c.m.OnEnvSteps(point)) << point;
    ASSERT_EQ(c.m.command().round, point / 1000);
    ASSERT_TRUE(c.m.OnScores(Answer(c.m, {MakeScore("Action", "Paddle", 2.0)})));
    if (point < 3000) {
      EXPECT_EQ(c.m.state().phase, Phase::kCollecting);
      EXPECT_EQ(c.m.command().step_base, point + 1000);
    }
  }
  // no link and the budget is spent: the chain ends without a task
  Command cmd = c.m.command();
  EXPECT_EQ(cmd.phase, "done");
  EXPECT_EQ(cmd.job, "idle");
  EXPECT_EQ(cmd.step_limit, 3000u);
  EXPECT_EQ(cmd.step_base, 3000u);
  EXPECT_NE(c.m.state().note.find("detect budget"), std::string::npos) << c.m.state().note;
}

TEST(ChainMachine, StaleAndDuplicateScoresAreIgnored) {
  Chain c;
  c.m.OnEnvSteps(1000);
  ScoresReport good = Answer(c.m, {MakeScore("Action", "Paddle", 6.0)});
  ScoresReport old_seq = good, old_round = good, other_source = good;
  old_seq.command_seq -= 1;
  old_round.round += 1;
  other_source.source = "Paddle";
  EXPECT_FALSE(c.m.OnScores(old_seq));
  EXPECT_FALSE(c.m.OnScores(old_round));
  EXPECT_FALSE(c.m.OnScores(other_source));
  EXPECT_EQ(c.m.state().phase, Phase::kDetecting);
  EXPECT_EQ(c.m.state().ignored_scores, 3u);
  ASSERT_TRUE(c.m.OnScores(good));
  Command after = c.m.command();
  EXPECT_FALSE(c.m.OnScores(good));  // a duplicate of the answer already acted on
  EXPECT_EQ(c.m.command(), after);
  EXPECT_EQ(c.m.state().links.size(), 1u);
}

TEST(ChainMachine, SkillConvergesWhenSuccessStopsImprovingAfterTheMinimum) {
  Chain c;
  AcceptPaddle(c.m);  // windows of 10 goals; at least 40 goals; n_complete 20 goals
  uint64_t started = 0, got = 0;
  c.m.OnSkillCounts(1, 0, 0);               // the base of the first window
  Window(c.m, 1, 1200, 5, &started, &got);  // 0.5: best at 10 goals
  Window(c.m, 1, 1400, 9, &started, &got);  // 0.9: best at 20 goals
  Window(c.m, 1, 1600, 9, &started, &got);  // 0.9: no rise, 30 goals
  EXPECT_EQ(c.m.state().phase, Phase::kTrainingSkill);
  EXPECT_FALSE(c.m.OnEnvSteps(2999));       // env steps alone never converge a skill
  Window(c.m, 1, 3000, 9, &started, &got);  // 40 goals, 20 since the best
  EXPECT_EQ(c.m.state().links[0].success.best_at, 1400u);
  EXPECT_EQ(c.m.state().links[0].success.best_at_goals, 20u);
  EXPECT_DOUBLE_EQ(c.m.state().links[0].success.best, 0.9);
  const Link& l = c.m.state().links[0];
  EXPECT_EQ(l.learned_by, "converged");
  EXPECT_EQ(l.learned_at_steps, 3000u);
  Command cmd = c.m.command();
  EXPECT_EQ(cmd.phase, "collecting");
  EXPECT_EQ(cmd.source, "Paddle");
  EXPECT_EQ(cmd.acting_level, 1);   // the Paddle skill runs with random goals
  EXPECT_EQ(cmd.step_base, 4000u);  // learned at 3000 + detect_every_steps
  EXPECT_EQ(c.m.Targets(), (std::vector<std::string>{"Ball", "Block"}));
}

// the first skill (over primitive actions) has its own patience; the skills above it the other
TEST(ChainMachine, TheFirstSkillConvergesByItsOwnPatience) {
  OrchestratorOptions o = SmallOptions();
  o.primitive_n_complete_goals = 10;
  o.n_complete_goals = 40;
  ChainMachine m(BreakoutLikeSpec(), o);
  AcceptPaddle(m);
  uint64_t started = 0, got = 0;
  m.OnSkillCounts(1, 0, 0);
  Window(m, 1, 1200, 5, &started, &got);
  Window(m, 1, 1400, 7, &started, &got);
  Window(m, 1, 1600, 9, &started, &got);  // best at 30 goals
  ASSERT_EQ(m.state().phase, Phase::kTrainingSkill);
  Window(m, 1, 1800, 9, &started, &got);  // 40 goals (the minimum), 10 since the best
  ASSERT_EQ(m.state().phase, Phase::kCollecting);
  EXPECT_EQ(m.state().links[0].learned_at_steps, 1800u);
  ASSERT_TRUE(m.OnEnvSteps(2800));
  ASSERT_TRUE(m.OnScores(Answer(m, {MakeScore("Paddle", "Ball", 50.0)})));
  ASSERT_EQ(m.state().links.size(), 2u);
  started = got = 0;
  m.OnSkillCounts(2, 0, 0);
  Window(m, 2, 3000, 5, &started, &got);  // best at 10 goals
  for (uint64_t at : {3200, 3400, 3600}) Window(m, 2, at, 5, &started, &got);
  EXPECT_EQ(m.state().phase, Phase::kTrainingSkill) << "40 goals, 30 since the best: patience 40, not 10";
  Window(m, 2, 3800, 5, &started, &got);  // 50 goals, 40 since the best
  EXPECT_EQ(m.state().phase, Phase::kTask);
  EXPECT_EQ(m.state().links[1].learned_at_steps, 3800u);
}

TEST(ChainMachine, SmallRisesBelowTheToleranceDoNotResetConvergence) {
  Chain c;
  AcceptPaddle(c.m);
  uint64_t started = 0, got = 0;
  c.m.OnSkillCounts(1, 0, 0);
  Window(c.m, 1, 1500, 9, &started, &got);  // 0.9 at 1500 (10 goals)
  c.m.OnEnvSteps(2500);
  started += 1000;  // a large window: 0.905, a rise below 0.01
  got += 905;
  EXPECT_TRUE(c.m.OnSkillCounts(1, started, got));
  EXPECT_EQ(c.m.state().links[0].success.best_at, 1500u);
  EXPECT_EQ(c.m.state().links[0].learned_by, "converged");
}

TEST(ChainMachine, SkillWithoutMeasuredSuccessEndsOnlyAtItsBudget) {
  Chain c;
  AcceptPaddle(c.m);
  EXPECT_FALSE(c.m.OnEnvSteps(1000 + 49'999));
  EXPECT_TRUE(c.m.OnEnvSteps(1000 + 50'000));
  EXPECT_EQ(c.m.state().links[0].learned_by, "budget");
  EXPECT_NE(c.m.state().note.find("budget"), std::string::npos) << c.m.state().note;
  EXPECT_EQ(c.m.state().phase, Phase::kCollecting);
}

TEST(ChainMachine, SuccessWindowsRebaseWhenCountsDrop) {
  SuccessTracker t;
  EXPECT_FALSE(UpdateSuccess(t, 100, 50, 10, 10, 0.01));  // base
  EXPECT_TRUE(UpdateSuccess(t, 110, 58, 20, 10, 0.01));   // 8 of 10
  EXPECT_DOUBLE_EQ(t.rate, 0.8);
  EXPECT_FALSE(UpdateSuccess(t, 5, 1, 30, 10, 0.01));   // an actor restarted: new base
  EXPECT_FALSE(UpdateSuccess(t, 14, 1, 40, 10, 0.01));  // 9 goals: window still open
  EXPECT_TRUE(UpdateSuccess(t, 15, 2, 50, 10, 0.01));   // 1 of 10
  EXPECT_DOUBLE_EQ(t.rate, 0.1);
  EXPECT_DOUBLE_EQ(t.best, 0.8);
  EXPECT_EQ(t.best_at, 20u);
  EXPECT_EQ(t.windows, 2u);
}

// Paddle learned at 3000 (budgets small); then Paddle's rounds fail until its budget ends
void ReachTask(ChainMachine& m) {
  AcceptPaddle(m);
  uint64_t started = 0, got = 0;
  m.OnSkillCounts(1, 0, 0);
  for (uint64_t at : {1500u, 2000u, 2500u, 3000u}) Window(m, 1, at, 9, &started, &got);  // 40 goals: converged
  ASSERT_EQ(m.state().phase, Phase::kCollecting);
  for (uint64_t point : {4000u, 5000u, 6000u}) {
    ASSERT_TRUE(m.OnEnvSteps(point));
    ASSERT_TRUE(m.OnScores(Answer(m, {MakeScore("Paddle", "Ball", 1.0), MakeScore("Paddle", "Block", 2.0)})));
  }
  ASSERT_EQ(m.state().phase, Phase::kTask);
}

TEST(ChainMachine, TaskTrainsOverTheLastSkillAndConvergesOnTheEvalReturn) {
  Chain c;
  ReachTask(c.m);
  Command cmd = c.m.command();
  EXPECT_EQ(cmd.job, "train-task");
  EXPECT_EQ(cmd.acting_level, 2);
  EXPECT_EQ(cmd.step_base, 6000u + 500u);
  EXPECT_EQ(cmd.steps_per_update, 2.0);
  EXPECT_EQ(cmd.step_limit, 6000u + 100'000u);
  // an evaluation of another command does not count for the task
  LearnerReport stale = Eval(c.m, 6500, 50.0);
  stale.command_seq -= 1;
  c.m.OnLearner(stale);
  EXPECT_EQ(c.m.state().task.evals, 0u);
  LearnerReport skill_eval = Eval(c.m, 6600, 40.0);  // a skill's evaluation is not the task's
  skill_eval.job = "train-skill";
  c.m.OnLearner(skill_eval);
  EXPECT_EQ(c.m.state().eval.env_steps, 6500u);
  c.m.OnEnvSteps(7000);
  c.m.OnLearner(Eval(c.m, 7000, 10.0));
  c.m.OnEnvSteps(8000);
  c.m.OnLearner(Eval(c.m, 8000, 20.0));  // best at 8000
  c.m.OnEnvSteps(9000);
  c.m.OnLearner(Eval(c.m, 9000, 20.5));  // within the tolerance of 1.0
  EXPECT_EQ(c.m.state().task.best_at, 8000u);
  EXPECT_DOUBLE_EQ(c.m.state().eval.mean, 20.5);
  EXPECT_FALSE(c.m.OnEnvSteps(10'999));
  EXPECT_TRUE(c.m.OnEnvSteps(11'000));  // 3000 steps without a rise, 5000 in phase
  cmd = c.m.command();
  EXPECT_EQ(cmd.phase, "done");
  EXPECT_EQ(cmd.step_limit, 11'000u);
  EXPECT_EQ(cmd.acting_level, 2);
  EXPECT_NE(c.m.state().note.find("converged"), std::string::npos) << c.m.state().note;
}

TEST(ChainMachine, TaskEndsAtItsBudget) {
  Chain c;
  ReachTask(c.m);
  EXPECT_FALSE(c.m.OnEnvSteps(6000 + 99'999));
  EXPECT_TRUE(c.m.OnEnvSteps(6000 + 100'000));
  EXPECT_EQ(c.m.state().phase, Phase::kDone);
  EXPECT_NE(c.m.state().note.find("budget"), std::string::npos) << c.m.state().note;
}

TEST(ChainMachine, AFailedSkillJobDropsItsLinkAndEndsTheChain) {
  Chain c;
  AcceptPaddle(c.m);
  LearnerReport r;
  r.command_seq = c.m.command().seq;
  r.job = "train-skill";
  r.state = "failed";
  r.message = "diverged";
  ASSERT_TRUE(c.m.OnLearner(r));
  EXPECT_EQ(c.m.state().phase, Phase::kDone);
  EXPECT_TRUE(c.m.state().links.empty());
  EXPECT_NE(c.m.state().note.find("diverged"), std::string::npos);
}

TEST(ChainMachine, AFailedDetectRoundCountsAsNoPass) {
  Chain c;
  c.m.OnEnvSteps(1000);
  LearnerReport r;
  r.command_seq = c.m.command().seq;
  r.job = "detect";
  r.state = "failed";
  r.message = "too few samples";
  ASSERT_TRUE(c.m.OnLearner(r));
  EXPECT_EQ(c.m.state().phase, Phase::kCollecting);
  EXPECT_EQ(c.m.command().step_base, 2000u);
}

TEST(ChainMachine, ScoresThatNeverArriveAreAskedForAgain) {
  Chain c;
  c.m.OnEnvSteps(1000);
  LearnerReport r;
  r.command_seq = c.m.command().seq;
  r.job = "detect";
  r.state = "done";
  r.scores_round = 1;
  EXPECT_FALSE(c.m.OnLearner(r));
  EXPECT_FALSE(c.m.OnLearner(r));
  EXPECT_TRUE(c.m.OnLearner(r));
  EXPECT_EQ(c.m.command().round, 2u);
  EXPECT_EQ(c.m.command().seq, 3u);
  EXPECT_EQ(c.m.command().step_base, 1000u);  // the same data, scored again
}

// the first round of the next source: a learner that starts scoring it still reports the round
// of the previous source's scores (1) until it publishes this one's; that is no lost answer
TEST(ChainMachine, ALearnerStillScoringIsNotTakenForLostScores) {
  Chain c;
  AcceptPaddle(c.m);
  uint64_t started = 0, got = 0;
  c.m.OnSkillCounts(1, 0, 0);
  for (uint64_t at : {1200, 1400, 1600, 3000}) Window(c.m, 1, at, 9, &started, &got);
  ASSERT_EQ(c.m.state().phase, Phase::kCollecting);
  ASSERT_TRUE(c.m.OnEnvSteps(4000));
  ASSERT_EQ(c.m.state().phase, Phase::kDetecting);
  const Command cmd = c.m.command();
  ASSERT_EQ(cmd.source, "Paddle");
  ASSERT_EQ(cmd.round, 1u);
  LearnerReport r;
  r.command_seq = cmd.seq;
  r.job = "detect";
  r.state = "running";
  r.scores_round = 1;  // Action's round 1
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(c.m.OnLearner(r));
  EXPECT_EQ(c.m.command().seq, cmd.seq);
  EXPECT_EQ(c.m.command().round, 1u);
  // the answer then comes and is taken
  ASSERT_TRUE(c.m.OnScores(Answer(c.m, {MakeScore("Paddle", "Ball", 50.0)})));
  EXPECT_EQ(c.m.state().links.back().spec.target, "Ball");
}

// only Block (a multi-instance class, never a skill's goal) is left beside the learned Paddle:
// no round could accept a link, so the chain ends as the skill is learned
TEST(ChainMachine, NoTargetASkillCouldControlEndsTheChainAsTheSkillIsLearned) {
  envs::EnvSpec spec = BreakoutLikeSpec();
  spec.factors.erase(spec.factors.begin() + 2);  // Ball
  ChainMachine m(spec, SmallOptions());
  AcceptPaddle(m);
  m.OnSkillCounts(1, 0, 0);
  ASSERT_TRUE(m.OnEnvSteps(1000 + 50'000));  // skill budget
  EXPECT_EQ(m.state().phase, Phase::kTask);
  EXPECT_EQ(m.state().source, "Paddle");
  EXPECT_NE(m.state().note.find("no target a skill could control remains"), std::string::npos) << m.state().note;
  EXPECT_EQ(m.command().acting_level, 2);  // the task over the Paddle skill
}

TEST(ChainMachine, RestoreRefusesAStateThatDoesNotFitTheSpec) {
  ChainState s;
  s.source = "Gripper";
  auto m = ChainMachine::Restore(BreakoutLikeSpec(), SmallOptions(), s);
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.status().message().find("Gripper"), std::string::npos);
  s.source = "Action";
  s.phase = Phase::kTask;
  EXPECT_FALSE(ChainMachine::Restore(BreakoutLikeSpec(), SmallOptions(), s).ok());
}

// every step of a whole chain; after each, a machine restored from the persisted (JSON) state
// must hold the same command and react to the next input exactly like the original
TEST(ChainMachine, ResumeFromThePersistedStateAtEveryPhaseGivesTheSameNextCommand) {
  using Step = std::function<void(ChainMachine&)>;
  std::vector<Step> script = {
      [](ChainMachine& m) { m.OnEnvSteps(500); },
      [](ChainMachine& m) { m.OnEnvSteps(1000); },                                           // detecting
      [](ChainMachine& m) { m.OnScores(Answer(m, {MakeScore("Action", "Paddle", 2.0)})); },  // collecting
      [](ChainMachine& m) { m.OnEnvSteps(2000); },
      [](ChainMachine& m) { m.OnScores(Answer(m, {MakeScore("Action", "Paddle", 6.0)})); },  // training
      [](ChainMachine& m) { m.OnSkillCounts(1, 0, 0); },
      [](ChainMachine& m) { m.OnEnvSteps(2500); },
      [](ChainMachine& m) { m.OnSkillCounts(1, 10, 9); },
      [](ChainMachine& m) { m.OnSkillCounts(1, 15, 14); },
      [](ChainMachine& m) { m.OnSkillCounts(1, 30, 27); },
      [](ChainMachine& m) { m.OnEnvSteps(4500); },
      [](ChainMachine& m) { m.OnSkillCounts(1, 40, 36); },  // converged: collecting for Paddle
      [](ChainMachine& m) { m.OnEnvSteps(5500); },          // detecting Paddle
      [](ChainMachine& m) { m.OnScores(Answer(m, {MakeScore("Paddle", "Ball", 1.0)})); },
      [](ChainMachine& m) { m.OnEnvSteps(6500); },
      [](ChainMachine& m) { m.OnScores(Answer(m, {MakeScore("Paddle", "Ball", 1.0)})); },
      [](ChainMachine& m) { m.OnEnvSteps(7500); },
      [](ChainMachine& m) { m.OnScores(Answer(m, {MakeScore("Paddle", "Ball", 1.0)})); },  // task
      [](ChainMachine& m) { m.OnEnvSteps(8000); },
      [](ChainMachine& m) { m.OnLearner(Eval(m, 8000, 5.0)); },
      [](ChainMachine& m) { m.OnEnvSteps(12'000); },  // done
      [](ChainMachine& m) { m.OnEnvSteps(13'000); },
  };
  Chain c;
  std::set<std::string> phases;
  for (size_t i = 0; i + 1 < script.size(); ++i) {
    script[i](c.m);
    phases.insert(c.m.command().phase);
    auto json = StateToJson(c.m.state());
    auto state = StateFromJson(nlohmann::json::parse(json.dump()));
    ASSERT_TRUE(state.ok()) << state.status().message();
    ASSERT_EQ(*state, c.m.state()) << "step " << i;
    auto resumed = ChainMachine::Restore(BreakoutLikeSpec(), SmallOptions(), *state);
    ASSERT_TRUE(resumed.ok()) << resumed.status().message();
    EXPECT_EQ(resumed->command(), c.m.command()) << "step " << i;
    // the next input, to a copy of the original and to the resumed machine
    ChainMachine original = c.m;
    script[i + 1](original);
    script[i + 1](*resumed);
    EXPECT_EQ(resumed->command(), original.command()) << "after step " << i + 1;
    EXPECT_EQ(resumed->state(), original.state()) << "after step " << i + 1;
  }
  EXPECT_EQ(phases, (std::set<std::string>{"collecting", "detecting", "training-skill", "task", "done"}));
}

// orchestrator.chain none: the task over primitive actions from the first step (the vanilla
// baseline), judged by the same budgets; a persisted state of it restores only with that option
TEST(ChainMachine, WithoutAChainTheTaskTrainsOverPrimitiveActionsFromTheStart) {
  OrchestratorOptions o = SmallOptions();
  o.chain = "none";
  ChainMachine m(BreakoutLikeSpec(), o);
  Command cmd = m.command();
  EXPECT_EQ(cmd.phase, "task");
  EXPECT_EQ(cmd.job, "train-task");
  EXPECT_EQ(cmd.acting_level, 1);
  EXPECT_TRUE(cmd.links.empty());
  EXPECT_EQ(cmd.step_base, 500u);
  EXPECT_NE(m.Describe().find("primitive actions"), std::string::npos) << m.Describe();
  m.OnEnvSteps(1000);
  m.OnLearner(Eval(m, 1000, -5.0));
  EXPECT_EQ(m.state().task.evals, 1u);
  EXPECT_TRUE(m.OnEnvSteps(100'000));
  EXPECT_EQ(m.state().phase, Phase::kDone);
  EXPECT_TRUE(ChainMachine::Restore(BreakoutLikeSpec(), o, m.state()).ok());
  ChainState task = m.state();
  task.phase = Phase::kTask;
  EXPECT_TRUE(ChainMachine::Restore(BreakoutLikeSpec(), o, task).ok());
  EXPECT_FALSE(ChainMachine::Restore(BreakoutLikeSpec(), SmallOptions(), task).ok());
}

TEST(ChainMachine, ATransferStartsInTheTaskOverTheLearnedLinksUpToItsSkill) {
  Chain c;
  ReachTask(c.m);
  const ChainState learned = c.m.state();
  ASSERT_GE(learned.links.size(), 1u);
  const std::string top = learned.links.back().spec.target;
  auto t = TransferState(learned, top);
  ASSERT_TRUE(t.ok()) << t.status().message();
  EXPECT_EQ(t->phase, Phase::kTask);
  EXPECT_EQ(t->links, learned.links);
  EXPECT_EQ(t->seq, 1u);
  EXPECT_EQ(t->env_steps, 0u);
  EXPECT_TRUE(t->task.started);
  EXPECT_EQ(t->task.evals, 0u);
  auto m = ChainMachine::Restore(BreakoutLikeSpec(), SmallOptions(), *t);
  ASSERT_TRUE(m.ok()) << m.status().message();
  EXPECT_EQ(m->command().job, "train-task");
  EXPECT_EQ(m->command().acting_level, int64_t(learned.links.size()) + 1);

  auto none = TransferState(learned, "Nothing");
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.status().message().find("the chain has no Nothing skill (its links: Action->Paddle"),
            std::string::npos)
      << none.status().message();
  ChainState training = learned;
  training.links.back().learned_at_steps = 0;
  auto unlearned = TransferState(training, top);
  ASSERT_FALSE(unlearned.ok());
  EXPECT_NE(unlearned.status().message().find("not learned yet"), std::string::npos);
}

}  // namespace
}  // namespace coins::chain
