#include "learner/replay_client/sample_source.h"

#include <algorithm>

#include "common/transition_batch.h"

namespace coins {

void SampleColumns::Resize(uint32_t count, uint32_t features, uint32_t actions, uint32_t goals) {
  n = count;
  feature_dim = features;
  action_dim = actions;
  goal_dim = goals;
  state.resize(size_t(n) * feature_dim);
  next_state.resize(size_t(n) * feature_dim);
  action.resize(size_t(n) * action_dim);
  goal.resize(size_t(n) * goal_dim);
  for (auto* v : {&reward, &discount, &weight}) v->resize(n);
  key.resize(n);
  interactions.resize(n);
  flags.resize(n);
  skill_level.resize(n);
  policy_version.resize(n);
}

void FillRequest(const SampleSpec& s, msg::SampleRequest* q) {
  q->schema_version(msg::SAMPLING_SCHEMA);
  q->strategy(s.strategy);
  q->skill_level(s.skill_level);
  q->level_mask(s.level_mask);
  q->n_step(s.n_step);
  q->gamma(s.gamma);
  q->her_strategy(s.her_strategy);
  q->her_ratio(s.her_ratio);
  q->goal_mask(s.goal_mask);
  q->target_offset(s.target_offset);
  q->goal_epsilon(s.goal_epsilon);
  q->goal_norm(s.goal_norm);
  q->features(s.features);
  q->step_reward(s.step_reward);
  q->success_reward(s.success_reward);
  q->interaction_reward(s.interaction_reward);
  q->episode_end_reward(s.episode_end_reward);
  q->require_interaction(s.require_interaction);
  q->terminate_on_interaction(s.terminate_on_interaction);
}

void SplitBatch(std::span<const uint64_t> sizes, uint32_t batch, std::vector<uint32_t>* counts) {
  const size_t K = sizes.size();
  counts->assign(K, 0);
  if (K == 0) return;
  uint64_t total = 0;
  for (uint64_t s : sizes) total += s;
  // floors first, then one more each to the largest remainders (ties: the lower shard)
  std::vector<double> rem(K);
  uint32_t given = 0;
  for (size_t k = 0; k < K; ++k) {
    double share = total ? double(batch) * double(sizes[k]) / double(total) : double(batch) / double(K);
    (*counts)[k] = uint32_t(share);
    rem[k] = share - double((*counts)[k]);
    given += (*counts)[k];
  }
  for (; given < batch; ++given) {
    size_t best = size_t(std::max_element(rem.begin(), rem.end()) - rem.begin());
    (*counts)[best]++;
    rem[best] -= 1.0;
  }
}

namespace {
// checks one reply's columns against its own dims; the error names the shard and the column
Status CheckReply(const msg::SampleReply& r, uint32_t shard) {
  auto bad = [&](std::string_view what) {
    return Errorf("replay shard {}: reply {}: {}", shard, r.correlation_id(), what);
  };
  if (r.schema_version() != msg::SAMPLING_SCHEMA) return bad(fmt::format("schema_version {}", r.schema_version()));
  if (r.status() != msg::SAMPLE_OK) return bad(fmt::format("status {}: {}", r.status(), r.error()));
  const size_t n = r.n(), F = r.feature_dim();
  auto sized = [&](size_t got, size_t want, const char* column) -> Status {
    if (got != want) return bad(fmt::format("{} has {} values, expected {}", column, got, want));
    return Status::Ok();
  };
  COINS_RETURN_IF_ERROR(sized(r.state().size(), n * F, "state"));
  COINS_RETURN_IF_ERROR(sized(r.action().size(), n * r.action_dim(), "action"));
  COINS_RETURN_IF_ERROR(sized(r.goal().size(), n * r.goal_dim(), "goal"));
  for (auto [size, column] :
       {std::pair{r.reward().size(), "reward"}, std::pair{r.discount().size(), "discount"},
        std::pair{r.weight().size(), "weight"}, std::pair{r.key().size(), "key"},
        std::pair{r.next_end().size(), "next_end"}, std::pair{r.interactions().size(), "interactions"},
        std::pair{r.flags().size(), "flags"}, std::pair{r.skill_level().size(), "skill_level"},
        std::pair{r.policy_version().size(), "policy_version"}})
    COINS_RETURN_IF_ERROR(sized(size, n, column));
  COINS_RETURN_IF_ERROR(sized(r.next_value().size(), r.next_index().size(), "next_value"));
  uint32_t prev = 0;
  for (uint32_t e : r.next_end()) {
    if (e < prev || e > r.next_index().size()) return bad("next_end is not a non-decreasing end of next_index");
    prev = e;
  }
  if (prev != r.next_index().size()) return bad("next_end does not end at the number of deltas");
  for (uint16_t j : r.next_index())
    if (j >= F) return bad(fmt::format("next_index {} outside the {} feature columns", j, F));
  return Status::Ok();
}

// copies reply r into out's rows [at, at + r.n())
void CopyReply(const msg::SampleReply& r, uint32_t shard, uint32_t at, SampleColumns* out) {
  const size_t n = r.n(), F = out->feature_dim, A = out->action_dim, G = out->goal_dim;
  std::copy_n(r.state().data(), n * F, out->state.data() + at * F);
  std::copy_n(r.state().data(), n * F, out->next_state.data() + at * F);
  for (uint32_t i = 0; i < n; ++i) {
    const uint32_t begin = i ? r.next_end()[i - 1] : 0;
    ApplyDeltas(r.next_index().data() + begin, r.next_value().data() + begin, r.next_end()[i] - begin,
                out->next_state.data() + (at + i) * F);
    out->key[at + i] = SampleKey(shard, r.key()[i]);
  }
  std::copy_n(r.action().data(), n * A, out->action.data() + at * A);
  std::copy_n(r.goal().data(), n * G, out->goal.data() + at * G);
  std::copy_n(r.reward().data(), n, out->reward.data() + at);
  std::copy_n(r.discount().data(), n, out->discount.data() + at);
  std::copy_n(r.weight().data(), n, out->weight.data() + at);
  std::copy_n(r.interactions().data(), n, out->interactions.data() + at);
  std::copy_n(r.flags().data(), n, out->flags.data() + at);
  std::copy_n(r.skill_level().data(), n, out->skill_level.data() + at);
  std::copy_n(r.policy_version().data(), n, out->policy_version.data() + at);
}
}  // namespace

Status MergeReplies(std::span<const ShardReply> replies, SampleColumns* out) {
  if (replies.empty()) return Errorf("replay: no replies to merge");
  const msg::SampleReply& first = *replies[0].reply;
  uint32_t total = 0;
  for (const ShardReply& s : replies) {
    const msg::SampleReply& r = *s.reply;
    COINS_RETURN_IF_ERROR(CheckReply(r, s.shard));
    if (r.feature_dim() != first.feature_dim() || r.action_dim() != first.action_dim() ||
        r.goal_dim() != first.goal_dim() || r.state_dim() != first.state_dim())
      return Errorf(
          "replay shard {}: reply dims state {} / feature {} / action {} / goal {} differ from shard {}'s "
          "{} / {} / {} / {}",
          s.shard, r.state_dim(), r.feature_dim(), r.action_dim(), r.goal_dim(), replies[0].shard, first.state_dim(),
          first.feature_dim(), first.action_dim(), first.goal_dim());
    total += r.n();
  }
  out->Resize(total, first.feature_dim(), first.action_dim(), first.goal_dim());
  out->state_dim = first.state_dim();
  uint32_t at = 0;
  for (const ShardReply& s : replies) {
    CopyReply(*s.reply, s.shard, at, out);
    at += s.reply->n();
  }
  return Status::Ok();
}

void ColumnsToBatch(const SampleColumns& c, rl::Batch* batch) {
  const int n = int(c.n), F = int(c.feature_dim), G = int(c.goal_dim), A = int(c.action_dim);
  batch->Resize(F + G, A, n);
  // a row-major n x d block is the column-major d x n matrix of the same memory
  using Cols = Eigen::Map<const Eigen::MatrixXf>;
  batch->obs.topRows(F) = Cols(c.state.data(), F, n);
  batch->next_obs.topRows(F) = Cols(c.next_state.data(), F, n);
  if (G > 0) {
    batch->obs.bottomRows(G) = Cols(c.goal.data(), G, n);
    batch->next_obs.bottomRows(G) = Cols(c.goal.data(), G, n);
  }
  batch->actions = Cols(c.action.data(), A, n);
  batch->rewards = Cols(c.reward.data(), 1, n);
  batch->discounts = Cols(c.discount.data(), 1, n);
  batch->weights = Cols(c.weight.data(), 1, n);
  std::copy(c.key.begin(), c.key.end(), batch->keys.begin());
}

Status SampleBatchSource::Sample(int batch_size, rl::Batch* batch) {
  COINS_RETURN_IF_ERROR(source_->Sample(spec_, batch_size, &columns_));
  ColumnsToBatch(columns_, batch);
  return Status::Ok();
}

}  // namespace coins
