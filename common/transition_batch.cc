#include "common/transition_batch.h"

#include <algorithm>
#include <cassert>
#include <cstring>

#include "common/splitmix.h"

namespace coins {

namespace {
constexpr uint64_t kPrime = 0x100000001b3ULL;

template <typename T>
uint64_t HashVec(const std::vector<T>& v, uint64_t h) {
  return HashBytes(v.data(), v.size() * sizeof(T), h);
}

// bit-exact float comparison (0.0 vs -0.0 and NaN payloads count as changes)
inline bool SameBits(float a, float b) {
  uint32_t x, y;
  std::memcpy(&x, &a, 4);
  std::memcpy(&y, &b, 4);
  return x == y;
}
}  // namespace

uint64_t HashBytes(const void* data, size_t n, uint64_t seed) {
  // Fletcher-style sums in 8 lanes of 32-bit words (first- and second-order sums, so the order
  // of words matters); the plain loops vectorise. The lanes are folded through a mixer.
  constexpr int kLanes = 8;
  const auto* p = static_cast<const uint8_t*>(data);
  uint64_t s1[kLanes], s2[kLanes];
  for (int l = 0; l < kLanes; ++l) {
    s1[l] = seed ^ (kSplitMixGamma * (l + 1));
    s2[l] = 0;
  }
  size_t blocks = n / (4 * kLanes);
  for (size_t i = 0; i < blocks; ++i) {
    uint32_t w[kLanes];
    std::memcpy(w, p + i * 4 * kLanes, sizeof(w));
    for (int l = 0; l < kLanes; ++l) {
      s1[l] += w[l];
      s2[l] += s1[l];
    }
  }
  // fold through a full 64-bit mixer: a plain xor-multiply fold would let a difference that
  // every lane shares (e.g. the seed's top bit) cancel out
  uint64_t h = 0xcbf29ce484222325ULL;
  for (int l = 0; l < kLanes; ++l) {
    h = SplitMix64Mix(h ^ s1[l]);
    h = SplitMix64Mix(h ^ s2[l]);
  }
  for (size_t i = blocks * 4 * kLanes; i < n; ++i) h = (h ^ p[i]) * kPrime;
  return SplitMix64Mix(h ^ n);
}

uint32_t LayoutHash(std::string_view env_name, uint32_t state_dim, uint32_t action_dim, uint32_t goal_dim) {
  uint64_t h = HashBytes(env_name.data(), env_name.size());
  uint32_t dims[3] = {state_dim, action_dim, goal_dim};
  h = HashBytes(dims, sizeof(dims), h);
  uint32_t folded = static_cast<uint32_t>(h ^ (h >> 32));
  return folded == 0 ? 1 : folded;  // 0 means "any layout" to ValidateBatch
}

void ProvenanceBlock(const TransitionBatch& b, uint64_t out[kProvenanceWords]) {
  out[0] = b.command_seq();
  for (size_t i = 0; i < COINS_MAX_LEVELS; ++i)
    out[1 + i] = i < b.policy_versions().size() ? b.policy_versions()[i] : 0;
}

uint64_t HeaderHash(uint32_t schema_version, const BatchHeader& h, uint32_t n_rows) {
  // fixed-width words, so the piece has no padding and one layout on every machine
  const uint64_t words[12] = {schema_version, h.actor_id,  h.incarnation, h.seq,      h.env_id,       h.layout_hash,
                              n_rows,         h.state_dim, h.action_dim,  h.goal_dim, h.episode_base, 0x5eedba7cULL};
  return HashBytes(words, sizeof(words));
}

uint64_t PayloadHash(const TransitionBatch& b) {
  BatchHeader header{b.actor_id(),  b.incarnation(), b.seq(),      b.env_id(),      b.layout_hash(),
                     b.state_dim(), b.action_dim(),  b.goal_dim(), b.episode_base()};
  uint64_t h = HashVec(b.first_state(), HeaderHash(b.schema_version(), header, b.n_rows()));
  h = HashVec(b.delta_end(), h);
  h = HashVec(b.delta_index(), h);
  h = HashVec(b.delta_value(), h);
  h = HashVec(b.action(), h);
  h = HashVec(b.goal(), h);
  h = HashVec(b.reward(), h);
  h = HashVec(b.flags(), h);
  h = HashVec(b.skill_level(), h);
  h = HashVec(b.interactions(), h);
  uint64_t block[kProvenanceWords];
  ProvenanceBlock(b, block);
  return HashBytes(block, sizeof(block), h);
}

bool AllFinite(const float* v, size_t n) {
  // a float is NaN or infinite when its exponent bits are all ones; OR-reduce that test
  uint32_t bad = 0;
  for (size_t i = 0; i < n; ++i) {
    uint32_t bits;
    std::memcpy(&bits, v + i, 4);
    bad |= uint32_t((bits & 0x7f800000u) == 0x7f800000u);
  }
  return bad == 0;
}

uint32_t CountTransitions(const TransitionBatch& b) {
  uint32_t count = 0;
  for (uint16_t f : b.flags()) count += (f & msg::ROW_SEGMENT_START) == 0;
  return count;
}

Status ValidateBatch(const TransitionBatch& b, uint32_t expected_layout, bool check_hash) {
  auto bad = [&b](std::string_view what) {
    return Errorf("batch from actor {} seq {}: {}", b.actor_id(), b.seq(), what);
  };
  if (b.schema_version() != msg::TRANSITION_BATCH_SCHEMA)
    return bad(
        fmt::format("schema version {} (this build reads {})", b.schema_version(), msg::TRANSITION_BATCH_SCHEMA));
  const size_t n = b.n_rows();
  if (n == 0 || n > COINS_BATCH_MAX_ROWS || b.state_dim() == 0 || b.state_dim() > COINS_BATCH_MAX_STATE ||
      b.action_dim() > COINS_BATCH_MAX_VALUES || b.goal_dim() > COINS_BATCH_MAX_VALUES)
    return bad(fmt::format("bad size (n_rows {}, state_dim {}, action_dim {}, goal_dim {})", n, b.state_dim(),
                           b.action_dim(), b.goal_dim()));
  if (b.first_state().size() != b.state_dim() || b.delta_end().size() != n || b.reward().size() != n ||
      b.flags().size() != n || b.skill_level().size() != n || b.interactions().size() != n ||
      b.action().size() != n * b.action_dim() || b.goal().size() != n * b.goal_dim() ||
      b.delta_index().size() != b.delta_value().size())
    return bad("column lengths do not match n_rows and the dimensions");
  if (expected_layout != 0 && b.layout_hash() != expected_layout)
    return bad(fmt::format("layout {:08x} differs from this shard's {:08x}", b.layout_hash(), expected_layout));
  if ((b.flags()[0] & msg::ROW_SEGMENT_START) == 0) return bad("row 0 must start a segment");
  // delta_end starts at 0, never decreases and ends at the number of deltas
  uint32_t prev = 0;
  if (b.delta_end()[0] != 0) return bad("delta_end[0] must be 0");
  for (uint32_t e : b.delta_end()) {
    if (e < prev) return bad("delta_end decreases");
    prev = e;
  }
  if (prev != b.delta_index().size()) return bad("delta_end does not end at the number of deltas");
  uint16_t max_index = 0;
  for (uint16_t i : b.delta_index()) max_index = std::max(max_index, i);
  if (!b.delta_index().empty() && max_index >= b.state_dim())
    return bad(fmt::format("delta index {} outside the state ({} features)", max_index, b.state_dim()));
  if (!AllFinite(b.first_state().data(), b.first_state().size()) ||
      !AllFinite(b.delta_value().data(), b.delta_value().size()) || !AllFinite(b.action().data(), b.action().size()) ||
      !AllFinite(b.goal().data(), b.goal().size()) || !AllFinite(b.reward().data(), b.reward().size()))
    return bad("non-finite values");
  if (check_hash && PayloadHash(b) != b.payload_hash()) return bad("payload hash mismatch");
  return Status::Ok();
}

void DecodeDeltaRows(const float* first_state, uint32_t dim, uint32_t n_rows, const uint32_t* delta_end,
                     const uint16_t* delta_index, const float* delta_value, float* out) {
  if (n_rows == 0) return;
  std::memcpy(out, first_state, size_t(dim) * sizeof(float));
  for (uint32_t r = 1; r < n_rows; ++r) {
    float* row = out + size_t(r) * dim;
    std::memcpy(row, row - dim, size_t(dim) * sizeof(float));
    const uint32_t begin = delta_end[r - 1];
    ApplyDeltas(delta_index + begin, delta_value + begin, delta_end[r] - begin, row);
  }
}

void DecodeStates(const TransitionBatch& b, float* out) {
  DecodeDeltaRows(b.first_state().data(), b.state_dim(), b.n_rows(), b.delta_end().data(), b.delta_index().data(),
                  b.delta_value().data(), out);
}

void BatchBuilder::Begin(TransitionBatch* batch, const BatchHeader& header, uint32_t max_rows) {
  b_ = batch;
  h_ = header;
  max_rows_ = max_rows == 0 || max_rows > COINS_BATCH_MAX_ROWS ? COINS_BATCH_MAX_ROWS : max_rows;
  // action and goal values bound the rows too
  uint32_t per_row = std::max<uint32_t>(header.action_dim, header.goal_dim);
  if (per_row) max_rows_ = std::min<uint32_t>(max_rows_, COINS_BATCH_MAX_VALUES / per_row);
  rows_ = 0;
  prev_.resize(header.state_dim);
  b_->first_state().clear();
  b_->delta_end().clear();
  b_->delta_index().clear();
  b_->delta_value().clear();
  b_->action().clear();
  b_->goal().clear();
  b_->reward().clear();
  b_->flags().clear();
  b_->skill_level().clear();
  b_->interactions().clear();
}

void BatchBuilder::SetProvenance(uint64_t command_seq, std::span<const uint64_t> policy_versions) {
  h_.command_seq = command_seq;
  for (size_t i = 0; i < COINS_MAX_LEVELS; ++i)
    h_.policy_versions[i] = i < policy_versions.size() ? policy_versions[i] : 0;
}

bool BatchBuilder::full() const {
  return rows_ >= max_rows_ || b_->delta_index().size() + h_.state_dim > COINS_BATCH_MAX_DELTAS;
}

void BatchBuilder::AddRow(std::span<const float> state, std::span<const float> action, std::span<const float> goal,
                          float reward, uint16_t flags, uint8_t skill_level, uint32_t interactions) {
  assert(!full() && state.size() == h_.state_dim && action.size() == h_.action_dim && goal.size() == h_.goal_dim);
  if (rows_ == 0) {
    b_->first_state().assign(state.begin(), state.end());
  } else {
    // only the features that changed since the previous row
    // only the features that changed since the previous row; most 16-feature blocks of a
    // factored state are untouched by a step, so compare blocks first
    auto& index = b_->delta_index();
    auto& value = b_->delta_value();
    const uint32_t dim = h_.state_dim;
    const float* now = state.data();
    const float* before = prev_.data();
    for (uint32_t block = 0; block < dim; block += 16) {
      uint32_t end = std::min(dim, block + 16);
      if (std::memcmp(now + block, before + block, (end - block) * sizeof(float)) == 0) continue;
      for (uint32_t i = block; i < end; ++i) {
        if (!SameBits(now[i], before[i])) {
          index.push_back(static_cast<uint16_t>(i));
          value.push_back(now[i]);
        }
      }
    }
  }
  std::memcpy(prev_.data(), state.data(), state.size_bytes());
  b_->delta_end().push_back(static_cast<uint32_t>(b_->delta_index().size()));
  b_->action().insert(b_->action().end(), action.begin(), action.end());
  b_->goal().insert(b_->goal().end(), goal.begin(), goal.end());
  b_->reward().push_back(reward);
  b_->flags().push_back(flags);
  b_->skill_level().push_back(skill_level);
  b_->interactions().push_back(interactions);
  ++rows_;
}

uint64_t BatchBuilder::Finish() {
  b_->schema_version(msg::TRANSITION_BATCH_SCHEMA);
  b_->actor_id(h_.actor_id);
  b_->incarnation(h_.incarnation);
  b_->seq(h_.seq);
  b_->env_id(h_.env_id);
  b_->layout_hash(h_.layout_hash);
  b_->n_rows(rows_);
  b_->state_dim(h_.state_dim);
  b_->action_dim(h_.action_dim);
  b_->goal_dim(h_.goal_dim);
  b_->episode_base(h_.episode_base);
  b_->command_seq(h_.command_seq);
  b_->policy_versions().assign(h_.policy_versions, h_.policy_versions + COINS_MAX_LEVELS);
  uint64_t h = PayloadHash(*b_);
  b_->payload_hash(h);
  return h;
}

}  // namespace coins
