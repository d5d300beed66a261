#include "actors/envs/env_cli.h"

#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <memory>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "actors/envs/breakout_planner.h"
#include "actors/envs/render.h"
#include "actors/envs/rng.h"
#include "actors/envs/rollout_format.h"
#include "common/cli_checks.h"

namespace coins::envs {
namespace {

constexpr uint64_t kPolicySalt = 0x70a11c1e5eedull;  // keeps the policy's stream apart from the env's

using FilePtr = std::unique_ptr<FILE, int (*)(FILE*)>;

std::string Trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string_view::npos) return "";
  const auto e = s.find_last_not_of(" \t\r");
  return std::string(s.substr(b, e - b + 1));
}

// one line of an actions file into an action vector
Status ParseAction(const ActionSpec& a, const std::string& line, std::vector<float>* out) {
  out->clear();
  if (a.discrete) {
    long v = 0;
    auto [p, ec] = std::from_chars(line.data(), line.data() + line.size(), v);
    if (ec != std::errc() || p != line.data() + line.size()) return Errorf("'{}' is not an integer action", line);
    if (v < 0 || v >= a.n) return Errorf("action {} is out of range [0, {}]", v, a.n - 1);
    out->push_back(static_cast<float>(v));
    return Status::Ok();
  }
  size_t start = 0;
  while (start <= line.size()) {
    const size_t comma = std::min(line.find(',', start), line.size());
    const std::string tok = Trim(std::string_view(line).substr(start, comma - start));
    float v = 0;
    auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
    if (tok.empty() || ec != std::errc() || p != tok.data() + tok.size())
      return Errorf("'{}' is not a number (in '{}')", tok, line);
    out->push_back(v);
    start = comma + 1;
  }
  if (static_cast<int>(out->size()) != a.dim)
    return Errorf("'{}' has {} values, the action space needs {}", line, out->size(), a.dim);
  for (float v : *out)
    if (!std::isfinite(v)) return Errorf("'{}' is not a finite action", line);
  return Status::Ok();
}

Result<std::vector<std::vector<float>>> ReadActions(const std::string& path, const ActionSpec& a) {
  std::ifstream in(path);
  if (!in) return Errorf("--actions {}: cannot open", path);
  std::vector<std::vector<float>> actions;
  std::string line;
  std::vector<float> act;
  for (int n = 1; std::getline(in, line); ++n) {
    const std::string t = Trim(line);
    if (t.empty()) continue;
    Status st = ParseAction(a, t, &act);
    if (!st.ok()) return st.WithContext(fmt::format("--actions {} line {}", path, n));
    actions.push_back(act);
  }
  if (actions.empty()) return Errorf("--actions {}: no actions in the file", path);
  return actions;
}

void RandomAction(const ActionSpec& a, Rng& rng, std::vector<float>* out) {
  out->resize(a.dim);
  if (a.discrete) {
    (*out)[0] = static_cast<float>(rng.UniformInt(0, a.n - 1));
    return;
  }
  for (int i = 0; i < a.dim; ++i) (*out)[i] = static_cast<float>(rng.Uniform(a.low[i], a.high[i]));
}

}  // namespace

Status RunList(bool json) {
  nlohmann::json all = nlohmann::json::array();
  for (const std::string& name : EnvNames()) {
    Result<std::unique_ptr<Env>> env = MakeEnv(name);
    if (!env.ok()) return env.status();
    const EnvSpec& s = (*env)->spec();
    if (json) {
      nlohmann::json j;
      j["name"] = s.name;
      j["action"] = {{"discrete", s.action.discrete},
                     {"n", s.action.n},
                     {"dim", s.action.dim},
                     {"low", s.action.low},
                     {"high", s.action.high}};
      for (const FactorSpec& f : s.factors)
        j["factors"].push_back({{"name", f.name},
                                {"features", f.features},
                                {"instances", f.instances},
                                {"multi_instance", f.multi_instance},
                                {"feature_names", f.feature_names},
                                {"low", f.low},
                                {"high", f.high}});
      for (const InteractionPair& p : s.interactions) j["interactions"].push_back(p.label());
      j["max_episode_steps"] = s.max_episode_steps;
      j["state_dim"] = s.state_dim();
      all.push_back(j);
      continue;
    }
    std::string factors;
    for (const FactorSpec& f : s.factors)
      factors += fmt::format("{}{} {}x{}", factors.empty() ? "" : ", ", f.name, f.instances, f.features);
    std::string action = s.action.discrete ? fmt::format("discrete {}", s.action.n)
                                           : fmt::format("continuous {} in [{}, {}]", s.action.dim,
                                                         fmt::join(s.action.low, " "), fmt::join(s.action.high, " "));
    std::string inter;
    for (const InteractionPair& p : s.interactions) inter += (inter.empty() ? "" : ", ") + p.label();
    fmt::print("{}\n  action: {}\n  factors: {} (state_dim {})\n  interactions: {}\n  horizon: {}\n", s.name, action,
               factors, s.state_dim(), inter,
               s.max_episode_steps ? std::to_string(s.max_episode_steps) : std::string("none"));
  }
  if (json) fmt::print("{}\n", all.dump());
  return Status::Ok();
}

// the rollout's lines into `out`
Status WriteRollout(Env& env, const RolloutOptions& o, const std::vector<std::vector<float>>& file_actions, int steps,
                    FILE* out);

Status RunRollout(const RolloutOptions& o) {
  Result<std::unique_ptr<Env>> made = MakeEnv(o.env);
  if (!made.ok()) return made.status().WithContext("--env");
  Env& env = **made;
  const EnvSpec& spec = env.spec();
  // actions: a file, or a random policy for --steps
  std::vector<std::vector<float>> file_actions;
  if (!o.actions_file.empty()) {
    auto r = ReadActions(o.actions_file, spec.action);
    if (!r.ok()) return r.status();
    file_actions = std::move(r).value();
  } else if (o.policy != "random") {
    return Errorf("rollout: give --actions FILE or --policy random with --steps S");
  } else if (o.steps <= 0) {
    return Errorf("--steps: must be a positive number of steps with --policy random, got {}", o.steps);
  }
  const int steps = file_actions.empty() ? o.steps
                                         : (o.steps > 0 ? std::min<int>(o.steps, file_actions.size())
                                                        : static_cast<int>(file_actions.size()));
  // written to a temporary file renamed over --out at the end: a run that fails leaves no
  // partial file behind (and an older file of that name intact)
  const std::string tmp = o.out + ".tmp";
  FilePtr out(std::fopen(tmp.c_str(), "w"), &std::fclose);
  if (!out) return Errorf("--out {}: cannot open {} for writing", o.out, tmp);
  Status written = WriteRollout(env, o, file_actions, steps, out.get());
  if (written.ok() && std::fflush(out.get()) != 0) written = Errorf("--out {}: write failed", o.out);
  out.reset();
  if (written.ok() && std::rename(tmp.c_str(), o.out.c_str()) != 0)
    written = Errorf("--out {}: cannot rename {} to it", o.out, tmp);
  if (!written.ok()) std::remove(tmp.c_str());
  return written;
}

Status WriteRollout(Env& env, const RolloutOptions& o, const std::vector<std::vector<float>>& file_actions, int steps,
                    FILE* out) {
  const EnvSpec& spec = env.spec();

  std::vector<float> state(spec.state_dim()), next(spec.state_dim()), action;
  Rng policy(o.seed ^ kPolicySalt);
  env.Reset(o.seed, state);
  std::string line;
  int episode = 0;
  for (int t = 0; t < steps; ++t) {
    if (file_actions.empty())
      RandomAction(spec.action, policy, &action);
    else
      action = file_actions[t];
    StepResult r;
    Status st = env.Step(action, next, &r);
    if (!st.ok()) return st.WithContext(fmt::format("step {}", t));
    // one JSON object per transition
    line.clear();
    AppendRolloutLine(spec, t, episode, state, action, next, r, &line);
    if (std::fwrite(line.data(), 1, line.size(), out) != line.size()) return Errorf("--out {}: write failed", o.out);
    // next episode after done or truncated
    if (r.done || r.truncated) {
      ++episode;
      env.ResetNext(next);
    }
    std::swap(state, next);
  }
  return Status::Ok();
}

Status RunRender(const RenderOptions& o) {
  const bool gif = o.out.size() > 4 && o.out.compare(o.out.size() - 4, 4, ".gif") == 0;
  const bool png = o.out.size() > 4 && o.out.compare(o.out.size() - 4, 4, ".png") == 0;
  if (!gif && !png) return Errorf("--out {}: must end in .png or .gif", o.out);
  if (o.policy != "random") return Errorf("--policy {}: only 'random' is supported", o.policy);
  if (gif && o.steps > 3000) return Errorf("--steps {}: at most 3000 frames in a gif", o.steps);
  Result<std::unique_ptr<Env>> made = MakeEnv(o.env);
  if (!made.ok()) return made.status().WithContext("--env");
  Env& env = **made;
  const EnvSpec& spec = env.spec();
  auto renderer = MakeRenderer(env, o.scale, o.width, o.height);
  if (!renderer.ok()) return renderer.status();

  std::vector<float> state(spec.state_dim()), action;
  Rng policy(o.seed ^ kPolicySalt);
  env.Reset(o.seed, state);
  std::vector<Image> frames;
  auto grab = [&]() -> Status {
    Result<Image> img = (*renderer)->Render(env);
    if (!img.ok()) return img.status();
    frames.push_back(std::move(img).value());
    return Status::Ok();
  };
  if (gif) COINS_RETURN_IF_ERROR(grab());
  for (int t = 0; t < o.steps; ++t) {
    RandomAction(spec.action, policy, &action);
    StepResult r;
    Status st = env.Step(action, state, &r);
    if (!st.ok()) return st.WithContext(fmt::format("step {}", t));
    if (gif) COINS_RETURN_IF_ERROR(grab());
    if (r.done || r.truncated) env.ResetNext(state);
  }
  if (png) {
    COINS_RETURN_IF_ERROR(grab());
    return WritePng(o.out, frames.back());
  }
  return WriteGif(o.out, frames, o.delay_cs);
}

Status RunPlan(const AnglePlanOptions& o, bool json) {
  const auto t0 = std::chrono::steady_clock::now();
  Result<AnglePlanResult> r = PlanAngles(o);
  if (!r.ok()) return r.status();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double n = double(r->returns.size());
  if (json) {
    nlohmann::json j{{"env", o.env},           {"depth", o.depth},
                     {"episodes", o.episodes}, {"seed", o.seed},
                     {"mean", r->mean()},      {"sd", r->sd()},
                     {"returns", r->returns},  {"bounces", r->bounces},
                     {"drops", r->drops},      {"env_steps", r->env_steps},
                     {"seconds", seconds}};
    fmt::print("{}\n", j.dump());
  } else {
    fmt::print(
        "{}, ideal ball controller, {}: return {:.2f} +- {:.2f} over {} episodes ({:.2f} paddle bounces an "
        "episode, {} drops, {} env steps, {:.1f} s)\n",
        o.env, o.depth == 0 ? std::string("random reachable angles") : fmt::format("search depth {}", o.depth),
        r->mean(), r->sd(), o.episodes, double(r->bounces) / n, r->drops, r->env_steps, seconds);
  }
  return Status::Ok();
}

void AddEnvCommands(CLI::App& app) {
  CLI::App* env = app.add_subcommand("env", "Environments: list them, write rollouts, render pictures");
  env->require_subcommand(1);
  const std::vector<std::string> names = EnvNames();
  // seeds take every 64-bit value and nothing beyond (CLI11 alone clamps 2^64 to 2^64 - 1)
  const CLI::Validator seed_check = cli::Unsigned();

  // list
  auto json = std::make_shared<bool>(false);
  CLI::App* list = env->add_subcommand("list", "List the envs: factors, action spaces, interactions");
  list->add_flag("--json", *json, "Print one JSON array instead of text");
  list->callback([json] { cli::FailIf("env list", RunList(*json), 1); });

  // rollout
  auto ro = std::make_shared<RolloutOptions>();
  CLI::App* rollout = env->add_subcommand("rollout", "Run an env and write one JSON object per transition");
  rollout->add_option("--env", ro->env, "Env name")->required()->check(CLI::IsMember(names));
  rollout->add_option("--seed", ro->seed, "Env seed")->required()->check(seed_check);
  auto* actions = rollout
                      ->add_option("--actions", ro->actions_file,
                                   "File with one action per line (integer, or comma-separated floats)")
                      ->check(CLI::ExistingFile);
  auto* pol =
      rollout->add_option("--policy", ro->policy, "Action policy instead of a file")->check(CLI::IsMember({"random"}));
  actions->excludes(pol);
  rollout->add_option("--steps", ro->steps, "Number of steps (with --actions: at most this many)")
      ->check(cli::Integer(1, std::numeric_limits<int>::max()));
  rollout->add_option("--out", ro->out, "Output file (JSON lines)")->required();
  rollout->callback([ro] { cli::FailIf("env rollout", RunRollout(*ro), 1); });

  // render
  auto rd = std::make_shared<RenderOptions>();
  CLI::App* render = env->add_subcommand("render", "Render frames of a random-policy run to PNG (last frame) or GIF");
  render->add_option("--env", rd->env, "Env name")->required()->check(CLI::IsMember(names));
  render->add_option("--seed", rd->seed, "Env seed")->required()->check(seed_check);
  render->add_option("--policy", rd->policy, "Action policy")->check(CLI::IsMember({"random"}));
  render->add_option("--steps", rd->steps, "Number of steps")->check(cli::Integer(0, 1'000'000));
  render->add_option("--out", rd->out, "Output file, .png or .gif")->required();
  render->add_option("--scale", rd->scale, "Breakout: image pixels per game pixel")->check(CLI::Range(1, 16));
  render->add_option("--width", rd->width, "Pushing: image width (<= 640)")->check(CLI::Range(16, 640));
  render->add_option("--height", rd->height, "Pushing: image height (<= 480)")->check(CLI::Range(16, 480));
  render->add_option("--delay", rd->delay_cs, "GIF frame delay in 1/100 s")->check(CLI::Range(1, 1000));
  render->callback([rd] { cli::FailIf("env render", RunRender(*rd), 1); });

  // plan
  auto po = std::make_shared<AnglePlanOptions>();
  auto plan_json = std::make_shared<bool>(false);
  std::vector<std::string> breakouts;
  for (const std::string& n : names)
    if (n.rfind("breakout", 0) == 0) breakouts.push_back(n);
  CLI::App* plan = env->add_subcommand(
      "plan",
      "A reference, not a method: Breakout with an ideal ball controller choosing each bounce angle by search over "
      "the next --depth bounces in copies of the simulator (0: random angles)");
  plan->add_option("--env", po->env, "Breakout env name")->required()->check(CLI::IsMember(breakouts));
  plan->add_option("--episodes", po->episodes, "Episodes")->check(cli::Integer(1, 1'000'000));
  plan->add_option("--depth", po->depth, "Bounces searched ahead, 0 to 4 (0: random reachable angles)")
      ->check(cli::Integer(0, 4));
  plan->add_option("--seed", po->seed, "Episode e starts from seed + e")->check(seed_check);
  plan->add_option("--max-steps", po->max_steps, "Env steps per episode at most")->check(cli::Integer(1, 10'000'000));
  plan->add_flag("--json", *plan_json, "Print one JSON object");
  plan->callback([po, plan_json] { cli::FailIf("env plan", RunPlan(*po, *plan_json), 1); });
}

}  // namespace coins::envs
