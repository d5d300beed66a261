// Actor: steps environments with the skill hierarchy and streams their rows, batched, into a
// BatchSink.
//
// Each env runs a HierarchyRunner (actors/hierarchy.h); its rows go to one stream per level
// (idl/transition.idl: env_id = env index * COINS_MAX_LEVELS + stream), each stream filling its
// own batch: row 0 of a batch repeats the stream's last state, later rows carry the features
// that changed. A stream-0 batch is published when full, together with the other streams of
// that env holding a transition, so high-level rows reach replay as fast as the steps they span.
// Rows carry the skill level, goal, termination and interaction flags, the simulator's labels,
// and each batch the command and weights versions in force.
//
// It knows nothing of DDS: the sink decides where batches go, and the caller's hooks apply new
// weights and commands (Configure, between steps) and pace the stepping.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "actors/actor_options.h"
#include "actors/batch_sink.h"
#include "actors/envs/env.h"
#include "actors/hierarchy.h"
#include "common/transition_batch.h"

namespace coins {

struct ActorCounters {
  uint64_t steps = 0;
  uint64_t episodes = 0;
  uint64_t batches = 0;
  uint64_t transitions_published = 0;
  uint64_t payload_checksum = 0;  // sum of payload hashes of published batches
  double return_sum = 0;          // over finished episodes
  uint64_t returns_counted = 0;
  uint64_t paced_waits = 0;     // times stepping waited for its allowance
  uint64_t step_errors = 0;     // env steps refused (the episode ended, the actor went on)
  HierarchyCounters hierarchy;  // summed over envs
};

class Actor {
 public:
  // makes `options.envs` environments named env_name; seeds derive from (seed, actor_id, env index)
  static Result<std::unique_ptr<Actor>> Create(const std::string& env_name, const ActorOptions& options,
                                               uint32_t actor_id, uint64_t seed, BatchSink* sink);
  ~Actor();

  struct Hooks {
    std::function<bool()> stop = [] { return false; };
    std::function<void(const ActorCounters&)> on_period = [](const ActorCounters&) {};
    std::chrono::milliseconds period{1000};
    // called between steps every few milliseconds: apply new weights and commands (Configure)
    std::function<void(Actor&)> poll = [](Actor&) {};
    // total steps this actor may have taken by now (pacing); UINT64_MAX: no limit
    std::function<uint64_t()> allowance = [] { return UINT64_MAX; };
  };
  // steps until max_steps (0: unbounded) or until hooks.stop() is true. While the allowance is
  // used up it publishes its partial batches and waits (polling, bounded sleeps). Partial
  // batches are published before returning.
  void Run(uint64_t max_steps, const Hooks& hooks);
  // before Run: counters.steps starts from `steps` (a resumed run's actor counts on from its
  // share of the run's env steps, which max_steps and the allowance are measured in)
  void CountStepsFrom(uint64_t steps) { counters_.steps = steps; }
  // the earlier form: uniform random actions unless configured
  void Run(uint64_t max_steps, const std::function<bool()>& stop,
           const std::function<void(const ActorCounters&)>& on_period, std::chrono::milliseconds period);

  // the hierarchy to run from the next step on: models (owned by the caller, alive while they
  // are configured), the acting level (0: random primitive actions), the command they come
  // from and the weights version of each level (stamped on batches). With restart, every env
  // opens new segments (goals and decisions start afresh): after a change of the acting level
  // or of a level's spec. New weights of the same specs need no restart.
  void Configure(const HierarchyModels* models, int acting_level, uint64_t command_seq, std::vector<uint64_t> versions,
                 bool restart);

  // the seed env i of this actor is reset with
  static uint64_t EnvSeed(uint64_t seed, uint32_t actor_id, uint64_t env_index);

  const ActorCounters& counters() const { return counters_; }
  // random per process start; stamped on every batch and status report
  uint64_t incarnation() const { return incarnation_; }
  const envs::EnvSpec& spec() const;
  uint32_t layout_hash() const { return layout_; }
  int action_dim() const { return action_dim_; }
  int goal_dim() const { return goal_dim_; }
  // the row widths a batch of this env needs: room for the env's action or any level's action,
  // and for the goal of any single factor
  static void RowWidths(const envs::EnvSpec& spec, int* action_dim, int* goal_dim);

 private:
  struct Stream {
    msg::TransitionBatch* batch = nullptr;
    BatchBuilder builder;
    std::vector<float> last_state;
    bool has_last = false;
    uint8_t last_skill = 0;
  };
  struct EnvSlot;
  class SlotSink;

  Actor(uint32_t actor_id, const ActorOptions& options, BatchSink* sink);
  bool StepOnce(EnvSlot& slot);  // false when the sink is stopping
  bool AddRow(EnvSlot& slot, int stream, std::span<const float> state, std::span<const float> action,
              std::span<const float> goal, float reward, uint16_t flags, uint8_t skill, uint32_t interactions);
  bool StartBatch(EnvSlot& slot, int stream, bool context_row);
  void PublishBatch(EnvSlot& slot, int stream);
  void PublishEnv(EnvSlot& slot);  // every stream of the env that holds a transition
  void PublishAll();
  void SumCounters();

  uint32_t actor_id_;
  ActorOptions options_;
  BatchSink* sink_;
  std::vector<std::unique_ptr<EnvSlot>> envs_;
  uint32_t layout_ = 0;
  int action_dim_ = 1, goal_dim_ = 0;
  uint64_t incarnation_ = 0;
  uint64_t seq_ = 0;
  const HierarchyModels* models_ = nullptr;
  int acting_ = 0;
  uint64_t command_seq_ = 0;
  std::vector<uint64_t> versions_;
  std::vector<float> zero_action_, zero_goal_;
  ActorCounters counters_;
};

}  // namespace coins
