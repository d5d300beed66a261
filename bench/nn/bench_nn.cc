// coins-bench-nn: how fast the learning core trains, against the machine's GEMM rate.
//
// For an MLP 20-256-256-256-8 at batch 256 and a pair-net over 100 instances at batch 128
// (point MLP 128-128-128-256-1024, max-pool, 256 dense), one update = Forward + Backward +
// Adam step. Counted FLOPs are the matrix products only: forward 2 B MACs, backward the weight
// gradients (2 B MACs) and the input gradients of every layer but the first. The baseline runs
// exactly those products as raw Eigen GEMMs on preallocated matrices at the same shapes in the
// same repetition; the figure is the ratio. Each figure is the median over repetitions.
// Unless --no-paddle, the Breakout paddle skill is trained from several seeds and the medians
// of env steps and wall time to 95% greedy success are reported.
// Pushing's sac levels: updates/s (actor, twin critics, targets, temperature; batch 128) at the
// shapes of the task (57 rows, 15 obstacle regions of 3 at row 6) and of the block skill, for the
// Mlp 128x3 of deploy/configs/pushing.yaml (the baseline) against pair networks over the regions
// up to the paper's 128-128-128-256-1024, and the paper's 256x4-128 block skill; each as a ratio
// to the baseline, measured alternately in the same repetitions.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "common/cli_checks.h"
#include "common/figures.h"
#include "common/nn/adam.h"
#include "common/nn/mlp.h"
#include "common/nn/pairnet.h"
#include "learner/rl/paddle_skill.h"
#include "learner/rl/sac.h"

namespace {

using Clock = std::chrono::steady_clock;

// seconds per call of fn, running it for at least min_seconds after one warm-up call
double TimePerCall(const std::function<void()>& fn, double min_seconds) {
  fn();
  int calls = 0;
  const auto start = Clock::now();
  double elapsed = 0.0;
  do {
    fn();
    ++calls;
    elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  } while (elapsed < min_seconds);
  return elapsed / calls;
}

// the GEMMs of one update: per layer (out x in weights, `cols` columns) forward W X,
// weight gradient D X^T, and input gradient W^T D when the layer is not the first
class GemmBaseline {
 public:
  void AddLayer(int in, int out, int cols, bool input_grad) {
    Layer l;
    l.w = Eigen::MatrixXf::Random(out, in);
    l.x = Eigen::MatrixXf::Random(in, cols);
    l.z = Eigen::MatrixXf::Zero(out, cols);
    l.d = Eigen::MatrixXf::Random(out, cols);
    l.gw = Eigen::MatrixXf::Zero(out, in);
    l.dx = Eigen::MatrixXf::Zero(in, cols);
    l.input_grad = input_grad;
    flops_ += 2.0 * double(in) * out * cols * (input_grad ? 3.0 : 2.0);
    layers_.push_back(std::move(l));
  }
  void Run() {
    for (Layer& l : layers_) l.z.noalias() = l.w * l.x;
    for (Layer& l : layers_) {
      l.gw.noalias() = l.d * l.x.transpose();
      if (l.input_grad) l.dx.noalias() = l.w.transpose() * l.d;
    }
  }
  double flops() const { return flops_; }

 private:
  struct Layer {
    Eigen::MatrixXf w, x, z, d, gw, dx;
    bool input_grad = false;
  };
  std::vector<Layer> layers_;
  double flops_ = 0.0;
};

struct Samples {
  std::vector<double> updates_per_s, gflops, matmul_gflops, ratio;
};

void Record(coins::Figures* f, const std::string& prefix, Samples s) {
  f->AddMedian(prefix + "_updates_per_s", s.updates_per_s, "updates/s");
  f->AddMedian(prefix + "_gflops", s.gflops, "GFLOP/s");
  f->AddMedian(prefix + "_matmul_gflops", s.matmul_gflops, "GFLOP/s");
  f->AddMedian(prefix + "_flop_ratio", s.ratio, "ratio");
}

// reps measurements of a network update against the same layers' plain matrix products
template <typename Update>
Samples Measure(Update& update, GemmBaseline& gemm, int reps, double min_seconds) {
  Samples s;
  for (int r = 0; r < reps; ++r) {
    const double t_net = TimePerCall(update, min_seconds);
    const double t_mm = TimePerCall([&] { gemm.Run(); }, min_seconds);
    s.updates_per_s.push_back(1.0 / t_net);
    s.gflops.push_back(gemm.flops() / t_net * 1e-9);
    s.matmul_gflops.push_back(gemm.flops() / t_mm * 1e-9);
    s.ratio.push_back(t_mm / t_net);
  }
  return s;
}

Samples BenchMlp(int reps, double min_seconds) {
  using namespace coins::nn;
  const int batch = 256;
  const std::vector<int> sizes = {20, 256, 256, 256, 8};
  Mlp net({sizes, Activation::kRelu, Activation::kIdentity}, 1);
  Adam adam({.lr = 1e-4f}, net.params().size());
  Eigen::MatrixXf x = Eigen::MatrixXf::Random(sizes.front(), batch);
  Eigen::MatrixXf dout = Eigen::MatrixXf::Random(sizes.back(), batch) * 1e-3f;
  GemmBaseline gemm;
  for (size_t l = 0; l + 1 < sizes.size(); ++l) gemm.AddLayer(sizes[l], sizes[l + 1], batch, l > 0);
  auto update = [&] {
    net.Forward(x);
    net.Backward(dout);
    adam.Step(&net.params());
  };
  return Measure(update, gemm, reps, min_seconds);
}

Samples BenchPairNet(int reps, double min_seconds) {
  using namespace coins::nn;
  const int batch = 128, instances = 100;
  PairNetOptions o;
  o.source_dim = 5;  // a Breakout factor [y, x, vy, vx, attr]
  o.instance_dim = 5;
  o.max_instances = instances;
  o.relative = LeadingRelative(2);
  PairNet net(o, 1);
  Adam adam({.lr = 1e-4f}, net.params().size());
  Eigen::MatrixXf src = Eigen::MatrixXf::Random(o.source_dim, batch);
  Eigen::MatrixXf inst = Eigen::MatrixXf::Random(o.instance_dim * instances, batch);
  Eigen::MatrixXf mask = Eigen::MatrixXf::Ones(instances, batch);
  Eigen::MatrixXf dout = Eigen::MatrixXf::Random(o.output_dim, batch) * 1e-3f;
  GemmBaseline gemm;
  int in = o.point_input_dim();
  for (size_t l = 0; l < o.point_sizes.size(); ++l) {
    gemm.AddLayer(in, o.point_sizes[l], batch * instances, l > 0);
    in = o.point_sizes[l];
  }
  gemm.AddLayer(in, o.output_dim, batch, true);
  auto update = [&] {
    net.Forward(src, inst, mask);
    net.Backward(dout);
    adam.Step(&net.params());
  };
  return Measure(update, gemm, reps, min_seconds);
}

// one sac update on a fixed random batch of a level's shape
struct SacBench {
  coins::rl::Sac sac;
  coins::rl::Batch batch;
  SacBench(int obs, int action, int batch_size, std::vector<int> hidden, coins::nn::InstanceSplit split)
      : sac(Options(obs, action, batch_size, std::move(hidden), split)) {
    batch.obs = Eigen::MatrixXf::Random(obs, batch_size);
    batch.next_obs = Eigen::MatrixXf::Random(obs, batch_size);
    batch.actions = Eigen::MatrixXf::Random(action, batch_size);
    batch.rewards = Eigen::MatrixXf::Random(1, batch_size);
    batch.discounts = Eigen::MatrixXf::Constant(1, batch_size, 0.99f);
    batch.weights = Eigen::MatrixXf::Ones(1, batch_size);
  }
  static coins::rl::SacOptions Options(int obs, int action, int batch_size, std::vector<int> hidden,
                                       coins::nn::InstanceSplit split) {
    coins::rl::SacOptions o;
    o.obs_dim = obs;
    o.action_dim = action;
    o.hidden = std::move(hidden);
    o.batch_size = batch_size;
    o.split = split;
    return o;
  }
  double UpdatesPerSecond(double min_seconds) {
    return 1.0 / TimePerCall([&] { sac.Update(batch); }, min_seconds);
  }
};

struct SacVariant {
  std::string name;
  std::vector<int> hidden;
  coins::nn::InstanceSplit split;
};

// updates/s of each variant and its ratio to the baseline, measured alternately
void BenchSacVariants(coins::Figures* f, const std::string& prefix, int obs, int action, int batch,
                      const SacVariant& baseline, const std::vector<SacVariant>& variants, int reps,
                      double min_seconds) {
  SacBench base(obs, action, batch, baseline.hidden, baseline.split);
  std::vector<std::unique_ptr<SacBench>> nets;
  for (const SacVariant& v : variants)
    nets.push_back(std::make_unique<SacBench>(obs, action, batch, v.hidden, v.split));
  std::vector<double> base_rate;
  std::vector<std::vector<double>> rate(variants.size()), ratio(variants.size());
  for (int r = 0; r < reps; ++r) {
    base_rate.push_back(base.UpdatesPerSecond(min_seconds));
    for (size_t i = 0; i < variants.size(); ++i) {
      rate[i].push_back(nets[i]->UpdatesPerSecond(min_seconds));
      ratio[i].push_back(rate[i].back() / base_rate.back());
    }
  }
  f->AddMedian(prefix + baseline.name + "_updates_per_s", base_rate, "updates/s");
  for (size_t i = 0; i < variants.size(); ++i) {
    f->AddMedian(prefix + variants[i].name + "_updates_per_s", rate[i], "updates/s");
    f->AddMedian(prefix + variants[i].name + "_vs_" + baseline.name, ratio[i], "ratio");
  }
}

// pushing's sac levels at the widths of deploy/configs/pushing.yaml against wider ones
void BenchPushingSac(coins::Figures* f, int reps, double min_seconds) {
  const coins::nn::InstanceSplit regions{6, 15, 3, -1, {}};  // the task's 15 obstacle regions at row 6
  BenchSacVariants(f, "pushing_task_sac_", 57, 2, 128, {"mlp_128x3", {128, 128, 128}, {}},
                   {{"pair_64x2", {64, 64}, regions},
                    {"pair_128x3", {128, 128, 128}, regions},
                    {"pair_paper", {128, 128, 128, 256, 1024}, regions}},
                   reps, min_seconds);
  // learner.task_relative all: 9 flat relative rows (obs 63) and each region's point also sees
  // Gripper, Block and Target (rows 0-5, 51-53) minus the region (9 features), against the same
  // network without the per-point features
  coins::nn::InstanceSplit relative = regions;
  for (int row : {0, 1, 2, 3, 4, 5, 51, 52, 53}) relative.relative.push_back({row, row % 3, 1.0f, 0.0f});
  BenchSacVariants(f, "pushing_task_all_sac_", 63, 2, 128, {"pair_64x2", {64, 64}, regions},
                   {{"pair_64x2_relative", {64, 64}, relative}}, reps, min_seconds);
  // the block skill: gripper, block, their difference and the x, y goal in; a gripper goal out
  BenchSacVariants(f, "pushing_block_sac_", 11, 3, 128, {"mlp_128x3", {128, 128, 128}, {}},
                   {{"mlp_paper", {256, 256, 256, 256, 128}, {}}}, reps, min_seconds);
}

void BenchPaddle(coins::Figures* f, int seeds) {
  std::vector<double> steps, seconds, success;
  for (int seed = 1; seed <= seeds; ++seed) {
    coins::rl::PaddleSkillOptions o;
    o.seed = uint64_t(seed);
    auto r = coins::rl::TrainPaddleSkill(o);
    if (!r.ok()) {
      std::fprintf(stderr, "paddle skill: %s\n", r.status().message().c_str());
      return;
    }
    // a run that misses the target counts as the whole budget
    steps.push_back(r->env_steps_to_target >= 0 ? double(r->env_steps_to_target) : double(o.max_env_steps));
    seconds.push_back(r->env_steps_to_target >= 0 ? r->seconds_to_target : r->wall_seconds);
    success.push_back(r->env_steps_to_target >= 0 ? 1.0 : 0.0);
  }
  f->AddMedian("paddle_env_steps_to_95", steps, "steps");
  f->AddMedian("paddle_seconds_to_95", seconds, "s");
  double reached = 0.0;
  for (double s : success) reached += s;
  f->Add("paddle_seeds_reaching_95", reached / double(success.size()), "fraction");
}

}  // namespace

int main(int argc, char** argv) {
  bool json = false, paddle = true;
  int reps = 5, seeds = 5;
  double min_seconds = 0.5;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--json") {
      json = true;
    } else if (arg == "--reps" && i + 1 < argc) {
      auto v = coins::cli::ParseInteger(argv[++i], 1, 1000);
      if (!v.ok()) {
        std::fprintf(stderr, "coins-bench-nn: --reps: %s\n", v.status().message().c_str());
        return 2;
      }
      reps = int(*v);
    } else if (arg == "--quick") {
      reps = 1;
      min_seconds = 0.05;
      seeds = 1;
    } else if (arg == "--no-paddle") {
      paddle = false;
    } else if (arg == "--seeds" && i + 1 < argc) {
      auto v = coins::cli::ParseInteger(argv[++i], 1, 1000);
      if (!v.ok()) {
        std::fprintf(stderr, "coins-bench-nn: --seeds: %s\n", v.status().message().c_str());
        return 2;
      }
      seeds = int(*v);
    } else {
      std::fprintf(stderr, "usage: coins-bench-nn [--json] [--reps N] [--seeds N] [--quick] [--no-paddle]\n");
      return 2;
    }
  }
  coins::Figures figures;
  Record(&figures, "mlp", BenchMlp(reps, min_seconds));
  Record(&figures, "pairnet", BenchPairNet(reps, min_seconds));
  BenchPushingSac(&figures, reps, min_seconds);
  if (paddle) BenchPaddle(&figures, seeds);
  figures.Print(json);
  return 0;
}
