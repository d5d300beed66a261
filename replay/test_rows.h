// Hand-written batches for sampler tests: every row spelled out (state, flags, level, goal,
// reward, ground-truth interactions), so that tests can state expected samples by hand.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "common/transition_batch.h"

namespace coins::testing {

struct TestRow {
  std::vector<float> state;
  uint16_t flags = 0;
  uint8_t level = 1;
  std::vector<float> goal;  // goal_dim floats (empty: zeros)
  float reward = 0;
  uint32_t interactions = 0;
  float action = 0;
};

struct TestLayout {
  uint32_t state_dim = 0;
  uint32_t goal_dim = 0;
  std::string name = "hand";
  uint32_t hash() const { return LayoutHash(name, state_dim, 1, goal_dim); }
};

// one batch of the rows (row 0 must carry ROW_SEGMENT_START), stamped with the provenance
inline std::unique_ptr<TransitionBatch> MakeBatch(const TestLayout& layout, uint32_t actor, uint64_t seq,
                                                  const std::vector<TestRow>& rows,
                                                  std::vector<uint64_t> policy_versions = {}, uint64_t command_seq = 0,
                                                  uint64_t incarnation = 1) {
  auto b = std::make_unique<TransitionBatch>();
  BatchBuilder builder;
  builder.Begin(b.get(),
                {.actor_id = actor,
                 .incarnation = incarnation,
                 .seq = seq,
                 .env_id = 0,
                 .layout_hash = layout.hash(),
                 .state_dim = layout.state_dim,
                 .action_dim = 1,
                 .goal_dim = layout.goal_dim},
                uint32_t(rows.size()));
  for (const TestRow& r : rows) {
    std::vector<float> goal = r.goal;
    goal.resize(layout.goal_dim, 0.0f);
    float a[1] = {r.action};
    builder.AddRow(r.state, a, goal, r.reward, r.flags, r.level, r.interactions);
  }
  builder.SetProvenance(command_seq, policy_versions);
  builder.Finish();
  return b;
}

// a batch of one-feature states: a context row, then n transitions of one level, the states
// counting up from `first` (actor 0)
inline std::unique_ptr<TransitionBatch> MakeRun(uint64_t seq, uint8_t level, int n, float first) {
  std::vector<TestRow> rows(size_t(n) + 1);
  for (int i = 0; i <= n; ++i) {
    rows[size_t(i)].state = {first + float(i)};
    rows[size_t(i)].level = level;
  }
  rows[0].flags = msg::ROW_SEGMENT_START;
  return MakeBatch(TestLayout{1, 0}, 0, seq, rows);
}

}  // namespace coins::testing
