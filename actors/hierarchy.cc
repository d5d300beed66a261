#include "actors/hierarchy.h"

#include <algorithm>
#include <cassert>

#include "common/policy/actions.h"
#include "idl/transition.h"

namespace coins {

int HierarchyModels::contiguous() const {
  int n = 0;
  while (size_t(n) < levels.size() && levels[size_t(n)] &&
         (levels[size_t(n)]->spec().detector.empty() || levels[size_t(n)]->detector))
    ++n;
  return n;
}

HierarchyRunner::HierarchyRunner(const envs::EnvSpec& spec, int action_dim, int goal_dim, uint64_t seed)
    : env_(spec), action_dim_(action_dim), goal_dim_(goal_dim), rng_(seed) {
  full_goal_.resize(size_t(goal_dim));
  zero_action_.assign(size_t(action_dim), 0.0f);
  row_action_.resize(size_t(action_dim));
}

void HierarchyRunner::Configure(const HierarchyModels* models, int acting, bool explore, float eval_explore) {
  models_ = models;
  explore_ = explore;
  eval_explore_ = eval_explore;
  const int available = models ? models->contiguous() : 0;
  acting_ = std::clamp(acting, 0, available);
  if (size_t(acting_) > levels_.size()) levels_.resize(size_t(acting_));
  ends_.resize(levels_.size());
  size_t widest = 0;
  for (int L = 1; L <= acting_; ++L) {
    const policy::LevelSpec& s = models_->at(L)->spec();
    LevelState& ls = levels_[size_t(L) - 1];
    ls.goal.resize(size_t(s.goal.dim()));
    ls.action.resize(size_t(action_dim_));
    widest = std::max({widest, s.obs_index.size(), size_t(s.obs_dim())});
  }
  features_.resize(widest);
  obs_.resize(widest);
  achieved_.resize(size_t(goal_dim_));
}

bool HierarchyRunner::is_skill(int level) const {
  return level >= 1 && level <= acting_ && !models_->at(level)->spec().is_task();
}

std::span<const float> HierarchyRunner::goal(int level) const {
  if (level < 1 || level > acting_ || !levels_[size_t(level) - 1].has_goal) return {};
  return levels_[size_t(level) - 1].goal;
}

std::span<const float> HierarchyRunner::FullGoal(int level) {
  std::fill(full_goal_.begin(), full_goal_.end(), 0.0f);
  if (is_skill(level) && levels_[size_t(level) - 1].has_goal) {
    const policy::GoalSpace& g = models_->at(level)->spec().goal;
    for (int i = 0; i < g.dim(); ++i)
      full_goal_[size_t(g.masked[size_t(i)])] = levels_[size_t(level) - 1].goal[size_t(i)];
  }
  return full_goal_;
}

void HierarchyRunner::StartEpisode(std::span<const float> state, RowSink* sink, bool episode_start) {
  const uint16_t flags = uint16_t(msg::ROW_SEGMENT_START | (episode_start ? msg::ROW_EPISODE_START : 0));
  for (auto& ls : levels_) ls = LevelState{false, ls.goal, 0, false, ls.action, 0, 0.0f, false};
  sink->Row(0, state, zero_action_, FullGoal(1), 0.0f, flags, uint8_t(acting_ >= 1 ? 1 : 0), 0);
  for (int L = 2; L <= acting_; ++L) sink->Row(L, state, zero_action_, FullGoal(L), 0.0f, flags, uint8_t(L), 0);
}

void HierarchyRunner::Act(int level, const float* obs, float* action) {
  LevelModel* m = models_->at(level);
  // the level being trained explores; the levels below it are frozen and act greedily
  const float explore = level != acting_ ? 0.0f : explore_ ? m->spec().explore : eval_explore_;
  if (!m->trained) {
    policy::RandomAction(m->spec(), &rng_, action);
    return;
  }
  m->net.Act(obs, explore, &rng_, action);
}

void HierarchyRunner::ChooseAction(int level, std::span<const float> state) {
  const policy::LevelSpec& s = models_->at(level)->spec();
  LevelState& ls = levels_[size_t(level) - 1];
  policy::GatherFeatures(s, state.data(), features_.data());
  policy::BuildObservation(s, features_.data(), ls.goal.data(), obs_.data());
  std::fill(ls.action.begin(), ls.action.end(), 0.0f);
  Act(level, obs_.data(), ls.action.data());
  ls.action_active = true;
  ls.action_steps = 0;
  ls.reward_sum = 0.0f;
  ls.interaction_seen = false;
  if (level == 1) return;
  // the child's goal
  LevelState& child = levels_[size_t(level) - 2];
  if (policy::ToChildGoal(s, models_->at(level - 1)->spec().goal, ls.action.data(), state.data(), child.goal.data()))
    counters_.goals_clipped[level - 2]++;
  child.has_goal = true;
  child.goal_steps = 0;
}

void HierarchyRunner::Decide(std::span<const float> state, std::span<float> env_action) {
  if (acting_ == 0) {
    const envs::ActionSpec& a = env_.action;
    for (int i = 0; i < a.dim; ++i)
      env_action[size_t(i)] = a.discrete
                                  ? float(std::uniform_int_distribution<int>(0, a.n - 1)(rng_))
                                  : std::uniform_real_distribution<float>(a.low[size_t(i)], a.high[size_t(i)])(rng_);
    return;
  }
  for (int L = acting_; L >= 1; --L) {
    LevelState& ls = levels_[size_t(L) - 1];
    if (L == acting_ && is_skill(L) && !ls.has_goal) {
      const policy::GoalSpace& g = models_->at(L)->spec().goal;
      policy::RandomGoal(g, goal_sample_ratio_ >= 0 ? goal_sample_ratio_ : g.sample_ratio, state.data(), &rng_,
                         ls.goal.data());
      ls.has_goal = true;
      ls.goal_steps = 0;
    }
    // level 1 acts every step; higher levels when their decision ended
    if (L == 1 || !ls.action_active) ChooseAction(L, state);
  }
  policy::ToPrimitiveAction(models_->at(1)->spec(), levels_[0].action.data(), env_action.data());
}

void HierarchyRunner::DetectInteractions(std::span<const float> state, std::span<const float> env_action,
                                         std::span<const float> next, uint32_t interactions) {
  for (int L = 1; L <= acting_; ++L) {
    Ends& e = ends_[size_t(L) - 1];
    e.interaction = false;
    LevelModel* m = models_->at(L);
    if (!m->detector) continue;
    e.interaction = m->detector->Test(state.data(), env_action.data(), next.data());
    // the highest link with a detector is the one counted against the labels
    bool top = true;
    for (int H = L + 1; H <= acting_; ++H) top = top && !models_->at(H)->detector;
    if (!top || m->interaction_bit < 0) continue;
    const bool truth = (interactions >> m->interaction_bit) & 1u;
    counters_.detector_states++;
    counters_.detector_truth += truth;
    counters_.detector_fp += e.interaction && !truth;
    counters_.detector_fn += truth && !e.interaction;
  }
}

void HierarchyRunner::EndGoals(std::span<const float> next, bool done) {
  for (int L = 1; L <= acting_; ++L) {
    Ends& e = ends_[size_t(L) - 1];
    e.terminated = e.success = e.natural = e.goal_end = e.action_end = e.reached = false;
    LevelState& ls = levels_[size_t(L) - 1];
    ls.action_steps++;
    if (!is_skill(L) || !ls.has_goal) continue;
    const policy::LevelSpec& s = models_->at(L)->spec();
    ls.goal_steps++;
    s.goal.Achieved(next.data(), achieved_.data());
    const bool reached = s.goal.Reached(achieved_.data(), ls.goal.data());
    e.reached = reached;
    e.success = reached && (e.interaction || !s.require_interaction);
    e.terminated = e.success || (s.terminate_on_interaction && e.interaction);
    // a goal that interactions do not end (a block's position) ends once the target is there,
    // whether or not the detector caught a push at this step; success still needs one
    const bool placed = reached && !s.terminate_on_interaction;
    e.natural = e.terminated || placed || ls.goal_steps >= s.timeout;
  }
  // a child's natural end ends its parent's decision; a parent's decision end cuts its child
  for (int L = acting_; L >= 1; --L) {
    Ends& e = ends_[size_t(L) - 1];
    if (L == acting_) e.goal_end = e.natural || done;
    if (L == 1) continue;
    const policy::LevelSpec& s = models_->at(L)->spec();
    Ends& child = ends_[size_t(L) - 2];
    const bool period = s.decision_period > 0 && levels_[size_t(L) - 1].action_steps >= s.decision_period;
    // a held action outlasts its child's goal: the child keeps it, reached or timed out, until the period ends
    const bool child_ends_action = child.natural && !s.hold_decision;
    e.action_end = child_ends_action || period || e.goal_end || done;
    child.goal_end = child_ends_action || e.action_end || done;
  }
  if (acting_ >= 1) ends_[0].action_end = true;  // level 1 decides every step
}

void HierarchyRunner::EmitRows(std::span<const float> next, std::span<const float> env_action, float reward, bool done,
                               bool truncated, uint32_t interactions, RowSink* sink) {
  const uint16_t env_flags = uint16_t((done && !truncated ? msg::ROW_DONE : 0) | (truncated ? msg::ROW_TRUNCATED : 0));
  auto goal_flags = [&](int L) {
    const Ends& e = ends_[size_t(L) - 1];
    if (!is_skill(L)) return uint16_t(0);
    return uint16_t((e.terminated ? msg::ROW_SKILL_TERMINATED : 0) |
                    (e.goal_end && !e.terminated ? msg::ROW_GOAL_END : 0));
  };
  // stream 0: the env step
  std::fill(row_action_.begin(), row_action_.end(), 0.0f);
  std::copy(env_action.begin(), env_action.end(), row_action_.begin());
  uint16_t f0 = env_flags;
  if (acting_ >= 1) f0 |= goal_flags(1) | (ends_[0].interaction ? msg::ROW_INTERACTION : 0);
  sink->Row(0, next, row_action_, FullGoal(1), reward, f0, uint8_t(acting_ >= 1 ? 1 : 0), interactions);
  // streams of the levels whose decision ended
  for (int L = 2; L <= acting_; ++L) {
    LevelState& ls = levels_[size_t(L) - 1];
    ls.reward_sum += reward;
    ls.interaction_seen |= ends_[size_t(L) - 1].interaction;
    if (!ends_[size_t(L) - 1].action_end) continue;
    const uint16_t f = uint16_t(env_flags | goal_flags(L) | (ls.interaction_seen ? msg::ROW_INTERACTION : 0));
    sink->Row(L, next, ls.action, FullGoal(L), ls.reward_sum, f, uint8_t(L), interactions);
    ls.action_active = false;
  }
}

void HierarchyRunner::Observe(std::span<const float> state, std::span<const float> env_action,
                              std::span<const float> next, float reward, bool done, bool truncated,
                              uint32_t interactions, RowSink* sink) {
  if (acting_ == 0) {
    const uint16_t flags = uint16_t((done && !truncated ? msg::ROW_DONE : 0) | (truncated ? msg::ROW_TRUNCATED : 0));
    std::fill(row_action_.begin(), row_action_.end(), 0.0f);
    std::copy(env_action.begin(), env_action.end(), row_action_.begin());
    sink->Row(0, next, row_action_, FullGoal(1), reward, flags, 0, interactions);
    return;
  }
  DetectInteractions(state, env_action, next, interactions);
  EndGoals(next, done);
  EmitRows(next, env_action, reward, done, truncated, interactions, sink);
  // goals that ended are dropped (a new one is chosen at the next decision) and counted as
  // attempts when they ended on their own (reached, an interaction, the timeout); a goal cut by
  // the episode's end counts as a failed attempt only for a level whose goals are attempts at
  // an interaction (the ball skill that lets the ball drop), not for one whose target simply
  // stopped (the paddle when the ball drops), and not when the episode ended with a positive
  // reward (the board cleared: the ball never came back); a goal its parent replaced is not counted
  const bool won = done && !truncated && reward > 0;
  for (int L = 1; L <= acting_; ++L) {
    const Ends& e = ends_[size_t(L) - 1];
    LevelState& ls = levels_[size_t(L) - 1];
    if (!is_skill(L) || !ls.has_goal || !e.goal_end) continue;
    const bool cut = !e.natural && done && models_->at(L)->spec().terminate_on_interaction;
    const bool attempt = e.natural || (cut && !won);
    counters_.goals_cut_by_win[L - 1] += cut && won;
    counters_.goals_ended[L - 1] += attempt;
    counters_.goals_reached[L - 1] += attempt && e.success;
    counters_.goals_interacted[L - 1] += attempt && e.interaction;
    counters_.goals_arrived[L - 1] += attempt && e.reached;
    ls.has_goal = false;
  }
}

}  // namespace coins
