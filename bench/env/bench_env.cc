// coins-bench-env: env throughput on one core.
//
// Breakout: steps/s with the full factored state written every step (random actions from a
// pre-drawn table, ResetNext on done), for the base game and each variant. Pushing: control
// steps/s of the env (random actions, each 25 physics substeps, episode resets included), and
// the same number of bare mj_step calls on the same model and scene in the same run; the ratio
// is bare time / env time (1.0 = the wrapper costs nothing). Each figure is the median of
// --reps repetitions (default 5), run interleaved.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "actors/envs/breakout.h"
#include "actors/envs/pushing.h"
#include "common/cli_checks.h"
#include "common/figures.h"

namespace {

using coins::envs::Env;
using coins::envs::StepResult;
using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

// steps/s of env over n steps, actions cycling through a pre-drawn table
double RunEnv(Env& env, const std::vector<float>& actions, int dim, long n, uint64_t seed) {
  std::vector<float> state(env.spec().state_dim());
  env.Reset(seed, state);
  const long table = static_cast<long>(actions.size()) / dim;
  StepResult r;
  const auto t0 = Clock::now();
  for (long i = 0; i < n; ++i) {
    const float* a = actions.data() + (i % table) * dim;
    if (!env.Step({a, static_cast<size_t>(dim)}, state, &r).ok()) std::abort();
    if (r.done || r.truncated) env.ResetNext(state);
  }
  const auto t1 = Clock::now();
  return n / Seconds(t0, t1);
}

// mj_step calls/s on a private mjData of the same model, started from the env's reset scene,
// with new random servo targets every control period
double RunBare(const coins::envs::PushingEnv& env, long substeps, uint64_t seed) {
  const mjModel* m = env.model();
  coins::envs::DataPtr d(mj_makeData(m));
  mj_copyData(d.get(), m, env.data());
  coins::envs::Rng rng(seed);
  const int period = coins::envs::PushingEnv::kSubsteps;
  const auto t0 = Clock::now();
  for (long i = 0; i < substeps; ++i) {
    if (i % period == 0)
      for (int k = 0; k < 3; ++k) d->ctrl[k] = rng.Uniform(k == 2 ? 0.0 : -0.1, 0.1);
    mj_step(m, d.get());
  }
  const auto t1 = Clock::now();
  return substeps / Seconds(t0, t1);
}

int Usage(const std::string& error) {
  std::fprintf(stderr, "coins-bench-env: %s\nusage: coins-bench-env [--json] [--reps N] [--scale F]\n", error.c_str());
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  bool json = false;
  int reps = 5;
  double scale = 1.0;  // --scale 0.1 for a quick run
  // --scale multiplies the step counts (2M Breakout steps, 3000 pushing steps at 1)
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--json")) {
      json = true;
      continue;
    }
    const bool has_value = i + 1 < argc;
    if (!std::strcmp(argv[i], "--reps") && has_value) {
      auto v = coins::cli::ParseInteger(argv[++i], 1, 1000);
      if (!v.ok()) return Usage("--reps: " + v.status().message());
      reps = int(*v);
    } else if (!std::strcmp(argv[i], "--scale") && has_value) {
      auto v = coins::cli::ParseFinite(argv[++i], 0, 100, /*min_open=*/true);
      if (!v.ok()) return Usage("--scale: " + v.status().message());
      scale = *v;
    } else {
      return Usage(std::string("unknown argument '") + argv[i] + "'");
    }
  }
  coins::Figures figures;
  coins::envs::Rng rng(1);

  // breakout and its variants
  std::vector<float> discrete(1 << 16);
  for (float& a : discrete) a = static_cast<float>(rng.UniformInt(0, 3));
  const long breakout_steps = static_cast<long>(2'000'000 * scale);
  for (int v = 0; v <= 6; ++v) {
    const auto variant = static_cast<coins::envs::BreakoutVariant>(v);
    coins::envs::BreakoutEnv env(variant);
    std::vector<double> samples;
    for (int r = 0; r < reps; ++r) samples.push_back(RunEnv(env, discrete, 1, breakout_steps, 100 + r));
    std::string name = coins::envs::BreakoutName(variant);
    for (char& c : name)
      if (c == '-') c = '_';
    figures.AddMedian(name + "_steps_per_s", samples, "steps/s");
  }

  // pushing: the env against bare mj_step, interleaved
  auto made = coins::envs::PushingEnv::Create(false);
  if (!made.ok()) {
    std::fprintf(stderr, "error: %s\n", made.status().message().c_str());
    return 1;
  }
  auto& pushing = *made.value();
  std::vector<float> continuous(3 << 14);
  for (float& a : continuous) a = static_cast<float>(rng.Uniform(-1.0, 1.0));
  const long control_steps = static_cast<long>(3000 * scale);
  std::vector<double> env_rate, bare_rate, ratio;
  for (int r = 0; r < reps; ++r) {
    const double e = RunEnv(pushing, continuous, 3, control_steps, 200 + r);
    std::vector<float> state(pushing.spec().state_dim());
    pushing.Reset(300 + r, state);
    const double b = RunBare(pushing, control_steps * coins::envs::PushingEnv::kSubsteps, 400 + r);
    env_rate.push_back(e);
    bare_rate.push_back(b);
    ratio.push_back(e * coins::envs::PushingEnv::kSubsteps / b);
  }
  figures.AddMedian("pushing_control_steps_per_s", env_rate, "steps/s");
  std::vector<double> env_substeps;
  for (double e : env_rate) env_substeps.push_back(e * coins::envs::PushingEnv::kSubsteps);
  figures.AddMedian("pushing_env_substeps_per_s", env_substeps, "steps/s");
  figures.AddMedian("pushing_bare_mj_steps_per_s", bare_rate, "steps/s");
  figures.AddMedian("pushing_wrapper_ratio", ratio, "ratio");
  figures.Print(json);
  return 0;
}
