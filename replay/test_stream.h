// A synthetic env stream for replay tests: state = [t, episode, t % 7, t] after env step t,
// action t % 3, reward 0.5 t, goal [episode, 5]; episodes end (ROW_DONE) every `episode_len`
// steps. Batches follow the wire rules (row 0 repeats the previous batch's last state), so a
// sampled transition satisfies next[0] == state[0] + k for a k-step return.
#pragma once

#include <array>
#include <memory>

#include "common/transition_batch.h"

namespace coins::testing {

class TestStream {
 public:
  TestStream(uint32_t actor, uint64_t incarnation, int64_t episode_len = 100, uint8_t skill = 0)
      : actor_(actor), incarnation_(incarnation), episode_len_(episode_len), skill_(skill) {}
  static uint32_t Layout() { return LayoutHash("test-stream", 4, 1, 2); }

  std::unique_ptr<TransitionBatch> Next(uint32_t rows) {
    auto b = std::make_unique<TransitionBatch>();
    BatchBuilder builder;
    builder.Begin(b.get(),
                  {.actor_id = actor_,
                   .incarnation = incarnation_,
                   .seq = seq_++,
                   .env_id = 0,
                   .layout_hash = Layout(),
                   .state_dim = 4,
                   .action_dim = 1,
                   .goal_dim = 2,
                   .episode_base = uint64_t(ep_)},
                  rows);
    auto state = [&] { return std::array<float, 4>{float(t_), float(ep_), float(t_ % 7), float(t_)}; };
    std::array<float, 2> goal{float(ep_), 5.0f};
    float a0[1] = {0};
    uint16_t f0 = msg::ROW_SEGMENT_START | (fresh_ ? msg::ROW_EPISODE_START : 0);
    fresh_ = false;
    builder.AddRow(state(), a0, goal, 0, f0, skill_, 0);
    for (uint32_t r = 1; r < rows; ++r) {
      ++t_;
      float a[1] = {float(t_ % 3)};
      bool done = t_ % episode_len_ == 0;
      goal = {float(ep_), 5.0f};
      builder.AddRow(state(), a, goal, 0.5f * float(t_), done ? msg::ROW_DONE : 0, skill_, 0);
      if (done) {
        ++ep_;
        fresh_ = true;
        if (r + 1 < rows) {
          // the next episode's first state inside this batch
          ++r;
          goal = {float(ep_), 5.0f};
          builder.AddRow(state(), a0, goal, 0, msg::ROW_SEGMENT_START | msg::ROW_EPISODE_START, skill_, 0);
          fresh_ = false;
        }
      }
    }
    builder.Finish();
    return b;
  }
  int64_t t() const { return t_; }

 private:
  uint32_t actor_;
  uint64_t incarnation_;
  int64_t episode_len_;
  uint8_t skill_;
  uint64_t seq_ = 0;
  int64_t t_ = 0, ep_ = 0;
  bool fresh_ = true;
};

}  // namespace coins::testing
