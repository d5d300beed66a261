// The learning path in one process (actors, replay shards, learner; no DDS): a detect round on
// random data finds Action -> Paddle and no other link, and the paddle skill, trained from
// replay with hindsight and run by the actors' hierarchy with the learner's weights, reaches
// its goals in a greedy evaluation.
#include "learner/local_run.h"

#include <gtest/gtest.h>

namespace coins {
namespace {

msg::ChainCommand Command(uint64_t seq, const std::string& job, int acting, uint64_t step_base) {
  msg::ChainCommand c;
  c.schema_version(msg::CHAIN_COMMAND_SCHEMA);
  c.seq(seq);
  c.job(job);
  c.acting_level(acting);
  c.step_base(step_base);
  return c;
}

msg::LinkSpec LinkFrom(const msg::InteractionScore& s) {
  msg::LinkSpec l;
  l.source(s.source());
  l.target(s.target());
  l.score(s.score());
  l.mask(s.mask());
  l.goal_kind(s.goal_kind());
  l.goal_set(s.goal_set());
  l.interaction_rate(s.interaction_rate());
  return l;
}

LocalRunOptions Options() {
  LocalRunOptions o;
  o.actors = 2;
  o.shards = 2;
  o.seed = 3;
  o.actor.batch_rows = 256;
  o.replay.capacity = 200000;
  o.replay.capacity_mb = 64;
  o.learner.detector.passive_steps = o.learner.detector.passive_hard_steps = 1500;
  o.learner.detector.active_steps = 3000;
  o.learner.eval_every_steps = 4000;
  o.learner.eval_goals = 100;
  if (getenv("EXPLORE")) o.learner.primitive.explore = atof(getenv("EXPLORE"));
  return o;
}

TEST(LocalRun, FindsActionToPaddleAndTrainsThePaddleSkill) {
  auto made = LocalRun::Create(Options());
  ASSERT_TRUE(made.ok()) << made.status().message();
  LocalRun& r = **made;
  ASSERT_TRUE(r.Command(Command(1, "idle", 0, 6000)).ok());
  ASSERT_TRUE(r.StepActors(100000).ok());
  EXPECT_EQ(r.env_steps(), 6000u);

  // detect: every target of the primitive action; only the paddle passes
  msg::ChainCommand detect = Command(2, "detect", 0, 6000);
  detect.source("Action");
  detect.targets({"Paddle", "Ball", "Block"});
  detect.round(1);
  ASSERT_TRUE(r.Command(detect).ok());
  auto worked = r.LearnerWork(1);
  ASSERT_TRUE(worked.ok()) << worked.status().message();
  ASSERT_EQ(r.scores().size(), 1u);
  const auto& scores = r.scores()[0].scores();
  ASSERT_EQ(scores.size(), 3u);
  const msg::InteractionScore* paddle = nullptr;
  for (const auto& s : scores) {
    if (s.target() == "Paddle")
      paddle = &s;
    else
      EXPECT_FALSE(s.pass()) << s.target() << " Sc_I " << s.score();
  }
  ASSERT_NE(paddle, nullptr);
  EXPECT_TRUE(paddle->pass()) << paddle->score();
  EXPECT_TRUE(paddle->eligible());
  EXPECT_EQ(std::vector<float>(paddle->mask().begin(), paddle->mask().end()), (std::vector<float>{0, 1, 0, 0, 0}));

  // train the paddle skill, paced at one update per env step after 1000 random-goal steps
  msg::ChainCommand train = Command(3, "train-skill", 1, 7000);
  train.steps_per_update(1.0);
  train.links({LinkFrom(*paddle)});
  ASSERT_TRUE(r.Command(train).ok());
  while (r.env_steps() < 26000) {
    ASSERT_TRUE(r.StepActors(250).ok());
    auto w = r.LearnerWork(1000);
    ASSERT_TRUE(w.ok()) << w.status().message();
    static uint64_t last_eval = 0;
    if (r.learner().status().eval_env_steps() != last_eval) {
      last_eval = r.learner().status().eval_env_steps();
      printf("eval at %lu: %.2f (updates %lu loss %.3f)\n", last_eval, r.learner().status().eval_success(),
             r.learner().status().updates(), r.learner().status().loss());
    }
  }
  const msg::LearnerStatus st = r.learner().status();
  EXPECT_GT(st.updates(), 15000u);
  EXPECT_GE(st.eval_env_steps(), 20000u);
  EXPECT_GE(st.eval_success(), 0.9) << "greedy goal-reaching rate at " << st.eval_env_steps() << " steps";
  EXPECT_EQ(r.rejected(), 0u);
  // the actors ran the skill: level-1 goals ended, most reached by the end
  const HierarchyCounters& c = r.actor(0).counters().hierarchy;
  EXPECT_GT(c.goals_ended[0], 100u);
}

}  // namespace
}  // namespace coins
