// PolicyTrainer: trains one hierarchy level (a skill or the task) from replay samples.
//
// It asks replay for the level's rows (stream and skill level), only the features its
// observation reads, with the level's goal rewards computed and hindsight relabelling done at
// sample time by the shards (idl/sampling.idl); builds observations exactly as actors do
// (common/policy/policy_net.h); and takes one dqn, ddpg or sac step per Update. The acting network's
// weights (ActingBlob) load into a PolicyNet of the same spec: the algorithm's online acting
// network, or with options.acting_average > 0 a running average of it updated after every step
// (kept in ExportState after the algorithm's own sets). One thread at a time.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "common/policy/level_spec.h"
#include "learner/learner_options.h"
#include "learner/replay_client/sample_source.h"
#include "learner/rl/algorithm_state.h"
#include "learner/rl/batch.h"

namespace coins {

namespace rl {
class Dqn;
class Ddpg;
class Sac;
}  // namespace rl

struct TrainStep {
  float loss = 0.0f;
  float mean_q = 0.0f;
};

class PolicyTrainer {
 public:
  static Result<std::unique_ptr<PolicyTrainer>> Create(const policy::LevelSpec& spec, const LevelTrainOptions& options,
                                                       uint64_t seed);
  ~PolicyTrainer();

  const policy::LevelSpec& spec() const { return spec_; }
  // what the level's updates sample (the rows of its stream, its features, its rewards)
  const SampleSpec& sample_spec() const { return sample_; }
  // samples one batch and takes one gradient step
  Result<TrainStep> Update(SampleSource* source);
  // the batch of the last Update (policy versions, flags, ...)
  const SampleColumns& last() const { return columns_; }
  int64_t updates() const;
  // the Polyak factor of the acting weights' running average (0: the online weights)
  double acting_average() const { return options_.acting_average; }
  // weights the level acts with (PolicyNet layout): the online network's, or their average
  std::vector<uint8_t> ActingBlob() const;
  // replaces the acting network's weights, and their average (a blob of ActingBlob's layout; a
  // damaged or foreign one is refused and nothing changes). The algorithm's other networks and
  // optimiser state stay as they are: for a skill whose training has ended (learner/skill_selection.h).
  Status LoadActing(std::span<const uint8_t> blob);
  rl::AlgorithmState ExportState() const;
  Status ImportState(const rl::AlgorithmState& state);

  // observations of sampled columns (for tests): obs_dim x n
  void Observations(const SampleColumns& c, bool next, Eigen::MatrixXf* obs);

 private:
  PolicyTrainer(policy::LevelSpec spec, LevelTrainOptions options);
  void ToBatch(const SampleColumns& c);
  const nn::ParamSet& acting_params() const;  // the algorithm's online acting network
  nn::ParamSet& acting_params();
  bool averages() const { return options_.acting_average > 0; }
  rl::AlgorithmState ExportAlgorithmState() const;               // the algorithm's own state, without the average
  Status ImportAlgorithmState(const rl::AlgorithmState& state);  // its sets first; later ones are left

  policy::LevelSpec spec_;
  LevelTrainOptions options_;
  SampleSpec sample_;
  std::unique_ptr<rl::Dqn> dqn_;
  std::unique_ptr<rl::Ddpg> ddpg_;
  std::unique_ptr<rl::Sac> sac_;
  nn::ParamSet average_;       // with averages(): the acting weights
  size_t algorithm_sets_ = 0;  // sets of the algorithm's own state (the average follows them)
  SampleColumns columns_;
  rl::Batch batch_;
  Eigen::MatrixXf goals_, priorities_;
};

}  // namespace coins
