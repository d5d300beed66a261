// coins-paddle-skill: trains the Breakout paddle skill and prints wall time and env steps to
// the target success rate (figures: "name value unit" lines, or one JSON object with --json).
#include <cstdio>
#include <cstdlib>
#include <string>

#include "common/figures.h"
#include "learner/rl/paddle_skill.h"

int main(int argc, char** argv) {
  coins::rl::PaddleSkillOptions options;
  bool json = false, curve = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", arg.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (arg == "--json")
      json = true;
    else if (arg == "--curve")
      curve = true;
    else if (arg == "--seed")
      options.seed = std::strtoull(value(), nullptr, 10);
    else if (arg == "--steps")
      options.max_env_steps = std::strtoll(value(), nullptr, 10);
    else if (arg == "--eval-every")
      options.eval_every = std::atoi(value());
    else if (arg == "--no-stop")
      options.stop_at_target = false;
    else {
      std::fprintf(stderr,
                   "usage: coins-paddle-skill [--json] [--curve] [--seed N] [--steps N] "
                   "[--eval-every N] [--no-stop]\n");
      return 2;
    }
  }
  auto result = coins::rl::TrainPaddleSkill(options);
  if (!result.ok()) {
    std::fprintf(stderr, "error: %s\n", result.status().message().c_str());
    return 1;
  }
  if (curve)
    for (auto [steps, success] : result->curve)
      std::fprintf(stderr, "steps %lld success %.2f\n", static_cast<long long>(steps), success);
  coins::Figures figures;
  figures.Add("paddle_env_steps_to_95", double(result->env_steps_to_target), "steps");
  figures.Add("paddle_seconds_to_95", result->seconds_to_target, "s");
  figures.Add("paddle_final_success", result->final_success, "fraction");
  figures.Add("paddle_env_steps", double(result->env_steps), "steps");
  figures.Add("paddle_wall_seconds", result->wall_seconds, "s");
  figures.Print(json);
  return result->env_steps_to_target >= 0 ? 0 : 3;
}
