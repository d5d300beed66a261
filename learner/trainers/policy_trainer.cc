#include "learner/trainers/policy_trainer.h"

#include "common/nn/serialize.h"
#include "common/policy/policy_net.h"
#include "learner/rl/ddpg.h"
#include "learner/rl/dqn.h"
#include "learner/rl/sac.h"

namespace coins {

namespace {

uint8_t HerCode(const std::string& her) {
  if (her == "final") return msg::HER_FINAL;
  if (her == "future") return msg::HER_FUTURE;
  return msg::HER_NONE;
}

// the stream and level bits of a level's rows: level 1 lives in stream 0 as skill level 1
SampleSpec MakeSampleSpec(const policy::LevelSpec& s, const LevelTrainOptions& o) {
  SampleSpec q;
  q.strategy = o.prioritized ? msg::SAMPLE_PRIORITIZED : msg::SAMPLE_UNIFORM;
  q.level_mask = 1u << s.level;
  q.n_step = uint32_t(o.n_step);
  q.gamma = float(o.gamma);
  for (int i : s.obs_index) q.features.push_back(uint16_t(i));
  if (s.is_task()) return q;
  q.her_strategy = HerCode(o.her);
  q.her_ratio = q.her_strategy == msg::HER_NONE ? 0.0f : float(o.her_ratio);
  q.goal_mask = s.goal.mask;
  q.target_offset = uint32_t(s.goal.offset);
  q.goal_epsilon = s.goal.epsilon;
  q.goal_norm = s.goal.norm == GoalNorm::kL1 ? msg::GOAL_NORM_L1 : msg::GOAL_NORM_LINF;
  q.step_reward = float(o.step_reward);
  q.success_reward = float(o.success_reward);
  q.interaction_reward = float(o.interaction_reward);
  q.episode_end_reward = float(o.episode_end_reward);
  q.require_interaction = s.require_interaction;
  q.terminate_on_interaction = s.terminate_on_interaction;
  return q;
}

}  // namespace

PolicyTrainer::PolicyTrainer(policy::LevelSpec spec, LevelTrainOptions options)
    : spec_(std::move(spec)), options_(std::move(options)), sample_(MakeSampleSpec(spec_, options_)) {}

PolicyTrainer::~PolicyTrainer() = default;

Result<std::unique_ptr<PolicyTrainer>> PolicyTrainer::Create(const policy::LevelSpec& spec, const LevelTrainOptions& o,
                                                             uint64_t seed) {
  COINS_RETURN_IF_ERROR(spec.Validate());
  std::unique_ptr<PolicyTrainer> t(new PolicyTrainer(spec, o));
  if (spec.algorithm == "dqn") {
    rl::DqnOptions d;
    d.obs_dim = spec.obs_dim();
    d.num_actions = spec.num_actions;
    d.hidden = spec.hidden;
    d.split = spec.pair;
    d.activation = spec.activation;
    d.dueling = spec.dueling;
    d.distributional = spec.atoms > 1;
    d.atoms = std::max(spec.atoms, 2);
    d.v_min = spec.v_min;
    d.v_max = spec.v_max;
    d.lr = float(o.lr);
    d.target_update_period = int(o.target_update);
    d.batch_size = int(o.batch);
    d.seed = seed;
    COINS_RETURN_IF_ERROR(d.Validate().WithContext(spec.name));
    t->dqn_ = std::make_unique<rl::Dqn>(d);
  } else if (spec.algorithm == "sac") {
    rl::SacOptions d;
    d.obs_dim = spec.obs_dim();
    d.action_dim = spec.action_dim;
    d.hidden = spec.hidden;
    d.split = spec.pair;
    d.activation = spec.activation;
    d.actor_lr = d.critic_lr = d.alpha_lr = float(o.lr);
    d.tau = float(o.tau);
    d.init_alpha = float(o.sac_alpha);
    d.batch_size = int(o.batch);
    d.seed = seed;
    COINS_RETURN_IF_ERROR(d.Validate().WithContext(spec.name));
    t->sac_ = std::make_unique<rl::Sac>(d);
  } else {
    rl::DdpgOptions d;
    d.obs_dim = spec.obs_dim();
    d.action_dim = spec.action_dim;
    d.hidden = spec.hidden;
    d.activation = spec.activation;
    d.actor_lr = d.critic_lr = float(o.lr);
    d.tau = float(o.tau);
    d.exploration_sigma = spec.explore;
    d.batch_size = int(o.batch);
    d.seed = seed;
    COINS_RETURN_IF_ERROR(d.Validate().WithContext(spec.name));
    t->ddpg_ = std::make_unique<rl::Ddpg>(d);
  }
  // the acting network of the spec must be what the algorithm trains
  auto net = policy::PolicyNet::Create(spec);
  if (!net.ok()) return net.status();
  if (!net->params().SameShape(t->acting_params()))
    return Errorf("{}: the trained network does not match the acting network", spec.name);
  if (t->averages()) t->average_ = t->acting_params();
  t->algorithm_sets_ = t->ExportAlgorithmState().sets.size();
  return t;
}

int64_t PolicyTrainer::updates() const { return dqn_ ? dqn_->updates() : sac_ ? sac_->updates() : ddpg_->updates(); }

const nn::ParamSet& PolicyTrainer::acting_params() const {
  return dqn_ ? dqn_->online().params() : sac_ ? sac_->actor().params() : ddpg_->actor().params();
}

nn::ParamSet& PolicyTrainer::acting_params() {
  return dqn_ ? dqn_->online().params() : sac_ ? sac_->actor().params() : ddpg_->actor().params();
}

std::vector<uint8_t> PolicyTrainer::ActingBlob() const { return nn::ToBlob(averages() ? average_ : acting_params()); }

Status PolicyTrainer::LoadActing(std::span<const uint8_t> blob) {
  nn::ParamSet loaded = acting_params();
  COINS_RETURN_IF_ERROR(nn::FromBlob(blob, &loaded, spec_.name + " acting weights"));
  nn::HardUpdate(loaded, &acting_params());  // in place: the networks keep their views
  if (averages()) nn::HardUpdate(loaded, &average_);
  return Status::Ok();
}

rl::AlgorithmState PolicyTrainer::ExportAlgorithmState() const {
  return dqn_ ? dqn_->ExportState() : sac_ ? sac_->ExportState() : ddpg_->ExportState();
}

Status PolicyTrainer::ImportAlgorithmState(const rl::AlgorithmState& state) {
  return dqn_ ? dqn_->ImportState(state) : sac_ ? sac_->ImportState(state) : ddpg_->ImportState(state);
}

rl::AlgorithmState PolicyTrainer::ExportState() const {
  rl::AlgorithmState state = ExportAlgorithmState();
  if (averages()) state.sets.push_back(average_);
  return state;
}

Status PolicyTrainer::ImportState(const rl::AlgorithmState& state) {
  COINS_RETURN_IF_ERROR(ImportAlgorithmState(state));
  if (!averages()) return Status::Ok();
  // a state written without the average (an earlier run, or averaging newly turned on) starts
  // it at the online weights
  size_t next = algorithm_sets_;
  if (state.sets.size() <= next) {
    nn::HardUpdate(acting_params(), &average_);
    return Status::Ok();
  }
  return rl::RestoreParams(state, &next, &average_).WithContext(spec_.name + " acting average");
}

void PolicyTrainer::Observations(const SampleColumns& c, bool next, Eigen::MatrixXf* obs) {
  const Eigen::Index n = c.n, F = c.feature_dim;
  const float* feats = next ? c.next_state.data() : c.state.data();
  // masked goal values: the goal column holds the target factor's features
  const int gd = spec_.goal.dim();
  goals_.resize(gd, n);
  for (Eigen::Index b = 0; b < n && gd > 0; ++b)
    for (int i = 0; i < gd; ++i) goals_(i, b) = c.goal[size_t(b) * c.goal_dim + size_t(spec_.goal.masked[size_t(i)])];
  policy::BuildObservations(spec_, Eigen::Map<const Eigen::MatrixXf>(feats, F, n), goals_, obs);
}

void PolicyTrainer::ToBatch(const SampleColumns& c) {
  const int n = int(c.n);
  Observations(c, false, &batch_.obs);
  Observations(c, true, &batch_.next_obs);
  const int ad = spec_.discrete_actions() ? 1 : spec_.action_dim;
  batch_.actions.resize(ad, n);
  for (int b = 0; b < n; ++b)
    for (int i = 0; i < ad; ++i) batch_.actions(i, b) = c.action[size_t(b) * c.action_dim + size_t(i)];
  batch_.rewards = Eigen::Map<const Eigen::MatrixXf>(c.reward.data(), 1, n);
  batch_.discounts = Eigen::Map<const Eigen::MatrixXf>(c.discount.data(), 1, n);
  batch_.weights = Eigen::Map<const Eigen::MatrixXf>(c.weight.data(), 1, n);
  batch_.keys.assign(c.key.begin(), c.key.end());
}

Result<TrainStep> PolicyTrainer::Update(SampleSource* source) {
  COINS_RETURN_IF_ERROR(source->Sample(sample_, int(options_.batch), &columns_).WithContext(spec_.name));
  ToBatch(columns_);
  TrainStep step;
  if (dqn_) {
    const rl::DqnStats s = dqn_->Update(batch_, &priorities_);
    step.loss = s.loss;
    step.mean_q = s.mean_q;
  } else if (sac_) {
    const rl::SacStats s = sac_->Update(batch_, &priorities_);
    step.loss = s.critic_loss;
  } else {
    const rl::DdpgStats s = ddpg_->Update(batch_, &priorities_);
    step.loss = s.critic_loss;
  }
  if (options_.prioritized) source->UpdatePriorities(batch_.keys, {priorities_.data(), size_t(priorities_.size())});
  if (averages()) nn::SoftUpdate(acting_params(), float(options_.acting_average), &average_);
  return step;
}

}  // namespace coins
