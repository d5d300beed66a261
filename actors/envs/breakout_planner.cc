#include "actors/envs/breakout_planner.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "actors/envs/rng.h"
#include "common/figures.h"

namespace coins::envs {
namespace {

constexpr int kAngles = 4;
constexpr float kNoop = 0.0f, kLeft = 2.0f, kRight = 3.0f;
// a trial ends by then: the env re-serves a ball the paddle has not touched for kNoTouchReserve steps
constexpr int kTrialSteps = 2 * BreakoutEnv::kNoTouchReserve + 200;
constexpr uint64_t kPlannerSalt = 0x9a7e5eedb0c1ull;  // keeps tie-breaking apart from the env's stream

// the angle the ball left the paddle at, from its velocity right after the bounce
int AngleOf(const BreakoutEnv& env) {
  if (env.ball_vx() < 0) return env.ball_vy() == -1 ? 0 : 1;
  return env.ball_vy() == -2 ? 2 : 3;
}

float Toward(int paddle_x, int target_x) { return target_x > paddle_x ? kRight : target_x < paddle_x ? kLeft : kNoop; }

struct Trial {
  bool ended = false;    // done before any paddle bounce
  bool dropped = false;  // ... by a drop
  bool bounced = false;
  int angle = -1;
  float reward = 0.0f;
  bool done = false;
  int steps = 0;
};

// drives the paddle to x and waits for the next bounce or the episode's end
Trial Drive(BreakoutEnv& env, int x, int max_steps, std::vector<float>& state) {
  Trial t;
  const int drops_before = env.drops();
  while (t.steps < max_steps) {
    const float action = Toward(env.paddle_x(), x);
    StepResult r;
    if (!env.Step({&action, 1}, state, &r).ok()) break;
    ++t.steps;
    t.reward += r.reward;
    t.done = r.done;
    if (r.interactions & BreakoutEnv::kPaddleBall) {
      t.bounced = true;
      t.angle = AngleOf(env);
      return t;
    }
    if (r.done) {
      t.ended = true;
      t.dropped = env.drops() > drops_before;
      return t;
    }
  }
  return t;
}

std::vector<float> StateBuffer(const BreakoutEnv& env) { return std::vector<float>(env.spec().state_dim()); }

// the env's drop when no angle is reachable: the ball falls past the paddle
BounceOutcome FallToEnd(BreakoutEnv& env, int max_steps) {
  std::vector<float> state = StateBuffer(env);
  BounceOutcome o;
  o.reachable = true;
  while (o.steps < max_steps && !o.done) {
    StepResult r;
    if (!env.Step({&kNoop, 1}, state, &r).ok()) break;
    ++o.steps;
    o.reward += r.reward;
    o.done = r.done;
  }
  return o;
}

class Planner {
 public:
  Planner(BreakoutEnv& scratch, BreakoutEnv& copy, int depth, int max_steps, uint64_t seed)
      : scratch_(scratch), copy_(copy), depth_(depth), max_steps_(max_steps), rng_(seed ^ kPlannerSalt) {}

  // the angle to ask for at this decision, or -1 when none is reachable
  int Choose(BreakoutEnv& env) {
    std::vector<int> reachable;
    std::vector<double> values;
    const std::vector<uint8_t> here = env.SaveState();
    for (int a = 0; a < kAngles; ++a) {
      (void)copy_.RestoreState(here);
      const BounceOutcome o = BounceAt(copy_, scratch_, a, max_steps_);
      if (!o.reachable) continue;
      reachable.push_back(a);
      values.push_back(depth_ == 0 ? 0.0 : o.reward + (o.done ? 0.0 : Value(copy_, depth_ - 1)));
    }
    if (reachable.empty()) return -1;
    const double best = *std::max_element(values.begin(), values.end());
    std::vector<int> ties;
    for (size_t i = 0; i < reachable.size(); ++i)
      if (values[i] >= best - 1e-6) ties.push_back(reachable[i]);
    return ties[rng_.UniformInt(0, int(ties.size()) - 1)];
  }

 private:
  // the best return over the next `left` chosen bounces and the flight after them, from `env`
  // just after a bounce (env is left in an unspecified state)
  double Value(BreakoutEnv& env, int left) {
    const std::vector<uint8_t> here = env.SaveState();
    double best = -std::numeric_limits<double>::infinity();
    for (int a = 0; a < kAngles; ++a) {
      (void)env.RestoreState(here);
      const BounceOutcome o = BounceAt(env, scratch_, a, max_steps_);
      if (!o.reachable) continue;
      const double v = o.reward + (o.done || left == 0 ? 0.0 : Value(env, left - 1));
      best = std::max(best, v);
      if (left == 0) break;  // the last flight's rewards do not depend on the angle asked
    }
    if (std::isinf(best)) {
      (void)env.RestoreState(here);
      return FallToEnd(env, max_steps_).reward;
    }
    return best;
  }

  BreakoutEnv& scratch_;
  BreakoutEnv& copy_;
  int depth_;
  int max_steps_;
  Rng rng_;
};

// the variant of a Breakout env name (MakeEnv knows the names)
Result<BreakoutVariant> VariantNamed(const std::string& name) {
  auto env = MakeEnv(name);
  const auto* breakout = env.ok() ? dynamic_cast<const BreakoutEnv*>(env->get()) : nullptr;
  if (breakout == nullptr) return Errorf("env '{}' is not a Breakout env (the angle planner needs one)", name);
  return breakout->variant();
}

}  // namespace

Status AnglePlanOptions::Validate() const {
  if (episodes < 1) return Errorf("episodes: expected >= 1, got {}", episodes);
  if (depth < 0 || depth > 4) return Errorf("depth: expected 0 to 4 (4^depth leaves), got {}", depth);
  if (max_steps < 1) return Errorf("max_steps: expected >= 1, got {}", max_steps);
  return VariantNamed(env).status();
}

double AnglePlanResult::mean() const { return MeanSd(returns).mean; }

double AnglePlanResult::sd() const { return MeanSd(returns).sd; }

BounceOutcome BounceAt(BreakoutEnv& env, BreakoutEnv& scratch, int angle, int max_steps) {
  std::vector<float> state = StateBuffer(env);
  const std::vector<uint8_t> here = env.SaveState();
  for (int x = BreakoutEnv::kPaddleMinX; x <= BreakoutEnv::kPaddleMaxX; x += BreakoutEnv::kPaddleStep) {
    (void)scratch.RestoreState(here);
    const Trial t = Drive(scratch, x, std::min(max_steps, kTrialSteps), state);
    // an episode that ends before the ball reaches the paddle ends the same for every x
    const bool chosen = (t.ended && !t.dropped) || (t.bounced && t.angle == angle);
    if (!chosen) continue;
    const Trial replay = Drive(env, x, std::min(max_steps, kTrialSteps), state);  // deterministic: the same steps again
    return BounceOutcome{true, replay.bounced, replay.reward, replay.done, replay.steps};
  }
  return BounceOutcome{};
}

Result<AnglePlanResult> PlanAngles(const AnglePlanOptions& o) {
  COINS_RETURN_IF_ERROR(o.Validate());
  const BreakoutVariant variant = *VariantNamed(o.env);
  BreakoutEnv env(variant), scratch(variant), copy(variant);
  Planner planner(scratch, copy, o.depth, o.max_steps, o.seed);
  std::vector<float> state = StateBuffer(env);
  AnglePlanResult result;
  for (int e = 0; e < o.episodes; ++e) {
    env.Reset(o.seed + uint64_t(e), state);
    double total = 0.0;
    int steps = 0;
    bool done = false;
    while (!done && steps < o.max_steps) {
      const int angle = planner.Choose(env);
      const BounceOutcome b =
          angle < 0 ? FallToEnd(env, o.max_steps - steps) : BounceAt(env, scratch, angle, o.max_steps - steps);
      if (angle < 0) ++result.drops;
      if (b.bounced) ++result.bounces;
      total += b.reward;
      steps += b.steps;
      done = b.done || b.steps == 0;
    }
    result.env_steps += steps;
    result.returns.push_back(total);
  }
  return result;
}

}  // namespace coins::envs
