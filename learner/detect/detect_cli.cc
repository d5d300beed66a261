#include "learner/detect/detect_cli.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include <fmt/format.h>
#include <memory>

#include "common/cli_checks.h"
#include "common/config/config_flags.h"
#include "learner/detect/detect_run.h"

namespace coins::detector {

namespace {

struct CliState {
  DetectRequest req;
  bool json = false;
  bool paper_sizes = false;
  std::vector<int> hidden;
  std::unique_ptr<ConfigFlags> detector_flags;  // one flag per DetectorOptions field
};

// steps of data: int-indexed downstream; memory bounds them further (RunDetect)
constexpr int64_t kMaxSteps = std::numeric_limits<int32_t>::max();

void Run(CliState& c) {
  // options: the defaults (the env's proximity), --hidden for both models, then the flags
  DetectorOptions o;
  if (!c.hidden.empty()) o.passive_hidden = o.active_hidden = c.hidden;
  ConfigLoader loader({ConfigSection::Of("detector", o)});
  cli::FailIf("detect", c.detector_flags->Apply(loader), 2);
  cli::FailIf("detect", loader.Validate(), 2);
  if (o.close_distance < 0) o.close_distance = EnvCloseDistance(c.req.env);
  o.seed = c.req.seed;
  c.req.options = o;
  c.req.paper_sizes = c.paper_sizes;
  Result<nlohmann::json> r = RunDetect(c.req);
  if (!r.ok()) cli::Fail("detect", r.status().message(), 1);
  if (c.json) {
    std::printf("%s\n", r->dump().c_str());
  } else {
    std::printf("%s", FormatDetectTable(r.value()).c_str());
  }
}

}  // namespace

void AddDetectCommand(CLI::App& app) {
  auto c = std::make_shared<CliState>();
  CLI::App* cmd =
      app.add_subcommand("detect", "train interaction detectors (passive/active Granger models) for one source");
  cmd->add_option("--env", c->req.env, "environment name (see `env list`)")->required();
  cmd->add_option("--source", c->req.source, "source factor, e.g. Action, Paddle, Gripper")->required();
  cmd->add_option("--policy", c->req.policy,
                  "data policy: random, goals (scripted paddle/gripper to random targets) or a "
                  "file with one action per line")
      ->capture_default_str();
  cmd->add_option("--steps", c->req.steps, "environment steps of data (memory bounds it too)")
      ->required()
      ->check(cli::Integer(1, kMaxSteps));
  cmd->add_option("--seed", c->req.seed, "seed of data and models")->capture_default_str()->check(cli::Unsigned());
  cmd->add_option("--targets", c->req.targets, "targets (default: every uncontrolled factor)")->delimiter(',');
  cmd->add_flag("--json", c->json, "print one JSON object");
  cmd->add_flag("--eval", c->req.eval, "false positives/negatives against the simulator's labels on fresh data");
  cmd->add_option("--eval-steps", c->req.eval_steps, "steps of evaluation data (default: --steps)")
      ->check(cli::Integer(0, kMaxSteps));
  cmd->add_option("--holdout", c->req.holdout,
                  "fraction of the data held out of training and scored (0: score the training data)")
      ->capture_default_str()
      ->check(cli::Finite(0.0, 0.99));
  cmd->add_flag("--granger", c->req.granger, "also run the linear Granger F-test on the same data");
  cmd->add_option("--screen", c->req.screen_alpha, "linear Granger screen: skip targets with p-value >= this (0: off)")
      ->check(cli::Finite(0.0, 1.0));
  cmd->add_option("--granger-window", c->req.granger_window, "history window w of the linear test")
      ->capture_default_str()
      ->check(cli::Integer(1, 1000));
  // a wider layer is far beyond what trains here: 8192 x 8192 is already 64 M weights a layer
  cmd->add_option("--hidden", c->hidden, "hidden layer sizes of both models, e.g. 128,128 (each at most 8192)")
      ->delimiter(',')
      ->check(cli::Integer(1, 8192));
  cmd->add_flag("--paper-sizes", c->paper_sizes,
                "the paper's network sizes for the pairs it names (else --hidden or 128,128)");
  // every detector option (the config file's `detector` section), e.g. --passive-steps 2000;
  // the seed is --seed above
  DetectorOptions defaults;
  c->detector_flags = std::make_unique<ConfigFlags>(cmd, ConfigSection::Of("detector", defaults));
  cmd->callback([c] { Run(*c); });
}

}  // namespace coins::detector
