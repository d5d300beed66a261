// Actor: steps environments with a policy and streams their rows, batched, into a BatchSink.
//
// Each step's next state goes into the batch being filled as the features that changed (see
// idl/transition.idl); rows are labelled with episode boundaries and the simulator's
// ground-truth interactions.
// It knows nothing of DDS: the sink decides where batches go. For now the policy is uniform
// random over the env's action space; the skill hierarchy plugs in here in a later stage.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "actors/actor_options.h"
#include "actors/batch_sink.h"
#include "actors/envs/env.h"
#include "actors/envs/rng.h"
#include "common/transition_batch.h"

namespace coins {

struct ActorCounters {
  uint64_t steps = 0;
  uint64_t episodes = 0;
  uint64_t batches = 0;
  uint64_t transitions_published = 0;
  uint64_t payload_checksum = 0;   // sum of payload hashes of published batches
  double return_sum = 0;           // over finished episodes
  uint64_t returns_counted = 0;
};

class Actor {
 public:
  // makes `options.envs` environments named env_name; seeds derive from (seed, actor_id, env index)
  static Result<std::unique_ptr<Actor>> Create(const std::string& env_name, const ActorOptions& options,
                                               uint32_t actor_id, uint64_t seed, BatchSink* sink);

  // steps until max_steps (0: unbounded) or until stop() is true; calls on_period every
  // period with the counters. Partial batches are published before returning.
  void Run(uint64_t max_steps, const std::function<bool()>& stop,
           const std::function<void(const ActorCounters&)>& on_period, std::chrono::milliseconds period);

  // the seed env i of this actor is reset with
  static uint64_t EnvSeed(uint64_t seed, uint32_t actor_id, uint64_t env_index);

  const ActorCounters& counters() const { return counters_; }
  const envs::EnvSpec& spec() const { return envs_.front().env->spec(); }
  uint32_t layout_hash() const { return layout_; }

 private:
  struct EnvSlot {
    std::unique_ptr<envs::Env> env;
    std::vector<float> state;      // the env's current state
    std::vector<float> next;       // where Step writes the next state
    std::vector<float> action;
    msg::TransitionBatch* batch = nullptr;
    BatchBuilder builder;
    bool episode_start = true;     // the state in `state` starts an episode
    uint64_t episode = 0;
    double episode_return = 0;
  };

  Actor(uint32_t actor_id, const ActorOptions& options, BatchSink* sink)
      : actor_id_(actor_id), options_(options), sink_(sink) {}
  bool StepOnce(EnvSlot& slot);  // false when the sink is stopping
  bool StartBatch(EnvSlot& slot);
  void PublishBatch(EnvSlot& slot);
  void SampleAction(EnvSlot& slot);

  uint32_t actor_id_;
  ActorOptions options_;
  BatchSink* sink_;
  std::vector<EnvSlot> envs_;
  envs::Rng rng_;
  uint32_t layout_ = 0;
  uint64_t incarnation_ = 0;
  uint64_t seq_ = 0;
  ActorCounters counters_;
};

}  // namespace coins
