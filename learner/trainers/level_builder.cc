#include "learner/trainers/level_builder.h"

#include <algorithm>

#include "detector/detector_spec.h"

namespace coins {

namespace {

using policy::ActionKind;
using policy::GoalKind;
using policy::LevelSpec;

// the factor's features appended to the observation
void AddFactor(const envs::EnvSpec& env, int f, LevelSpec* s) {
  const envs::FactorSpec& fs = env.factors[size_t(f)];
  const int offset = env.factor_offset(f);
  for (int i = 0; i < fs.size(); ++i) {
    const int k = i % fs.features;
    s->obs_index.push_back(offset + i);
    s->obs_low.push_back(fs.low[size_t(k)]);
    s->obs_high.push_back(fs.high[size_t(k)]);
  }
}

// the observation row of a state feature already in the observation
int ObsRow(const LevelSpec& s, int full) {
  return int(std::find(s.obs_index.begin(), s.obs_index.end(), full) - s.obs_index.begin());
}

// relative positions of two single factors already in the observation (positions into obs_index)
void AddRelative(const envs::EnvSpec& env, int fa, int fb, LevelSpec* s) {
  if (fa < 0 || fb < 0) return;
  const envs::FactorSpec &a = env.factors[size_t(fa)], &b = env.factors[size_t(fb)];
  const int oa = env.factor_offset(fa), ob = env.factor_offset(fb);
  for (int i = 0; i < a.features; ++i) {
    const std::string& n = a.feature_names[size_t(i)];
    if (n != "x" && n != "y" && n != "z") continue;
    for (int j = 0; j < b.features; ++j)
      if (b.feature_names[size_t(j)] == n) {
        s->relative.emplace_back(ObsRow(*s, oa + i), ObsRow(*s, ob + j));
        s->relative_scale.push_back(0.5f * (b.high[size_t(j)] - b.low[size_t(j)]));
      }
  }
}

void SetNetwork(const LevelTrainOptions& o, LevelSpec* s) {
  s->algorithm = o.algorithm;
  s->hidden.assign(o.hidden.begin(), o.hidden.end());
  s->activation = nn::Activation::kRelu;
  s->dueling = o.dueling;
  s->atoms = int(o.atoms);
  s->v_min = float(o.v_min);
  s->v_max = float(o.v_max);
  s->explore = float(o.explore);
  s->timeout = int(o.timeout);
  s->decision_period = int(o.decision_period);
  s->hold_decision = o.hold_decision;
  s->child_ratio = float(o.child_ratio);
}

// continuous actions train with sac when the level's options ask for it, else with ddpg
std::string ContinuousAlgorithm(const LevelTrainOptions& o) { return o.algorithm == "sac" ? "sac" : "ddpg"; }

// actions that are goals of `child`
Status SetChildActions(const policy::LevelSpec& child, const LevelTrainOptions& o, LevelSpec* s) {
  if (child.goal.kind == GoalKind::kDiscrete) {
    s->action_kind = ActionKind::kChildDiscrete;
    s->num_actions = int(child.goal.goals.size());
    s->algorithm = "dqn";
    return Status::Ok();
  }
  if (!o.child_offsets.empty() && child.goal.dim() == 1) {
    s->action_kind = ActionKind::kChildOffsets;
    s->child_offsets.assign(o.child_offsets.begin(), o.child_offsets.end());
    s->num_actions = int(o.child_offsets.size());
    s->algorithm = "dqn";
    return Status::Ok();
  }
  s->action_kind = ActionKind::kChildContinuous;
  s->action_dim = child.goal.dim();
  s->algorithm = ContinuousAlgorithm(o);
  return Status::Ok();
}

void SetPrimitiveActions(const envs::EnvSpec& env, const LevelTrainOptions& o, LevelSpec* s) {
  const envs::ActionSpec& a = env.action;
  s->action_kind = a.discrete ? ActionKind::kPrimitiveDiscrete : ActionKind::kPrimitiveContinuous;
  s->num_actions = a.discrete ? a.n : 0;
  s->action_dim = a.discrete ? 1 : a.dim;
  s->action_low = a.low;
  s->action_high = a.high;
  s->algorithm = a.discrete ? "dqn" : ContinuousAlgorithm(o);
  s->decision_period = 1;
}

// the single-instance state factors (not Action, Done or Reward), in env order
std::vector<int> SingleStateFactors(const envs::EnvSpec& env) {
  std::vector<int> single;
  for (int f = 0; f < int(env.factors.size()); ++f) {
    const envs::FactorSpec& fs = env.factors[size_t(f)];
    if (!fs.multi_instance && fs.name != "Action" && fs.name != "Done" && fs.name != "Reward") single.push_back(f);
  }
  return single;
}

// relative positions of every pair of single-instance factors (Paddle-Ball, Block-Target)
void AddRelativeOfEveryPair(const envs::EnvSpec& env, LevelSpec* s) {
  const std::vector<int> single = SingleStateFactors(env);
  for (size_t a = 0; a < single.size(); ++a)
    for (size_t b = a + 1; b < single.size(); ++b) AddRelative(env, single[a], single[b], s);
}

// each point of the pair network also sees every single factor's x, y, z minus the instance's
// same feature, in the instance's normalised units: a normalised source value n_a is mapped by
// half_a / half_i * n_a + (mid_a - mid_i) / half_i, so the feature is (a - i) / half_i
void AddPairRelative(const envs::EnvSpec& env, LevelSpec* s) {
  const envs::FactorSpec& inst = env.factors[size_t(env.factor_index(s->pair_factor))];
  for (int f : SingleStateFactors(env)) {
    const envs::FactorSpec& a = env.factors[size_t(f)];
    for (int i = 0; i < a.features; ++i) {
      const std::string& n = a.feature_names[size_t(i)];
      if (n != "x" && n != "y" && n != "z") continue;
      const auto j = std::find(inst.feature_names.begin(), inst.feature_names.end(), n);
      if (j == inst.feature_names.end()) continue;
      const int row = ObsRow(*s, env.factor_offset(f) + i), k = int(j - inst.feature_names.begin());
      const float mid_a = 0.5f * (s->obs_high[size_t(row)] + s->obs_low[size_t(row)]);
      const float half_a = 0.5f * (s->obs_high[size_t(row)] - s->obs_low[size_t(row)]);
      const float mid_i = 0.5f * (inst.high[size_t(k)] + inst.low[size_t(k)]);
      const float half_i = 0.5f * (inst.high[size_t(k)] - inst.low[size_t(k)]);
      s->pair.relative.push_back({row, k, half_a / half_i, (mid_a - mid_i) / half_i});
    }
  }
}

// every factor but Action, Done and Reward; with pair_hidden, a pair network over the first
// multi-instance factor (its instances are contiguous in the observation; presence: attr, or
// every instance present when the class has no attr, like the pushing obstacles), whose points
// see the single factors relative to the instance when o.relative is "all"
void AddStateFactors(const envs::EnvSpec& env, const LevelTrainOptions& o, LevelSpec* s) {
  for (int f = 0; f < int(env.factors.size()); ++f) {
    const envs::FactorSpec& fs = env.factors[size_t(f)];
    if (fs.name == "Action" || fs.name == "Done" || fs.name == "Reward") continue;
    if (fs.multi_instance && !o.pair_hidden.empty() && !s->pair.enabled()) {
      const auto attr = std::find(fs.feature_names.begin(), fs.feature_names.end(), "attr");
      s->pair_factor = fs.name;
      s->pair = {int(s->obs_index.size()),
                 fs.instances,
                 fs.features,
                 attr == fs.feature_names.end() ? -1 : int(attr - fs.feature_names.begin()),
                 {},
                 {}};
      s->hidden.assign(o.pair_hidden.begin(), o.pair_hidden.end());
      s->pair.head.assign(o.pair_head.begin(), o.pair_head.end());
    }
    AddFactor(env, f, s);
  }
  if (s->pair.enabled() && o.relative == "all") AddPairRelative(env, s);
}

Status SetGoalSpace(const envs::EnvSpec& env, const msg::LinkSpec& link, const LevelTrainOptions& o, LevelSpec* s) {
  auto goal = policy::MakeGoalSpace(env, link.target(), link.mask());
  if (!goal.ok()) return goal.status();
  s->goal = std::move(*goal);
  const int d = s->goal.dim();
  const auto& set = link.goal_set();
  const float half = 0.5f * (s->goal.scale_high[0] - s->goal.scale_low[0]);
  if (link.goal_kind() == "discrete") {
    if (set.empty() || set.size() % size_t(d) != 0)
      return Errorf("link {}->{}: discrete goal set of {} values for {} masked features", link.source(), link.target(),
                    set.size(), d);
    s->goal.kind = GoalKind::kDiscrete;
    for (size_t i = 0; i < set.size(); i += size_t(d))
      s->goal.goals.emplace_back(set.begin() + long(i), set.begin() + long(i) + d);
    s->goal.epsilon = 1e-3f * half;  // discrete goals are met exactly
    s->goal.norm = GoalNorm::kLinf;
    return Status::Ok();
  }
  if (link.goal_kind() != "continuous" || set.size() != size_t(2 * d))
    return Errorf("link {}->{}: goal kind '{}' with {} values for {} masked features", link.source(), link.target(),
                  link.goal_kind(), set.size(), d);
  s->goal.kind = GoalKind::kContinuous;
  s->goal.low.assign(set.begin(), set.begin() + d);
  s->goal.high.assign(set.begin() + d, set.end());
  s->goal.epsilon = float(o.goal_epsilon) * half;
  s->goal.norm = GoalNorm::kLinf;
  s->goal.sample_ratio = float(o.goal_sample_ratio);
  return Status::Ok();
}

}  // namespace

Result<LevelSpec> BuildSkillSpec(const envs::EnvSpec& env, const msg::LinkSpec& link, int level, const LevelSpec* child,
                                 const LevelTrainOptions& o) {
  LevelSpec s;
  s.name = "skill/" + link.target();
  s.level = level;
  s.source = link.source();
  SetNetwork(o, &s);
  COINS_RETURN_IF_ERROR(SetGoalSpace(env, link, o, &s).WithContext("level " + std::to_string(level)));
  const int fs = link.source() == "Action" ? -1 : env.factor_index(link.source());
  const int ft = env.factor_index(link.target());
  if (link.source() != "Action" && fs < 0) return Errorf("env '{}' has no factor '{}'", env.name, link.source());
  if (fs >= 0) AddFactor(env, fs, &s);
  AddFactor(env, ft, &s);
  AddRelative(env, fs, ft, &s);
  if (level == 1) {
    SetPrimitiveActions(env, o, &s);
  } else {
    if (!child) return Errorf("level {} needs the spec of level {}", level, level - 1);
    COINS_RETURN_IF_ERROR(SetChildActions(*child, o, &s));
  }
  if (SparseLink(link)) {
    s.require_interaction = o.reach_needs_interaction;
    s.terminate_on_interaction = o.interaction_ends_goal == "rare";
    s.detector = detector::DetectorWeightsName(link.source(), link.target());
  }
  COINS_RETURN_IF_ERROR(s.Validate());
  return s;
}

Result<LevelSpec> BuildTaskSpec(const envs::EnvSpec& env, const LevelSpec& top, const LevelTrainOptions& o) {
  LevelSpec s;
  s.name = "task";
  s.level = top.level + 1;
  SetNetwork(o, &s);
  AddStateFactors(env, o, &s);
  if (o.relative == "all") {
    AddRelativeOfEveryPair(env, &s);
  } else {
    const int fs = top.source == "Action" ? -1 : env.factor_index(top.source);
    AddRelative(env, fs, env.factor_index(top.goal.factor), &s);
  }
  COINS_RETURN_IF_ERROR(SetChildActions(top, o, &s));
  COINS_RETURN_IF_ERROR(s.Validate());
  return s;
}

Result<LevelSpec> BuildPrimitiveTaskSpec(const envs::EnvSpec& env, const LevelTrainOptions& o) {
  LevelSpec s;
  s.name = "task";
  s.level = 1;
  SetNetwork(o, &s);
  AddStateFactors(env, o, &s);
  AddRelativeOfEveryPair(env, &s);
  if (o.decision_period > 1)
    return Errorf("learner.task_decision_period {}: the task over primitive actions of {} acts every env step (0 or 1)",
                  o.decision_period, env.name);
  SetPrimitiveActions(env, o, &s);
  if (s.algorithm != o.algorithm)
    return Errorf("the task over primitive actions of {} needs learner.task_algorithm {} (it is {})", env.name,
                  s.algorithm, o.algorithm);
  COINS_RETURN_IF_ERROR(s.Validate());
  return s;
}

}  // namespace coins
