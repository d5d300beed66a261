// TransitionSet: the detector's input, plain arrays of (state, action, next state) with the
// simulator's ground-truth interaction bits.
//
// Layout: column-major, features x batch like common/nn: transition t's state is
// states[t * state_dim, (t + 1) * state_dim). Only in-episode transitions are stored (the
// reset that follows a done/truncated step is not a transition); episode_start[t] = 1 marks
// the first transition of an episode so history windows never cross episodes. The learner fills a
// TransitionSet from replay samples with Append; actors/collect.h fills one from a live env.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "common/env_spec.h"
#include "common/status.h"

namespace coins::detector {

class TransitionSet {
 public:
  TransitionSet() = default;
  TransitionSet(int state_dim, int action_dim) : state_dim_(state_dim), action_dim_(action_dim) {}

  int state_dim() const { return state_dim_; }
  int action_dim() const { return action_dim_; }
  int64_t size() const { return int64_t(bits_.size()); }

  void Reserve(int64_t n);
  // appends one transition; asserts the sizes
  void Append(std::span<const float> state, std::span<const float> action, std::span<const float> next_state,
              uint32_t interactions, bool episode_start);

  std::span<const float> state(int64_t t) const { return {states_.data() + t * state_dim_, size_t(state_dim_)}; }
  std::span<const float> next_state(int64_t t) const {
    return {next_states_.data() + t * state_dim_, size_t(state_dim_)};
  }
  std::span<const float> action(int64_t t) const { return {actions_.data() + t * action_dim_, size_t(action_dim_)}; }
  uint32_t interactions(int64_t t) const { return bits_[t]; }
  bool episode_start(int64_t t) const { return starts_[t] != 0; }

  // appends every transition of other (same dims; asserted); its first starts an episode
  void AppendAll(const TransitionSet& other);
  // transitions [begin, end) as a new set
  TransitionSet Slice(int64_t begin, int64_t end) const;

 private:
  int state_dim_ = 0;
  int action_dim_ = 0;
  std::vector<float> states_, actions_, next_states_;
  std::vector<uint32_t> bits_;
  std::vector<uint8_t> starts_;
};

// index of bit "source->target" in spec.interactions, or -1 when the env does not label it
int InteractionBit(const envs::EnvSpec& spec, const std::string& source, const std::string& target);

}  // namespace coins::detector
