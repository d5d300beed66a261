#include "learner/rl/memory_replay.h"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace coins::rl {

Status MemoryReplayOptions::Validate() const {
  if (capacity <= 0) return Errorf("memory replay: capacity {} must be > 0", capacity);
  if (obs_dim <= 0) return Errorf("memory replay: obs_dim {} must be > 0", obs_dim);
  if (action_dim <= 0) return Errorf("memory replay: action_dim {} must be > 0", action_dim);
  if (n_step < 1) return Errorf("memory replay: n_step {} must be >= 1", n_step);
  if (!(gamma >= 0.0f && gamma <= 1.0f)) return Errorf("memory replay: gamma {} not in [0, 1]", gamma);
  if (goal_dim < 0) return Errorf("memory replay: goal_dim {} must be >= 0", goal_dim);
  if (!goal_mask.empty() && int(goal_mask.size()) != goal_dim)
    return Errorf("memory replay: goal_mask has {} entries, goal_dim is {}", goal_mask.size(),
                  goal_dim);
  if (prioritized && !(priority_alpha >= 0.0f && priority_beta >= 0.0f && priority_eps > 0.0f))
    return Errorf("memory replay: priority alpha {} and beta {} must be >= 0, eps {} > 0",
                  priority_alpha, priority_beta, priority_eps);
  if (!(her_ratio >= 0.0f && her_ratio <= 1.0f))
    return Errorf("memory replay: her_ratio {} not in [0, 1]", her_ratio);
  return Status::Ok();
}

MemoryReplay::MemoryReplay(MemoryReplayOptions options)
    : options_(std::move(options)), rng_(options_.seed) {
  assert(options_.Validate().ok());
  const Eigen::Index cap = options_.capacity;
  obs_.resize(options_.obs_dim, cap);
  next_obs_.resize(options_.obs_dim, cap);
  actions_.resize(options_.action_dim, cap);
  goals_.resize(options_.goal_dim, cap);
  achieved_.resize(options_.goal_dim, cap);
  rewards_.resize(size_t(cap));
  terminal_.resize(size_t(cap));
  seg_begin_.resize(size_t(cap));
  seg_end_.resize(size_t(cap));
  goal_.resize(options_.goal_dim);
  if (options_.prioritized) tree_ = SumTree(cap);
}

void MemoryReplay::Add(const ReplayStep& step) {
  const int64_t s = Slot(total_);
  assert(int(step.obs.size()) == options_.obs_dim && int(step.next_obs.size()) == options_.obs_dim);
  assert(int(step.action.size()) == options_.action_dim);
  obs_.col(s) = Eigen::Map<const Eigen::VectorXf>(step.obs.data(), options_.obs_dim);
  next_obs_.col(s) = Eigen::Map<const Eigen::VectorXf>(step.next_obs.data(), options_.obs_dim);
  actions_.col(s) = Eigen::Map<const Eigen::VectorXf>(step.action.data(), options_.action_dim);
  if (options_.goal_dim > 0) {
    assert(int(step.goal.size()) == options_.goal_dim);
    assert(int(step.achieved.size()) == options_.goal_dim);
    goals_.col(s) = Eigen::Map<const Eigen::VectorXf>(step.goal.data(), options_.goal_dim);
    achieved_.col(s) = Eigen::Map<const Eigen::VectorXf>(step.achieved.data(), options_.goal_dim);
  }
  rewards_[size_t(s)] = step.reward;
  terminal_[size_t(s)] = step.terminal;
  seg_begin_[size_t(s)] = open_begin_;
  seg_end_[size_t(s)] = -1;
  if (options_.prioritized) tree_.Set(s, std::pow(max_priority_, double(options_.priority_alpha)));
  ++total_;
  // close the segment: every step in it learns its end
  if (step.segment_end || step.terminal) {
    for (int64_t a = std::max(open_begin_, total_ - options_.capacity); a < total_; ++a)
      seg_end_[size_t(Slot(a))] = total_;
    open_begin_ = total_;
  }
}

bool MemoryReplay::Reached(int64_t abs, const Eigen::VectorXf& goal) const {
  const int64_t s = Slot(abs);
  return GoalReached({achieved_.col(s).data(), size_t(options_.goal_dim)},
                     {goal.data(), size_t(options_.goal_dim)}, options_.goal_mask,
                     options_.goal_epsilon, options_.goal_norm);
}

Status MemoryReplay::Sample(int batch_size, Batch* batch) {
  if (total_ == 0) return Errorf("memory replay: cannot sample from an empty buffer");
  const int od = options_.obs_dim, gd = options_.goal_dim;
  batch->Resize(od + gd, options_.action_dim, batch_size);
  batch->weights.setOnes();
  const int64_t oldest = std::max<int64_t>(0, total_ - options_.capacity);
  std::uniform_int_distribution<int64_t> pick(oldest, total_ - 1);
  std::uniform_real_distribution<float> coin(0.0f, 1.0f);
  const bool goals = gd > 0;
  const int64_t n = size();
  double max_weight = 0.0;
  for (int b = 0; b < batch_size; ++b) {
    int64_t t = 0;
    if (options_.prioritized) {
      // stratified proportional draw, then the importance weight (N P(i))^-beta
      const double total = tree_.Total();
      const double u = (double(b) + coin(rng_)) * total / double(batch_size);
      const int64_t slot = tree_.Find(u);
      t = slot + ((total_ - 1 - slot) / options_.capacity) * options_.capacity;
      const double w = std::pow(double(n) * tree_.Get(slot) / total, -double(options_.priority_beta));
      batch->weights(0, b) = float(w);
      max_weight = std::max(max_weight, w);
    } else {
      t = pick(rng_);
    }
    const int64_t s = Slot(t);
    const int64_t begin = std::max(seg_begin_[size_t(s)], oldest);
    const int64_t end = seg_end_[size_t(s)] < 0 ? total_ : seg_end_[size_t(s)];
    // the goal: stored, or hindsight from the same segment
    if (goals) {
      goal_ = goals_.col(s);
      if (options_.her != HerStrategy::kNone && coin(rng_) < options_.her_ratio)
        goal_ = achieved_.col(Slot(SelectHindsightIndex(options_.her, t, begin, end, &rng_)));
    }
    // n-step return inside the segment
    float ret = 0.0f, discount = 1.0f;
    int64_t last = t;
    for (int k = 0; k < options_.n_step && t + k < end; ++k) {
      const int64_t abs = t + k;
      bool terminal = terminal_[size_t(Slot(abs))] != 0;
      float r = rewards_[size_t(Slot(abs))];
      if (goals) {
        const bool reached = Reached(abs, goal_);
        r = SkillReward(reached, options_.step_reward, options_.success_reward);
        terminal = terminal || (options_.terminate_on_success && reached);
      }
      ret += discount * r;
      discount *= options_.gamma;
      last = abs;
      if (terminal) {
        discount = 0.0f;
        break;
      }
    }
    batch->obs.col(b).head(od) = obs_.col(s);
    batch->next_obs.col(b).head(od) = next_obs_.col(Slot(last));
    if (goals) {
      batch->obs.col(b).tail(gd) = goal_;
      batch->next_obs.col(b).tail(gd) = goal_;
    }
    batch->actions.col(b) = actions_.col(s);
    batch->rewards(0, b) = ret;
    batch->discounts(0, b) = discount;
    batch->keys[size_t(b)] = uint64_t(t);
  }
  if (options_.prioritized && max_weight > 0.0) batch->weights /= float(max_weight);
  return Status::Ok();
}

void MemoryReplay::UpdatePriorities(std::span<const uint64_t> keys,
                                    std::span<const float> priorities) {
  if (!options_.prioritized) return;
  assert(keys.size() == priorities.size());
  const int64_t oldest = std::max<int64_t>(0, total_ - options_.capacity);
  for (size_t i = 0; i < keys.size(); ++i) {
    const int64_t t = int64_t(keys[i]);
    if (t < oldest || t >= total_) continue;
    const double p = double(std::max(priorities[i], 0.0f)) + options_.priority_eps;
    max_priority_ = std::max(max_priority_, p);
    tree_.Set(Slot(t), std::pow(p, double(options_.priority_alpha)));
  }
}

}  // namespace coins::rl
