// The hierarchy runner on Breakout with untrained levels (random actions): the rows it writes
// and the goals it counts follow the rules of actors/hierarchy.h.
#include "actors/hierarchy.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <set>
#include <vector>

#include "actors/actor.h"
#include "actors/envs/env.h"
#include "actors/evaluate.h"
#include "idl/transition.h"

namespace coins {
namespace {

struct RecordedRow {
  int stream;
  std::vector<float> state, action, goal;
  float reward;
  uint16_t flags;
  uint8_t skill;
};

class Recorder final : public RowSink {
 public:
  void Row(int stream, std::span<const float> state, std::span<const float> action, std::span<const float> goal,
           float reward, uint16_t flags, uint8_t skill, uint32_t) override {
    rows.push_back({stream,
                    {state.begin(), state.end()},
                    {action.begin(), action.end()},
                    {goal.begin(), goal.end()},
                    reward,
                    flags,
                    skill});
  }
  std::vector<RecordedRow> rows;
};

policy::LevelSpec Paddle(const envs::EnvSpec& env) {
  policy::LevelSpec s;
  s.name = "skill/Paddle";
  s.level = 1;
  s.source = "Action";
  s.goal = *policy::MakeGoalSpace(env, "Paddle", {0, 1, 0, 0, 0});
  s.goal.kind = policy::GoalKind::kContinuous;
  s.goal.low = {7.5f};
  s.goal.high = {75.5f};
  s.goal.epsilon = 1.0f;
  const int p = env.factor_offset(env.factor_index("Paddle"));
  for (int i = 0; i < 5; ++i) s.obs_index.push_back(p + i), s.obs_low.push_back(-100), s.obs_high.push_back(100);
  s.num_actions = 4;
  s.timeout = 30;
  s.hidden = {8};
  return s;
}

policy::LevelSpec Ball(const envs::EnvSpec& env) {
  policy::LevelSpec s = Paddle(env);
  s.name = "skill/Ball";
  s.level = 2;
  s.source = "Paddle";
  s.goal = *policy::MakeGoalSpace(env, "Ball", {0, 0, 1, 1, 0});
  s.goal.kind = policy::GoalKind::kDiscrete;
  s.goal.goals = {{-1, -1}, {-2, -1}, {-2, 1}, {-1, 1}};
  s.goal.epsilon = 0.01f;
  s.action_kind = policy::ActionKind::kChildOffsets;
  s.child_offsets = {-1, 0, 1};
  s.num_actions = 3;
  s.timeout = 300;
  s.decision_period = 3;
  return s;
}

HierarchyModels Models(const std::vector<policy::LevelSpec>& specs) {
  HierarchyModels m;
  for (const auto& s : specs) {
    auto lm = std::make_unique<LevelModel>();
    lm->net = *policy::PolicyNet::Create(s);
    m.levels.push_back(std::move(lm));
  }
  return m;
}

// runs `steps` env steps of the hierarchy, calling decided(state) after each decision; returns
// the recorder
Recorder RunSteps(envs::Env& env, HierarchyRunner& runner, int steps,
                  const std::function<void(const std::vector<float>&)>& decided = {}) {
  Recorder rec;
  std::vector<float> state(size_t(env.spec().state_dim())), next(state.size()), action(1);
  env.Reset(7, state);
  runner.StartEpisode(state, &rec);
  for (int t = 0; t < steps; ++t) {
    runner.Decide(state, action);
    if (decided) decided(state);
    envs::StepResult r;
    EXPECT_TRUE(env.Step(action, next, &r).ok());
    runner.Observe(state, action, next, r.reward, r.done || r.truncated, r.truncated, r.interactions, &rec);
    std::swap(state, next);
    if (r.done || r.truncated) {
      env.ResetNext(state);
      runner.StartEpisode(state, &rec);
    }
  }
  return rec;
}

// 5,000 steps of a paddle skill (untrained, exploring) alone on Breakout
struct FirstSkillRun {
  Recorder rec;
  HierarchyCounters counters;
  int px = 0;  // the paddle's x in the state
  explicit FirstSkillRun(const std::function<void(policy::LevelSpec*)>& change = {}) {
    auto env = envs::MakeEnv("breakout");
    const envs::EnvSpec& spec = (*env)->spec();
    policy::LevelSpec paddle = Paddle(spec);
    if (change) change(&paddle);
    const HierarchyModels models = Models({paddle});
    int action_dim, goal_dim;
    Actor::RowWidths(spec, &action_dim, &goal_dim);
    HierarchyRunner runner(spec, action_dim, goal_dim, 5);
    runner.Configure(&models, 1, true);
    rec = RunSteps(**env, runner, 5000);
    counters = runner.counters();
    px = spec.factor_offset(spec.factor_index("Paddle")) + 1;
  }
};

TEST(Hierarchy, FirstSkillRowsMarkReachedAndTimedOutGoals) {
  const FirstSkillRun run;
  const Recorder& rec = run.rec;
  const int px = run.px;
  uint64_t reached = 0, timed_out = 0;
  int since_goal = 0;
  for (const auto& row : rec.rows) {
    ASSERT_EQ(row.stream, 0);
    if (row.flags & msg::ROW_SEGMENT_START) {
      since_goal = 0;
      continue;
    }
    EXPECT_EQ(row.skill, 1);
    ++since_goal;
    const bool at_goal = std::abs(row.state[size_t(px)] - row.goal[1]) <= 1.0f;
    // a step that reaches its goal terminates it, and only such a step
    EXPECT_EQ((row.flags & msg::ROW_SKILL_TERMINATED) != 0, at_goal);
    if (row.flags & msg::ROW_SKILL_TERMINATED) ++reached;
    if (row.flags & msg::ROW_GOAL_END) {
      // the timeout, or the episode's end cut the goal short (not counted as an attempt)
      EXPECT_TRUE(since_goal == 30 || (row.flags & msg::ROW_DONE)) << since_goal;
      timed_out += since_goal == 30;
    }
    if (row.flags & (msg::ROW_SKILL_TERMINATED | msg::ROW_GOAL_END)) since_goal = 0;
  }
  EXPECT_GT(reached, 20u);
  EXPECT_GT(timed_out, 20u);
  EXPECT_EQ(run.counters.goals_reached[0], reached);
  EXPECT_EQ(run.counters.goals_ended[0], reached + timed_out);
}

// a level whose success needs its link's interaction, but whose goals interactions do not end
// (pushing's block), ends a goal once reached without one: not a success, and not held to the
// timeout (the paddle stands in for the block; no detector, so no interaction is ever seen)
TEST(Hierarchy, AGoalThatNeedsAnInteractionToSucceedStillEndsWhenReached) {
  const FirstSkillRun run([](policy::LevelSpec* s) { s->require_interaction = true; });
  const Recorder& rec = run.rec;
  const int px = run.px;
  uint64_t placed = 0, timed_out = 0;
  int since_goal = 0;
  for (const auto& row : rec.rows) {
    if (row.flags & msg::ROW_SEGMENT_START) {
      since_goal = 0;
      continue;
    }
    ++since_goal;
    const bool at_goal = std::abs(row.state[size_t(px)] - row.goal[1]) <= 1.0f;
    EXPECT_FALSE(row.flags & msg::ROW_SKILL_TERMINATED);  // never a success without the interaction
    EXPECT_TRUE(!at_goal || (row.flags & msg::ROW_GOAL_END)) << "a reached goal went on";
    if (!(row.flags & msg::ROW_GOAL_END)) continue;
    EXPECT_TRUE(at_goal || since_goal == 30 || (row.flags & msg::ROW_DONE)) << since_goal;
    placed += at_goal;
    timed_out += !at_goal && since_goal == 30;
    since_goal = 0;
  }
  EXPECT_GT(placed, 20u);
  EXPECT_GT(timed_out, 20u);
  EXPECT_EQ(run.counters.goals_reached[0], 0u);
  EXPECT_EQ(run.counters.goals_ended[0], placed + timed_out);
  EXPECT_EQ(run.counters.goals_arrived[0], placed);  // arrived, though never a success
}

// the largest distance between a new goal and the paddle's x where it was drawn, over `steps`
float FarthestNewGoal(envs::Env& env, HierarchyRunner& runner, int steps, int* goals) {
  const int px = env.spec().factor_offset(env.spec().factor_index("Paddle")) + 1;
  float farthest = 0, last_goal = -1;
  *goals = 0;
  RunSteps(env, runner, steps, [&](const std::vector<float>& state) {
    const float goal = runner.goal(1)[0];
    if (goal != last_goal) farthest = std::max(farthest, std::abs(goal - state[size_t(px)])), ++*goals;
    last_goal = goal;
  });
  return farthest;
}

TEST(Hierarchy, RandomGoalsWithASampleRatioAreDrawnNearTheTarget) {
  auto env = envs::MakeEnv("breakout");
  const envs::EnvSpec& spec = (*env)->spec();
  policy::LevelSpec paddle = Paddle(spec);
  paddle.goal.sample_ratio = 0.1f;  // within 6.8 px of the paddle (range 68)
  const HierarchyModels models = Models({paddle});
  int action_dim, goal_dim, goals = 0;
  Actor::RowWidths(spec, &action_dim, &goal_dim);
  HierarchyRunner runner(spec, action_dim, goal_dim, 5);
  runner.Configure(&models, 1, true);
  EXPECT_LE(FarthestNewGoal(**env, runner, 3000, &goals), 6.8f + 1e-3f);
  EXPECT_GT(goals, 100);
  runner.SetGoalSampleRatio(0.0f);  // evaluation's override: anywhere in [7.5, 75.5]
  EXPECT_GT(FarthestNewGoal(**env, runner, 3000, &goals), 30.0f);
}

TEST(Hierarchy, SecondLevelDecidesEveryThreeStepsAndWritesItsOwnStream) {
  auto env = envs::MakeEnv("breakout");
  const envs::EnvSpec& spec = (*env)->spec();
  const HierarchyModels models = Models({Paddle(spec), Ball(spec)});
  int action_dim, goal_dim;
  Actor::RowWidths(spec, &action_dim, &goal_dim);
  HierarchyRunner runner(spec, action_dim, goal_dim, 9);
  runner.Configure(&models, 2, true);
  const Recorder rec = RunSteps(**env, runner, 3000);
  int steps_since_decision = 0, decisions = 0;
  for (const auto& row : rec.rows) {
    if (row.flags & msg::ROW_SEGMENT_START) {
      steps_since_decision = 0;
      continue;
    }
    if (row.stream == 0) {
      ++steps_since_decision;
      // the paddle's goal never outlives the ball skill's decision
      EXPECT_LE(steps_since_decision, 3);
      continue;
    }
    ASSERT_EQ(row.stream, 2);
    EXPECT_EQ(row.skill, 2);
    ++decisions;
    EXPECT_GE(steps_since_decision, 1);
    steps_since_decision = 0;
    // the action is an offset index, the goal one of the four ball velocities
    EXPECT_GE(row.action[0], 0.0f);
    EXPECT_LE(row.action[0], 2.0f);
    EXPECT_EQ(std::abs(row.goal[3]), 1.0f);
    EXPECT_TRUE(std::abs(row.goal[2]) == 1.0f || std::abs(row.goal[2]) == 2.0f);
  }
  EXPECT_GT(decisions, 900);
}

// env steps of each ball decision that ended without its goal or episode ending
std::vector<int> OpenDecisionLengths(const Recorder& rec) {
  std::vector<int> lengths;
  int steps = 0;
  for (const auto& row : rec.rows) {
    if (row.flags & msg::ROW_SEGMENT_START) {
      steps = 0;
    } else if (row.stream == 0) {
      ++steps;
    } else {
      const uint16_t ends = msg::ROW_DONE | msg::ROW_TRUNCATED | msg::ROW_SKILL_TERMINATED | msg::ROW_GOAL_END;
      if (!(row.flags & ends)) lengths.push_back(steps);
      steps = 0;
    }
  }
  return lengths;
}

TEST(Hierarchy, AHeldDecisionLastsItsWholePeriodWhenThePaddleArrivesSooner) {
  auto env = envs::MakeEnv("breakout");
  const envs::EnvSpec& spec = (*env)->spec();
  policy::LevelSpec held = Ball(spec);
  held.hold_decision = true;
  int action_dim, goal_dim;
  Actor::RowWidths(spec, &action_dim, &goal_dim);
  auto lengths = [&](const policy::LevelSpec& ball) {
    const HierarchyModels models = Models({Paddle(spec), ball});
    HierarchyRunner runner(spec, action_dim, goal_dim, 9);
    runner.Configure(&models, 2, true);
    return OpenDecisionLengths(RunSteps(**env, runner, 3000));
  };
  // unheld, a decision ends when the paddle reaches its goal: the offset 0 after one step
  const std::vector<int> free = lengths(Ball(spec));
  EXPECT_GT(std::count(free.begin(), free.end(), 1), 100);
  const std::vector<int> kept = lengths(held);
  ASSERT_GT(kept.size(), 500u);
  for (int n : kept) EXPECT_EQ(n, 3);
}

// the share of a level's decisions in a rollout that equal its net's greedy choice. Rows hold
// the state after a decision: the decision was taken at the stream's previous row's state,
// towards the goal the row carries.
double GreedyShare(const HierarchyModels& models, const Recorder& rec, int stream, int level) {
  const policy::LevelSpec& spec = models.at(level)->spec();
  std::vector<float> features(spec.obs_index.size()), goal(size_t(spec.goal.dim())), obs(size_t(spec.obs_dim()));
  std::mt19937_64 rng(1);
  const std::vector<float>* before = nullptr;
  int decisions = 0, greedy = 0;
  for (const auto& row : rec.rows) {
    if (row.stream != stream) continue;
    if (before && !(row.flags & msg::ROW_SEGMENT_START)) {
      for (size_t i = 0; i < goal.size(); ++i) goal[i] = row.goal[size_t(spec.goal.masked[i])];
      policy::GatherFeatures(spec, before->data(), features.data());
      policy::BuildObservation(spec, features.data(), goal.data(), obs.data());
      float action = -1;
      models.at(level)->net.Act(obs.data(), 0.0f, &rng, &action);
      ++decisions;
      greedy += action == row.action[0];
    }
    before = &row.state;
  }
  EXPECT_GT(decisions, 150) << "stream " << stream;
  return decisions ? double(greedy) / decisions : 0.0;
}

TEST(Hierarchy, EvaluationEpsilonRandomisesOnlyTheActingLevel) {
  auto env = envs::MakeEnv("breakout");
  const envs::EnvSpec& spec = (*env)->spec();
  HierarchyModels models = Models({Paddle(spec), Ball(spec)});
  for (auto& level : models.levels) level->trained = true;  // act with the nets, not at random
  int action_dim, goal_dim;
  Actor::RowWidths(spec, &action_dim, &goal_dim);
  for (float eps : {0.0f, 0.6f}) {
    HierarchyRunner runner(spec, action_dim, goal_dim, 3);
    runner.Configure(&models, 2, /*explore=*/false, eps);
    const Recorder rec = RunSteps(**env, runner, 1500);
    // the paddle skill below stays greedy; the acting ball level is random in eps of its
    // decisions (a random pick of 3 offsets is the greedy one a third of the time)
    EXPECT_EQ(GreedyShare(models, rec, 0, 1), 1.0) << eps;
    const double expected = 1.0 - eps + eps / 3.0;
    EXPECT_NEAR(GreedyShare(models, rec, 2, 2), expected, eps > 0 ? 0.1 : 0.0) << eps;
  }
}

// the same rule on the training side (an actor exploring, whose counters feed the chain's
// success windows): a ball goal cut by the block breaking is not an attempt, one cut by a drop is
TEST(Hierarchy, TrainingCountersLeaveOutGoalsCutByAWonEpisodeEnd) {
  auto env = envs::MakeEnv("breakout-single");
  ASSERT_TRUE(env.ok()) << env.status().message();
  const envs::EnvSpec& spec = (*env)->spec();
  policy::LevelSpec ball = Ball(spec);
  ball.require_interaction = ball.terminate_on_interaction = true;
  const HierarchyModels models = Models({Paddle(spec), ball});
  int action_dim, goal_dim;
  Actor::RowWidths(spec, &action_dim, &goal_dim);
  HierarchyRunner runner(spec, action_dim, goal_dim, 11);
  runner.Configure(&models, 2, /*explore=*/true);
  const Recorder rec = RunSteps(**env, runner, 60000);
  int wins = 0, losses = 0;
  for (const auto& row : rec.rows)
    if (row.stream == 0 && (row.flags & msg::ROW_DONE)) (row.reward > 0 ? wins : losses)++;
  ASSERT_GT(wins, 0) << "random play breaks the single block now and then";
  ASSERT_GT(losses, 0);
  const HierarchyCounters& c = runner.counters();
  EXPECT_EQ(c.goals_cut_by_win[1], uint64_t(wins)) << "no detector: no goal ends by a bounce before a win";
  EXPECT_EQ(c.goals_interacted[1], 0u);
  // every episode's end cuts the ball goal in force; the drops' are failed attempts, the others
  // end by the timeout
  EXPECT_GE(c.goals_ended[1], uint64_t(losses));
  EXPECT_EQ(c.goals_reached[1], 0u);
  // a goal that times out with the ball moving at its velocity arrived there, but without a
  // detected bounce it is not reached
  EXPECT_GT(c.goals_arrived[1], 0u);
  EXPECT_LT(c.goals_arrived[1], c.goals_ended[1]);
}

// a skill evaluation does not count as failed the goals that an episode end with a positive
// reward cut (breakout-single ends when its block breaks): those goals had no chance; a goal
// cut by a drop (-10) still counts, as a goal without its bounce. Its returns are the episodes'
TEST(Evaluate, GoalsCutByAWonEpisodeEndAreNotAttemptsAndEndedEpisodesGiveTheReturns) {
  auto env = envs::MakeEnv("breakout-single");
  ASSERT_TRUE(env.ok()) << env.status().message();
  const envs::EnvSpec& spec = (*env)->spec();
  policy::LevelSpec ball = Ball(spec);
  ball.require_interaction = ball.terminate_on_interaction = true;  // an interaction goal, as in a chain
  const HierarchyModels models = Models({Paddle(spec), ball});
  int wins = 0, losses = 0;
  EvalOptions o;
  o.episodes = 300;  // goals
  o.max_steps = 1'000'000;
  o.seed = 5;
  std::vector<double> sums;   // per episode, from the steps seen
  std::vector<double> ended;  // the sums of the episodes the env ended
  auto r = Evaluate(**env, models, 2, o, [&](const EvalStep& s) {
    wins += s.result->done && s.result->reward > 0;
    losses += s.result->done && s.result->reward < 0;
    ASSERT_TRUE(size_t(s.episode) == sums.size() || size_t(s.episode) + 1 == sums.size()) << s.episode;
    if (size_t(s.episode) == sums.size()) sums.push_back(0);
    sums.back() += s.result->reward;
    if (s.result->done || s.result->truncated) ended.push_back(sums.back());
  });
  ASSERT_TRUE(r.ok()) << r.status().message();
  ASSERT_GT(wins, 0) << "random play breaks the single block now and then";
  ASSERT_GT(losses, 0);
  // no detector here: goals end by the timeout or by the episode's end, never by a bounce
  EXPECT_EQ(r->goals_cut_by_win, uint64_t(wins));
  EXPECT_EQ(r->goals_interacted, 0u);
  EXPECT_EQ(r->goals_ended, uint64_t(o.episodes));
  EXPECT_GE(r->goals_ended, uint64_t(losses));
  // the returns are those of the episodes the env ended (a last one cut by the goal budget is
  // left out; here the budget's last goal ended with its episode)
  EXPECT_EQ(r->returns, ended);
  EXPECT_EQ(r->returns.size(), size_t(wins + losses));
  EXPECT_GT(r->returns.size(), 100u);
  EXPECT_TRUE(sums.size() == ended.size() || sums.size() == ended.size() + 1) << sums.size();
}

// a skill with discrete goals is counted per goal: the tallies follow the goal space's order,
// sum to the totals, each goal gets attempts, and a goal counts as reached exactly when the step
// under it ends with the ball at that velocity (no interaction needed here; so goals that an
// episode's end cuts are not attempts, and the easily reached goals have more of them)
TEST(Evaluate, DiscreteGoalsAreCountedPerGoal) {
  auto env = envs::MakeEnv("breakout");
  ASSERT_TRUE(env.ok()) << env.status().message();
  const envs::EnvSpec& spec = (*env)->spec();
  const policy::LevelSpec ball = Ball(spec);
  const HierarchyModels models = Models({Paddle(spec), ball});
  EvalOptions o;
  o.episodes = 400;  // goals
  o.max_steps = 1'000'000;
  o.seed = 9;
  const int vy = spec.factor_offset(spec.factor_index("Ball")) + 2;
  std::vector<uint64_t> reached_steps(ball.goal.goals.size(), 0);
  auto r = Evaluate(**env, models, 2, o, [&](const EvalStep& s) {
    for (size_t k = 0; k < ball.goal.goals.size(); ++k)
      if (std::equal(s.goal.begin(), s.goal.end(), ball.goal.goals[k].begin(), ball.goal.goals[k].end()) &&
          s.next[size_t(vy)] == ball.goal.goals[k][0] && s.next[size_t(vy) + 1] == ball.goal.goals[k][1])
        ++reached_steps[k];
  });
  ASSERT_TRUE(r.ok()) << r.status().message();
  ASSERT_EQ(r->by_goal.size(), ball.goal.goals.size());
  uint64_t ended = 0, reached = 0, interacted = 0;
  for (size_t k = 0; k < r->by_goal.size(); ++k) {
    const GoalTally& t = r->by_goal[k];
    EXPECT_EQ(t.goal, ball.goal.goals[k]);
    EXPECT_GT(t.ended, 20u) << "goal " << k << " of 400 random goals";
    EXPECT_EQ(t.reached, reached_steps[k]) << "goal " << k;
    ended += t.ended, reached += t.reached, interacted += t.interacted;
  }
  EXPECT_EQ(ended, r->goals_ended);
  EXPECT_EQ(reached, r->goals_reached);
  EXPECT_EQ(interacted, r->goals_interacted);
  EXPECT_EQ(r->goals_arrived, r->goals_reached) << "no interaction needed: arriving is reaching";
  EXPECT_GT(reached, 0u) << "random paddle moves bounce the ball up now and then";

  // a skill with continuous goals has no per-goal counts
  auto paddle = Evaluate(**env, models, 1, o);
  ASSERT_TRUE(paddle.ok());
  EXPECT_TRUE(paddle->by_goal.empty());
}

// a skill playing the task: whole episodes as a task would be evaluated (every episode counts,
// the budget is per episode, not in goals), its goals still counted; the same skill under a goal
// budget only keeps the episodes the env ended
TEST(Evaluate, ASkillPlayingTheTaskPlaysWholeEpisodesAndCountsItsGoals) {
  auto env = envs::MakeEnv("breakout-single");
  ASSERT_TRUE(env.ok());
  const envs::EnvSpec& spec = (*env)->spec();
  policy::LevelSpec ball = Ball(spec);
  ball.require_interaction = ball.terminate_on_interaction = true;
  const HierarchyModels models = Models({Paddle(spec), ball});
  EvalOptions o;
  o.episodes = 12;
  o.max_steps = 40;  // per episode: a served ball drops after about 36 steps; one bounced up is cut here
  o.seed = 4;
  o.skill_plays_task = true;
  std::vector<double> sums(size_t(o.episodes), 0.0);
  std::vector<int64_t> lengths(size_t(o.episodes), 0);
  int terminal = 0;
  auto r = Evaluate(**env, models, 2, o, [&](const EvalStep& s) {
    sums[size_t(s.episode)] += s.result->reward;
    ++lengths[size_t(s.episode)];
    terminal += s.result->done;
  });
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_EQ(r->returns, sums) << "every episode, however it ended";
  EXPECT_EQ(r->episodes_done, terminal);
  EXPECT_GT(terminal, 0);
  EXPECT_LT(terminal, o.episodes) << "some episodes run into the 40-step cut";
  for (int64_t n : lengths) EXPECT_LE(n, o.max_steps);
  EXPECT_GT(r->goals_ended, 0u) << "the skill's goals are counted as in a skill evaluation";
  o.skill_plays_task = false;
  o.max_steps = 100000;
  auto budget = Evaluate(**env, models, 2, o);
  ASSERT_TRUE(budget.ok());
  EXPECT_EQ(budget->goals_ended, uint64_t(o.episodes)) << "a goal budget otherwise";
}

// acting 0: uniform random primitive actions, evaluated as a task (the reference of the
// experiment tables): every episode counts, each return is the sum of its rewards, and the same
// seed gives the same episodes
TEST(Evaluate, RandomActionsPlayWholeEpisodesLikeATask) {
  auto env = envs::MakeEnv("breakout-hard");
  ASSERT_TRUE(env.ok());
  EvalOptions o;
  o.episodes = 40;
  o.seed = 3;
  std::vector<double> sums(size_t(o.episodes), 0.0);
  std::set<float> actions;
  auto r = Evaluate(**env, HierarchyModels{}, 0, o, [&](const EvalStep& s) {
    sums[size_t(s.episode)] += s.result->reward;
    actions.insert(s.action[0]);
  });
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_EQ(r->returns, sums);
  std::vector<double> sorted = sums;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_DOUBLE_EQ(r->return_median, 0.5 * (sorted[19] + sorted[20])) << "40 episodes: the middle two";
  EXPECT_DOUBLE_EQ(r->return_min, sorted.front());
  EXPECT_EQ(r->episodes_done, o.episodes) << "each ends at a drop or at the target";
  EXPECT_EQ(actions, (std::set<float>{0, 1, 2, 3}));
  EXPECT_EQ(r->goals_ended, 0u);
  // hard: -1 a bounce, -2 a drop, +1 the target; random play mostly drops at once
  EXPECT_GT(r->return_mean, -4.0);
  EXPECT_LT(r->return_mean, -1.0);
  auto again = Evaluate(**env, HierarchyModels{}, 0, o);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->returns, r->returns);
  EXPECT_FALSE(Evaluate(**env, HierarchyModels{}, -1, o).ok());
}

}  // namespace
}  // namespace coins
