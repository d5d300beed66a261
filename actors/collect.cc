#include "actors/collect.h"

#include <algorithm>
#include <cassert>
#include <charconv>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include "common/splitmix.h"

namespace coins::detector {

Status CollectOptions::Validate() const {
  if (steps <= 0) return Errorf("--steps must be positive, got {}", steps);
  if (policy.empty()) return Errorf("--policy must be 'random', 'goals' or a file path");
  if (goal_timeout <= 0) return Errorf("goal_timeout must be positive, got {}", goal_timeout);
  return Status::Ok();
}

namespace {

// reads one action per line; every line is blank or holds exactly dim finite numbers (a token
// that is not one, like "abc", "nan" or "inf", is an error naming the line, never skipped)
Result<std::vector<float>> ReadActionFile(const std::string& path, int dim) {
  std::ifstream in(path);
  if (!in) return Errorf("--policy: cannot open action file '{}' (or use random|goals)", path);
  std::vector<float> actions;
  std::string line;
  int lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream ss(line);
    std::vector<float> row;
    std::string token;
    while (ss >> token) {
      float v = 0;
      auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
      if (ec != std::errc() || end != token.data() + token.size() || !std::isfinite(v))
        return Errorf("--policy file '{}' line {}: '{}' is not a finite number", path, lineno, token);
      row.push_back(v);
    }
    if (row.empty()) continue;
    if (int(row.size()) != dim) {
      return Errorf("--policy file '{}' line {}: expected {} numbers, got {}", path, lineno, dim, row.size());
    }
    actions.insert(actions.end(), row.begin(), row.end());
  }
  if (actions.empty()) return Errorf("--policy file '{}' holds no actions", path);
  return actions;
}

// the scripted goal follower: Breakout's paddle or pushing's gripper chases random targets
class GoalPolicy {
 public:
  GoalPolicy(const envs::EnvSpec& spec, int timeout, uint64_t seed) : rng_(seed), timeout_(timeout) {
    paddle_ = spec.factor_index("Paddle");
    gripper_ = spec.factor_index("Gripper");
    offset_ = paddle_ >= 0 ? spec.factor_offset(paddle_) : gripper_ >= 0 ? spec.factor_offset(gripper_) : -1;
    if (gripper_ >= 0) {
      const auto& f = spec.factors[gripper_];
      lo_ = f.low;
      hi_ = f.high;
    }
  }
  bool supported() const { return offset_ >= 0; }

  void Act(std::span<const float> state, std::span<float> action) {
    if (paddle_ >= 0) {
      // paddle x centre chases a target x; 2 left, 3 right, 0 stay
      const float x = state[offset_ + 1];
      if (target_.empty() || age_ >= timeout_ || std::abs(x - target_[0]) <= 1.0f) NewTarget();
      ++age_;
      const float dx = target_[0] - x;
      action[0] = dx > 1.0f ? 3.0f : dx < -1.0f ? 2.0f : 0.0f;
      return;
    }
    // gripper: proportional step toward the target, clipped to the action box
    float dist = 0.0f;
    for (int i = 0; i < 3; ++i)
      dist = std::max(dist, std::abs(target_.empty() ? 1.0f : target_[i] - state[offset_ + i]));
    if (target_.empty() || age_ >= timeout_ || dist < 0.005f) NewTarget();
    ++age_;
    for (int i = 0; i < 3; ++i) {
      action[i] = std::clamp((target_[i] - state[offset_ + i]) / 0.05f, -1.0f, 1.0f);
    }
  }

 private:
  void NewTarget() {
    age_ = 0;
    if (paddle_ >= 0) {
      std::uniform_real_distribution<float> u(8.0f, 76.0f);
      target_ = {u(rng_)};
    } else {
      target_.resize(3);
      // x, y anywhere; z in the lowest quarter, where the fingertip can reach the cube
      for (int i = 0; i < 3; ++i) {
        const float hi = i == 2 ? lo_[i] + 0.25f * (hi_[i] - lo_[i]) : hi_[i];
        target_[i] = std::uniform_real_distribution<float>(lo_[i], hi)(rng_);
      }
    }
  }

  std::mt19937_64 rng_;
  int timeout_;
  int paddle_ = -1, gripper_ = -1, offset_ = -1;
  int age_ = 0;
  std::vector<float> lo_, hi_, target_;
};

}  // namespace

Result<TransitionSet> CollectTransitions(envs::Env& env, const CollectOptions& options) {
  COINS_RETURN_IF_ERROR(options.Validate());
  const envs::EnvSpec& spec = env.spec();
  const int sd = spec.state_dim(), ad = spec.action.dim;

  // choose the policy
  std::vector<float> file_actions;
  const bool random = options.policy == "random";
  const bool goals = options.policy == "goals";
  GoalPolicy goal_policy(spec, options.goal_timeout, options.seed ^ kSplitMixGamma);
  if (goals && !goal_policy.supported()) {
    return Errorf("--policy goals: env '{}' has no Paddle or Gripper factor", spec.name);
  }
  if (!random && !goals) {
    Result<std::vector<float>> r = ReadActionFile(options.policy, ad);
    if (!r.ok()) return r.status();
    file_actions = std::move(r.value());
  }

  TransitionSet set(sd, ad);
  set.Reserve(options.steps);
  std::vector<float> s(sd), s2(sd), a(ad);
  std::mt19937_64 rng(options.seed * 6364136223846793005ULL + 1442695040888963407ULL);
  env.Reset(options.seed, s);
  bool start = true;
  size_t file_pos = 0;
  for (int64_t t = 0; t < options.steps; ++t) {
    // pick the action
    if (random) {
      if (spec.action.discrete) {
        a[0] = float(std::uniform_int_distribution<int>(0, spec.action.n - 1)(rng));
      } else {
        for (int i = 0; i < ad; ++i) {
          a[i] = std::uniform_real_distribution<float>(spec.action.low[i], spec.action.high[i])(rng);
        }
      }
    } else if (goals) {
      goal_policy.Act(s, a);
    } else {
      for (int i = 0; i < ad; ++i) a[i] = file_actions[file_pos + i];
      file_pos = (file_pos + ad) % file_actions.size();
    }
    // step and record
    envs::StepResult r;
    Status st = env.Step(a, s2, &r);
    if (!st.ok()) return st.WithContext(fmt::format("collecting step {}", t));
    set.Append(s, a, s2, r.interactions, start);
    start = false;
    if (r.done || r.truncated) {
      env.ResetNext(s);
      start = true;
    } else {
      std::swap(s, s2);
    }
  }
  return set;
}

}  // namespace coins::detector
