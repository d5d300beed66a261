#include "actors/evaluate.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "actors/actor.h"
#include "common/figures.h"

namespace coins {

namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

class DiscardRows final : public RowSink {
 public:
  void Row(int, std::span<const float>, std::span<const float>, std::span<const float>, float, uint16_t, uint8_t,
           uint32_t) override {}
};

void Summarise(EvalResult* r) {
  if (r->returns.empty()) return;
  const MeanAndSd m = MeanSd(r->returns);
  r->return_mean = m.mean;
  r->return_sd = m.sd;
  r->return_median = Median(r->returns);
  r->return_min = *std::min_element(r->returns.begin(), r->returns.end());
}

// one tally per discrete goal of the level's space; none for other goal spaces
std::vector<GoalTally> DiscreteGoalTallies(const HierarchyModels& models, int level) {
  std::vector<GoalTally> tallies;
  const LevelModel* m = models.at(level);
  if (!m || m->spec().goal.kind != policy::GoalKind::kDiscrete) return tallies;
  for (const auto& g : m->spec().goal.goals) tallies.push_back({g, 0, 0, 0});
  return tallies;
}

// the tally of a goal in force (the space's goals are exact values), or null
GoalTally* TallyOf(std::vector<GoalTally>& tallies, std::span<const float> goal) {
  for (GoalTally& t : tallies)
    if (std::equal(t.goal.begin(), t.goal.end(), goal.begin(), goal.end())) return &t;
  return nullptr;
}

}  // namespace

Result<EvalResult> Evaluate(envs::Env& env, const HierarchyModels& models, int acting, const EvalOptions& o,
                            const std::function<void(const EvalStep&)>& on_step) {
  if (acting < 0 || acting > models.contiguous()) return Errorf("evaluate: level {} has no model", acting);
  // acting 0, uniform random primitive actions, is evaluated as a task: whole episodes
  const bool task = acting == 0 || models.at(acting)->spec().is_task();
  const bool whole_episodes = task || o.skill_plays_task;
  int action_dim = 1, goal_dim = 0;
  Actor::RowWidths(env.spec(), &action_dim, &goal_dim);
  HierarchyRunner runner(env.spec(), action_dim, goal_dim, o.seed ^ 0x6576616cULL);
  runner.Configure(&models, acting, /*explore=*/false, task ? o.task_explore : 0.0f);
  runner.SetGoalSampleRatio(o.goal_sample_ratio);
  DiscardRows rows;
  const size_t dim = size_t(env.spec().state_dim());
  std::vector<float> state(dim), next(dim), action(size_t(env.spec().action.dim));
  EvalResult r;
  const int skill_level = task ? acting - 1 : acting;  // < 1: no skill's goals to count
  const HierarchyCounters& counts = runner.counters();
  auto ended = [&] { return skill_level >= 1 ? counts.goals_ended[skill_level - 1] : 0; };
  std::vector<GoalTally> tallies = DiscreteGoalTallies(models, skill_level);
  std::vector<float> goal_in_force;
  goal_in_force.reserve(size_t(env.spec().state_dim()));
  // a skill is evaluated until its goal (or step) budget is spent, over as many episodes as that
  // takes; each starts from a fresh Reset, and those the env ended count their returns
  bool budget_spent = false;
  for (int ep = 0; !budget_spent && ep < (whole_episodes ? o.episodes : 1 << 30); ++ep) {
    env.Reset(o.seed + uint64_t(ep), state);
    runner.StartEpisode(state, &rows);
    double ret = 0;
    bool over = false;
    for (int64_t t = 0; t < o.max_steps && !over; ++t) {
      const auto t0 = Clock::now();
      runner.Decide(state, action);
      envs::StepResult sr;
      const auto t1 = Clock::now();
      COINS_RETURN_IF_ERROR(env.Step(action, next, &sr).WithContext("evaluate"));
      const auto t2 = Clock::now();
      const std::span<const float> g = tallies.empty() ? std::span<const float>() : runner.goal(skill_level);
      goal_in_force.assign(g.begin(), g.end());
      const uint64_t ended_before = ended();
      const uint64_t interacted_before = skill_level >= 1 ? counts.goals_interacted[skill_level - 1] : 0;
      const uint64_t reached_before = skill_level >= 1 ? counts.goals_reached[skill_level - 1] : 0;
      runner.Observe(state, action, next, sr.reward, sr.done || sr.truncated, sr.truncated, sr.interactions, &rows);
      r.control_seconds += Seconds(t0, Clock::now());
      r.env_seconds += Seconds(t1, t2);
      if (ended() != ended_before)
        if (GoalTally* tally = TallyOf(tallies, goal_in_force)) {
          tally->ended += ended() - ended_before;
          tally->interacted += counts.goals_interacted[skill_level - 1] - interacted_before;
          tally->reached += counts.goals_reached[skill_level - 1] - reached_before;
        }
      if (on_step) on_step({ep, state, action, next, &sr, goal_in_force});
      ret += sr.reward;
      ++r.steps;
      if (whole_episodes && sr.done) ++r.episodes_done;
      if (whole_episodes && !env.spec().penalty_means.empty() && sr.reward <= env.spec().penalty_reward)
        ++r.penalty_steps;
      over = sr.done || sr.truncated;
      std::swap(state, next);
      budget_spent = !whole_episodes && (ended() >= uint64_t(o.episodes) || r.steps >= o.max_steps);
      if (budget_spent) break;
    }
    // a whole episode counts however it ended; a skill's cut by its goal budget only when the env ended it
    if (whole_episodes || over) r.returns.push_back(ret);
  }
  if (skill_level >= 1) {
    r.goals_ended = ended();
    r.goals_cut_by_win = counts.goals_cut_by_win[skill_level - 1];
    r.goals_reached = counts.goals_reached[skill_level - 1];
    r.goals_interacted = counts.goals_interacted[skill_level - 1];
    r.goals_arrived = counts.goals_arrived[skill_level - 1];
    r.success = r.goals_ended ? double(r.goals_reached) / double(r.goals_ended) : 0.0;
    r.hit_rate = r.goals_ended ? double(r.goals_interacted) / double(r.goals_ended) : 0.0;
    r.accuracy = r.goals_interacted ? double(r.goals_reached) / double(r.goals_interacted) : 0.0;
    r.arrived = r.goals_ended ? double(r.goals_arrived) / double(r.goals_ended) : 0.0;
    r.by_goal = std::move(tallies);
  }
  Summarise(&r);
  return r;
}

}  // namespace coins
