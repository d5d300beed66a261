#include "learner/rl/memory_replay.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <random>

#include "common/transition_batch.h"
#include "learner/replay_client/sample_source.h"
#include "replay/sampler.h"
#include "replay/shard.h"

namespace coins::rl {

namespace {
// each step is one chunk of two rows: row 0 holds the state before the step (no step leads into
// it), row 1 the step into the state after it; so step t is the shard's global row 2t + 1
constexpr uint32_t kRowsPerStep = 2;
uint64_t RowOfStep(uint64_t t) { return t * kRowsPerStep + 1; }
uint64_t StepOfRow(uint64_t row) { return row / kRowsPerStep; }

// the shard holds exactly `capacity` steps: its arena fits that many chunks of the largest
// two-row shape (so bytes, rows and descriptors never evict before the transition count does)
ReplayOptions ShardOptions(const MemoryReplayOptions& o) {
  const uint32_t S = uint32_t(o.obs_dim + o.goal_dim), A = uint32_t(o.action_dim), G = uint32_t(o.goal_dim);
  const int64_t step = ChunkStore::ChunkBytes(S, A, G, kRowsPerStep, S);
  const int64_t largest = ChunkStore::ChunkBytes(S, A, G, COINS_BATCH_MAX_ROWS, COINS_BATCH_MAX_DELTAS);
  const int64_t bytes = std::max((o.capacity + 2) * step, 2 * largest);
  ReplayOptions r;
  r.capacity = o.capacity;
  r.capacity_mb = bytes / (1 << 20) + 1;
  r.priority_exponent = o.priority_alpha;
  r.importance_exponent = o.priority_beta;
  return r;
}

uint8_t HerOf(HerStrategy h) {
  if (h == HerStrategy::kFinal) return msg::HER_FINAL;
  return h == HerStrategy::kFuture ? msg::HER_FUTURE : msg::HER_NONE;
}

// the request every Sample sends (batch_size aside): the state is [obs; achieved], the goal's
// target factor the achieved part, the features returned the obs part
msg::SampleRequest RequestFor(const MemoryReplayOptions& o) {
  SampleSpec spec;
  spec.strategy = o.prioritized ? msg::SAMPLE_PRIORITIZED : msg::SAMPLE_UNIFORM;
  spec.n_step = uint32_t(o.n_step);
  spec.gamma = o.gamma;
  if (o.goal_dim > 0) {
    spec.her_strategy = HerOf(o.her);
    spec.her_ratio = o.her_ratio;
    spec.goal_mask = o.goal_mask.empty() ? std::vector<float>(size_t(o.goal_dim), 1.0f) : o.goal_mask;
    spec.target_offset = uint32_t(o.obs_dim);
    spec.goal_epsilon = o.goal_epsilon;
    spec.goal_norm = o.goal_norm == GoalNorm::kL1 ? msg::GOAL_NORM_L1 : msg::GOAL_NORM_LINF;
    for (int j = 0; j < o.obs_dim; ++j) spec.features.push_back(uint16_t(j));
    spec.step_reward = o.step_reward;
    spec.success_reward = o.success_reward;
    spec.interaction_reward = o.step_reward;  // no step is flagged an interaction
  }
  msg::SampleRequest q;
  FillRequest(spec, &q);
  q.shard_id(0);
  return q;
}
}  // namespace

// the service's structures over one in-memory shard, and the scratch of Add and Sample
struct MemoryReplay::State {
  explicit State(const MemoryReplayOptions& o)
      : shard(0, ShardOptions(o)),
        sampler(SamplerOptions{o.priority_beta, std::min<int64_t>(o.capacity, int64_t(1) << 20), 64}),
        rng(o.seed),
        request(RequestFor(o)),
        before(size_t(o.obs_dim + o.goal_dim)),
        after(size_t(o.obs_dim + o.goal_dim)),
        no_action(size_t(o.action_dim)) {
    const uint32_t S = uint32_t(o.obs_dim + o.goal_dim), A = uint32_t(o.action_dim), G = uint32_t(o.goal_dim);
    header = {.actor_id = 0,
              .incarnation = 1,
              .layout_hash = LayoutHash("memory-replay", S, A, G),
              .state_dim = S,
              .action_dim = A,
              .goal_dim = G};
    reply.schema_version(msg::SAMPLING_SCHEMA);
  }
  coins::Shard shard;
  Sampler sampler;
  std::mt19937_64 rng;
  msg::SampleRequest request;
  msg::SampleReply reply;
  SampleColumns columns;
  BatchHeader header;
  BatchBuilder builder;
  TransitionBatch batch;
  std::vector<float> before, after;  // [obs; achieved] before and after the step
  std::vector<float> no_action;      // row 0's action
  bool open = false;                 // the last step stored left its segment open
};

Status MemoryReplayOptions::Validate() const {
  if (capacity <= 0) return Errorf("memory replay: capacity {} must be > 0", capacity);
  if (obs_dim <= 0) return Errorf("memory replay: obs_dim {} must be > 0", obs_dim);
  if (action_dim <= 0) return Errorf("memory replay: action_dim {} must be > 0", action_dim);
  if (n_step < 1) return Errorf("memory replay: n_step {} must be >= 1", n_step);
  if (!(gamma >= 0.0f && gamma <= 1.0f)) return Errorf("memory replay: gamma {} not in [0, 1]", gamma);
  if (goal_dim < 0) return Errorf("memory replay: goal_dim {} must be >= 0", goal_dim);
  if (int64_t(obs_dim) + goal_dim > int64_t(COINS_BATCH_MAX_STATE) || action_dim > int(COINS_BATCH_MAX_VALUES / 2) ||
      goal_dim > int(COINS_BATCH_MAX_VALUES / 2))
    return Errorf("memory replay: obs_dim {} + goal_dim {} or action_dim {} exceed the replay service's bounds",
                  obs_dim, goal_dim, action_dim);
  if (!goal_mask.empty() && int(goal_mask.size()) != goal_dim)
    return Errorf("memory replay: goal_mask has {} entries, goal_dim is {}", goal_mask.size(), goal_dim);
  if (goal_dim > 0 && her == HerStrategy::kEpisode)
    return Errorf("memory replay: hindsight from the whole episode is not a replay service strategy (final, future)");
  if (goal_dim > 0 && !terminate_on_success)
    return Errorf(
        "memory replay: terminate_on_success must be true (the replay service ends a window at a "
        "reached goal)");
  if (prioritized && !(priority_alpha >= 0.0f && priority_beta >= 0.0f && priority_eps > 0.0f))
    return Errorf("memory replay: priority alpha {} and beta {} must be >= 0, eps {} > 0", priority_alpha,
                  priority_beta, priority_eps);
  if (!(her_ratio >= 0.0f && her_ratio <= 1.0f)) return Errorf("memory replay: her_ratio {} not in [0, 1]", her_ratio);
  return Status::Ok();
}

MemoryReplay::MemoryReplay(MemoryReplayOptions options) : options_(std::move(options)) {
  assert(options_.Validate().ok());
  state_ = std::make_unique<State>(options_);
}

MemoryReplay::~MemoryReplay() = default;

int64_t MemoryReplay::size() const { return state_->shard.store().transitions(); }

void MemoryReplay::Add(const ReplayStep& step) {
  const size_t O = size_t(options_.obs_dim), G = size_t(options_.goal_dim);
  assert(step.obs.size() == O && step.next_obs.size() == O && int(step.action.size()) == options_.action_dim);
  assert(step.goal.size() == G && step.achieved.size() == G);
  State& s = *state_;
  // the step continues the open segment when it starts where the last one ended; row 0 then
  // repeats the last state whole (achieved part included), so the rows chain across chunks
  const bool continues = s.open && std::memcmp(step.obs.data(), s.after.data(), O * sizeof(float)) == 0;
  std::copy_n(step.obs.data(), O, s.before.data());
  std::copy_n(continues ? s.after.data() + O : step.achieved.data(), G, s.before.data() + O);
  std::copy_n(step.next_obs.data(), O, s.after.data());
  std::copy_n(step.achieved.data(), G, s.after.data() + O);
  const uint16_t start = msg::ROW_SEGMENT_START | (continues ? 0 : msg::ROW_EPISODE_START);
  const uint16_t end = step.terminal ? msg::ROW_DONE : step.segment_end ? msg::ROW_TRUNCATED : 0;
  s.header.seq = uint64_t(total_);
  s.builder.Begin(&s.batch, s.header, kRowsPerStep);
  s.builder.AddRow(s.before, s.no_action, step.goal, 0.0f, start, 0, 0);
  s.builder.AddRow(s.after, step.action, step.goal, step.reward, end, 0, 0);
  s.builder.Finish();
  const bool stored = s.shard.Receive(s.batch) == coins::Shard::Outcome::kStored;
  s.open = stored && !(step.terminal || step.segment_end);
  if (stored) ++total_;
}

Status MemoryReplay::Sample(int batch_size, Batch* batch) {
  if (total_ == 0) return Errorf("memory replay: cannot sample from an empty buffer");
  State& s = *state_;
  const ChunkStore& store = s.shard.store();
  s.request.batch_size(uint32_t(std::max(batch_size, 0)));
  COINS_RETURN_IF_ERROR(ValidateSampleRequest(s.request, store.state_dim()).WithContext("memory replay"));
  COINS_RETURN_IF_ERROR(
      s.sampler.Sample(store, s.shard.priorities(), s.request, &s.reply, &s.rng).WithContext("memory replay"));
  s.reply.status(msg::SAMPLE_OK);
  const ShardReply reply{&s.reply, 0};
  COINS_RETURN_IF_ERROR(MergeReplies({&reply, 1}, &s.columns).WithContext("memory replay"));
  ColumnsToBatch(s.columns, batch);
  // keys of shard 0 are its global rows: back to step numbers
  for (uint64_t& key : batch->keys) key = StepOfRow(KeyRow(key));
  return Status::Ok();
}

void MemoryReplay::UpdatePriorities(std::span<const uint64_t> keys, std::span<const float> priorities) {
  if (!options_.prioritized) return;
  assert(keys.size() == priorities.size());
  const ChunkStore& store = state_->shard.store();
  for (size_t i = 0; i < keys.size(); ++i) {
    const uint64_t row = RowOfStep(keys[i]);
    if (row < store.first_row() || row >= store.end_row() || !std::isfinite(priorities[i])) continue;
    state_->shard.priorities().SetPriority(row, double(std::max(priorities[i], 0.0f)) + options_.priority_eps);
  }
}

}  // namespace coins::rl
