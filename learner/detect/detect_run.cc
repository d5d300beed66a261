#include "learner/detect/detect_run.h"

#include <chrono>
#include <cmath>
#include <map>

#include <fmt/format.h>

#include "actors/collect.h"
#include "actors/envs/env.h"
#include "common/machine.h"
#include "detector/granger.h"
#include "detector/interaction.h"
#include "detector/transitions.h"

namespace coins::detector {

namespace {

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// a double that JSON can hold (NaN and inf become null)
nlohmann::json Num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

// the data sets (training and evaluation) must fit in memory with room to train: each step is
// held about three times (collected, its training/scoring slices, a model's pair data)
Status CheckDataFits(const DetectRequest& req, const envs::EnvSpec& spec) {
  const double per_step = (2.0 * spec.state_dim() + spec.action.dim) * sizeof(float) + 8;
  const int64_t eval = req.eval ? (req.eval_steps > 0 ? req.eval_steps : req.steps) : 0;
  const double need = 3.0 * per_step * double(req.steps + eval);
  const double have = 0.8 * double(PhysicalMemoryBytes());
  if (have <= 0 || need <= have) return Status::Ok();
  const std::string what =
      req.eval ? fmt::format("--steps {} and --eval-steps {}", req.steps, eval) : fmt::format("--steps {}", req.steps);
  return Errorf(
      "{}: the data would take about {} ({} a step of {}, held about three times while training), "
      "more than 80% of this machine's {} of memory; use fewer steps",
      what, HumanBytes(need), HumanBytes(per_step), req.env, HumanBytes(double(PhysicalMemoryBytes())));
}

}  // namespace

Status DetectRequest::Validate() const {
  if (env.empty()) return Errorf("--env is required");
  if (source.empty()) return Errorf("--source is required");
  if (steps <= 0) return Errorf("--steps must be positive, got {}", steps);
  if (eval_steps < 0) return Errorf("--eval-steps must be >= 0, got {}", eval_steps);
  if (!(holdout >= 0.0 && holdout < 1.0)) return Errorf("--holdout must be in [0, 1), got {}", holdout);
  if (!(screen_alpha >= 0.0 && screen_alpha <= 1.0)) return Errorf("--screen must be in [0, 1], got {}", screen_alpha);
  if (granger_window < 1) return Errorf("--granger-window must be >= 1, got {}", granger_window);
  return options.Validate();
}

namespace {

Status CheckSource(const DetectRequest& req, const envs::EnvSpec& spec) {
  if (req.source == "Action" || spec.factor_index(req.source) >= 0) return Status::Ok();
  std::string names;
  for (const auto& f : spec.factors) names += (names.empty() ? "" : ", ") + f.name;
  return Errorf("--source: env '{}' has no factor '{}' (factors: {})", req.env, req.source, names);
}

// the targets: every uncontrolled factor unless given; errors name a bad target
Result<std::vector<std::string>> ResolveTargets(const DetectRequest& req, const envs::EnvSpec& spec) {
  std::vector<std::string> targets = req.targets;
  if (targets.empty()) {
    for (const auto& f : spec.factors) {
      if (f.name == "Action" || f.name == req.source || f.name == "Done" || f.name == "Reward") continue;
      targets.push_back(f.name);
    }
  }
  for (const std::string& t : targets) {
    if (spec.factor_index(t) < 0) return Errorf("--targets: env '{}' has no factor '{}'", req.env, t);
    if (t == req.source) return Errorf("--targets: '{}' is the source", t);
  }
  return targets;
}

// the linear Granger test on the data (also the optional screen): report["granger"] and the
// p-value of each target
Result<std::map<std::string, double>> RunGranger(const DetectRequest& req, const envs::EnvSpec& spec,
                                                 const TransitionSet& data, const std::vector<std::string>& targets,
                                                 nlohmann::json& report) {
  std::map<std::string, double> p_values;
  GrangerOptions go;
  go.window = req.granger_window;
  go.seed = req.seed;
  auto t4 = std::chrono::steady_clock::now();
  Result<std::vector<GrangerResult>> g = LinearGrangerTest(spec, data, req.source, targets, go);
  if (!g.ok()) return g.status();
  report["granger_seconds"] = Seconds(t4);
  report["granger"] = nlohmann::json::array();
  for (const GrangerResult& r : g.value()) {
    p_values[r.target] = r.p_value;
    report["granger"].push_back({{"target", r.target},
                                 {"f_stat", Num(r.f_stat)},
                                 {"p_value", Num(r.p_value)},
                                 {"df1", r.df1},
                                 {"df2", r.df2},
                                 {"feature", r.feature},
                                 {"causes", r.causes},
                                 {"samples", r.samples}});
  }
  return p_values;
}

// a target screened out by the linear test: no neural models
nlohmann::json ScreenedTarget(const DetectRequest& req, const envs::EnvSpec& spec, const std::string& target,
                              double p_value) {
  const envs::FactorSpec& f = spec.factors[spec.factor_index(target)];
  nlohmann::json j = {{"target", target},
                      {"score", 0.0},
                      {"mg_score", nullptr},
                      {"interactions", 0},
                      {"samples", 0},
                      {"features", f.feature_names},
                      {"mask", std::vector<int>(f.features, 0)},
                      {"mask_diff", std::vector<float>(f.features, 0.0f)},
                      {"goal_set", nlohmann::json::array()},
                      {"goal_kind", "empty"},
                      {"pass", false},
                      {"train_seconds", 0.0},
                      {"score_seconds", 0.0},
                      {"screened", true},
                      {"note", fmt::format("linear Granger p {:.3g} >= --screen {}", p_value, req.screen_alpha)}};
  if (req.eval) {
    j["fp_per_state"] = nullptr;
    j["fn_per_interaction"] = nullptr;
    j["true_interactions"] = 0;
    j["detected"] = 0;
    j["false_positives"] = 0;
    j["fp_after_interaction"] = 0;
    j["false_negatives"] = 0;
    j["fn_reasons"] = nlohmann::json::object();
  }
  return j;
}

// a target's scores, mask and goal set
void AddScores(const PairScores& s, nlohmann::json& j) {
  j["score"] = Num(s.score);
  j["mg_score"] = Num(s.mg_score);
  j["mean_ll_act"] = Num(s.mean_ll_act);
  j["mean_ll_pas"] = Num(s.mean_ll_pas);
  j["interactions"] = s.interactions;
  j["chance_interactions"] = Num(s.chance_interactions);
  j["samples"] = s.samples;
  j["features"] = s.feature_names;
  j["mask"] = s.mask;
  j["mask_diff"] = s.mask_diff;
  j["goal_kind"] = GoalKindName(s.goals.kind);
  if (s.goals.kind == GoalSet::Kind::kContinuous) {
    j["goal_set"] = {{"low", s.goals.low}, {"high", s.goals.high}};
  } else {
    j["goal_set"] = s.goals.goals;
    j["goal_counts"] = s.goals.counts;
  }
  j["goal_unique_raw"] = s.goals.raw_unique;
  j["goal_interactions"] = s.goal_interactions;
  j["pass"] = s.pass;
  if (!s.note.empty()) j["note"] = s.note;
}

// the detector against the simulator's labels on the evaluation data
void AddEvaluation(PairDetector& det, const envs::EnvSpec& spec, const TransitionSet& eval_data, nlohmann::json& j) {
  auto t3 = std::chrono::steady_clock::now();
  PairEvaluation e = det.Evaluate(spec, eval_data);
  j["eval_seconds"] = Seconds(t3);
  j["fp_per_state"] = e.has_truth ? Num(e.fp_per_state) : nlohmann::json();
  j["fn_per_interaction"] = e.has_truth ? Num(e.fn_per_interaction) : nlohmann::json();
  j["true_interactions"] = e.true_interactions;
  j["detected"] = e.detected;
  j["false_positives"] = e.false_positives;
  j["fp_after_interaction"] = e.fp_after_interaction;  // within kFalsePositiveWindow steps of a label
  j["false_negatives"] = e.false_negatives;
  j["fn_reasons"] = {{"active_low", e.fn_act_low},
                     {"passive_high", e.fn_pas_high},
                     {"far", e.fn_far},
                     {"counterfactual", e.fn_counterfactual}};
}

// trains the pair's detector on `train`, scores it on `scored` and evaluates it on eval_data
// (when req.eval)
Result<nlohmann::json> DetectTarget(const DetectRequest& req, const envs::EnvSpec& spec, const TransitionSet& train,
                                    const TransitionSet& scored, const TransitionSet& eval_data,
                                    const std::string& target) {
  DetectorOptions opts = req.options;
  if (req.paper_sizes) {
    const DetectorOptions p = DefaultDetectorOptions(req.env, true, req.source, target);
    if (p.active_hidden != DetectorOptions().active_hidden) {
      opts.passive_hidden = p.passive_hidden;
      opts.active_hidden = p.active_hidden;
    }
  }
  auto t1 = std::chrono::steady_clock::now();
  Result<PairDetector> det = PairDetector::Train(spec, train, req.source, target, opts);
  if (!det.ok()) return det.status();
  const double train_s = Seconds(t1);
  auto t2 = std::chrono::steady_clock::now();
  PairScores s = ScoreRound(*det, train, scored);
  const double score_s = Seconds(t2);
  nlohmann::json j;
  j["target"] = target;
  AddScores(s, j);
  j["hidden"] = opts.active_hidden;
  j["train_seconds"] = train_s;
  const PairDetector::TrainStats& ts = det->train_stats();
  j["train"] = {{"samples", ts.samples},
                {"passive_pool", ts.passive_pool},
                {"upweighted", ts.upweighted},
                {"passive_loss", ts.passive_loss},
                {"active_loss", ts.active_loss}};
  j["score_seconds"] = score_s;
  if (req.eval) AddEvaluation(*det, spec, eval_data, j);
  return j;
}

}  // namespace

Result<nlohmann::json> RunDetect(const DetectRequest& req) {
  COINS_RETURN_IF_ERROR(req.Validate());
  Result<std::unique_ptr<envs::Env>> env = envs::MakeEnv(req.env);
  if (!env.ok()) return env.status().WithContext("--env");
  const envs::EnvSpec& spec = (*env)->spec();
  COINS_RETURN_IF_ERROR(CheckSource(req, spec));
  COINS_RETURN_IF_ERROR(CheckDataFits(req, spec));
  Result<std::vector<std::string>> targets = ResolveTargets(req, spec);
  if (!targets.ok()) return targets.status();

  // collect the data
  auto t0 = std::chrono::steady_clock::now();
  CollectOptions co;
  co.policy = req.policy;
  co.steps = req.steps;
  co.seed = req.seed;
  Result<TransitionSet> data = CollectTransitions(**env, co);
  if (!data.ok()) return data.status();
  nlohmann::json report;
  report["env"] = req.env;
  report["source"] = req.source;
  report["policy"] = req.policy;
  report["steps"] = req.steps;
  report["seed"] = req.seed;
  report["collect_seconds"] = Seconds(t0);
  // split: train on the head, score on the held-out tail
  const int64_t n_score = int64_t(req.holdout * double(data->size()));
  const TransitionSet train = n_score > 0 ? data->Slice(0, data->size() - n_score) : data->Slice(0, data->size());
  const TransitionSet scored =
      n_score > 0 ? data->Slice(data->size() - n_score, data->size()) : data->Slice(0, data->size());
  report["holdout"] = req.holdout;
  report["scored_states"] = scored.size();
  report["eps_si"] = req.options.eps_si;
  report["mask_rule"] = MaskRuleName(req.options.mask_rule);
  report["options"] = OptionsJson(req.options);

  // a fresh evaluation set from another seed
  TransitionSet eval_data;
  if (req.eval) {
    co.steps = req.eval_steps > 0 ? req.eval_steps : req.steps;
    co.seed = req.seed + 1000003;
    Result<TransitionSet> ed = CollectTransitions(**env, co);
    if (!ed.ok()) return ed.status();
    eval_data = std::move(ed.value());
    report["eval_states"] = eval_data.size();
  }

  std::map<std::string, double> p_values;
  if (req.granger || req.screen_alpha > 0.0) {
    auto p = RunGranger(req, spec, data.value(), *targets, report);
    if (!p.ok()) return p.status();
    p_values = std::move(*p);
  }
  // train and score every target
  report["targets"] = nlohmann::json::array();
  for (const std::string& target : *targets) {
    if (req.screen_alpha > 0.0 && p_values[target] >= req.screen_alpha) {
      report["targets"].push_back(ScreenedTarget(req, spec, target, p_values[target]));
      continue;
    }
    Result<nlohmann::json> j = DetectTarget(req, spec, train, scored, eval_data, target);
    if (!j.ok()) return j.status();
    report["targets"].push_back(std::move(*j));
  }
  return report;
}

std::string FormatDetectTable(const nlohmann::json& r) {
  std::string out =
      fmt::format("env {}  source {}  policy {}  steps {}  (collected in {:.1f} s)\n", r["env"].get<std::string>(),
                  r["source"].get<std::string>(), r["policy"].get<std::string>(), r["steps"].get<int64_t>(),
                  r["collect_seconds"].get<double>());
  const bool eval = r.contains("eval_states");
  out += fmt::format("{:<10} {:>9} {:>9} {:>8} {:<6}  {:<22} {:<11} {}\n", "target", "Sc_I", "MG", "N_int", "pass",
                     "mask", "goal kind", "goal set");
  for (const auto& t : r["targets"]) {
    std::string mask;
    const auto& names = t["features"];
    for (size_t k = 0; k < t["mask"].size(); ++k) {
      if (!t["mask"][k].get<int>()) continue;
      if (!mask.empty()) mask += ',';
      mask += names[k].get<std::string>();
    }
    if (mask.empty()) mask.push_back('-');
    auto num = [](const nlohmann::json& v) {
      return v.is_null() ? std::string("nan") : fmt::format("{:.3f}", v.get<double>());
    };
    out += fmt::format("{:<10} {:>9} {:>9} {:>8} {:<6}  {:<22} {:<11} {}\n", t["target"].get<std::string>(),
                       num(t["score"]), num(t["mg_score"]), t["interactions"].get<int64_t>(),
                       t["pass"].get<bool>() ? "PASS" : "fail", mask, t["goal_kind"].get<std::string>(),
                       t["goal_set"].dump());
    out += fmt::format("{:<10} train {:.1f} s, score {:.2f} s\n", "", t["train_seconds"].get<double>(),
                       t["score_seconds"].get<double>());
    if (t.contains("note")) out += fmt::format("{:<10} note: {}\n", "", t["note"].get<std::string>());
    if (eval) {
      out += fmt::format(
          "{:<10} eval: fp/state {}  fn/interaction {}  ({} labelled, {} detected, {} false positives, "
          "{} of them within {} steps after a label; misses: {})\n",
          "", t["fp_per_state"].is_null() ? "n/a" : fmt::format("{:.3g}", t["fp_per_state"].get<double>()),
          t["fn_per_interaction"].is_null() ? "n/a" : fmt::format("{:.3g}", t["fn_per_interaction"].get<double>()),
          t["true_interactions"].get<int64_t>(), t["detected"].get<int64_t>(), t["false_positives"].get<int64_t>(),
          t["fp_after_interaction"].get<int64_t>(), kFalsePositiveWindow, t["fn_reasons"].dump());
    }
  }
  if (r.contains("granger")) {
    out += "linear Granger test (F-test, alpha 1e-3):\n";
    for (const auto& g : r["granger"]) {
      out +=
          fmt::format("{:<10} F {:>12.4g}  p {:>10.3g}  causes {}  (feature {}, n {})\n",
                      g["target"].get<std::string>(), g["f_stat"].is_null() ? NAN : g["f_stat"].get<double>(),
                      g["p_value"].is_null() ? NAN : g["p_value"].get<double>(), g["causes"].get<bool>() ? "yes" : "no",
                      g["feature"].get<std::string>(), g["samples"].get<int64_t>());
    }
  }
  return out;
}

}  // namespace coins::detector
