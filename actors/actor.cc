#include "actors/actor.h"

#include <cstring>
#include <random>

namespace coins {

namespace {
uint64_t Mix(uint64_t a, uint64_t b) {
  uint64_t z = a * 0x9e3779b97f4a7c15ULL + b + 0x632be59bd9b4e019ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}
}  // namespace

uint64_t Actor::EnvSeed(uint64_t seed, uint32_t actor_id, uint64_t env_index) {
  return Mix(Mix(seed, actor_id), env_index);
}

Result<std::unique_ptr<Actor>> Actor::Create(const std::string& env_name, const ActorOptions& options,
                                             uint32_t actor_id, uint64_t seed, BatchSink* sink) {
  std::unique_ptr<Actor> actor(new Actor(actor_id, options, sink));
  actor->rng_.Seed(Mix(seed, actor_id));
  // a fresh incarnation per process start, so shards tell a restarted actor from duplicates
  actor->incarnation_ = Mix(std::random_device{}(), static_cast<uint64_t>(
      std::chrono::steady_clock::now().time_since_epoch().count()));
  for (int64_t i = 0; i < options.envs; ++i) {
    auto env = envs::MakeEnv(env_name);
    if (!env.ok()) return env.status();
    EnvSlot slot;
    slot.env = std::move(env.value());
    const auto& spec = slot.env->spec();
    slot.state.resize(spec.state_dim());
    slot.next.resize(spec.state_dim());
    slot.action.resize(spec.action.dim);
    slot.env->Reset(EnvSeed(seed, actor_id, i), slot.state);
    actor->envs_.push_back(std::move(slot));
  }
  const auto& spec = actor->spec();
  actor->layout_ = LayoutHash(spec.name, spec.state_dim(), spec.action.dim, 0);
  return actor;
}

void Actor::SampleAction(EnvSlot& slot) {
  const auto& a = slot.env->spec().action;
  if (a.discrete) {
    slot.action[0] = static_cast<float>(rng_.UniformInt(0, a.n - 1));
  } else {
    for (int i = 0; i < a.dim; ++i) slot.action[i] = static_cast<float>(rng_.Uniform(a.low[i], a.high[i]));
  }
}

bool Actor::StartBatch(EnvSlot& slot) {
  slot.batch = sink_->Acquire();
  if (!slot.batch) return false;
  const auto& spec = slot.env->spec();
  BatchHeader h{.actor_id = actor_id_,
                .incarnation = incarnation_,
                .seq = 0,  // stamped at publication, so shards see 0, 1, 2, ... in order
                .env_id = static_cast<uint32_t>(&slot - envs_.data()),
                .layout_hash = layout_,
                .state_dim = static_cast<uint32_t>(spec.state_dim()),
                .action_dim = static_cast<uint32_t>(spec.action.dim),
                .goal_dim = 0,
                .episode_base = slot.episode};
  slot.builder.Begin(slot.batch, h, static_cast<uint32_t>(options_.batch_rows));
  // row 0 repeats the state the env is in, so the batch stands alone
  std::fill(slot.action.begin(), slot.action.end(), 0.0f);
  uint16_t flags = msg::ROW_SEGMENT_START | (slot.episode_start ? msg::ROW_EPISODE_START : 0);
  slot.builder.AddRow(slot.state, slot.action, {}, 0.0f, flags, 0, 0);
  return true;
}

void Actor::PublishBatch(EnvSlot& slot) {
  slot.builder.set_seq(seq_);  // stamped at publication, so shards see 0, 1, 2, ... in order
  uint64_t hash = slot.builder.Finish();
  uint32_t transitions = CountTransitions(*slot.batch);
  if (sink_->Publish(slot.batch)) {
    counters_.batches++;
    seq_++;
    counters_.transitions_published += transitions;
    counters_.payload_checksum += hash;
  }
  slot.batch = nullptr;
}

bool Actor::StepOnce(EnvSlot& slot) {
  if (!slot.batch && !StartBatch(slot)) return false;
  SampleAction(slot);
  envs::StepResult result;
  Status s = slot.env->Step(slot.action, slot.next, &result);
  assert(s.ok() && "the random policy only draws valid actions");
  (void)s;
  uint16_t flags = (result.done ? msg::ROW_DONE : 0) | (result.truncated ? msg::ROW_TRUNCATED : 0);
  slot.builder.AddRow(slot.next, slot.action, {}, result.reward, flags, 0, result.interactions);
  std::swap(slot.state, slot.next);
  slot.episode_start = false;
  slot.episode_return += result.reward;
  counters_.steps++;

  if (result.done || result.truncated) {
    counters_.episodes++;
    counters_.return_sum += slot.episode_return;
    counters_.returns_counted++;
    slot.episode_return = 0;
    slot.episode++;
    slot.env->ResetNext(slot.state);
    slot.episode_start = true;
    // the next episode starts in this batch when a transition still fits after its first row
    if (slot.builder.rows() + 2 <= slot.builder.max_rows() && !slot.builder.full()) {
      std::fill(slot.action.begin(), slot.action.end(), 0.0f);
      slot.builder.AddRow(slot.state, slot.action, {}, 0.0f, msg::ROW_SEGMENT_START | msg::ROW_EPISODE_START, 0, 0);
      slot.episode_start = false;
    } else {
      PublishBatch(slot);
    }
  }
  if (slot.batch && slot.builder.full()) PublishBatch(slot);
  return true;
}

void Actor::Run(uint64_t max_steps, const std::function<bool()>& stop,
                const std::function<void(const ActorCounters&)>& on_period, std::chrono::milliseconds period) {
  auto next_report = std::chrono::steady_clock::now() + period;
  bool running = true;
  while (running) {
    for (auto& slot : envs_) {
      if ((max_steps && counters_.steps >= max_steps) || !StepOnce(slot)) {
        running = false;
        break;
      }
    }
    // check the clock and the stop flag every 256 rounds
    if ((counters_.steps & 255) < envs_.size()) {
      if (stop()) running = false;
      auto now = std::chrono::steady_clock::now();
      if (now >= next_report) {
        on_period(counters_);
        next_report = now + period;
      }
    }
  }
  // publish what is left (a batch holding only its context row carries no transition)
  for (auto& slot : envs_) {
    if (!slot.batch) continue;
    if (slot.builder.rows() > 1) {
      PublishBatch(slot);
    } else {
      sink_->Release(slot.batch);
      slot.batch = nullptr;
    }
  }
  on_period(counters_);
}

}  // namespace coins
