#include "replay/sampler.h"

#include <algorithm>
#include <cmath>

#include "common/hindsight.h"

namespace coins {

namespace {
constexpr uint16_t kEnds = msg::ROW_DONE | msg::ROW_TRUNCATED | msg::ROW_SKILL_TERMINATED;
constexpr uint16_t kTerminal = msg::ROW_DONE | msg::ROW_SKILL_TERMINATED;
}  // namespace

Status ValidateSampleRequest(const msg::SampleRequest& q, uint32_t state_dim) {
  if (q.schema_version() != msg::SAMPLING_SCHEMA)
    return Errorf("sample request {}: schema_version {} (expected {})", q.correlation_id(), q.schema_version(),
                  msg::SAMPLING_SCHEMA);
  if (q.batch_size() < 1 || q.batch_size() > COINS_SAMPLE_MAX_BATCH)
    return Errorf("sample request {}: batch_size {} not in [1, {}]", q.correlation_id(), q.batch_size(),
                  COINS_SAMPLE_MAX_BATCH);
  if (uint64_t(q.batch_size()) * state_dim > COINS_SAMPLE_MAX_VALUES)
    return Errorf("sample request {}: batch_size {} x state_dim {} exceeds the reply bound", q.correlation_id(),
                  q.batch_size(), state_dim);
  if (q.strategy() > msg::SAMPLE_WEIGHTED) return Errorf("sample request {}: unknown strategy {}", q.correlation_id(), q.strategy());
  if (q.her_strategy() > msg::HER_FUTURE)
    return Errorf("sample request {}: unknown her_strategy {}", q.correlation_id(), q.her_strategy());
  if (q.n_step() < 1 || q.n_step() > 1000) return Errorf("sample request {}: n_step {} not in [1, 1000]", q.correlation_id(), q.n_step());
  if (!(q.gamma() >= 0 && q.gamma() <= 1)) return Errorf("sample request {}: gamma {} not in [0, 1]", q.correlation_id(), q.gamma());
  if (!(q.her_ratio() >= 0 && q.her_ratio() <= 1))
    return Errorf("sample request {}: her_ratio {} not in [0, 1]", q.correlation_id(), q.her_ratio());
  if (!(q.goal_epsilon() >= 0 && std::isfinite(q.goal_epsilon())))
    return Errorf("sample request {}: goal_epsilon {} must be finite and >= 0", q.correlation_id(), q.goal_epsilon());
  if (q.her_strategy() != msg::HER_NONE && q.goal_mask().empty())
    return Errorf("sample request {}: hindsight relabelling needs a goal_mask", q.correlation_id());
  if (uint64_t(q.target_offset()) + q.goal_mask().size() > state_dim)
    return Errorf("sample request {}: goal_mask of {} at target_offset {} exceeds state_dim {}", q.correlation_id(),
                  q.goal_mask().size(), q.target_offset(), state_dim);
  if (!AllFinite(q.goal_mask().data(), q.goal_mask().size()))
    return Errorf("sample request {}: goal_mask has non-finite values", q.correlation_id());
  return Status::Ok();
}

bool Sampler::Draw(const ChunkStore& store, const Priorities& prio, const msg::SampleRequest& req,
                   std::mt19937_64* rng, Pos* pos, double* prob) {
  const uint64_t first = store.first_row(), rows = store.end_row() - first;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int tries = 0; tries < options_.redraws; ++tries) {
    uint64_t row;
    *prob = 1.0;
    if (req.strategy() == msg::SAMPLE_UNIFORM || (req.strategy() == msg::SAMPLE_WEIGHTED && !prio.has_weights())) {
      row = first + std::uniform_int_distribution<uint64_t>(0, rows - 1)(*rng);
    } else {
      const SumTree& tree = req.strategy() == msg::SAMPLE_PRIORITIZED ? prio.priority_tree() : *prio.weights();
      if (tree.Total() <= 0) return false;
      int64_t slot = tree.Find(unit(*rng) * tree.Total());
      // slot back to its global row: rows held are a contiguous range of fewer than slots rows
      const int64_t slots = tree.size();
      row = first + uint64_t((slot - prio.Slot(first) + slots) % slots);
      if (row >= store.end_row()) continue;
      *prob = tree.Get(slot) / tree.Total();
    }
    size_t c = store.ChunkOfRow(row);
    uint32_t r = uint32_t(row - store.chunk(c).row_base);
    if (store.flags(c)[r] & msg::ROW_SEGMENT_START) continue;
    if (req.skill_level() >= 0 && store.skill_levels(c)[r] != uint32_t(req.skill_level())) continue;
    *pos = {uint32_t(c), r};
    return true;
  }
  return false;
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
  for (uint32_t k = 0; k < n; ++k) state[index[k]] = value[k];
}

Status Sampler::Sample(const ChunkStore& store, const Priorities& prio, const msg::SampleRequest& req,
                       msg::SampleReply* out, std::mt19937_64* rng) {
  const uint32_t B = req.batch_size(), S = store.state_dim(), A = store.action_dim();
  const uint32_t m = uint32_t(req.goal_mask().size());
  const bool her_mode = m > 0;
  const uint32_t G = her_mode ? m : store.goal_dim();
  const uint32_t n_step = her_mode ? 1 : req.n_step();
  if (store.chunks() == 0) return Errorf("shard holds no transitions");
  state_.resize(S);
  next_.resize(S);
  goal_state_.resize(S);
  achieved_.resize(std::max<uint32_t>(m, 1));
  walk_.resize(size_t(options_.max_segment_rows));
  probs_.resize(B);
  out->n(B);
  out->state_dim(S);
  out->action_dim(A);
  out->goal_dim(G);
  out->state().resize(size_t(B) * S);
  out->action().resize(size_t(B) * A);
  out->goal().resize(size_t(B) * G);
  out->reward().resize(B);
  out->discount().resize(B);
  out->weight().resize(B);
  out->key().resize(B);
  out->next_end().resize(B);
  out->next_index().clear();
  out->next_value().clear();
  std::span<const float> mask(req.goal_mask().data(), m);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto her = req.her_strategy() == msg::HER_FINAL ? HerStrategy::kFinal : HerStrategy::kFuture;

  for (uint32_t i = 0; i < B; ++i) {
    Pos p;
    double prob;
    if (!Draw(store, prio, req, rng, &p, &prob))
      return req.skill_level() >= 0 ? Errorf("no transitions of skill level {} found", req.skill_level())
                                    : Errorf("no transitions found");
    probs_[i] = prob;
    const Pos start = p;
    out->key()[i] = store.chunk(p.chunk).row_base + p.row;
    std::copy_n(store.actions(p.chunk) + size_t(p.row) * A, A, out->action().data() + size_t(i) * A);
    // the state before the step, then walk n steps applying deltas
    store.DecodeRow(p.chunk, p.row - 1, state_.data());
    std::copy(state_.begin(), state_.end(), out->state().data() + size_t(i) * S);
    std::copy(state_.begin(), state_.end(), next_.begin());
    float reward = 0, discount = 1;
    bool done = false;
    for (uint32_t k = 0;; ++k) {
      ApplyRow(store, p, next_.data());
      reward += discount * store.rewards(p.chunk)[p.row];
      discount *= req.gamma();
      uint16_t f = store.flags(p.chunk)[p.row];
      if (f & kTerminal) {
        done = true;
        break;
      }
      if (k + 1 >= n_step || !Advance(store, &p)) break;
    }
    if (done) discount = 0;
    // next_state as deltas against state
    const float* s = out->state().data() + size_t(i) * S;
    for (uint32_t j = 0; j < S; ++j)
      if (next_[j] != s[j]) {
        out->next_index().push_back(uint16_t(j));
        out->next_value().push_back(next_[j]);
      }
    out->next_end()[i] = uint32_t(out->next_index().size());

    float* goal = out->goal().data() + size_t(i) * G;
    if (!her_mode) {
      std::copy_n(store.goals(start.chunk) + size_t(start.row) * G, G, goal);
    } else {
      bool relabel = store.goal_dim() != m ||
                     (req.her_strategy() != msg::HER_NONE && unit(*rng) < double(req.her_ratio()));
      if (relabel) {
        // walk the segment from the sampled step to its end (bounded)
        int64_t len = 0;
        Pos w = start;
        walk_[size_t(len++)] = w;
        while (len < options_.max_segment_rows && Advance(store, &w)) walk_[size_t(len++)] = w;
        auto strategy = req.her_strategy() == msg::HER_NONE ? HerStrategy::kFinal : her;
        Pos g = walk_[size_t(SelectHindsightIndex(strategy, 0, 0, len, rng))];
        store.DecodeRow(g.chunk, g.row, goal_state_.data());
        MaskedGoal(std::span<const float>(goal_state_.data() + req.target_offset(), m), mask,
                       std::span<float>(goal, m));
      } else {
        std::copy_n(store.goals(start.chunk) + size_t(start.row) * G, G, goal);
      }
      MaskedGoal(std::span<const float>(next_.data() + req.target_offset(), m), mask,
                     std::span<float>(achieved_.data(), m));
      bool reached = GoalReached(std::span<const float>(achieved_.data(), m), std::span<const float>(goal, m),
                                     mask, req.goal_epsilon(), GoalNorm::kLinf);
      reward = SkillReward(reached);
      discount = (reached || done) ? 0.0f : req.gamma();
    }
    out->reward()[i] = reward;
    out->discount()[i] = discount;
  }

  // importance weights
  if (req.strategy() == msg::SAMPLE_PRIORITIZED) {
    const double N = double(store.transitions());
    double max_w = 0;
    for (uint32_t i = 0; i < B; ++i) {
      double w = std::pow(std::max(N * probs_[i], 1e-12), -options_.importance_exponent);
      out->weight()[i] = float(w);
      max_w = std::max(max_w, w);
    }
    for (uint32_t i = 0; i < B; ++i) out->weight()[i] = float(out->weight()[i] / max_w);
  } else {
    std::fill(out->weight().begin(), out->weight().end(), 1.0f);
  }
  return Status::Ok();
}

}  // namespace coins
