#include "orchestrator/experiment_command.h"

#include <signal.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "actors/envs/breakout_planner.h"
#include "actors/envs/env.h"
#include "actors/evaluate.h"
#include "common/cli_checks.h"
#include "common/figures.h"
#include "common/files.h"
#include "common/process.h"
#include "orchestrator/child_process.h"
#include "orchestrator/run_queue.h"
#include "orchestrator/run_report.h"

namespace coins {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// what one experiment compares: its variants (envs), methods and the paper's numbers
struct Suite {
  std::string name;                   // the subcommand; the tables' file names
  std::string title;                  // the tables' heading
  std::string env_prefix;             // a variant's env: prefix + variant
  std::string skill;                  // the chain's top skill the coins method's task acts through
  std::string pretrain_env;           // finetune's pre-training env ("": no finetune method)
  std::vector<std::string> variants;  // known variants, in the tables' order
  std::vector<std::string> methods;   // known methods, in the tables' order
  int64_t eval_episodes;              // the final evaluation's episodes by default
  std::map<std::string, std::map<std::string, double>> paper;  // variant -> method -> final return
};

const Suite& TransferSuite() {
  // the paper's final returns: shared/reference/breakout.md, Table 3
  static const Suite s{"transfer",
                       "Transfer to the Breakout variants",
                       "breakout-",
                       "Ball",
                       "breakout",
                       {"single", "hard", "big", "neg", "center", "prox"},
                       {"coins", "vanilla", "finetune"},
                       20,
                       {{"single", {{"coins", -3.2}, {"vanilla", -5.8}}},
                        {"hard", {{"coins", -4.2}, {"vanilla", -7.1}}},
                        {"big", {{"coins", 0.85}, {"vanilla", 0.74}}},
                        {"neg", {{"coins", 3.6}, {"vanilla", 2.9}}},
                        {"center", {{"coins", -12}, {"vanilla", -37}}},
                        {"prox", {{"coins", 0.5}, {"vanilla", 0.1}}}}};
  return s;
}

const Suite& PushingSuite() {
  // shared/reference/pushing.md: COInS -21.6 within 700k steps, vanilla SAC -30 (never touches
  // the block). A run's task is evaluated as its learner.eval_task_explore says (pushing.yaml: 1,
  // the sac policy sampled).
  static const Suite s{"pushing",
                       "Robot pushing with negative reward regions: COInS against vanilla SAC",
                       "",
                       "Block",
                       "",
                       {"pushing"},
                       {"coins", "vanilla"},
                       50,
                       {{"pushing", {{"coins", -21.6}, {"vanilla", -30}}}}};
  return s;
}

const Suite& SuiteNamed(const std::string& name) { return name == "pushing" ? PushingSuite() : TransferSuite(); }

std::string Known(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

struct Cell {
  std::vector<double> finals, medians, done, penalty;  // per run: final return, its median episode, goal-reaching
                                                       // and penalty fractions
  std::vector<RunResult> runs;
  double mean = 0, sd = 0;
  std::string not_run;  // why the method could not run on this variant
};

fs::path RunDir(const ExperimentFlags& f, const std::string& variant, const std::string& method, int64_t seed) {
  return fs::path(f.out) / variant / fmt::format("{}-seed{}", method, seed);
}

fs::path PretrainDir(const ExperimentFlags& f, int64_t seed) {
  return fs::path(f.out) / "pretrain" / fmt::format("vanilla-seed{}", seed);
}

// variant "" with method vanilla: finetune's pre-training (on the suite's pretrain_env)
std::vector<std::string> RunArgv(const ExperimentFlags& f, const std::string& variant, const std::string& method,
                                 int64_t seed) {
  const Suite& suite = SuiteNamed(f.suite);
  const std::string coins = SelfDirectory() + "/coins";
  const bool pretrain = variant.empty();
  const std::string dir = (pretrain ? PretrainDir(f, seed) : RunDir(f, variant, method, seed)).string();
  const std::string env = pretrain ? suite.pretrain_env : suite.env_prefix + variant;
  const int64_t steps = pretrain ? f.pretrain_steps : f.steps;
  std::vector<std::string> argv;
  if (method == "coins") {
    argv = {coins, "transfer", f.chain, "--env", env, "--steps", std::to_string(steps), "--skill", suite.skill};
  } else if (method == "finetune") {
    argv = {coins, "transfer", PretrainDir(f, seed).string(), "--env", env, "--steps", std::to_string(steps)};
  } else {
    // primitive actions every env step: a chain task's cap on its decisions does not apply
    argv = {coins,      "run",
            "--config", (fs::path(f.chain) / "config.yaml").string(),
            "--env",    env,
            "--set",    "orchestrator.chain=none",
            "--set",    "learner.task_decision_period=0",
            "--set",    "learner.task_hold_decision=false",
            "--set",    "run.steps=0",
            "--set",    fmt::format("orchestrator.task_max_steps={}", steps),
            "--set",    fmt::format("orchestrator.task_min_steps={}", steps),
            "--set",    "replay.snapshot_dir=" + dir + "/replay"};
  }
  for (const std::string& s :
       {std::string("--dir"), dir, std::string("--quiet"), std::string("--set"), fmt::format("run.seed={}", seed)})
    argv.push_back(s);
  for (const std::string& s : f.overrides) {
    argv.push_back("--set");
    argv.push_back(s);
  }
  return argv;
}

// runs one child to its end; Ctrl-C stops it (SIGINT, its own clean stop) and the experiment.
// A run refused before it started (exit code 2) sets *refused to its one-line reason.
Status RunChild(const std::vector<std::string>& argv, const std::string& log, std::string* refused) {
  auto child = ChildProcess::Spawn("run", argv, log);
  if (!child.ok()) return child.status();
  while (!child->WaitFor(std::chrono::milliseconds(200))) {
    if (!StopRequested()) continue;
    child->Signal(SIGINT);
    if (!child->WaitFor(std::chrono::seconds(120))) child->Signal(SIGKILL), child->WaitFor(std::chrono::seconds(5));
    return Errorf("interrupted; the finished runs are kept (run the same command again to continue)");
  }
  if (refused && WIFEXITED(child->status()) && WEXITSTATUS(child->status()) == 2) {
    std::ifstream in(log);
    std::getline(in, *refused);
    return Status::Ok();
  }
  if (!child->succeeded()) return Errorf("{} {}; see {}", argv[1], child->Describe(), log);
  return Status::Ok();
}

// the final return of a finished run: `coins eval` of its newest checkpoint (the task greedy but
// for the run's learner.eval_task_explore, eval_episodes episodes, a fixed seed), kept in
// dir/final-eval.json
Status FinalEval(const fs::path& dir, const ExperimentFlags& f, int64_t seed, RunResult* r) {
  const fs::path file = dir / "final-eval.json";
  if (!fs::exists(file)) {
    std::vector<std::string> argv = {
        SelfDirectory() + "/coins",  "eval",  dir.string(), "--episodes", std::to_string(f.eval_episodes), "--seed",
        std::to_string(1000 + seed), "--json"};
    auto ran = RunBounded(argv, file.string() + ".tmp", std::chrono::seconds(1800));
    if (!Succeeded(ran)) return Errorf("coins eval {} failed; see {}.tmp", dir.string(), file.string());
    fs::rename(file.string() + ".tmp", file);
  }
  std::ifstream in(file);
  const json j = json::parse(in, nullptr, false);
  if (!j.is_object() || !j.contains("return_mean"))
    return Errorf("{}: not a `coins eval --json` result", file.string());
  r->final_return = j["return_mean"].get<double>();
  r->final_sd = j.value("return_sd", 0.0);
  for (auto [key, out] : {std::pair{"done_fraction", &r->done_fraction},
                          {"penalty_fraction", &r->penalty_fraction},
                          {"return_median", &r->final_median}})
    if (j.contains(key) && j[key].is_number()) *out = j[key].get<double>();
  return Status::Ok();
}

// one line of the experiment's progress (runs may end on several threads at once)
void Say(const std::string& line) {
  static std::mutex mu;
  std::lock_guard<std::mutex> lock(mu);
  std::cout << line << std::endl;
}

// argv with the run on `domain` (nullopt: as its config and --set say); the last --set wins
std::vector<std::string> OnDomain(std::vector<std::string> argv, std::optional<int> domain) {
  if (domain) {
    argv.push_back("--set");
    argv.push_back(fmt::format("dds.domain={}", *domain));
  }
  return argv;
}

// a finished run in dir, run now when it is not there yet; refused: see RunChild
Result<RunResult> EnsureRun(const fs::path& dir, const std::vector<std::string>& argv, const std::string& what,
                            std::optional<int> domain, std::string* refused) {
  auto result = ReadRunResult(dir.string());
  if (!result.ok() || result->done) return result;
  Say(fmt::format("{}: running in {}{}", what, dir.string(),
                  domain ? fmt::format(" (DDS domain {})", *domain) : std::string()));
  fs::create_directories(dir.parent_path());
  COINS_RETURN_IF_ERROR(RunChild(OnDomain(argv, domain), dir.string() + ".log", refused));
  if (refused && !refused->empty()) return RunResult{};
  result = ReadRunResult(dir.string());
  if (result.ok() && !result->done)
    return Errorf("{}: the run ended without finishing its task (see {}.log)", dir.string(), dir.string());
  return result;
}

void Add(Cell& c, const RunResult& r) {
  c.finals.push_back(r.final_return);
  if (!std::isnan(r.final_median)) c.medians.push_back(r.final_median);
  if (!std::isnan(r.done_fraction)) c.done.push_back(r.done_fraction);
  if (!std::isnan(r.penalty_fraction)) c.penalty.push_back(r.penalty_fraction);
  c.runs.push_back(r);
  const MeanAndSd m = MeanSd(c.finals, /*sample=*/true);
  c.mean = m.mean;
  c.sd = m.sd;
}

// a table cell of values over runs: " -12.30 +- 4.10 |" (mean +- sd), or of fractions as
// percentages, " 41.3 +- 2.0% |"; " - |" without values
std::string MeanSdCell(const std::vector<double>& values, bool percent = false) {
  if (values.empty()) return " - |";
  const auto [mean, sd] = MeanSd(values, /*sample=*/true);
  return percent ? fmt::format(" {:.1f} +- {:.1f}% |", 100 * mean, 100 * sd)
                 : fmt::format(" {:.2f} +- {:.2f} |", mean, sd);
}

// mean over vanilla's runs of their last periodic evaluation (a run without one: its final)
double VanillaCurveFinal(const Cell& vanilla) {
  std::vector<double> last;
  for (const RunResult& r : vanilla.runs) last.push_back(r.curve.empty() ? r.final_return : r.curve.back().second);
  return MeanSd(last, /*sample=*/true).mean;
}

// the references a variant's returns are read against, each over as many episodes as the
// methods' final evaluations hold together: uniform random primitive actions (a method must beat
// them to have learned anything) and, on Breakout, an ideal ball controller under random angles
// and under a search of the next bounces in simulator copies (actors/envs/breakout_planner.h:
// what a task over a perfect ball skill could score without and with foresight)
struct Reference {
  std::string key;     // in the JSON table
  std::string column;  // in the Markdown table
  double mean = 0, sd = 0;
  int64_t episodes = 0;
};

constexpr int kPlanDepth = 2;
constexpr uint64_t kReferenceSeed = 1001;

bool HasAngleReferences(const Suite& suite) { return suite.env_prefix == "breakout-"; }

Result<Reference> RandomPolicyReturn(int episodes, const std::string& env_name) {
  auto env = envs::MakeEnv(env_name);
  if (!env.ok()) return env.status();
  EvalOptions o;
  o.episodes = episodes;
  o.seed = kReferenceSeed;
  auto r = Evaluate(**env, HierarchyModels{}, /*acting=*/0, o);
  if (!r.ok()) return r.status();
  return Reference{"random_actions", "random actions", r->return_mean, r->return_sd, int64_t(r->returns.size())};
}

Result<Reference> PlannedAnglesReturn(int episodes, const std::string& env_name, int depth) {
  envs::AnglePlanOptions o;
  o.env = env_name;
  o.episodes = episodes;
  o.depth = depth;
  o.seed = kReferenceSeed;
  auto r = envs::PlanAngles(o);
  if (!r.ok()) return r.status();
  if (depth == 0)
    return Reference{"ideal_ball_random_angles", "ideal ball, random angles", r->mean(), r->sd(), episodes};
  return Reference{fmt::format("ideal_ball_search_{}", depth), fmt::format("ideal ball, {}-bounce search", depth),
                   r->mean(), r->sd(), episodes};
}

Result<std::vector<Reference>> References(const ExperimentFlags& f, const std::string& variant) {
  const Suite& suite = SuiteNamed(f.suite);
  const std::string env = suite.env_prefix + variant;
  const int episodes = int(f.eval_episodes * f.seeds);
  std::vector<Result<Reference>> got{RandomPolicyReturn(episodes, env)};
  if (HasAngleReferences(suite)) {
    got.push_back(PlannedAnglesReturn(episodes, env, 0));
    got.push_back(PlannedAnglesReturn(episodes, env, kPlanDepth));
  }
  std::vector<Reference> refs;
  for (auto& r : got) {
    if (!r.ok()) return r.status();
    refs.push_back(*r);
  }
  return refs;
}

// env steps of the first evaluation at or above `level`, per run (nullopt: never)
json StepsToReach(const Cell& c, double level) {
  json per_run = json::array();
  for (const RunResult& r : c.runs) {
    json at = nullptr;
    for (const auto& [steps, ret] : r.curve)
      if (ret >= level) {
        at = steps;
        break;
      }
    per_run.push_back(at);
  }
  return per_run;
}

std::string Reach(const json& per_run) {
  std::vector<uint64_t> got;
  for (const json& s : per_run)
    if (!s.is_null()) got.push_back(s.get<uint64_t>());
  if (got.empty()) return "never";
  std::sort(got.begin(), got.end());
  return fmt::format("{:.0f}k ({}/{} seeds)", double(got[got.size() / 2]) / 1e3, got.size(), per_run.size());
}

Status WriteCurves(const ExperimentFlags& f, const std::string& variant) {
  const std::string gnuplot = FindInPath("gnuplot");
  if (gnuplot.empty()) return Errorf("gnuplot not found (Debian package gnuplot-nox): no curves");
  const std::string png = (fs::path(f.out) / fmt::format("curves-{}.png", variant)).string();
  std::string script = fmt::format(
      "set datafile separator ','\nset terminal pngcairo size 900,540\nset grid\nset xlabel 'env steps'\n"
      "set ylabel 'eval return'\nset key bottom right\nset output '{}'\nset title '{}: eval return'\nplot ",
      png, SuiteNamed(f.suite).env_prefix + variant);
  bool first = true;
  for (size_t m = 0; m < f.methods.size(); ++m)
    for (int64_t s = 1; s <= f.seeds; ++s) {
      const fs::path csv = RunDir(f, variant, f.methods[m], s) / "eval.csv";
      if (!fs::exists(csv)) continue;
      // a colour per method, a dash pattern per seed: two seeds of one method stay apart
      script += fmt::format("{}'{}' every ::1 using 1:2 with lines lw 2 lc {} dt {} title '{} seed {}'",
                            first ? "" : ", ", csv.string(), m + 1, s, f.methods[m], s);
      first = false;
    }
  if (first) return Status::Ok();
  const std::string gp = (fs::path(f.out) / fmt::format("curves-{}.gp", variant)).string();
  std::ofstream(gp) << script << "\n";
  auto r = RunBounded({gnuplot, gp}, (fs::path(f.out) / "gnuplot.log").string(), std::chrono::seconds(30));
  if (!Succeeded(r)) return Errorf("gnuplot failed on {}; see {}/gnuplot.log", gp, f.out);
  return Status::Ok();
}

// the Markdown table's header: final returns, the paper's, the final evaluations' median episodes,
// steps to vanilla's final, and the goal and penalty fractions when the runs' evaluations have them
std::string TableHeader(const ExperimentFlags& f, bool fractions) {
  std::string md = "| variant |";
  size_t columns = 4 * f.methods.size();
  for (const auto& m : f.methods) md += fmt::format(" {} |", m);
  md += " random actions |";
  ++columns;
  if (HasAngleReferences(SuiteNamed(f.suite))) {
    md += fmt::format(" ideal ball, random angles | ideal ball, {}-bounce search |", kPlanDepth);
    columns += 2;
  }
  for (const auto& m : f.methods) md += fmt::format(" {} (paper) |", m);
  for (const auto& m : f.methods) md += fmt::format(" {}: median episode |", m);
  for (const auto& m : f.methods) md += fmt::format(" {}: steps to vanilla's final (periodic evals) |", m);
  if (fractions) {
    for (const auto& m : f.methods) md += fmt::format(" {}: episodes reaching the goal |", m);
    for (const auto& m : f.methods) md += fmt::format(" {}: steps in penalty regions |", m);
    columns += 2 * f.methods.size();
  }
  md += "\n|---|";
  for (size_t i = 0; i < columns; ++i) md += "---|";
  return md + "\n";
}

Status WriteTables(const ExperimentFlags& f, const std::map<std::string, std::map<std::string, Cell>>& cells,
                   const std::map<std::string, std::vector<Reference>>& references) {
  const Suite& suite = SuiteNamed(f.suite);
  json j = {{"suite", f.suite},
            {"chain", fs::absolute(f.chain).lexically_normal().string()},
            {"steps", f.steps},
            {"seeds", f.seeds},
            {"methods", f.methods},
            {"final", fmt::format("coins eval of each run's final checkpoint, {} episodes", f.eval_episodes)}};
  bool fractions = false;
  for (const auto& [v, row] : cells)
    for (const auto& [m, c] : row) fractions = fractions || !c.done.empty() || !c.penalty.empty();
  std::string md = fmt::format(
      "# {}\n\nChain: `{}`. Budget: {} env steps per run, {} seeds. Final return: `coins eval` of each run's final "
      "checkpoint ({} episodes, the task's evaluation explore: learner.eval_task_explore); mean +- sd over seeds. "
      "Median episode: the median episode return of each final evaluation, mean +- sd over seeds (a few lost "
      "episodes move the mean, not the median). "
      "Random actions: uniform random primitive actions, the return a method must beat to have learned anything "
      "(mean +- sd over episodes).{}\n\n",
      suite.title, f.chain, f.steps, f.seeds, f.eval_episodes,
      HasAngleReferences(suite)
          ? fmt::format(" Ideal ball: not a method but a bound, `coins env plan` (actors/envs/breakout_planner.h): the "
                        "paddle placed from the simulator's state so the ball leaves at the chosen one of the four "
                        "angles, the angles chosen at random or by searching the next {} bounces in copies of the "
                        "simulator; what a task over a perfect ball skill could score without and with that "
                        "foresight.",
                        kPlanDepth)
          : std::string());
  md += TableHeader(f, fractions);
  for (const auto& v : f.variants) {
    const auto& row = cells.at(v);
    const bool has_vanilla = row.count("vanilla") && !row.at("vanilla").finals.empty();
    // the level is vanilla's final return as its periodic evaluations measured it (the curves
    // are those evaluations, so a method is compared with vanilla on one measurement)
    const double level = has_vanilla ? VanillaCurveFinal(row.at("vanilla")) : NAN;
    if (has_vanilla) j["variants"][v]["vanilla_final_periodic"] = level;
    md += "| " + v + " |";
    for (const auto& m : f.methods) {
      const Cell& c = row.at(m);
      json& out = j["variants"][v][m];
      out = {{"mean", c.mean}, {"sd", c.sd}, {"runs", c.finals}};
      if (!c.medians.empty()) out["median_episode"] = c.medians;
      if (!c.done.empty()) out["done_fraction"] = c.done;
      if (!c.penalty.empty()) out["penalty_fraction"] = c.penalty;
      if (!c.not_run.empty()) out["not_run"] = c.not_run;
      md += c.finals.empty() ? " not run |" : MeanSdCell(c.finals);
      if (has_vanilla) out["steps_to_vanilla_final"] = StepsToReach(c, level);
    }
    for (const Reference& ref : references.at(v)) {
      j["variants"][v][ref.key] = {{"mean", ref.mean}, {"sd", ref.sd}, {"episodes", ref.episodes}};
      md += fmt::format(" {:.2f} +- {:.2f} |", ref.mean, ref.sd);
    }
    for (const auto& m : f.methods) {
      const auto p = suite.paper.count(v) && suite.paper.at(v).count(m) ? suite.paper.at(v).at(m) : NAN;
      j["variants"][v]["paper"][m] = std::isnan(p) ? json(nullptr) : json(p);
      md += std::isnan(p) ? " - |" : fmt::format(" {} |", p);
    }
    for (const auto& m : f.methods) md += MeanSdCell(row.at(m).medians);
    for (const auto& m : f.methods)
      md += has_vanilla ? " " + Reach(j["variants"][v][m]["steps_to_vanilla_final"]) + " |" : " - |";
    if (fractions) {
      for (const auto& m : f.methods) md += MeanSdCell(row.at(m).done, /*percent=*/true);
      for (const auto& m : f.methods) md += MeanSdCell(row.at(m).penalty, /*percent=*/true);
    }
    md += "\n";
  }
  for (const auto& v : f.variants)
    for (const auto& m : f.methods)
      if (!cells.at(v).at(m).not_run.empty())
        md += fmt::format("\n- {} on {}: not run: {}", m, suite.env_prefix + v, cells.at(v).at(m).not_run);
  COINS_RETURN_IF_ERROR(WriteFileAtomic((fs::path(f.out) / (f.suite + ".json")).string(), j.dump(1) + "\n"));
  return WriteFileAtomic((fs::path(f.out) / (f.suite + ".md")).string(), md + "\n");
}

Status Check(ExperimentFlags& f) {
  const Suite& suite = SuiteNamed(f.suite);
  if (!fs::exists(fs::path(f.chain) / "config.yaml")) return Errorf("--chain {}: not a run directory", f.chain);
  if (f.variants.empty()) f.variants = suite.variants;
  if (f.methods.empty()) f.methods = suite.methods;
  for (const auto& v : f.variants)
    if (std::find(suite.variants.begin(), suite.variants.end(), v) == suite.variants.end())
      return Errorf("--variants: unknown variant '{}' (known: {})", v, Known(suite.variants));
  for (const auto& m : f.methods)
    if (std::find(suite.methods.begin(), suite.methods.end(), m) == suite.methods.end())
      return Errorf("--methods: unknown method '{}' (known: {})", m, Known(suite.methods));
  COINS_RETURN_IF_ERROR(CheckDomains(f.domains));
  if (f.eval_episodes == 0) f.eval_episodes = suite.eval_episodes;
  if (f.out.empty()) f.out = (fs::path(f.chain) / ("experiment-" + f.suite)).string();
  std::error_code ec;
  fs::create_directories(f.out, ec);
  if (ec) return Errorf("--out {}: {}", f.out, ec.message());
  return Status::Ok();
}

// one run of an experiment; variant "" is finetune's pre-training for `seed`
struct PlannedRun {
  std::string variant, method;
  int64_t seed = 1;
  std::string what;                 // its progress label
  std::optional<RunResult> result;  // once finished and evaluated
  std::string refused;              // why it could not start
};

// the runs, in the order the table lists them: every variant, method and seed
std::vector<PlannedRun> PlanRuns(const ExperimentFlags& f) {
  std::vector<PlannedRun> runs;
  const int64_t total = int64_t(f.variants.size() * f.methods.size()) * f.seeds;
  for (const auto& v : f.variants)
    for (const auto& m : f.methods)
      for (int64_t s = 1; s <= f.seeds; ++s)
        runs.push_back(
            {v, m, s,
             fmt::format("[{}/{}] {} {} seed {}", runs.size() + 1, total, SuiteNamed(f.suite).env_prefix + v, m, s),
             std::nullopt, ""});
  return runs;
}

// finetune's pre-training runs (one per seed), which every finetune run of that seed starts from
std::vector<PlannedRun> PlanPretraining(const ExperimentFlags& f) {
  std::vector<PlannedRun> runs;
  if (std::find(f.methods.begin(), f.methods.end(), "finetune") == f.methods.end()) return runs;
  for (int64_t s = 1; s <= f.seeds; ++s)
    runs.push_back({"", "vanilla", s,
                    fmt::format("pre-training vanilla on {}, seed {} ({} env steps)", SuiteNamed(f.suite).pretrain_env,
                                s, f.pretrain_steps),
                    std::nullopt, ""});
  return runs;
}

Status RunPretraining(const ExperimentFlags& f, std::vector<PlannedRun>& runs) {
  return RunQueue(runs.size(), f.domains, [&](size_t j, std::optional<int> domain) -> Status {
    const PlannedRun& r = runs[j];
    return EnsureRun(PretrainDir(f, r.seed), RunArgv(f, "", "vanilla", r.seed), r.what, domain, nullptr).status();
  });
}

Status RunAndEvaluate(const ExperimentFlags& f, std::vector<PlannedRun>& runs) {
  return RunQueue(runs.size(), f.domains, [&](size_t j, std::optional<int> domain) -> Status {
    PlannedRun& r = runs[j];
    const fs::path dir = RunDir(f, r.variant, r.method, r.seed);
    auto result = EnsureRun(dir, RunArgv(f, r.variant, r.method, r.seed), r.what, domain, &r.refused);
    if (!result.ok()) return result.status();
    if (!r.refused.empty()) {
      Say(r.what + ": not run: " + r.refused);
      return Status::Ok();
    }
    COINS_RETURN_IF_ERROR(FinalEval(dir, f, r.seed, &*result));
    Say(fmt::format("{}: final eval return {:.2f} ({:.0f} s)", r.what, result->final_return, result->wall_s));
    r.result = std::move(*result);
    return Status::Ok();
  });
}

}  // namespace

Result<RunResult> ReadRunResult(const std::string& dir) {
  RunResult r;
  const json summary = [&] {
    std::ifstream in(fs::path(dir) / "summary.json");
    return in ? json::parse(in, nullptr, false) : json();
  }();
  if (!summary.is_object()) return r;
  r.done = summary.value("phase", "") == "done";
  r.wall_s = summary.value("wall_s", 0.0);
  if (summary.contains("eval") && summary["eval"].is_object()) r.final_return = summary["eval"].value("mean", 0.0);
  std::ifstream csv(fs::path(dir) / "eval.csv");
  for (std::string line; std::getline(csv, line);)
    if (auto e = ParseEvalRow(line)) r.curve.emplace_back(e->env_steps, e->mean);  // not the header, a cut row
  return r;
}

Status RunExperiment(const ExperimentFlags& flags) {
  ExperimentFlags f = flags;
  COINS_RETURN_IF_ERROR(Check(f));
  InstallStopSignals();
  std::vector<PlannedRun> pretraining = PlanPretraining(f);
  COINS_RETURN_IF_ERROR(RunPretraining(f, pretraining));
  std::vector<PlannedRun> runs = PlanRuns(f);
  COINS_RETURN_IF_ERROR(RunAndEvaluate(f, runs));
  std::map<std::string, std::map<std::string, Cell>> cells;
  for (const PlannedRun& r : runs) {
    Cell& c = cells[r.variant][r.method];
    if (!r.refused.empty()) c.not_run = r.refused;
    if (r.result) Add(c, *r.result);
  }
  std::map<std::string, std::vector<Reference>> references;
  for (const auto& v : f.variants) {
    auto refs = References(f, v);
    if (!refs.ok()) return refs.status();
    references[v] = std::move(*refs);
  }
  COINS_RETURN_IF_ERROR(WriteTables(f, cells, references));
  for (const auto& v : f.variants)
    if (Status s = WriteCurves(f, v); !s.ok()) std::cerr << "coins experiment: " << s.message() << "\n";
  if (auto md = ReadFileText((fs::path(f.out) / (f.suite + ".md")).string()); md.ok()) std::cout << *md << "\n";
  std::cout << fmt::format("coins experiment: tables in {}/{}.md and {}.json, curves in {}/curves-*.png\n", f.out,
                           f.suite, f.suite, f.out);
  return Status::Ok();
}

namespace {

void AddSuiteCommand(CLI::App* exp, const Suite& suite, const std::string& help, int* exit_code) {
  auto f = std::make_shared<ExperimentFlags>();
  f->suite = suite.name;
  CLI::App* t = exp->add_subcommand(suite.name, help);
  t->add_option("--chain", f->chain, fmt::format("run directory of a learned chain (with its {} skill)", suite.skill))
      ->required();
  t->add_option("--variants", f->variants, fmt::format("variants (default: {})", Known(suite.variants)))
      ->delimiter(',');
  t->add_option("--methods", f->methods, fmt::format("methods (default: {})", Known(suite.methods)))->delimiter(',');
  t->add_option("--seeds", f->seeds, "seeds per variant and method")->check(CLI::Range(1, 100));
  t->add_option("--steps", f->steps, "env steps of each run")->check(cli::Integer(1000, int64_t(1) << 40));
  t->add_option("--eval-episodes", f->eval_episodes,
                fmt::format("episodes of the final evaluation of each run (default {})", suite.eval_episodes))
      ->check(CLI::Range(1, 100000));
  if (!suite.pretrain_env.empty())
    t->add_option("--pretrain-steps", f->pretrain_steps,
                  fmt::format("finetune: env steps of the vanilla run on {}", suite.pretrain_env))
        ->check(cli::Integer(1000, int64_t(1) << 40));
  t->add_option("--out", f->out, fmt::format("output directory (default: CHAIN/experiment-{})", suite.name));
  t->add_option("--set", f->overrides, "a config override for every run (repeatable)");
  t->add_option("--domains", f->domains,
                "run several runs at once, one per DDS domain listed (e.g. 81,82; default: one run at a time "
                "on the domain of the chain's config and --set)")
      ->delimiter(',');
  t->callback([f, exit_code] {
    if (Status s = RunExperiment(*f); !s.ok()) {
      std::cerr << "coins experiment " << f->suite << ": " << s.message() << "\n";
      *exit_code = 2;
    }
  });
}

}  // namespace

void AddExperimentCommand(CLI::App& app, int* exit_code) {
  CLI::App* exp = app.add_subcommand("experiment", "Run a whole experiment of several runs and write its tables.");
  exp->require_subcommand(1);
  AddSuiteCommand(exp, TransferSuite(),
                  "COInS transfer against vanilla DQN and fine-tuning on the Breakout variants (the paper's "
                  "transfer table).",
                  exit_code);
  AddSuiteCommand(exp, PushingSuite(),
                  "COInS (a task over the chain's frozen Block skill) against vanilla SAC on robot pushing.",
                  exit_code);
}

}  // namespace coins
