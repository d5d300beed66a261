#include "learner/rl/paddle_skill.h"

#include <chrono>
#include <cmath>
#include <memory>
#include <random>

#include "actors/envs/breakout.h"
#include "actors/envs/env.h"
#include "common/nn/normalizer.h"
#include "learner/rl/memory_replay.h"

namespace coins::rl {
namespace {

using Clock = std::chrono::steady_clock;
using envs::BreakoutEnv;

constexpr int kPaddleFeatures = 5;  // y, x, vy, vx, attr
constexpr int kX = 1;               // the controlled feature (mask [0, 1, 0, 0, 0])
constexpr int kObsDim = kPaddleFeatures + 1;

// the paddle factor of the state and its normaliser, from the env spec
struct PaddleView {
  int offset = 0;
  nn::Normalizer norm;

  // [normalised paddle features; goal]
  void Observe(const std::vector<float>& state, float goal, float* out) const {
    for (int i = 0; i < kPaddleFeatures; ++i) out[i] = state[size_t(offset + i)];
    norm.Apply(Eigen::Map<Eigen::MatrixXf>(out, kPaddleFeatures, 1));
    out[kPaddleFeatures] = goal;
  }
  float X(const std::vector<float>& state) const {
    return (state[size_t(offset + kX)] - norm.mid()[kX]) / norm.half_range()[kX];
  }
  float Eps() const { return 1.001f / norm.half_range()[kX]; }  // 1 px, normalised
};

// a random reachable paddle x centre (left edges 4, 6, ..., 72), normalised
float RandomGoal(const PaddleView& view, std::mt19937_64* rng) {
  const int slots = (BreakoutEnv::kPaddleMaxX - BreakoutEnv::kPaddleMinX) / BreakoutEnv::kPaddleStep;
  const int k = std::uniform_int_distribution<int>(0, slots)(*rng);
  const float x = float(BreakoutEnv::kPaddleMinX + k * BreakoutEnv::kPaddleStep) + 0.5f * float(BreakoutEnv::kPaddleW);
  return (x - view.norm.mid()[kX]) / view.norm.half_range()[kX];
}

Result<PaddleView> MakeView(const envs::EnvSpec& spec) {
  const int f = spec.factor_index("Paddle");
  if (f < 0) return Errorf("paddle skill: env '{}' has no Paddle factor", spec.name);
  const envs::FactorSpec& factor = spec.factors[size_t(f)];
  if (factor.features != kPaddleFeatures)
    return Errorf("paddle skill: Paddle has {} features, expected {}", factor.features, kPaddleFeatures);
  PaddleView view;
  view.offset = spec.factor_offset(f);
  auto norm = nn::Normalizer::FromBounds(factor.low, factor.high);
  if (!norm.ok()) return norm.status().WithContext("paddle skill");
  view.norm = *norm;
  return view;
}

// greedy success over fresh random goals, each with its own timeout
Result<double> Evaluate(Dqn* dqn, envs::Env* env, const PaddleView& view, int goals, int timeout,
                        std::mt19937_64* rng) {
  std::vector<float> state(size_t(env->spec().state_dim()));
  env->GetState(state);
  float obs[kObsDim];
  int reached = 0;
  for (int g = 0; g < goals; ++g) {
    const float goal = RandomGoal(view, rng);
    bool ok = std::abs(view.X(state) - goal) <= view.Eps();
    for (int t = 0; t < timeout && !ok; ++t) {
      view.Observe(state, goal, obs);
      const float action = float(dqn->Act({obs, kObsDim}, 0.0f, rng));
      envs::StepResult r;
      COINS_RETURN_IF_ERROR(env->Step({&action, 1}, state, &r));
      ok = std::abs(view.X(state) - goal) <= view.Eps();
      if (r.done || r.truncated) env->ResetNext(state);
    }
    reached += ok;
  }
  return double(reached) / goals;
}

}  // namespace

Status PaddleSkillOptions::Validate() const {
  if (max_env_steps <= 0) return Errorf("paddle skill: max_env_steps {} must be > 0", max_env_steps);
  if (timeout <= 0) return Errorf("paddle skill: timeout {} must be > 0", timeout);
  if (eval_every <= 0 || eval_goals <= 0)
    return Errorf("paddle skill: eval_every {} and eval_goals {} must be > 0", eval_every, eval_goals);
  if (updates_per_step < 0) return Errorf("paddle skill: updates_per_step must be >= 0");
  DqnOptions d = dqn;
  d.obs_dim = kObsDim;
  return d.Validate().WithContext("paddle skill");
}

namespace {

// the skill's replay: 2-step returns, hindsight over the paddle's x
MemoryReplayOptions ReplayOptionsFor(const PaddleSkillOptions& options, const PaddleView& view) {
  MemoryReplayOptions ro;
  ro.capacity = 100000;
  ro.obs_dim = kObsDim - 1;  // the replay appends the (relabelled) goal
  ro.action_dim = 1;
  ro.n_step = 2;
  ro.goal_dim = 1;
  ro.goal_epsilon = view.Eps();
  ro.goal_norm = GoalNorm::kL1;
  ro.her = HerStrategy::kFuture;
  ro.her_ratio = options.her_ratio;
  ro.seed = options.seed + 1;
  return ro;
}

}  // namespace

Result<PaddleSkillResult> TrainPaddleSkill(const PaddleSkillOptions& options) {
  COINS_RETURN_IF_ERROR(options.Validate());
  auto env_or = envs::MakeEnv("breakout");
  if (!env_or.ok()) return env_or.status().WithContext("paddle skill");
  auto eval_or = envs::MakeEnv("breakout");
  if (!eval_or.ok()) return eval_or.status().WithContext("paddle skill");
  std::unique_ptr<envs::Env> env = std::move(*env_or), eval_env = std::move(*eval_or);
  auto view_or = MakeView(env->spec());
  if (!view_or.ok()) return view_or.status();
  const PaddleView view = *view_or;

  DqnOptions dqn_options = options.dqn;
  dqn_options.obs_dim = kObsDim;
  dqn_options.seed = options.seed;
  Dqn dqn(dqn_options);
  MemoryReplay replay(ReplayOptionsFor(options, view));

  std::mt19937_64 rng(options.seed + 2), eval_rng(options.seed + 3);
  const size_t dim = size_t(env->spec().state_dim());
  std::vector<float> state(dim), next(dim);
  env->Reset(options.seed, state);
  eval_env->Reset(options.seed + 100, next);
  float goal = RandomGoal(view, &rng);
  int t = 0;
  float obs[kObsDim], next_obs[kObsDim];
  PaddleSkillResult result;
  const auto start = Clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };

  for (int64_t step = 1; step <= options.max_env_steps; ++step) {
    // act and step the env
    view.Observe(state, goal, obs);
    const float action = float(dqn.Act({obs, kObsDim}, options.epsilon.Value(step), &rng));
    envs::StepResult r;
    COINS_RETURN_IF_ERROR(env->Step({&action, 1}, next, &r).WithContext("paddle skill"));
    view.Observe(next, goal, next_obs);
    const float achieved = view.X(next);
    const bool reached = std::abs(achieved - goal) <= view.Eps();
    ++t;
    const bool episode_over = r.done || r.truncated;
    ReplayStep rs;
    rs.obs = {obs, kObsDim - 1};
    rs.next_obs = {next_obs, kObsDim - 1};
    rs.action = {&action, 1};
    rs.goal = {&goal, 1};
    rs.achieved = {&achieved, 1};
    rs.segment_end = reached || t == options.timeout || episode_over;
    replay.Add(rs);
    state.swap(next);
    if (episode_over) env->ResetNext(state);
    if (rs.segment_end) {
      goal = RandomGoal(view, &rng);
      t = 0;
    }
    // learn
    if (step >= options.learning_starts)
      for (int u = 0; u < options.updates_per_step; ++u) {
        auto stats = dqn.Train(&replay);
        if (!stats.ok()) return stats.status().WithContext("paddle skill");
      }
    result.env_steps = step;
    // evaluate
    if (step % options.eval_every == 0) {
      auto success = Evaluate(&dqn, eval_env.get(), view, options.eval_goals, options.timeout, &eval_rng);
      if (!success.ok()) return success.status().WithContext("paddle skill eval");
      result.curve.emplace_back(step, *success);
      result.final_success = *success;
      if (*success >= options.target_success && result.env_steps_to_target < 0) {
        result.env_steps_to_target = step;
        result.seconds_to_target = seconds();
        if (options.stop_at_target) break;
      }
    }
  }
  result.wall_seconds = seconds();
  return result;
}

}  // namespace coins::rl
