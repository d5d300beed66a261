#include "learner/detect/detect_cli.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include <fmt/format.h>
#include <memory>

#include "common/cli_checks.h"
#include "learner/detect/detect_run.h"

namespace coins::detector {

namespace {

struct CliState {
  DetectRequest req;
  bool json = false;
  bool paper_sizes = false;
  bool no_gate = false;
  std::string mask_rule = "relative";
  std::vector<int> hidden;
  double eps_si = -1.0;
  double close = -1.0;
};

// numbers with a short message naming the bad value (CLI11 prefixes the flag)
CLI::Validator NumberAtLeast(double min, bool strict, bool integer) {
  return CLI::Validator(
      [=](std::string& in) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(in.c_str(), &end);
        const bool parsed = end != in.c_str() && *end == '\0' && std::isfinite(v);
        const bool whole = !integer || v == std::floor(v);
        if (parsed && whole && (strict ? v > min : v >= min)) return "";
        return fmt::format("must be {} {}{}, got '{}'", integer ? "an integer" : "a number",
                           strict ? "> " : ">= ", min, in);
      },
      strict ? "POSITIVE" : "NONNEGATIVE");
}
const CLI::Validator kPositive = NumberAtLeast(0, true, false);
const CLI::Validator kNonNegative = NumberAtLeast(0, false, false);

// steps of data: int-indexed downstream; memory bounds them further (RunDetect)
constexpr int64_t kMaxSteps = std::numeric_limits<int32_t>::max();
constexpr int64_t kMaxTrainSteps = 100'000'000;

void Run(CliState& c) {
  // options: env defaults, then the flags
  DetectorOptions o = DefaultDetectorOptions(c.req.env, false);
  o.passive_steps = c.req.options.passive_steps;
  o.active_steps = c.req.options.active_steps;
  o.passive_hard_steps = c.req.options.passive_hard_steps;
  o.passive_hard_lambda = c.req.options.passive_hard_lambda;
  o.counterfactual_draws = c.req.options.counterfactual_draws;
  o.seed = c.req.seed;
  o.eps_act = c.req.options.eps_act;
  o.eps_pas = c.req.options.eps_pas;
  o.lambda = c.req.options.lambda;
  o.lr = c.req.options.lr;
  if (c.eps_si >= 0.0) o.eps_si = float(c.eps_si);
  if (c.close >= 0.0) o.close_distance = float(c.close);
  if (c.no_gate) o.proximity_gate = false;
  if (!c.hidden.empty()) o.passive_hidden = o.active_hidden = c.hidden;
  if (c.mask_rule == "absolute") o.mask_rule = MaskRule::kAbsolute;
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
  CLI::App* cmd = app.add_subcommand(
      "detect", "train interaction detectors (passive/active Granger models) for one source");
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
      ->capture_default_str()->check(cli::Finite(0.0, 0.99));
  cmd->add_flag("--granger", c->req.granger, "also run the linear Granger F-test on the same data");
  cmd->add_option("--screen", c->req.screen_alpha,
                  "linear Granger screen: skip targets with p-value >= this (0: off)")
      ->check(cli::Finite(0.0, 1.0));
  cmd->add_option("--granger-window", c->req.granger_window, "history window w of the linear test")
      ->capture_default_str()->check(cli::Integer(1, 1000));
  cmd->add_option("--passive-steps", c->req.options.passive_steps, "Adam steps of the passive model")
      ->capture_default_str()->check(cli::Integer(1, kMaxTrainSteps));
  cmd->add_option("--passive-hard-steps", c->req.options.passive_hard_steps,
                  "passive steps after the active model's warm start")
      ->capture_default_str()->check(cli::Integer(0, kMaxTrainSteps));
  cmd->add_option("--passive-hard-lambda", c->req.options.passive_hard_lambda,
                  "up-weight of the passive model's own misses in its second phase")
      ->capture_default_str()->check(kNonNegative);
  cmd->add_option("--counterfactual-draws", c->req.options.counterfactual_draws,
                  "draws of another transition's source in the counterfactual check (0: off)")
      ->capture_default_str()->check(cli::Integer(0, 1000));
  cmd->add_option("--active-steps", c->req.options.active_steps, "Adam steps of the active model")
      ->capture_default_str()->check(cli::Integer(1, kMaxTrainSteps));
  // a wider layer is far beyond what trains here: 8192 x 8192 is already 64 M weights a layer
  cmd->add_option("--hidden", c->hidden, "hidden layer sizes of both models, e.g. 128,128 (each at most 8192)")
      ->delimiter(',')->check(cli::Integer(1, 8192));
  cmd->add_flag("--paper-sizes", c->paper_sizes, "the paper's network sizes for the pairs it names (else --hidden or 128,128)");
  cmd->add_option("--lr", c->req.options.lr, "Adam learning rate")->capture_default_str()->check(kPositive);
  cmd->add_option("--lambda", c->req.options.lambda, "active up-weight of passive-error states")
      ->capture_default_str()->check(kNonNegative);
  cmd->add_option("--eps-act", c->req.options.eps_act, "active log-likelihood threshold")
      ->capture_default_str()->check(cli::Finite(-1e9, 1e9));
  cmd->add_option("--eps-pas", c->req.options.eps_pas, "passive log-likelihood threshold")
      ->capture_default_str()->check(cli::Finite(-1e9, 1e9));
  cmd->add_option("--eps-si", c->eps_si, "pass threshold on Sc_I (default 3)")->check(cli::Finite(0, 1e9));
  cmd->add_option("--close", c->close, "proximity L1 distance (default: 7 Breakout, 0.13 pushing; 0 turns it off)")
      ->check(kNonNegative);
  cmd->add_flag("--no-proximity-gate", c->no_gate, "do not require proximity in the interaction test");
  cmd->add_option("--mask-rule", c->mask_rule, "relative or absolute (eq. 10 literally)")
      ->check(CLI::IsMember({"relative", "absolute"}))->capture_default_str();
  cmd->callback([c] { Run(*c); });
}

}  // namespace coins::detector
