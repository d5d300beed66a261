#include "actors/actor.h"

#include <algorithm>
#include <cstring>
#include <random>
#include <thread>

#include <spdlog/spdlog.h>

#include "common/splitmix.h"

namespace coins {

namespace {
// a seed derived from two words
uint64_t Mix(uint64_t a, uint64_t b) { return SplitMix64Mix(a * kSplitMixGamma + b + 0x632be59bd9b4e019ULL); }
}  // namespace

struct Actor::EnvSlot {
  std::unique_ptr<envs::Env> env;
  uint32_t index = 0;
  std::vector<float> state, next, action;
  std::unique_ptr<HierarchyRunner> runner;
  std::vector<Stream> streams;
  std::unique_ptr<SlotSink> rows;
  bool segment_start = true;  // the runner must open new segments before the next step
  bool episode_start = true;  // ... and they start an episode
  uint64_t episode = 0;
  double episode_return = 0;
};

// routes the runner's rows into the slot's streams
class Actor::SlotSink final : public RowSink {
 public:
  SlotSink(Actor* actor, EnvSlot* slot) : actor_(actor), slot_(slot) {}
  void Row(int stream, std::span<const float> state, std::span<const float> action, std::span<const float> goal,
           float reward, uint16_t flags, uint8_t skill, uint32_t interactions) override {
    ok = actor_->AddRow(*slot_, stream, state, action, goal, reward, flags, skill, interactions) && ok;
  }
  bool ok = true;

 private:
  Actor* actor_;
  EnvSlot* slot_;
};

uint64_t Actor::EnvSeed(uint64_t seed, uint32_t actor_id, uint64_t env_index) {
  return Mix(Mix(seed, actor_id), env_index);
}

void Actor::RowWidths(const envs::EnvSpec& spec, int* action_dim, int* goal_dim) {
  int widest = 0;
  for (const auto& f : spec.factors)
    if (!f.multi_instance && f.instances == 1) widest = std::max(widest, f.features);
  *goal_dim = widest;
  *action_dim = std::max(spec.action.dim, widest);
}

Actor::Actor(uint32_t actor_id, const ActorOptions& options, BatchSink* sink)
    : actor_id_(actor_id), options_(options), sink_(sink) {}

Actor::~Actor() = default;

const envs::EnvSpec& Actor::spec() const { return envs_.front()->env->spec(); }

Result<std::unique_ptr<Actor>> Actor::Create(const std::string& env_name, const ActorOptions& options,
                                             uint32_t actor_id, uint64_t seed, BatchSink* sink) {
  std::unique_ptr<Actor> actor(new Actor(actor_id, options, sink));
  // a fresh incarnation per process start, so shards tell a restarted actor from duplicates
  actor->incarnation_ =
      Mix(std::random_device{}(), static_cast<uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count()));
  for (int64_t i = 0; i < options.envs; ++i) {
    auto env = envs::MakeEnv(env_name);
    if (!env.ok()) return env.status();
    auto slot = std::make_unique<EnvSlot>();
    slot->env = std::move(env.value());
    slot->index = uint32_t(i);
    const auto& spec = slot->env->spec();
    if (i == 0) RowWidths(spec, &actor->action_dim_, &actor->goal_dim_);
    slot->state.resize(spec.state_dim());
    slot->next.resize(spec.state_dim());
    slot->action.resize(spec.action.dim);
    slot->streams.resize(COINS_MAX_LEVELS);
    const uint64_t env_seed = EnvSeed(seed, actor_id, uint64_t(i));
    slot->runner = std::make_unique<HierarchyRunner>(slot->env->spec(), actor->action_dim_, actor->goal_dim_,
                                                     Mix(env_seed, 0x6869657261726368ULL));
    slot->env->Reset(env_seed, slot->state);
    slot->rows = std::make_unique<SlotSink>(actor.get(), slot.get());
    actor->envs_.push_back(std::move(slot));
  }
  const auto& spec = actor->spec();
  actor->layout_ = LayoutHash(spec.name, spec.state_dim(), actor->action_dim_, actor->goal_dim_);
  actor->versions_.assign(COINS_MAX_LEVELS, 0);
  actor->zero_action_.assign(size_t(actor->action_dim_), 0.0f);
  actor->zero_goal_.assign(size_t(actor->goal_dim_), 0.0f);
  for (auto& slot : actor->envs_) slot->runner->Configure(nullptr, 0, true);
  return actor;
}

void Actor::Configure(const HierarchyModels* models, int acting_level, uint64_t command_seq,
                      std::vector<uint64_t> versions, bool restart) {
  models_ = models;
  acting_ = acting_level;
  command_seq_ = command_seq;
  versions.resize(COINS_MAX_LEVELS, 0);
  versions_ = std::move(versions);
  for (auto& slot : envs_) {
    slot->runner->Configure(models, acting_level, true);
    if (restart) slot->segment_start = true;
  }
}

bool Actor::StartBatch(EnvSlot& slot, int stream, bool context_row) {
  Stream& st = slot.streams[size_t(stream)];
  st.batch = sink_->Acquire();
  if (!st.batch) return false;
  const auto& spec = slot.env->spec();
  BatchHeader h{.actor_id = actor_id_,
                .incarnation = incarnation_,
                .seq = 0,  // stamped at publication, so shards see 0, 1, 2, ... in order
                .env_id = slot.index * COINS_MAX_LEVELS + uint32_t(stream),
                .layout_hash = layout_,
                .state_dim = static_cast<uint32_t>(spec.state_dim()),
                .action_dim = static_cast<uint32_t>(action_dim_),
                .goal_dim = static_cast<uint32_t>(goal_dim_),
                .episode_base = slot.episode};
  st.builder.Begin(st.batch, h, static_cast<uint32_t>(options_.batch_rows));
  if (context_row) {
    // row 0 repeats the stream's last state, so the batch stands alone
    st.builder.AddRow(st.last_state, zero_action_, zero_goal_, 0.0f, msg::ROW_SEGMENT_START, st.last_skill, 0);
  }
  return true;
}

void Actor::PublishBatch(EnvSlot& slot, int stream) {
  Stream& st = slot.streams[size_t(stream)];
  if (!st.batch) return;
  // a batch holding only its context row carries no transition
  if (CountTransitions(*st.batch) == 0 && st.builder.rows() <= 1) {
    sink_->Release(st.batch);
    st.batch = nullptr;
    return;
  }
  st.builder.SetProvenance(command_seq_, versions_);
  st.builder.set_seq(seq_);  // stamped at publication, so shards see 0, 1, 2, ... in order
  uint64_t hash = st.builder.Finish();
  uint32_t transitions = CountTransitions(*st.batch);
  if (sink_->Publish(st.batch)) {
    counters_.batches++;
    seq_++;
    counters_.transitions_published += transitions;
    counters_.payload_checksum += hash;
  }
  st.batch = nullptr;
}

void Actor::PublishEnv(EnvSlot& slot) {
  for (int s = 0; s < int(COINS_MAX_LEVELS); ++s) PublishBatch(slot, s);
}

void Actor::PublishAll() {
  for (auto& slot : envs_) PublishEnv(*slot);
}

bool Actor::AddRow(EnvSlot& slot, int stream, std::span<const float> state, std::span<const float> action,
                   std::span<const float> goal, float reward, uint16_t flags, uint8_t skill, uint32_t interactions) {
  Stream& st = slot.streams[size_t(stream)];
  if (st.batch && st.builder.full()) {
    // a full stream-0 batch takes the env's other streams along
    if (stream == 0)
      PublishEnv(slot);
    else
      PublishBatch(slot, stream);
  }
  const bool segment_start = (flags & msg::ROW_SEGMENT_START) != 0;
  if (!st.batch && !StartBatch(slot, stream, st.has_last && !segment_start)) return false;
  st.builder.AddRow(state, action, goal, reward, flags, skill, interactions);
  st.last_state.assign(state.begin(), state.end());
  st.has_last = true;
  st.last_skill = skill;
  return true;
}

bool Actor::StepOnce(EnvSlot& slot) {
  if (slot.segment_start) {
    slot.runner->StartEpisode(slot.state, slot.rows.get(), slot.episode_start);
    slot.segment_start = slot.episode_start = false;
  }
  slot.runner->Decide(slot.state, slot.action);
  envs::StepResult result;
  Status s = slot.env->Step(slot.action, slot.next, &result);
  if (!s.ok()) {
    // an action the env refuses, or a simulator failure: end the episode, keep running
    spdlog::warn("actor {} env {}: {}; episode ended", actor_id_, slot.index, s.message());
    counters_.step_errors++;
    slot.env->ResetNext(slot.state);
    slot.segment_start = slot.episode_start = true;
    return slot.rows->ok;
  }
  slot.runner->Observe(slot.state, slot.action, slot.next, result.reward, result.done || result.truncated,
                       result.truncated, result.interactions, slot.rows.get());
  std::swap(slot.state, slot.next);
  slot.episode_return += result.reward;
  counters_.steps++;
  if (result.done || result.truncated) {
    counters_.episodes++;
    counters_.return_sum += slot.episode_return;
    counters_.returns_counted++;
    slot.episode_return = 0;
    slot.episode++;
    slot.env->ResetNext(slot.state);
    slot.segment_start = slot.episode_start = true;
  }
  return slot.rows->ok;
}

void Actor::SumCounters() {
  HierarchyCounters sum;
  for (const auto& slot : envs_) {
    const HierarchyCounters& c = slot->runner->counters();
    for (int i = 0; i < 8; ++i) {
      sum.goals_ended[i] += c.goals_ended[i];
      sum.goals_reached[i] += c.goals_reached[i];
    }
    sum.detector_states += c.detector_states;
    sum.detector_truth += c.detector_truth;
    sum.detector_fp += c.detector_fp;
    sum.detector_fn += c.detector_fn;
  }
  counters_.hierarchy = sum;
}

void Actor::Run(uint64_t max_steps, const Hooks& hooks) {
  using Clock = std::chrono::steady_clock;
  auto next_report = Clock::now() + hooks.period;
  auto next_poll = Clock::now();
  bool running = true;
  while (running) {
    // every 64 rounds: the clock, the stop flag, new weights and commands
    if ((counters_.steps & 63) < envs_.size()) {
      if (hooks.stop()) break;
      const auto now = Clock::now();
      if (now >= next_poll) {
        hooks.poll(*this);
        next_poll = now + std::chrono::milliseconds(5);
      }
      if (now >= next_report) {
        SumCounters();
        hooks.on_period(counters_);
        next_report = now + hooks.period;
      }
    }
    // pacing: out of allowance, publish what is held and wait for more
    if (counters_.steps >= hooks.allowance()) {
      PublishAll();
      counters_.paced_waits++;
      while (running && counters_.steps >= hooks.allowance()) {
        if (hooks.stop()) running = false;
        hooks.poll(*this);
        if (Clock::now() >= next_report) {
          SumCounters();
          hooks.on_period(counters_);
          next_report = Clock::now() + hooks.period;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
      }
      continue;
    }
    for (auto& slot : envs_) {
      if ((max_steps && counters_.steps >= max_steps) || !StepOnce(*slot)) {
        running = false;
        break;
      }
    }
  }
  PublishAll();
  SumCounters();
  hooks.on_period(counters_);
}

void Actor::Run(uint64_t max_steps, const std::function<bool()>& stop,
                const std::function<void(const ActorCounters&)>& on_period, std::chrono::milliseconds period) {
  Hooks hooks;
  hooks.stop = stop;
  hooks.on_period = on_period;
  hooks.period = period;
  Run(max_steps, hooks);
}

}  // namespace coins
