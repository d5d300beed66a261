// Finite-difference checks of the algorithms' assembled losses: the DQN loss (C51 + dueling,
// and Huber) and the SAC and DDPG actor losses, with respect to the online parameters.
#include <functional>
#include <random>

#include <gtest/gtest.h>

#include "learner/rl/ddpg.h"
#include "learner/rl/dqn.h"
#include "learner/rl/sac.h"

namespace coins::rl {
namespace {

Eigen::MatrixXf Random(int rows, int cols, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> n(0.0f, 1.0f);
  Eigen::MatrixXf m(rows, cols);
  for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = n(rng);
  return m;
}

// relative error of gradient g against central differences of loss over (a sample of) x
double RelError(Eigen::VectorXf* x, const Eigen::VectorXf& g, const std::function<double()>& loss, float eps) {
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<Eigen::Index> pick(0, x->size() - 1);
  double num = 0.0, den = 0.0;
  for (int k = 0; k < 300; ++k) {
    const Eigen::Index i = pick(rng);
    const float saved = (*x)[i];
    (*x)[i] = saved + eps;
    const double up = loss();
    (*x)[i] = saved - eps;
    const double down = loss();
    (*x)[i] = saved;
    const double fd = (up - down) / (2.0 * eps);
    num += (fd - g[i]) * (fd - g[i]);
    den += fd * fd + double(g[i]) * g[i];
  }
  return std::sqrt(num) / (std::sqrt(den) + 1e-12);
}

Batch MakeBatch(int obs_dim, int action_dim, int batch, int num_actions, uint64_t seed) {
  Batch b;
  b.Resize(obs_dim, action_dim, batch);
  b.obs = Random(obs_dim, batch, seed);
  b.next_obs = Random(obs_dim, batch, seed + 1);
  b.rewards = -Random(1, batch, seed + 2).cwiseAbs();
  b.discounts = Eigen::MatrixXf::Constant(1, batch, 0.98f);
  b.discounts(0, 0) = 0.0f;
  b.weights = Random(1, batch, seed + 3).cwiseAbs();
  if (num_actions > 0) {
    for (int i = 0; i < batch; ++i) b.actions(0, i) = float(i % num_actions);
  } else {
    b.actions = Random(action_dim, batch, seed + 4).array().tanh();
  }
  return b;
}

class DqnLossGrad : public ::testing::TestWithParam<bool> {};

TEST_P(DqnLossGrad, MatchesFiniteDifferences) {
  const bool rainbow = GetParam();
  DqnOptions o;
  o.obs_dim = 6;
  o.num_actions = 4;
  o.hidden = {16, 16};
  o.activation = nn::Activation::kTanh;
  o.distributional = o.dueling = o.double_q = rainbow;
  o.atoms = 11;
  o.v_min = -5.0f;
  o.v_max = 0.0f;
  Dqn dqn(o);
  Batch batch = MakeBatch(6, 1, 8, 4, 1);
  auto loss = [&] { return double(dqn.LossAndGrad(batch).loss); };
  loss();
  Eigen::VectorXf g = dqn.online().params().grads;
  EXPECT_LT(RelError(&dqn.online().params().values, g, loss, 1e-2f), 2e-2);
}

INSTANTIATE_TEST_SUITE_P(Variants, DqnLossGrad, ::testing::Values(true, false));

// the actor's gradient flows through the critics' action input: Mlps, and pair networks over
// 3 instances of 2 rows (every instance present) where the action joins the source part
class SacLossGrad : public ::testing::TestWithParam<bool> {};

TEST_P(SacLossGrad, ActorMatchesFiniteDifferences) {
  const bool pair = GetParam();
  SacOptions o;
  o.obs_dim = pair ? 9 : 5;
  o.action_dim = 2;
  o.hidden = {16, 16};
  o.activation = nn::Activation::kTanh;
  if (pair) o.split = {2, 3, 2, -1, {}};
  ASSERT_TRUE(o.Validate().ok()) << o.Validate().message();
  Sac sac(o);
  Eigen::MatrixXf obs = Random(o.obs_dim, 8, 1), noise = Random(2, 8, 2);
  auto loss = [&] { return double(sac.ActorLossAndGrad(obs, noise)); };
  loss();
  Eigen::VectorXf g = sac.actor().params().grads;
  EXPECT_LT(RelError(&sac.actor().params().values, g, loss, 1e-2f), 2e-2);
}

INSTANTIATE_TEST_SUITE_P(Networks, SacLossGrad, ::testing::Values(false, true));

TEST(DdpgLossGrad, ActorMatchesFiniteDifferences) {
  DdpgOptions o;
  o.obs_dim = 5;
  o.action_dim = 2;
  o.hidden = {16, 16};
  o.activation = nn::Activation::kTanh;
  Ddpg ddpg(o);
  Eigen::MatrixXf obs = Random(5, 8, 1);
  auto loss = [&] { return double(ddpg.ActorLossAndGrad(obs)); };
  loss();
  Eigen::VectorXf g = ddpg.actor().params().grads;
  EXPECT_LT(RelError(&ddpg.actor().params().values, g, loss, 1e-2f), 2e-2);
}

}  // namespace
}  // namespace coins::rl
