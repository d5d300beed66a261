// Sampler: answers one SampleRequest from a shard's store (idl/sampling.idl).
//
// Selection (replay/selectors/, one selector per strategy): uniform over transitions held,
// prioritised (P(i) = p_i^alpha / sum, importance weight (N P(i))^-beta normalised by the batch
// maximum), or weighted by a per-transition weight (importance weight 1: the bias is intended).
// Rows that are not transitions, and rows of a skill level the request does not ask for, are
// redrawn (bounded). Levels: a non-zero level_mask selects rows whose level L has bit L set;
// otherwise skill_level (-1: any).
//
// Segments: a walk from the sampled row goes row by row and across chunk links; it ends after a
// row flagged ROW_DONE, ROW_TRUNCATED, ROW_SKILL_TERMINATED or ROW_GOAL_END, before a
// ROW_SEGMENT_START row, at a chunk flagged ROW_EPISODE_START, or where the link is missing.
//
// Returns, n steps inside the segment (k = steps taken, 1 <= k <= n_step):
//   reward = sum_{j<k} gamma^j r_j, next_state = the state after the k-th step,
//   discount = 0 when step k was terminal, else gamma^k.
// Plain requests (goal_mask empty): r_j is the stored reward; terminal = ROW_DONE or
// ROW_SKILL_TERMINATED; the goal column is the stored goal (goal_dim floats).
// Goal-conditioned requests (goal_mask of m floats over the target factor at target_offset):
//   goal        = the stored goal's first m floats times the mask (a row's goal column holds
//                 the acting skill's goal as the whole target factor, so m <= goal_dim), or,
//                 for a fraction her_ratio of the batch (every sample when the store keeps no
//                 goals, goal_dim 0), the achieved goal mask * state[target_offset ..] at the
//                 next state of a row chosen in the segment from the sampled row on: its last
//                 row (HER_FINAL, also used for goal_dim 0 with HER_NONE) or a uniformly chosen
//                 one (HER_FUTURE); the walk is bounded by max_segment_rows.
//   per step j, with s' the state after it:
//   interaction = the row's ROW_INTERACTION flag
//   success     = GoalReached(mask * s'[target], goal, mask, goal_epsilon, goal_norm) and
//                 (interaction or not require_interaction)
//   r_j         = success ? success_reward : (interaction ? interaction_reward : step_reward),
//                 plus episode_end_reward when the row has ROW_DONE and no success
//   terminal    = success or ROW_DONE or (terminate_on_interaction and interaction)
//
// Columns: state and next_state hold the requested features in order (all when features is
// empty), feature_dim of them; next_state travels as deltas against state whose indices are
// feature columns. interactions, flags and skill_level are the sampled row's; policy_version is
// the weights version of the row's level from its chunk's provenance (level L >= 1:
// policy_versions[L - 1]; level 0, random actions: 0). Keys are global row numbers.
//
// Not thread-safe: the caller holds the shard's lock. Buffers are sized on the first request of
// a shape; after that a request allocates nothing (the reply's columns keep their capacity).
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "common/status.h"
#include "idl/sampling.h"
#include "replay/chunk_store.h"
#include "replay/level_index.h"
#include "replay/priorities.h"

namespace coins {

struct SamplerOptions {
  double importance_exponent = 0.4;  // beta
  int64_t max_segment_rows = 1000;   // hindsight walk bound
  int redraws = 64;                  // redraws per sample before giving up
};

// checks a request on its own and against the store's state_dim; the error names the field.
// What needs the rest of the store's layout (goal_dim, action_dim) Sampler::Sample checks.
Status ValidateSampleRequest(const msg::SampleRequest& req, uint32_t state_dim);

// empties every column of a reply (n = 0) and keeps their capacity
void ClearSampleColumns(msg::SampleReply* reply);

class Sampler {
 public:
  explicit Sampler(SamplerOptions options) : options_(options) {}

  // fills reply (dims, columns, keys, weights; not the header fields) with req.batch_size
  // samples; the request must have passed ValidateSampleRequest. Errors name the field that
  // does not fit the store (goal_mask longer than the stored goals, ...) or the selection that
  // found no rows.
  // levels (optional): the shard's level index; uniform requests with a level_mask then draw
  // exactly among the rows of those levels. Prioritised requests with a level_mask draw exactly
  // among them through prio's per-level masses. Otherwise (no index, weighted requests) rows of
  // other levels are redrawn, at most SamplerOptions::redraws times.
  Status Sample(const ChunkStore& store, const Priorities& prio, const msg::SampleRequest& req, msg::SampleReply* reply,
                std::mt19937_64* rng, const LevelIndex* levels = nullptr);

 private:
  struct Pos {
    uint32_t chunk;  // index (0 = oldest)
    uint32_t row;
  };
  // what one request fixes for all its samples
  struct Plan {
    uint32_t batch = 0, state_dim = 0, action_dim = 0, goal_dim = 0, feature_dim = 0, mask_size = 0;
    bool goal_conditioned = false;
  };
  // checks the request against the store's layout, sizes the reply's columns and the scratch
  Status Prepare(const ChunkStore& store, const msg::SampleRequest& req, msg::SampleReply* reply);
  // draws the batch's rows with a selector (replay/selectors/selector.h), transitions of the
  // selected levels, and prefetches them; false when the selector is empty or redraws ran out
  template <class Selector>
  bool DrawRows(const Selector& selector, const ChunkStore& store, const msg::SampleRequest& req, std::mt19937_64* rng);
  // asks the cache for the memory SampleOne will read at row p
  void Prefetch(const ChunkStore& store, Pos p) const;
  // fills sample i of the reply from the transition at row p
  void SampleOne(const ChunkStore& store, const msg::SampleRequest& req, Pos p, uint32_t i, msg::SampleReply* reply,
                 std::mt19937_64* rng);
  // the columns that come from row p alone: key, action, interactions, flags, level, version
  void RowColumns(const ChunkStore& store, Pos p, uint32_t i, msg::SampleReply* reply) const;
  // the goal of a goal-conditioned sample at row p (mask_size floats), stored or relabelled
  void ChooseGoal(const ChunkStore& store, const msg::SampleRequest& req, Pos p, float* goal, std::mt19937_64* rng);
  // walks up to n_step rows from p applying deltas to next_; writes the n-step reward and
  // discount (goal: the goal-conditioned rewards, nullptr: the stored ones)
  void Walk(const ChunkStore& store, const msg::SampleRequest& req, Pos p, const float* goal, float* reward,
            float* discount);
  // the goal-conditioned reward of one step whose next state is next_; sets *terminal
  float GoalReward(const msg::SampleRequest& req, uint16_t flags, const float* goal, bool* terminal);
  // the requested feature columns of a full state
  void Gather(const msg::SampleRequest& req, const float* full, float* out) const;
  // appends sample i's next-state deltas (feature columns where next_ differs from state_)
  void NextDeltas(const msg::SampleRequest& req, uint32_t i, msg::SampleReply* reply) const;
  void ImportanceWeights(const ChunkStore& store, const msg::SampleRequest& req, msg::SampleReply* reply) const;
  // the next row of the segment after p (following chunk links); false at the segment's end
  static bool Advance(const ChunkStore& store, Pos* p);
  // applies row p's deltas to state
  static void ApplyRow(const ChunkStore& store, Pos p, float* state);

  SamplerOptions options_;
  Plan plan_;
  std::vector<float> state_, next_, goal_state_, achieved_;
  std::vector<Pos> walk_, drawn_;
  std::vector<double> probs_;
};

}  // namespace coins
