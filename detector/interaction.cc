#include "detector/interaction.h"

#include "common/nn/serialize.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <fmt/format.h>

namespace coins::detector {

namespace {

GaussianModelOptions ModelOptions(const PairLayout& L, const DetectorOptions& o, bool active) {
  GaussianModelOptions m;
  m.input_dim = active ? L.active_input_dim() : L.passive_input_dim();
  m.output_dim = L.output_dim();
  m.hidden = active ? o.active_hidden : o.passive_hidden;
  m.lr = o.lr;
  m.clip_norm = o.clip_norm;
  m.min_std = o.min_std;
  return m;
}

}  // namespace

Result<PairDetector> PairDetector::Create(const PairLayout& layout, const DetectorOptions& options) {
  COINS_RETURN_IF_ERROR(options.Validate());
  PairDetector det;
  det.layout_ = layout;
  det.options_ = options;
  if (det.trained()) {
    det.passive_ = GaussianModel(ModelOptions(layout, options, false), options.seed + 1);
    det.active_ = GaussianModel(ModelOptions(layout, options, true), options.seed + 3);
  }
  return det;
}

std::vector<uint8_t> PairDetector::WeightsBlob() const {
  if (!trained()) return {};
  const nn::ParamSet* sets[2] = {&passive_.params(), &active_.params()};
  return nn::ToBlob(std::span<const nn::ParamSet* const>(sets, 2));
}

Status PairDetector::LoadWeights(std::span<const uint8_t> blob) {
  if (!trained()) return Errorf("{}->{}: the detector has no models to load", layout_.source, layout_.target);
  nn::ParamSet* sets[2] = {&passive_.net().params(), &active_.net().params()};
  return nn::FromBlob(blob, std::span<nn::ParamSet* const>(sets, 2),
                      fmt::format("{}->{} detector weights", layout_.source, layout_.target));
}

Result<PairDetector> PairDetector::Train(const envs::EnvSpec& spec, const TransitionSet& data,
                                         const std::string& source, const std::string& target,
                                         const DetectorOptions& options, const std::function<bool()>& stop) {
  COINS_RETURN_IF_ERROR(options.Validate());
  auto stopped = [&] { return stop && stop(); };
  auto stopped_error = [&] { return Errorf("not ready: stopped while training the {}->{} models", source, target); };
  Result<PairLayout> layout = FitPairLayout(spec, data, source, target, options);
  if (!layout.ok()) return layout.status();
  PairDetector det;
  det.layout_ = std::move(layout.value());
  det.options_ = options;
  if (!det.trained()) return det;
  const PairLayout& L = det.layout_;

  // encode the training samples
  PairSamples s = EncodePairs(L, data, options, /*all_instances=*/false, options.seed + 11);
  const int64_t m = s.size();

  // passive model, away from proximity
  det.passive_ = GaussianModel(ModelOptions(L, options, false), options.seed + 1);
  std::vector<int64_t> pool;
  pool.reserve(m);
  for (int64_t j = 0; j < m; ++j) {
    if (!L.has_proximity() || !s.close[j]) pool.push_back(j);
  }
  if (pool.empty()) {
    for (int64_t j = 0; j < m; ++j) pool.push_back(j);
  }
  det.passive_.Train(s.passive_in, s.target, pool, {}, options.passive_steps, options.batch, options.seed + 2, stop);
  if (stopped()) return stopped_error();

  det.stats_.passive_pool = int64_t(pool.size());

  // the active model starts as the passive one (warm start)
  GaussianModel active(ModelOptions(L, options, true), options.seed + 3);
  if (options.warm_start && options.active_hidden == options.passive_hidden) {
    active.WarmStartFrom(det.passive_, L.source_input_dim());
  }

  // second passive phase, while the active model trains: optionally up-sample the passive
  // model's own misses away from the source (passive_hard_lambda)
  Eigen::VectorXf ll_pas;
  if (options.passive_hard_steps > 0) {
    det.passive_.LogLikelihood(s.passive_in, s.target, &ll_pas);
    std::vector<float> pw(pool.size());
    for (size_t i = 0; i < pool.size(); ++i) {
      pw[i] = ll_pas[pool[i]] < options.eps_pas ? options.passive_hard_lambda + 1.0f : 1.0f;
    }
    det.stats_.passive_loss = det.passive_.Train(s.passive_in, s.target, pool, pw, options.passive_hard_steps,
                                                 options.batch, options.seed + 5, stop);
    if (stopped()) return stopped_error();
  }

  // active model, up-sampling close transitions the passive model gets wrong
  det.passive_.LogLikelihood(s.passive_in, s.target, &ll_pas);
  std::vector<float> w(m);
  pool.resize(m);
  for (int64_t j = 0; j < m; ++j) {
    pool[j] = j;
    const bool close = L.has_proximity() ? s.close[j] != 0 : !options.upweight_needs_proximity;
    w[j] = (ll_pas[j] < 0.0f && close) ? options.lambda + 1.0f : 1.0f;
  }
  det.active_ = std::move(active);
  det.stats_.active_loss =
      det.active_.Train(s.active_in, s.target, pool, w, options.active_steps, options.batch, options.seed + 4, stop);
  if (stopped()) return stopped_error();
  det.stats_.samples = m;
  for (float wj : w) det.stats_.upweighted += wj > 1.0f;
  return det;
}

Eigen::MatrixXf PairDetector::ActiveLlWithOtherSources(const Detection& d, const std::vector<int64_t>& at) {
  const int64_t m = d.samples.size();
  const int src = layout_.source_input_dim(), nrel = layout_.relative_dim();
  const int tfeat = layout_.target_features;
  Eigen::MatrixXf in(layout_.active_input_dim(), at.size()), tgt(layout_.output_dim(), at.size());
  Eigen::VectorXf ll;
  Eigen::MatrixXf out(Eigen::Index(at.size()), options_.counterfactual_draws);
  std::mt19937_64 rng(options_.seed + 31);
  std::uniform_int_distribution<int64_t> pick(0, m - 1);
  for (int k = 0; k < options_.counterfactual_draws; ++k) {
    for (size_t c = 0; c < at.size(); ++c) {
      const int64_t j = at[c];
      // another sample whose source differs (what if the source had been different)
      int64_t o = pick(rng);
      for (int tries = 0; tries < 16; ++tries) {
        if (d.samples.active_in.col(o).head(src) != d.samples.active_in.col(j).head(src)) break;
        o = pick(rng);
      }
      in.col(c) = d.samples.active_in.col(j);
      tgt.col(c) = d.samples.target.col(j);
      // the other sample's source, and relative positions recomputed against this target:
      // rel = (a - b) / r and normalised b = (b - mid) / half_b, so moving the other source onto
      // this target shifts rel by the difference of b in env units over r
      in.col(c).head(src) = d.samples.active_in.col(o).head(src);
      for (int p = 0; p < nrel; ++p) {
        const int ib = layout_.positions[p % int(layout_.positions.size())].second;
        const float rel_o = d.samples.active_in(src + tfeat + p, o);
        const float half_b = 0.5f * (layout_.target_high[ib] - layout_.target_low[ib]);
        const float db = d.samples.active_in(src + ib, o) - d.samples.active_in(src + ib, j);
        in(src + tfeat + p, c) = rel_o + db * half_b / layout_.relative_scale(p % int(layout_.positions.size()));
      }
    }
    active_.LogLikelihood(in, tgt, &ll);
    out.col(k) = ll;
  }
  return out;
}

PairDetector::Detection PairDetector::Detect(const TransitionSet& data, bool all_instances) {
  Detection d;
  d.samples = EncodePairs(layout_, data, options_, all_instances, options_.seed + 23);
  const int64_t m = d.samples.size();
  d.h.assign(m, 0);
  d.why.assign(m, kWhyActLow);
  if (!trained()) {
    d.ll_act = Eigen::VectorXf::Zero(m);
    d.ll_pas = Eigen::VectorXf::Zero(m);
    return d;
  }
  active_.LogLikelihood(d.samples.active_in, d.samples.target, &d.ll_act);
  passive_.LogLikelihood(d.samples.passive_in, d.samples.target, &d.ll_pas);
  const bool gate = options_.proximity_gate && layout_.has_proximity();
  d.why.assign(m, 0);
  for (int64_t j = 0; j < m; ++j) {
    uint8_t why = 0;
    if (!(d.ll_act[j] > options_.eps_act)) why |= kWhyActLow;
    if (!(d.ll_pas[j] < options_.eps_pas)) why |= kWhyPasHigh;
    if (gate && !d.samples.close[j]) why |= kWhyFar;
    d.why[j] = why;
    d.h[j] = why == 0;
  }

  // counterfactual check on the candidates: the source of other transitions must do worse
  std::vector<int64_t> cand;
  for (int64_t j = 0; j < m; ++j) {
    if (d.h[j]) cand.push_back(j);
  }
  if (options_.counterfactual_draws > 0 && !cand.empty() && m > 1) {
    const Eigen::VectorXf cf = ActiveLlWithOtherSources(d, cand).rowwise().mean();
    for (size_t c = 0; c < cand.size(); ++c) {
      if (d.ll_act[cand[c]] - cf[Eigen::Index(c)] <= options_.eps_cf) {
        d.h[cand[c]] = 0;
        d.why[cand[c]] |= kWhyCounterfactual;
      }
    }
  }
  return d;
}

PairScores PairDetector::Score(const TransitionSet& data) {
  const PairLayout& L = layout_;
  PairScores r;
  r.source = L.source;
  r.target = L.target;
  r.transitions = data.size();
  r.mask.assign(L.target_features, 0);
  r.mask_diff.assign(L.target_features, 0.0f);
  r.feature_names = L.target_feature_names;
  if (!trained()) {
    r.note = "the target never changes in the data";
    return r;
  }
  Detection d = Detect(data, /*all_instances=*/false);
  const int64_t m = d.samples.size();
  r.samples = m;

  // eq. 7 and eq. 9
  r.mean_ll_act = d.ll_act.cast<double>().mean();
  r.mean_ll_pas = d.ll_pas.cast<double>().mean();
  r.mg_score = r.mean_ll_act - r.mean_ll_pas;
  double sum = 0.0;
  std::vector<int64_t> hits;
  for (int64_t j = 0; j < m; ++j) {
    if (!d.h[j]) continue;
    hits.push_back(j);
    sum += double(d.ll_act[j]) - double(d.ll_pas[j]);
  }
  r.interactions = int64_t(hits.size());
  // detections expected by chance: the states a detection could be at (passive wrong, close),
  // with other transitions' sources in place of their own
  if (options_.counterfactual_draws > 0 && m > 1) {
    std::vector<int64_t> possible;
    const bool gate = options_.proximity_gate && L.has_proximity();
    for (int64_t j = 0; j < m; ++j) {
      if (d.ll_pas[j] < options_.eps_pas && (!gate || d.samples.close[j])) possible.push_back(j);
    }
    if (!possible.empty()) {
      const Eigen::MatrixXf other = ActiveLlWithOtherSources(d, possible);
      r.chance_interactions = double((other.array() > options_.eps_act).count()) / double(other.cols());
    }
  }
  const bool above_chance = double(r.interactions) > options_.chance_ratio * r.chance_interactions;
  if (r.interactions >= options_.min_interactions && above_chance) r.score = sum / double(r.interactions);
  if (r.interactions >= options_.min_interactions && !above_chance) {
    r.note = fmt::format("{} detections, not above {:g} x the {:.1f} with other transitions' sources (chance)",
                         r.interactions, options_.chance_ratio, r.chance_interactions);
  }
  r.pass = r.score > options_.eps_si;
  MaskAndGoals(data, d, hits, &r);
  return r;
}

void PairDetector::Characterize(const TransitionSet& data, PairScores* r) {
  if (!trained()) return;
  const Detection d = Detect(data, /*all_instances=*/false);
  std::vector<int64_t> hits;
  for (int64_t j = 0; j < int64_t(d.h.size()); ++j)
    if (d.h[j]) hits.push_back(j);
  MaskAndGoals(data, d, hits, r);
}

void PairDetector::MaskAndGoals(const TransitionSet& data, const Detection& d, const std::vector<int64_t>& hits,
                                PairScores* out) {
  const PairLayout& L = layout_;
  PairScores& r = *out;
  r.goal_interactions = int64_t(hits.size());
  r.mask.assign(size_t(L.target_features), 0);
  r.mask_diff.assign(size_t(L.target_features), 0.0f);
  r.goals = GoalSet();
  if (hits.empty()) return;
  // eq. 10: mean deviation of the post-interaction value from the passive prediction
  Eigen::MatrixXf hit_in(L.passive_input_dim(), hits.size()), mean;
  for (size_t i = 0; i < hits.size(); ++i) hit_in.col(i) = d.samples.passive_in.col(hits[i]);
  passive_.Mean(hit_in, &mean);
  std::vector<double> dev(L.target_features, 0.0);
  for (size_t i = 0; i < hits.size(); ++i) {
    const int64_t t = d.samples.transition[hits[i]];
    const int base = L.target_offset + d.samples.instance[hits[i]] * L.target_features;
    const auto s = data.state(t), s2 = data.next_state(t);
    for (int k = 0; k < L.target_features; ++k) {
      float pred = s[base + k];
      for (int q = 0; q < L.output_dim(); ++q) {
        if (L.dims[q] == k) pred += mean(q, i) * L.scale[q];
      }
      dev[k] += std::abs(s2[base + k] - pred) / L.mask_unit(k);
    }
  }
  double max_dev = 0.0;
  for (int k = 0; k < L.target_features; ++k) {
    r.mask_diff[k] = float(dev[k] / double(hits.size()));
    max_dev = std::max(max_dev, double(r.mask_diff[k]));
  }
  const double thr = options_.mask_rule == MaskRule::kRelative ? options_.eps_eta_relative * max_dev : options_.eps_eta;
  std::vector<int> feats;
  std::vector<float> half;
  for (int k = 0; k < L.target_features; ++k) {
    r.mask[k] = r.mask_diff[k] > thr && r.mask_diff[k] > 0.0f ? 1 : 0;
    if (r.mask[k]) {
      feats.push_back(k);
      half.push_back(0.5f * (L.target_high[k] - L.target_low[k]));
    }
  }

  // goal set: the masked post-interaction states
  Eigen::MatrixXf values(feats.size(), hits.size());
  for (size_t i = 0; i < hits.size(); ++i) {
    const int64_t t = d.samples.transition[hits[i]];
    const int base = L.target_offset + d.samples.instance[hits[i]] * L.target_features;
    const auto s2 = data.next_state(t);
    for (size_t q = 0; q < feats.size(); ++q) values(q, i) = s2[base + feats[q]];
  }
  r.goals = BuildGoalSet(feats, values, half, options_);
}

PairScores ScoreRound(PairDetector& det, TransitionSet train, const TransitionSet& held_out) {
  PairScores r = det.Score(held_out);
  train.AppendAll(held_out);
  det.Characterize(train, &r);
  return r;
}

std::vector<uint8_t> PairDetector::TransitionFlags(const TransitionSet& data) {
  std::vector<uint8_t> flags(data.size(), 0);
  Detection d = Detect(data, /*all_instances=*/true);
  for (int64_t j = 0; j < d.samples.size(); ++j) {
    if (d.h[j]) flags[d.samples.transition[j]] = 1;
  }
  return flags;
}

int64_t FalsePositivesAfterLabels(std::span<const uint8_t> flags, std::span<const uint8_t> truth,
                                  std::span<const uint8_t> episode_start, int window) {
  int64_t count = 0;
  int64_t since_label = -1;  // transitions since the episode's last label (-1: none yet)
  for (size_t t = 0; t < flags.size(); ++t) {
    if (episode_start[t]) since_label = -1;
    if (truth[t]) {
      since_label = 0;
      continue;
    }
    if (since_label >= 0) ++since_label;
    count += flags[t] && since_label >= 1 && since_label <= window;
  }
  return count;
}

PairEvaluation PairDetector::Evaluate(const envs::EnvSpec& spec, const TransitionSet& data) {
  PairEvaluation e;
  e.states = data.size();
  const int bit = InteractionBit(spec, layout_.source, layout_.target);
  e.has_truth = bit >= 0;
  std::vector<uint8_t> flags(data.size(), 0), why(data.size(), 0), truth(data.size(), 0), starts(data.size(), 0);
  Detection d = Detect(data, /*all_instances=*/true);
  for (int64_t j = 0; j < d.samples.size(); ++j) {
    const int64_t t = d.samples.transition[j];
    if (d.h[j]) flags[t] = 1;
    why[t] |= d.why[j];
  }
  for (int64_t t = 0; t < data.size(); ++t) {
    if (e.has_truth && (data.interactions(t) >> bit) & 1u && !flags[t]) {
      e.fn_act_low += (why[t] & kWhyActLow) != 0;
      e.fn_pas_high += (why[t] & kWhyPasHigh) != 0;
      e.fn_far += (why[t] & kWhyFar) != 0;
      e.fn_counterfactual += (why[t] & kWhyCounterfactual) != 0;
    }
    truth[t] = e.has_truth && (data.interactions(t) >> bit) & 1u;
    starts[t] = data.episode_start(t);
    e.detected += flags[t];
    e.true_interactions += truth[t];
    e.false_positives += flags[t] && !truth[t];
    e.false_negatives += truth[t] && !flags[t];
  }
  if (!e.has_truth) return e;
  e.fp_after_interaction = FalsePositivesAfterLabels(flags, truth, starts, kFalsePositiveWindow);
  e.fp_per_state = e.states ? double(e.false_positives) / double(e.states) : 0.0;
  e.fn_per_interaction = e.true_interactions ? double(e.false_negatives) / double(e.true_interactions) : 0.0;
  return e;
}

}  // namespace coins::detector
