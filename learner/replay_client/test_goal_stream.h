// A synthetic stream of goal-conditioned skill rows, and a reference check of any sample drawn
// from it with GoalStream::Spec(): tests of the sampling path (in-process and over DDS) check
// every sample against it.
//
// Row of env step t (t = 1, 2, ...): state [t, level, tx, ty, 7, episode] with tx = t % 5,
// ty = (t / 5) % 4 (the target factor (tx, ty) at offset 2); level t % 3; action t % 4;
// goal [tx(t + 1), ty(t + 1), 99] (the whole target factor plus one float); interactions = t;
// ROW_INTERACTION when t % 4 == 0, ROW_GOAL_END when t % 10 == 9, ROW_DONE when t % 50 == 0;
// reward 0.5 t. Batch `seq` carries policy_versions {1000 + seq, 2000 + seq}. Batches follow
// the wire rules (row 0 repeats the previous batch's last state; a new episode starts with a
// ROW_SEGMENT_START | ROW_EPISODE_START row of the same t).
#pragma once

#include <cmath>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "common/transition_batch.h"
#include "learner/replay_client/sample_source.h"

namespace coins::testing {

class GoalStream {
 public:
  static constexpr uint32_t kStateDim = 6, kGoalDim = 3;
  explicit GoalStream(uint32_t actor, uint64_t incarnation = 1) : actor_(actor), incarnation_(incarnation) {}
  static uint32_t Layout() { return LayoutHash("goal-stream", kStateDim, 1, kGoalDim); }
  static float Tx(int64_t t) { return float(t % 5); }
  static float Ty(int64_t t) { return float((t / 5) % 4); }
  static uint16_t Flags(int64_t t) {
    return uint16_t((t % 4 == 0 ? msg::ROW_INTERACTION : 0) | (t % 10 == 9 ? msg::ROW_GOAL_END : 0) |
                    (t % 50 == 0 ? msg::ROW_DONE : 0));
  }

  // features (tx, ty, t), levels 1 and 2, goal over (tx, ty), 2 steps, hindsight for half
  static SampleSpec Spec() {
    SampleSpec s;
    s.features = {2, 3, 0};
    s.level_mask = 0b110;
    s.goal_mask = {1, 1};
    s.target_offset = 2;
    s.goal_epsilon = 0.25f;
    s.goal_norm = msg::GOAL_NORM_LINF;
    s.n_step = 2;
    s.gamma = 0.5f;
    s.her_strategy = msg::HER_FUTURE;
    s.her_ratio = 0.5f;
    s.step_reward = -1;
    s.success_reward = 0;
    s.interaction_reward = -0.5f;
    return s;
  }

  std::unique_ptr<TransitionBatch> Next(uint32_t rows) {
    auto b = std::make_unique<TransitionBatch>();
    BatchBuilder builder;
    builder.Begin(b.get(),
                  {.actor_id = actor_,
                   .incarnation = incarnation_,
                   .seq = seq_,
                   .env_id = 0,
                   .layout_hash = Layout(),
                   .state_dim = kStateDim,
                   .action_dim = 1,
                   .goal_dim = kGoalDim,
                   .episode_base = uint64_t(ep_)},
                  rows);
    Add(builder, uint16_t(msg::ROW_SEGMENT_START | (fresh_ ? msg::ROW_EPISODE_START : 0)));
    fresh_ = false;
    for (uint32_t r = 1; r < rows; ++r) {
      ++t_;
      Add(builder, Flags(t_));
      if (t_ % 50 != 0) continue;
      ++ep_;
      fresh_ = true;
      if (r + 1 < rows) {
        ++r;
        Add(builder, msg::ROW_SEGMENT_START | msg::ROW_EPISODE_START);
        fresh_ = false;
      }
    }
    const uint64_t versions[2] = {1000 + seq_, 2000 + seq_};
    builder.SetProvenance(seq_, versions);
    builder.Finish();
    ++seq_;
    return b;
  }
  int64_t t() const { return t_; }

 private:
  void Add(BatchBuilder& builder, uint16_t flags) {
    const bool start = flags & msg::ROW_SEGMENT_START;
    const float state[kStateDim] = {float(t_), float(t_ % 3), Tx(t_), Ty(t_), 7, float(ep_)};
    const float goal[kGoalDim] = {Tx(t_ + 1), Ty(t_ + 1), 99};
    const float action[1] = {start ? 0.0f : float(t_ % 4)};
    builder.AddRow(state, action, goal, start ? 0.0f : 0.5f * float(t_), flags, uint8_t(start ? 0 : t_ % 3),
                   start ? 0 : uint32_t(t_));
  }

  uint32_t actor_;
  uint64_t incarnation_;
  uint64_t seq_ = 0;
  int64_t t_ = 0, ep_ = 0;
  bool fresh_ = true;
};

// "" when sample i of c is what GoalStream and GoalStream::Spec() imply (last_t: the newest step
// its shard holds), else what differs. *relabelled: the goal is not the stored one.
inline std::string CheckGoalSample(const SampleColumns& c, uint32_t i, int64_t last_t, bool* relabelled) {
  using S = GoalStream;
  if (c.feature_dim != 3 || c.goal_dim != 2 || c.action_dim != 1) return "dims";
  const float* s = &c.state[i * 3];
  const int64_t t0 = int64_t(s[2]) + 1;
  auto bad = [&](std::string what) { return fmt::format("sample {} (t {}): {}", i, t0, what); };
  if (s[0] != S::Tx(t0 - 1) || s[1] != S::Ty(t0 - 1)) return bad("state features");
  if (c.skill_level[i] != t0 % 3 || (t0 % 3) == 0) return bad(fmt::format("level {}", c.skill_level[i]));
  if (c.interactions[i] != uint32_t(t0) || c.flags[i] != S::Flags(t0) || c.action[i] != float(t0 % 4))
    return bad("row columns");
  if (c.policy_version[i] / 1000 != uint64_t(t0 % 3)) return bad(fmt::format("policy_version {}", c.policy_version[i]));
  // the segment from t0 ends at a goal end, an episode end or the newest data
  auto ends = [&](int64_t t) { return (S::Flags(t) & (msg::ROW_GOAL_END | msg::ROW_DONE)) || t >= last_t; };
  const float g0 = c.goal[i * 2], g1 = c.goal[i * 2 + 1];
  *relabelled = !(g0 == S::Tx(t0 + 1) && g1 == S::Ty(t0 + 1));
  if (*relabelled) {
    bool found = false;
    for (int64_t t = t0;; ++t) {
      found |= g0 == S::Tx(t) && g1 == S::Ty(t);
      if (ends(t)) break;
    }
    if (!found) return bad(fmt::format("goal ({}, {}) not achieved in the segment", g0, g1));
  }
  // the 2-step window with the goal-conditioned rewards
  float reward = 0, scale = 1;
  bool terminal = false;
  int64_t t = t0;
  for (int k = 0;; ++k, ++t) {
    const bool success = std::max(std::abs(S::Tx(t) - g0), std::abs(S::Ty(t) - g1)) <= 0.25f;
    const bool interaction = t % 4 == 0;
    reward += scale * (success ? 0.0f : interaction ? -0.5f : -1.0f);
    scale *= 0.5f;
    terminal = success || (S::Flags(t) & msg::ROW_DONE);
    if (terminal || k + 1 >= 2 || ends(t)) break;
  }
  const float* next = &c.next_state[i * 3];
  if (next[2] != float(t) || next[0] != S::Tx(t) || next[1] != S::Ty(t))
    return bad(fmt::format("next state at t {}, expected {}", next[2], t));
  if (std::abs(c.reward[i] - reward) > 1e-6f) return bad(fmt::format("reward {}, expected {}", c.reward[i], reward));
  const float discount = terminal ? 0.0f : scale;
  if (c.discount[i] != discount) return bad(fmt::format("discount {}, expected {}", c.discount[i], discount));
  return "";
}

}  // namespace coins::testing
