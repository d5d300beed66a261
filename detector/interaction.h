// PairDetector: the interaction detector of one (source a, target b) pair (paper sections
// 3.2-3.4, appendix B).
//
// Train: fits the pair layout; trains the passive model m_pas(s_b) for passive_steps on samples
// where a and b are not close (all samples when the pair has no proximity); copies it into the
// active model m_act(s_a, s_b) (warm_start: zero weights on the source inputs); then trains
// the passive model passive_hard_steps more and the active model active_steps, drawing samples
// in proportion to w = lambda + 1 when ll_pas < 0 and close, else 1 (w = 1 everywhere for a
// pair without positions when upweight_needs_proximity).
// Detect: per-sample log-likelihoods and the interaction test (eq. 8)
//   h = ll_act > eps_act  and  ll_pas < eps_pas  [and close, when proximity_gate]
//       [and ll_act - mean_k ll_act(other transitions' source) > eps_cf, counterfactual_draws]
// Score: on a data set, the MG score (eq. 7, mean ll_act - mean ll_pas), the interaction score
// Sc_I (eq. 9, mean of ll_act - ll_pas over detected interactions; 0 with fewer than
// min_interactions), the control mask (eq. 10, options.mask_rule) and the goal set;
// pass = Sc_I > eps_si. Score the models on data they did not train on (RunDetect holds out
// the tail of its data).
// Characterize: the mask and goal set again, from the detections in other data. A held-out
// share may hold too few interactions to show every goal (a detect round soon after a skill was
// learned: 13-16 bounces, one of the four angles missing or vx left out of the mask); the
// learner's rounds characterize on all their data and score Sc_I on the held-out share alone.
// Multi-instance targets share one model pair over instances, so a class is scored as one
// target; a transition interacts when any of its instances does.
// A PairDetector is used by one thread at a time (the models keep workspaces).
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "common/env_spec.h"
#include "common/status.h"
#include "detector/gaussian_model.h"
#include "detector/goal_set.h"
#include "detector/options.h"
#include "detector/pair_data.h"
#include "detector/transitions.h"

namespace coins::detector {

struct PairScores {
  std::string source, target;
  int64_t transitions = 0, samples = 0;
  double score = 0.0;     // Sc_I (eq. 9)
  double mg_score = 0.0;  // eq. 7
  double mean_ll_act = 0.0, mean_ll_pas = 0.0;
  int64_t interactions = 0;  // N_int: detected (sample-level)
  // detections with other transitions' sources in place of the real ones (mean over the
  // counterfactual draws): what a source unrelated to the target would score
  double chance_interactions = 0.0;
  bool pass = false;             // score > eps_si
  std::vector<int> mask;         // eta_b, one per target feature
  std::vector<float> mask_diff;  // d_k of eq. 10 (normalised units)
  std::vector<std::string> feature_names;
  GoalSet goals;
  int64_t goal_interactions = 0;  // the detections the mask and the goal set came from
  std::string note;               // why the pair was not trained, when it was not
};

struct PairEvaluation {
  bool has_truth = false;  // the env labels source->target
  int64_t states = 0, true_interactions = 0, detected = 0;
  int64_t false_positives = 0, false_negatives = 0;
  double fp_per_state = 0.0, fn_per_interaction = 0.0;
  // why labelled interactions were missed (a miss can have several reasons)
  int64_t fn_act_low = 0, fn_pas_high = 0, fn_far = 0, fn_counterfactual = 0;
  // false positives within kFalsePositiveWindow transitions after a labelled interaction of the
  // same episode: the target still moving on from it (a cube sliding after the push)
  int64_t fp_after_interaction = 0;
};

inline constexpr int kFalsePositiveWindow = 3;

// the detections (flags[t] set) at transitions without a label (truth[t] clear) that come at
// most `window` transitions after a labelled one, counting no further back than the episode's
// first transition (episode_start[t] set); all spans the same size
int64_t FalsePositivesAfterLabels(std::span<const uint8_t> flags, std::span<const uint8_t> truth,
                                  std::span<const uint8_t> episode_start, int window);

class PairDetector {
 public:
  struct Detection {
    PairSamples samples;
    Eigen::VectorXf ll_act, ll_pas;  // per sample
    std::vector<uint8_t> h;          // per sample
    std::vector<uint8_t> why;        // per sample: the failed conditions (Why* bits)
  };
  enum : uint8_t { kWhyActLow = 1, kWhyPasHigh = 2, kWhyFar = 4, kWhyCounterfactual = 8 };

  // errors come from FitPairLayout and DetectorOptions::Validate; stop (optional) is asked
  // during training, and when it says true Train ends early with a "not ready: stopped" error
  static Result<PairDetector> Train(const envs::EnvSpec& spec, const TransitionSet& data, const std::string& source,
                                    const std::string& target, const DetectorOptions& options,
                                    const std::function<bool()>& stop = nullptr);

  // an untrained detector with this layout (e.g. to load published weights into)
  static Result<PairDetector> Create(const PairLayout& layout, const DetectorOptions& options);
  // both models' weights in one blob (passive, then active; common/nn/serialize.h format)
  std::vector<uint8_t> WeightsBlob() const;
  Status LoadWeights(std::span<const uint8_t> blob);

  const PairLayout& layout() const { return layout_; }
  const DetectorOptions& options() const { return options_; }
  // false when the target never changes in the training data (nothing to model)
  bool trained() const { return layout_.output_dim() > 0; }

  Detection Detect(const TransitionSet& data, bool all_instances);
  PairScores Score(const TransitionSet& data);
  // replaces r's mask, mask_diff, goals and goal_interactions with those of the detections in data
  void Characterize(const TransitionSet& data, PairScores* r);
  // detections per transition against the env's labels (all instances of a class)
  PairEvaluation Evaluate(const envs::EnvSpec& spec, const TransitionSet& data);
  // one flag per transition: some sample of it is an interaction (what the learner labels)
  std::vector<uint8_t> TransitionFlags(const TransitionSet& data);

  // what training saw
  struct TrainStats {
    int64_t samples = 0, passive_pool = 0, upweighted = 0;
    float passive_loss = 0.0f, active_loss = 0.0f;
  };
  const TrainStats& train_stats() const { return stats_; }

  GaussianModel& passive() { return passive_; }
  GaussianModel& active() { return active_; }

 private:
  // the active model's log-likelihood of the samples `at` with the source (and relative
  // positions) of randomly drawn other samples: at.size() x counterfactual_draws
  Eigen::MatrixXf ActiveLlWithOtherSources(const Detection& d, const std::vector<int64_t>& at);
  // eq. 10's mask and the goal set of the detected samples `hits` of d (detections on data)
  void MaskAndGoals(const TransitionSet& data, const Detection& d, const std::vector<int64_t>& hits, PairScores* r);

  PairLayout layout_;
  DetectorOptions options_;
  GaussianModel passive_, active_;
  TrainStats stats_;
};

// det.Score(held_out), then det.Characterize(train and held_out together); train is taken by
// value so that a caller done with it moves it in instead of copying it
PairScores ScoreRound(PairDetector& det, TransitionSet train, const TransitionSet& held_out);

}  // namespace coins::detector
