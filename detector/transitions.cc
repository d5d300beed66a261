#include "detector/transitions.h"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace coins::detector {

void TransitionSet::Reserve(int64_t n) {
  states_.reserve(n * state_dim_);
  next_states_.reserve(n * state_dim_);
  actions_.reserve(n * action_dim_);
  bits_.reserve(n);
  starts_.reserve(n);
}

void TransitionSet::Append(std::span<const float> state, std::span<const float> action,
                           std::span<const float> next_state, uint32_t interactions, bool episode_start) {
  assert(int(state.size()) == state_dim_ && int(next_state.size()) == state_dim_);
  assert(int(action.size()) == action_dim_);
  states_.insert(states_.end(), state.begin(), state.end());
  actions_.insert(actions_.end(), action.begin(), action.end());
  next_states_.insert(next_states_.end(), next_state.begin(), next_state.end());
  bits_.push_back(interactions);
  starts_.push_back(episode_start ? 1 : 0);
}

TransitionSet TransitionSet::Slice(int64_t begin, int64_t end) const {
  assert(0 <= begin && begin <= end && end <= size());
  TransitionSet out(state_dim_, action_dim_);
  out.Reserve(end - begin);
  for (int64_t t = begin; t < end; ++t) {
    out.Append(state(t), action(t), next_state(t), bits_[t], t == begin || starts_[t]);
  }
  return out;
}

void TransitionSet::AppendAll(const TransitionSet& other) {
  assert(other.state_dim_ == state_dim_ && other.action_dim_ == action_dim_);
  Reserve(size() + other.size());
  for (int64_t t = 0; t < other.size(); ++t) {
    Append(other.state(t), other.action(t), other.next_state(t), other.bits_[t], t == 0 || other.starts_[t]);
  }
}

int InteractionBit(const envs::EnvSpec& spec, const std::string& source, const std::string& target) {
  for (size_t i = 0; i < spec.interactions.size(); ++i) {
    if (spec.interactions[i].source == source && spec.interactions[i].target == target) {
      return int(i);
    }
  }
  return -1;
}

}  // namespace coins::detector
