#include "learner/trainers/detect_round.h"

#include <algorithm>
#include <chrono>
#include <unordered_set>
#include <utility>

#include <spdlog/spdlog.h>

#include "common/process.h"
#include "common/splitmix.h"
#include "detector/pair_space.h"

namespace coins {

namespace {

void FillGoalSet(const detector::GoalSet& g, msg::InteractionScore* m) {
  m->goal_kind(detector::GoalKindName(g.kind));
  std::vector<float> values;
  if (g.kind == detector::GoalSet::Kind::kDiscrete) {
    for (const auto& goal : g.goals) values.insert(values.end(), goal.begin(), goal.end());
  } else if (g.kind == detector::GoalSet::Kind::kContinuous) {
    values = g.low;
    values.insert(values.end(), g.high.begin(), g.high.end());
  }
  m->goal_set(values);
}

}  // namespace

msg::InteractionScore ToScoreMessage(const detector::PairScores& s, const envs::EnvSpec& env, double train_seconds) {
  msg::InteractionScore m;
  m.source(s.source);
  m.target(s.target);
  m.score(s.score);
  m.mg_score(s.mg_score);
  m.interactions(uint64_t(std::max<int64_t>(0, s.interactions)));
  m.chance_interactions(s.chance_interactions);
  m.goal_interactions(uint64_t(std::max<int64_t>(0, s.goal_interactions)));
  m.pass(s.pass);
  std::vector<float> mask(s.mask.begin(), s.mask.end());
  m.mask(mask);
  FillGoalSet(s.goals, &m);
  m.transitions(uint64_t(s.transitions));
  m.interaction_rate(s.transitions ? double(s.interactions) / double(s.transitions) : 0.0);
  m.train_seconds(train_seconds);
  const int f = env.factor_index(s.target);
  const bool single = f >= 0 && !env.factors[size_t(f)].multi_instance && env.factors[size_t(f)].instances == 1;
  m.eligible(single && s.goals.kind != detector::GoalSet::Kind::kEmpty);
  m.note(!s.note.empty() ? s.note
         : !single       ? "a multi-instance class: scored, but a skill reaches goals of one factor"
         : s.goals.kind == detector::GoalSet::Kind::kEmpty ? "no goal set"
                                                           : "");
  return m;
}

Result<PairData> SamplePairData(SampleSource* source, const detector::PairSpace& space, int64_t wanted,
                                const DetectRoundOptions& o) {
  SampleSpec spec;
  spec.level_mask = o.level_mask;
  spec.n_step = 1;
  for (int g : space.gather) spec.features.push_back(uint16_t(g));
  const int adim = space.sub.action.dim;
  PairData d{detector::TransitionSet(space.sub.state_dim(), adim),
             detector::TransitionSet(space.sub.state_dim(), adim)};
  std::unordered_set<uint64_t> seen;
  SampleColumns c;
  const int64_t draws = 2 * wanted;
  const int chunk = int(std::clamp<int64_t>(COINS_SAMPLE_MAX_VALUES / std::max<size_t>(space.gather.size(), 1), 1,
                                            COINS_SAMPLE_MAX_BATCH));
  const uint64_t cut = uint64_t(o.holdout * 1000.0);
  for (int64_t drawn = 0; drawn < draws && int64_t(seen.size()) < wanted; drawn += chunk) {
    COINS_RETURN_IF_ERROR(source->Sample(spec, int(std::min<int64_t>(chunk, draws - drawn)), &c));
    const size_t F = c.feature_dim, A = c.action_dim;
    for (uint32_t i = 0; i < c.n; ++i) {
      if (!seen.insert(c.key[i]).second) continue;
      detector::TransitionSet& into = SplitMix64Mix(c.key[i]) % 1000 < cut ? d.held_out : d.train;
      into.Append({c.state.data() + i * F, F}, {c.action.data() + i * A, size_t(adim)},
                  {c.next_state.data() + i * F, F}, c.interactions[i], false);
    }
    o.tick();
  }
  if (d.train.size() == 0 || d.held_out.size() == 0)
    return Errorf(
        "too few primitive transitions of {} in replay to train and score on: {} distinct of {} wanted ({} to "
        "train, {} held out)",
        space.sub.factors.back().name, seen.size(), wanted, d.train.size(), d.held_out.size());
  return d;
}

Result<std::vector<DetectedTarget>> RunDetectRound(SampleSource* source, const envs::EnvSpec& env,
                                                   const std::string& source_factor,
                                                   const std::vector<std::string>& targets, int64_t rows_available,
                                                   const DetectRoundOptions& o) {
  std::vector<DetectedTarget> out;
  for (const std::string& target : targets) {
    // a stop between targets (a target's models train for seconds): the round has no result
    if (StopRequested()) return Errorf("not ready: stopping before {}->{}", source_factor, target);
    auto space = detector::MakePairSpace(env, source_factor, target);
    if (!space.ok()) return space.status();
    const int64_t wanted =
        std::min({rows_available, o.max_samples, o.max_floats / int64_t(std::max<size_t>(space->gather.size(), 1))});
    auto data = SamplePairData(source, *space, std::max<int64_t>(wanted, 2), o);
    if (!data.ok()) return data.status().WithContext(source_factor + "->" + target);
    const auto start = std::chrono::steady_clock::now();
    auto det = detector::PairDetector::Train(space->sub, data->train, source_factor, target, o.detector, [&o] {
      o.tick();
      return StopRequested();
    });
    if (!det.ok()) return det.status().WithContext(source_factor + "->" + target);
    o.tick();
    const detector::PairScores scores = detector::ScoreRound(*det, std::move(data->train), data->held_out);
    spdlog::info("{}->{}: Sc_I {:.2f} from {} held-out detections; mask and goal set from {} detections", source_factor,
                 target, scores.score, scores.interactions, scores.goal_interactions);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    DetectedTarget t;
    t.score = ToScoreMessage(scores, env, seconds);
    if (det->trained()) {
      t.spec = {det->layout(), o.detector, space->gather, space->full_state_dim};
      t.detector = std::make_unique<detector::PairDetector>(std::move(*det));
    }
    out.push_back(std::move(t));
    o.tick();
  }
  return out;
}

}  // namespace coins
