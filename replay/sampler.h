// Sampler: answers one SampleRequest from a shard's store (idl/sampling.idl).
//
// Selection: uniform over transitions held, prioritised (P(i) = p_i^alpha / sum, importance
// weight (N P(i))^-beta normalised by the batch maximum), or weighted by a per-transition
// weight (importance weight 1: the bias is intended). Rows that are not transitions, and rows
// of another skill level when the request names one, are redrawn (bounded).
//
// Returns: n-step inside the segment: reward = sum_{k<n} gamma^k r_{t+k}, next_state the state
// n steps later or at the segment's end, discount gamma^k, or 0 when the episode ended
// (ROW_DONE) or the acting skill terminated inside the window. Segments follow chunk links, so
// they span batches.
//
// Hindsight: with a goal mask, goals are mask-sized, goal[i] = state[target_offset + i] *
// mask[i], and a fraction her_ratio of the batch is relabelled with the achieved goal at the
// segment's final step (HER_FINAL) or at a uniformly chosen later step (HER_FUTURE), the walk
// bounded by max_segment_rows. Reward and discount are then recomputed for the goal, one step:
// reached = max_i |mask_i (achieved_i - goal_i)| <= goal_epsilon, reward = reached ? 0 : -1,
// discount = reached or done ? 0 : gamma. Rows whose stored goal is not mask-sized are always
// relabelled.
//
// Keys are global row numbers. Not thread-safe: the caller holds the shard's lock.
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "common/status.h"
#include "idl/sampling.h"
#include "replay/chunk_store.h"
#include "replay/priorities.h"

namespace coins {

struct SamplerOptions {
  double importance_exponent = 0.4;  // beta
  int64_t max_segment_rows = 1000;   // hindsight walk bound
  int redraws = 64;                  // redraws per sample before giving up
};

// checks a request against the store's dims; the error names the field
Status ValidateSampleRequest(const msg::SampleRequest& req, uint32_t state_dim);

class Sampler {
 public:
  explicit Sampler(SamplerOptions options) : options_(options) {}

  // fills reply (columns, keys, weights; not the header fields) with req.batch_size samples;
  // the request must have passed ValidateSampleRequest
  Status Sample(const ChunkStore& store, const Priorities& prio, const msg::SampleRequest& req,
                msg::SampleReply* reply, std::mt19937_64* rng);

 private:
  struct Pos {
    uint32_t chunk;  // index (0 = oldest)
    uint32_t row;
  };
  // draws one transition row; false when redraws ran out
  bool Draw(const ChunkStore& store, const Priorities& prio, const msg::SampleRequest& req, std::mt19937_64* rng,
            Pos* pos, double* prob);
  // the next row of the segment after p (following chunk links); false at the segment's end
  static bool Advance(const ChunkStore& store, Pos* p);
  // applies row p's deltas to state
  static void ApplyRow(const ChunkStore& store, Pos p, float* state);

  SamplerOptions options_;
  std::vector<float> state_, next_, goal_state_, achieved_;
  std::vector<Pos> walk_;
  std::vector<double> probs_;
};

}  // namespace coins
