#include "replay/sampler.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "common/hindsight.h"
#include "common/transition_batch.h"
#include "replay/selectors/level.h"
#include "replay/selectors/prioritized.h"
#include "replay/selectors/uniform.h"
#include "replay/selectors/weighted.h"

namespace coins {

namespace {
constexpr uint16_t kEnds = msg::ROW_DONE | msg::ROW_TRUNCATED | msg::ROW_SKILL_TERMINATED | msg::ROW_GOAL_END;
constexpr uint16_t kTerminal = msg::ROW_DONE | msg::ROW_SKILL_TERMINATED;

// reads the row's level only when the request selects by level (one cache line less)
bool LevelSelected(const msg::SampleRequest& req, const ChunkStore& store, size_t c, uint32_t r) {
  if (req.level_mask() == 0 && req.skill_level() < 0) return true;
  const uint8_t level = store.skill_levels(c)[r];
  if (req.level_mask() != 0) return level < 32 && ((req.level_mask() >> level) & 1u) != 0;
  return uint32_t(level) == uint32_t(req.skill_level());
}

uint32_t FeatureDim(const msg::SampleRequest& req, uint32_t state_dim) {
  return req.features().empty() ? state_dim : uint32_t(req.features().size());
}

// the checks of the selection, returns and hindsight fields
Status ValidateSelection(const msg::SampleRequest& q) {
  const auto id = q.correlation_id();
  if (q.strategy() > msg::SAMPLE_WEIGHTED) return Errorf("sample request {}: unknown strategy {}", id, q.strategy());
  if (q.her_strategy() > msg::HER_FUTURE)
    return Errorf("sample request {}: unknown her_strategy {}", id, q.her_strategy());
  if (q.level_mask() >> COINS_MAX_LEVELS)
    return Errorf("sample request {}: level_mask {:#x} names levels at or above {}", id, q.level_mask(),
                  COINS_MAX_LEVELS);
  if (q.n_step() < 1 || q.n_step() > 1000)
    return Errorf("sample request {}: n_step {} not in [1, 1000]", id, q.n_step());
  if (!(q.gamma() >= 0 && q.gamma() <= 1)) return Errorf("sample request {}: gamma {} not in [0, 1]", id, q.gamma());
  if (!(q.her_ratio() >= 0 && q.her_ratio() <= 1))
    return Errorf("sample request {}: her_ratio {} not in [0, 1]", id, q.her_ratio());
  if (!(q.goal_epsilon() >= 0 && std::isfinite(q.goal_epsilon())))
    return Errorf("sample request {}: goal_epsilon {} must be finite and >= 0", id, q.goal_epsilon());
  if (q.goal_norm() != msg::GOAL_NORM_LINF && q.goal_norm() != msg::GOAL_NORM_L1)
    return Errorf("sample request {}: unknown goal_norm {}", id, q.goal_norm());
  for (auto [name, v] : {std::pair{"step_reward", q.step_reward()}, std::pair{"success_reward", q.success_reward()},
                         std::pair{"interaction_reward", q.interaction_reward()},
                         std::pair{"episode_end_reward", q.episode_end_reward()}})
    if (!std::isfinite(v)) return Errorf("sample request {}: {} {} is not finite", id, name, v);
  if (q.her_strategy() != msg::HER_NONE && q.goal_mask().empty())
    return Errorf("sample request {}: hindsight relabelling needs a goal_mask", id);
  return Status::Ok();
}
}  // namespace

Status ValidateSampleRequest(const msg::SampleRequest& q, uint32_t state_dim) {
  const auto id = q.correlation_id();
  if (q.schema_version() != msg::SAMPLING_SCHEMA)
    return Errorf("sample request {}: schema_version {} (expected {})", id, q.schema_version(), msg::SAMPLING_SCHEMA);
  if (q.batch_size() < 1 || q.batch_size() > COINS_SAMPLE_MAX_BATCH)
    return Errorf("sample request {}: batch_size {} not in [1, {}]", id, q.batch_size(), COINS_SAMPLE_MAX_BATCH);
  COINS_RETURN_IF_ERROR(ValidateSelection(q));
  if (q.features().size() > COINS_SAMPLE_MAX_MASK)
    return Errorf("sample request {}: {} features exceed the bound {}", id, q.features().size(), COINS_SAMPLE_MAX_MASK);
  for (size_t j = 0; j < q.features().size(); ++j)
    if (q.features()[j] >= state_dim)
      return Errorf("sample request {}: features[{}] = {} outside the state ({} features)", id, j, q.features()[j],
                    state_dim);
  const uint32_t feature_dim = FeatureDim(q, state_dim);
  if (uint64_t(q.batch_size()) * feature_dim > COINS_SAMPLE_MAX_VALUES)
    return Errorf("sample request {}: batch_size {} x feature_dim {} exceeds the reply bound {}", id, q.batch_size(),
                  feature_dim, COINS_SAMPLE_MAX_VALUES);
  if (q.goal_mask().size() > COINS_SAMPLE_MAX_MASK ||
      uint64_t(q.batch_size()) * q.goal_mask().size() > COINS_SAMPLE_MAX_VALUES)
    return Errorf("sample request {}: goal_mask of {} with batch_size {} exceeds the reply bound", id,
                  q.goal_mask().size(), q.batch_size());
  if (uint64_t(q.target_offset()) + q.goal_mask().size() > state_dim)
    return Errorf("sample request {}: goal_mask of {} at target_offset {} exceeds state_dim {}", id,
                  q.goal_mask().size(), q.target_offset(), state_dim);
  if (!AllFinite(q.goal_mask().data(), q.goal_mask().size()))
    return Errorf("sample request {}: goal_mask has non-finite values", id);
  return Status::Ok();
}

void ClearSampleColumns(msg::SampleReply* r) {
  r->n(0);
  r->feature_dim(0);
  for (auto* v : {&r->state(), &r->next_value(), &r->action(), &r->goal(), &r->reward(), &r->discount(), &r->weight()})
    v->clear();
  r->next_end().clear();
  r->next_index().clear();
  r->key().clear();
  r->interactions().clear();
  r->flags().clear();
  r->skill_level().clear();
  r->policy_version().clear();
}

Status Sampler::Prepare(const ChunkStore& store, const msg::SampleRequest& req, msg::SampleReply* out) {
  if (store.chunks() == 0) return Errorf("shard holds no transitions");
  Plan& p = plan_;
  p.batch = req.batch_size();
  p.state_dim = store.state_dim();
  p.action_dim = store.action_dim();
  p.mask_size = uint32_t(req.goal_mask().size());
  p.goal_conditioned = p.mask_size > 0;
  p.goal_dim = p.goal_conditioned ? p.mask_size : store.goal_dim();
  p.feature_dim = FeatureDim(req, p.state_dim);
  if (p.goal_conditioned && store.goal_dim() != 0 && store.goal_dim() < p.mask_size)
    return Errorf("sample request {}: goal_mask of {} is longer than the stored goals ({} floats)",
                  req.correlation_id(), p.mask_size, store.goal_dim());
  if (uint64_t(p.batch) * std::max(p.action_dim, p.goal_dim) > COINS_SAMPLE_MAX_VALUES)
    return Errorf("sample request {}: batch_size {} x action_dim {} / goal_dim {} exceeds the reply bound",
                  req.correlation_id(), p.batch, p.action_dim, p.goal_dim);
  state_.resize(p.state_dim);
  next_.resize(p.state_dim);
  goal_state_.resize(p.state_dim);
  achieved_.resize(std::max<uint32_t>(p.mask_size, 1));
  walk_.resize(size_t(options_.max_segment_rows));
  probs_.resize(p.batch);
  drawn_.resize(p.batch);
  out->n(p.batch);
  out->state_dim(p.state_dim);
  out->action_dim(p.action_dim);
  out->goal_dim(p.goal_dim);
  out->feature_dim(p.feature_dim);
  out->state().resize(size_t(p.batch) * p.feature_dim);
  out->action().resize(size_t(p.batch) * p.action_dim);
  out->goal().resize(size_t(p.batch) * p.goal_dim);
  for (auto* v : {&out->reward(), &out->discount(), &out->weight()}) v->resize(p.batch);
  out->key().resize(p.batch);
  out->next_end().resize(p.batch);
  out->next_index().clear();
  out->next_value().clear();
  out->interactions().resize(p.batch);
  out->flags().resize(p.batch);
  out->skill_level().resize(p.batch);
  out->policy_version().resize(p.batch);
  return Status::Ok();
}

template <class Selector>
bool Sampler::DrawRows(const Selector& selector, const ChunkStore& store, const msg::SampleRequest& req,
                       std::mt19937_64* rng) {
  static_assert(RowSelector<Selector>);
  for (uint32_t i = 0; i < plan_.batch; ++i) {
    Pick pick;
    bool drawn = false;
    for (int tries = 0; tries < options_.redraws && !drawn; ++tries) {
      const Selected s = selector.Select(rng, &pick);
      if (s == Selected::kEmpty) return false;
      if (s == Selected::kMiss) continue;
      if constexpr (Selector::kExact) {
        drawn = true;
      } else {
        drawn = !(store.flags(pick.chunk)[pick.row] & msg::ROW_SEGMENT_START) &&
                LevelSelected(req, store, pick.chunk, pick.row);
      }
    }
    if (!drawn) return false;
    drawn_[i] = {pick.chunk, pick.row};
    probs_[i] = pick.prob;
    Prefetch(store, drawn_[i]);
  }
  return true;
}

bool Sampler::Advance(const ChunkStore& store, Pos* p) {
  const ChunkInfo& c = store.chunk(p->chunk);
  if (store.flags(p->chunk)[p->row] & kEnds) return false;
  if (p->row + 1 < c.n_rows) {
    // a segment start inside a chunk is a new episode
    if (store.flags(p->chunk)[p->row + 1] & msg::ROW_SEGMENT_START) return false;
    p->row++;
    return true;
  }
  // row 0 of the continuing chunk repeats this state: go on at its row 1
  int64_t next = c.next == ChunkInfo::kNoChunk ? -1 : store.IndexOf(c.next);
  if (next < 0 || store.chunk(size_t(next)).n_rows < 2) return false;
  if (store.flags(size_t(next))[0] & msg::ROW_EPISODE_START) return false;
  if (store.flags(size_t(next))[1] & msg::ROW_SEGMENT_START) return false;
  *p = {uint32_t(next), 1};
  return true;
}

void Sampler::ApplyRow(const ChunkStore& store, Pos p, float* state) {
  const uint16_t* index;
  const float* value;
  uint32_t n;
  store.RowDeltas(p.chunk, p.row, &index, &value, &n);
  ApplyDeltas(index, value, n, state);
}

void Sampler::Prefetch(const ChunkStore& store, Pos p) const {
  // the lines SampleOne reads first: the chunk's first state, the row's columns, provenance
  const uint8_t* chunk = store.bytes(p.chunk);
  for (int line = 0; line < 4; ++line) __builtin_prefetch(chunk + 64 * line);
  __builtin_prefetch(store.actions(p.chunk) + size_t(p.row) * plan_.action_dim);
  __builtin_prefetch(store.interactions(p.chunk) + p.row);
  __builtin_prefetch(store.rewards(p.chunk) + p.row);
  __builtin_prefetch(store.skill_levels(p.chunk) + p.row);
  __builtin_prefetch(store.provenance(p.chunk));
}

void Sampler::RowColumns(const ChunkStore& store, Pos p, uint32_t i, msg::SampleReply* out) const {
  const uint32_t A = plan_.action_dim;
  out->key()[i] = store.chunk(p.chunk).row_base + p.row;
  std::copy_n(store.actions(p.chunk) + size_t(p.row) * A, A, out->action().data() + size_t(i) * A);
  out->interactions()[i] = store.interactions(p.chunk)[p.row];
  out->flags()[i] = store.flags(p.chunk)[p.row];
  const uint8_t level = store.skill_levels(p.chunk)[p.row];
  out->skill_level()[i] = level;
  // provenance: command_seq, then the weights version of levels 1 .. COINS_MAX_LEVELS
  out->policy_version()[i] = level >= 1 && level <= COINS_MAX_LEVELS ? store.provenance(p.chunk)[level] : 0;
}

void Sampler::Gather(const msg::SampleRequest& req, const float* full, float* out) const {
  if (req.features().empty()) {
    std::copy_n(full, plan_.state_dim, out);
    return;
  }
  const uint16_t* f = req.features().data();
  for (uint32_t j = 0; j < plan_.feature_dim; ++j) out[j] = full[f[j]];
}

void Sampler::NextDeltas(const msg::SampleRequest& req, uint32_t i, msg::SampleReply* out) const {
  auto& index = out->next_index();
  auto& value = out->next_value();
  const float* next = next_.data();
  const float* state = state_.data();
  const uint32_t F = plan_.feature_dim;
  if (req.features().empty()) {
    // a step changes few features: skip 16-feature blocks that are bitwise unchanged
    for (uint32_t block = 0; block < F; block += 16) {
      const uint32_t end = std::min(F, block + 16);
      if (std::memcmp(next + block, state + block, (end - block) * sizeof(float)) == 0) continue;
      for (uint32_t j = block; j < end; ++j)
        if (next[j] != state[j]) {
          index.push_back(uint16_t(j));
          value.push_back(next[j]);
        }
    }
  } else {
    const uint16_t* features = req.features().data();
    for (uint32_t j = 0; j < F; ++j)
      if (next[features[j]] != state[features[j]]) {
        index.push_back(uint16_t(j));
        value.push_back(next[features[j]]);
      }
  }
  out->next_end()[i] = uint32_t(index.size());
}

void Sampler::ChooseGoal(const ChunkStore& store, const msg::SampleRequest& req, Pos start, float* goal,
                         std::mt19937_64* rng) {
  const uint32_t m = plan_.mask_size;
  const float* mask = req.goal_mask().data();
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const bool relabel =
      store.goal_dim() == 0 || (req.her_strategy() != msg::HER_NONE && unit(*rng) < double(req.her_ratio()));
  if (!relabel) {
    const float* stored = store.goals(start.chunk) + size_t(start.row) * store.goal_dim();
    for (uint32_t j = 0; j < m; ++j) goal[j] = stored[j] * mask[j];
    return;
  }
  // walk the segment from the sampled row to its end (bounded); row g's state is the next
  // state of the step into g
  int64_t len = 0;
  Pos w = start;
  walk_[size_t(len++)] = w;
  while (len < options_.max_segment_rows && Advance(store, &w)) walk_[size_t(len++)] = w;
  const auto strategy = req.her_strategy() == msg::HER_FUTURE ? HerStrategy::kFuture : HerStrategy::kFinal;
  const Pos g = walk_[size_t(SelectHindsightIndex(strategy, 0, 0, len, rng))];
  store.DecodeRow(g.chunk, g.row, goal_state_.data());
  MaskedGoal({goal_state_.data() + req.target_offset(), m}, {mask, m}, {goal, m});
}

float Sampler::GoalReward(const msg::SampleRequest& req, uint16_t flags, const float* goal, bool* terminal) {
  const uint32_t m = plan_.mask_size;
  std::span<const float> mask(req.goal_mask().data(), m);
  MaskedGoal({next_.data() + req.target_offset(), m}, mask, {achieved_.data(), m});
  const GoalNorm norm = req.goal_norm() == msg::GOAL_NORM_L1 ? GoalNorm::kL1 : GoalNorm::kLinf;
  const bool reached = GoalReached({achieved_.data(), m}, {goal, m}, mask, req.goal_epsilon(), norm);
  const bool interaction = (flags & msg::ROW_INTERACTION) != 0;
  const bool success = reached && (interaction || !req.require_interaction());
  const bool done = (flags & msg::ROW_DONE) != 0;
  *terminal = success || done || (req.terminate_on_interaction() && interaction);
  if (success) return req.success_reward();
  return (interaction ? req.interaction_reward() : req.step_reward()) + (done ? req.episode_end_reward() : 0.0f);
}

void Sampler::Walk(const ChunkStore& store, const msg::SampleRequest& req, Pos p, const float* goal, float* reward,
                   float* discount) {
  float sum = 0, scale = 1;
  bool terminal = false;
  for (uint32_t k = 0;; ++k) {
    ApplyRow(store, p, next_.data());
    const uint16_t flags = store.flags(p.chunk)[p.row];
    float r;
    if (goal) {
      r = GoalReward(req, flags, goal, &terminal);
    } else {
      r = store.rewards(p.chunk)[p.row];
      terminal = (flags & kTerminal) != 0;
    }
    sum += scale * r;
    scale *= req.gamma();
    if (terminal || k + 1 >= req.n_step() || !Advance(store, &p)) break;
  }
  *reward = sum;
  *discount = terminal ? 0.0f : scale;
}

void Sampler::SampleOne(const ChunkStore& store, const msg::SampleRequest& req, Pos p, uint32_t i,
                        msg::SampleReply* out, std::mt19937_64* rng) {
  RowColumns(store, p, i, out);
  // the state before the step, then the walk applies deltas from there
  store.DecodeRow(p.chunk, p.row - 1, state_.data());
  std::copy_n(state_.data(), plan_.state_dim, next_.data());
  Gather(req, state_.data(), out->state().data() + size_t(i) * plan_.feature_dim);
  float* goal = out->goal().data() + size_t(i) * plan_.goal_dim;
  if (plan_.goal_conditioned) {
    ChooseGoal(store, req, p, goal, rng);
  } else {
    std::copy_n(store.goals(p.chunk) + size_t(p.row) * plan_.goal_dim, plan_.goal_dim, goal);
  }
  Walk(store, req, p, plan_.goal_conditioned ? goal : nullptr, &out->reward()[i], &out->discount()[i]);
  NextDeltas(req, i, out);
}

void Sampler::ImportanceWeights(const ChunkStore& store, const msg::SampleRequest& req, msg::SampleReply* out) const {
  if (req.strategy() != msg::SAMPLE_PRIORITIZED) {
    std::fill(out->weight().begin(), out->weight().end(), 1.0f);
    return;
  }
  coins::ImportanceWeights(probs_, double(store.transitions()), options_.importance_exponent, out->weight());
}

Status Sampler::Sample(const ChunkStore& store, const Priorities& prio, const msg::SampleRequest& req,
                       msg::SampleReply* out, std::mt19937_64* rng, const LevelIndex* levels) {
  COINS_RETURN_IF_ERROR(Prepare(store, req, out));
  // every row first, its memory fetched ahead, then the samples: the cache misses of the
  // draws overlap instead of stalling one sample at a time
  bool drawn;
  if (levels && req.level_mask() != 0 && req.strategy() == msg::SAMPLE_UNIFORM)
    drawn = DrawRows(LevelSelector(store, *levels, req.level_mask()), store, req, rng);
  else if (req.level_mask() != 0 && req.strategy() == msg::SAMPLE_PRIORITIZED)
    drawn = DrawRows(PrioritizedLevelSelector(store, prio, req.level_mask()), store, req, rng);
  else if (req.strategy() == msg::SAMPLE_PRIORITIZED)
    drawn = DrawRows(PrioritizedSelector(store, prio), store, req, rng);
  else if (req.strategy() == msg::SAMPLE_WEIGHTED)
    drawn = DrawRows(WeightedSelector(store, prio), store, req, rng);
  else
    drawn = DrawRows(UniformSelector(store), store, req, rng);
  if (!drawn) {
    if (req.level_mask() != 0) return Errorf("no transitions of level_mask {:#x} found", req.level_mask());
    if (req.skill_level() >= 0) return Errorf("no transitions of skill level {} found", req.skill_level());
    return Errorf("no transitions found");
  }
  for (uint32_t i = 0; i < plan_.batch; ++i) SampleOne(store, req, drawn_[i], i, out, rng);
  ImportanceWeights(store, req, out);
  return Status::Ok();
}

}  // namespace coins
