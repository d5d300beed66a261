#include "orchestrator/run_report.h"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <sstream>

#include <fmt/format.h>

#include "common/files.h"
#include "learner/checkpoint_dirs.h"
#include "orchestrator/child_process.h"

namespace coins {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string Short(double x) {
  if (x >= 1e6) return fmt::format("{:.2f}M", x / 1e6);
  if (x >= 1e3) return fmt::format("{:.1f}k", x / 1e3);
  return fmt::format("{:.0f}", x);
}

std::string Mask(const std::vector<float>& m) {
  std::string out;
  for (float x : m) out += (out.empty() ? "" : " ") + fmt::format("{:g}", x);
  return "[" + out + "]";
}

std::string Goals(const std::string& kind, const std::vector<float>& g, size_t mask_dims) {
  if (kind == "continuous" && g.size() % 2 == 0 && !g.empty()) {
    std::vector<float> lo(g.begin(), g.begin() + long(g.size() / 2)), hi(g.begin() + long(g.size() / 2), g.end());
    return fmt::format("continuous {} .. {}", Mask(lo), Mask(hi));
  }
  const size_t n = mask_dims ? g.size() / mask_dims : g.size();
  return fmt::format("{} {} goals {}", kind.empty() ? "?" : kind, n, Mask(g));
}

size_t MaskedDims(const std::vector<float>& mask) {
  size_t n = 0;
  for (float x : mask) n += x != 0;
  return n;
}

}  // namespace

json DetectorJson(const DetectorCounts& d) {
  if (d.pair.empty()) return nullptr;
  return {{"pair", d.pair},
          {"states", d.states},
          {"labelled", d.labelled},
          {"false_positives", d.false_positives},
          {"missed", d.missed},
          {"fp_per_state", d.fp_per_state()},
          {"miss_rate", d.miss_rate()}};
}

std::string ChainProgress(const StatusView& v, int64_t restarts) {
  if (!v.chain) return fmt::format("chain (no status yet) | restarts {}", restarts);
  const msg::ChainStatus& c = v.chain->sample;
  std::string s = "chain " + c.phase();
  if (c.phase() == "collecting" || c.phase() == "detecting") s += fmt::format(" {} r{}", c.source(), c.round());
  for (const auto& l : c.links())
    s += fmt::format(" | {}->{} {:.2f} {:.2f}{}", l.source(), l.target(), l.score(), l.skill_success(),
                     l.state() == "training" ? "*" : "");
  if (c.eval_env_steps()) s += fmt::format(" | eval {:.1f}+-{:.1f}", c.eval_return_mean(), c.eval_return_sd());
  if (v.learner && v.learner->sample.eval_play_episodes())
    s += fmt::format(" | skill plays {:.1f}+-{:.1f}", v.learner->sample.eval_play_return_mean(),
                     v.learner->sample.eval_play_return_sd());
  if (v.learner)
    s += fmt::format(" | lag {:.1f} | {:.0f} upd/s", v.learner->sample.lag_median(), v.learner->sample.updates_per_s());
  return s + fmt::format(" | epoch {} | restarts {}", c.epoch(), restarts);
}

MetricsRow MakeRow(const StatusView& v, double wall_s, double steps_per_s, int64_t restarts) {
  MetricsRow r;
  r.wall_s = wall_s;
  r.env_steps = v.total_steps();
  r.steps_per_s = steps_per_s;
  r.restarts = restarts;
  if (v.learner) {
    r.updates_per_s = v.learner->sample.updates_per_s();
    r.lag_median = v.learner->sample.lag_median();
    r.greedy_env_steps = v.learner->sample.eval_env_steps();
    r.greedy_success = v.learner->sample.eval_success();
    r.greedy_hit_rate = v.learner->sample.eval_hit_rate();
    r.greedy_angle_accuracy = v.learner->sample.eval_angle_accuracy();
    r.play_mean = v.learner->sample.eval_play_return_mean();
    r.play_sd = v.learner->sample.eval_play_return_sd();
    r.play_episodes = v.learner->sample.eval_play_episodes();
  }
  if (v.chain) {
    const msg::ChainStatus& c = v.chain->sample;
    r.phase = c.phase();
    r.env_steps = std::max(r.env_steps, c.env_steps());
    r.eval_env_steps = c.eval_env_steps();
    r.eval_mean = c.eval_return_mean();
    r.eval_sd = c.eval_return_sd();
    r.epoch = c.epoch();
    for (const auto& l : c.links()) r.links.push_back({l.source() + "->" + l.target(), l.state(), l.skill_success()});
  }
  r.detector = v.detector();
  return r;
}

namespace {

constexpr const char* kEvalHeader = "env_steps,eval_return_mean,eval_return_sd,wall_s";

std::string MetricsHeader() {
  std::string h =
      "wall_s,env_steps,phase,steps_per_s,updates_per_s,lag_median,eval_env_steps,eval_return_mean,"
      "eval_return_sd,epoch,restarts";
  for (int i = 1; i <= RunMetrics::kMaxLevels; ++i) h += ",success_" + std::to_string(i);
  return h +
         ",detector_pair,detector_states,detector_fp_per_state,detector_miss_rate"
         ",greedy_env_steps,greedy_success,greedy_hit_rate,greedy_angle_accuracy";
}

// the lines of `file`; a last line without its newline (cut by a crash) is cut off the file too
std::vector<std::string> CompleteLines(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t last = text.rfind('\n');
  const size_t keep = last == std::string::npos ? 0 : last + 1;
  std::error_code ec;
  if (keep < text.size()) fs::resize_file(file, keep, ec);
  std::vector<std::string> lines;
  std::istringstream rows(text.substr(0, keep));
  for (std::string l; std::getline(rows, l);) lines.push_back(l);
  return lines;
}

// the rows a resumed run keeps of a CSV file: all of them when its header is `header`; a file
// with another header (an older coins) is moved aside to FILE.before-resume and none are kept
std::vector<std::string> ResumedRows(const fs::path& file, const std::string& header) {
  if (!fs::exists(file)) return {};
  std::vector<std::string> lines = CompleteLines(file);
  if (!lines.empty() && lines[0] == header) return {lines.begin() + 1, lines.end()};
  std::error_code ec;
  fs::rename(file, file.string() + ".before-resume", ec);
  return {};
}

}  // namespace

std::optional<EvalPoint> ParseEvalRow(const std::string& row) {
  EvalPoint e;
  std::istringstream in(row);
  char c1 = 0, c2 = 0;
  if (!(in >> e.env_steps >> c1 >> e.mean >> c2 >> e.sd) || c1 != ',' || c2 != ',') return std::nullopt;
  if (char c3 = 0; in >> c3 && (c3 != ',' || !(in >> e.wall_s))) return std::nullopt;
  if (!std::isfinite(e.mean) || !std::isfinite(e.sd) || !std::isfinite(e.wall_s)) return std::nullopt;
  return e;
}

namespace {

// the evaluations of a resumed run's eval.csv or skill_eval.csv, in order of env steps
std::vector<EvalPoint> ResumedEvals(const fs::path& file) {
  std::vector<EvalPoint> evals;
  for (const std::string& row : ResumedRows(file, kEvalHeader))
    if (auto e = ParseEvalRow(row); e && (evals.empty() || e->env_steps > evals.back().env_steps)) evals.push_back(*e);
  return evals;
}

// a new evaluation (newer than the last) as a row of its file
void AppendEval(std::ofstream& out, std::vector<EvalPoint>& evals, const EvalPoint& e) {
  if (!evals.empty() && e.env_steps <= evals.back().env_steps) return;
  out << fmt::format("{},{:.4f},{:.4f},{:.2f}\n", e.env_steps, e.mean, e.sd, e.wall_s);
  evals.push_back(e);
}

}  // namespace

Result<RunMetrics> RunMetrics::Open(const std::string& dir, bool resume) {
  RunMetrics m;
  m.dir_ = dir;
  const fs::path csv = fs::path(dir) / "metrics.csv", jsonl = fs::path(dir) / "metrics.jsonl",
                 eval = fs::path(dir) / "eval.csv", skill_eval = fs::path(dir) / "skill_eval.csv";
  if (resume) {
    const std::vector<std::string> rows = ResumedRows(csv, MetricsHeader());
    if (!rows.empty()) m.wall_offset_ = std::strtod(rows.back().c_str(), nullptr);
    m.evals_ = ResumedEvals(eval);
    m.skill_evals_ = ResumedEvals(skill_eval);
    if (fs::exists(jsonl)) CompleteLines(jsonl);
  }
  // a resumed run appends to a file that holds its header; everything else starts anew
  auto open = [&](std::ofstream& out, const fs::path& file, const std::string& header) {
    std::error_code ec;
    const bool append = resume && fs::exists(file) && fs::file_size(file, ec) > 0;
    out.open(file, append ? std::ios::app : std::ios::trunc);
    if (!append && !header.empty()) out << header << "\n" << std::flush;
  };
  open(m.csv_, csv, MetricsHeader());
  open(m.jsonl_, jsonl, "");
  open(m.eval_, eval, kEvalHeader);
  open(m.skill_eval_, skill_eval, kEvalHeader);
  if (!m.csv_ || !m.jsonl_ || !m.eval_ || !m.skill_eval_) return Errorf("cannot write the metrics files in {}", dir);
  return m;
}

void RunMetrics::Append(const MetricsRow& r) {
  const bool eval = r.eval_env_steps > 0;
  const double wall_s = r.wall_s + wall_offset_;
  csv_ << fmt::format("{:.2f},{},{},{:.1f},{:.2f},{:.3f},", wall_s, r.env_steps, r.phase, r.steps_per_s,
                      r.updates_per_s, r.lag_median);
  csv_ << (eval ? fmt::format("{},{:.4f},{:.4f}", r.eval_env_steps, r.eval_mean, r.eval_sd) : std::string(",,"));
  csv_ << fmt::format(",{},{}", r.epoch, r.restarts);
  for (int i = 0; i < kMaxLevels; ++i)
    csv_ << "," << (size_t(i) < r.links.size() ? fmt::format("{:.4f}", r.links[size_t(i)].success) : "");
  const DetectorCounts& d = r.detector;
  csv_ << (d.pair.empty() ? std::string(",,,,")
                          : fmt::format(",{},{},{:.3g},{:.4f}", d.pair, d.states, d.fp_per_state(), d.miss_rate()));
  csv_ << (r.greedy_env_steps ? fmt::format(",{},{:.4f},{:.4f},{:.4f}", r.greedy_env_steps, r.greedy_success,
                                            r.greedy_hit_rate, r.greedy_angle_accuracy)
                              : std::string(",,,,"));
  csv_ << "\n";
  json links = json::array();
  for (size_t i = 0; i < r.links.size(); ++i)
    links.push_back(
        {{"level", i + 1}, {"link", r.links[i].name}, {"state", r.links[i].state}, {"success", r.links[i].success}});
  json ev = eval ? json{{"env_steps", r.eval_env_steps}, {"mean", r.eval_mean}, {"sd", r.eval_sd}} : json(nullptr);
  jsonl_ << json{{"wall_s", wall_s},
                 {"env_steps", r.env_steps},
                 {"phase", r.phase},
                 {"steps_per_s", r.steps_per_s},
                 {"updates_per_s", r.updates_per_s},
                 {"lag_median", r.lag_median},
                 {"eval", ev},
                 {"epoch", r.epoch},
                 {"restarts", r.restarts},
                 {"links", links},
                 {"detector", DetectorJson(r.detector)},
                 {"greedy", r.greedy_env_steps ? json{{"env_steps", r.greedy_env_steps},
                                                      {"success", r.greedy_success},
                                                      {"hit_rate", r.greedy_hit_rate},
                                                      {"angle_accuracy", r.greedy_angle_accuracy},
                                                      {"play", r.play_episodes ? json{{"mean", r.play_mean},
                                                                                      {"sd", r.play_sd},
                                                                                      {"episodes", r.play_episodes}}
                                                                               : json(nullptr)}}
                                               : json(nullptr)}}
                .dump()
         << "\n";
  if (eval) AppendEval(eval_, evals_, {r.eval_env_steps, r.eval_mean, r.eval_sd, wall_s});
  if (r.greedy_env_steps && r.play_episodes)
    AppendEval(skill_eval_, skill_evals_, {r.greedy_env_steps, r.play_mean, r.play_sd, wall_s});
  // one row a second: flushed, so a run that is killed keeps its metrics
  csv_.flush(), jsonl_.flush(), eval_.flush(), skill_eval_.flush();
  levels_ = std::max(levels_, std::min(int(r.links.size()), kMaxLevels));
  for (size_t i = 0; i < r.links.size() && i < size_t(kMaxLevels); ++i) {
    if (names_.size() <= i) names_.resize(i + 1);
    names_[i] = r.links[i].name;
  }
}

Result<std::vector<std::string>> RunMetrics::Plot() {
  csv_.flush(), jsonl_.flush(), eval_.flush(), skill_eval_.flush();
  std::vector<std::string> files;
  std::string script =
      "set datafile separator ','\nset terminal pngcairo size 900,540\nset grid\n"
      "set xlabel 'env steps'\nset key bottom right\n";
  if (levels_ > 0) {
    const std::string out = (fs::path(dir_) / "skill_success.png").string();
    script += fmt::format(
        "set output '{}'\nset title 'Skill success (goal-reaching rate, windowed)'\n"
        "set ylabel 'success'\nset yrange [0:1.05]\nplot ",
        out);
    for (int i = 0; i < levels_; ++i)
      script += fmt::format("{}'{}' every ::1 using 2:{} with lines lw 2 title 'level {} {}'", i ? ", " : "",
                            (fs::path(dir_) / "metrics.csv").string(), 12 + i, i + 1, names_[size_t(i)]);
    script += "\nset yrange [*:*]\n";
    files.push_back(out);
  }
  if (!evals_.empty() || !skill_evals_.empty()) {
    const std::string out = (fs::path(dir_) / "eval_return.png").string();
    script += fmt::format("set output '{}'\nset title 'Task: greedy eval return'\nset ylabel 'return'\nplot ", out);
    const auto series = [&](const char* file, const char* title) {
      return fmt::format("'{}' every ::1 using 1:2:3 with yerrorlines lw 2 title '{}'",
                         (fs::path(dir_) / file).string(), title);
    };
    if (!skill_evals_.empty()) script += series("skill_eval.csv", "skill in training, random goals (mean +- sd)");
    if (!skill_evals_.empty() && !evals_.empty()) script += ", ";
    if (!evals_.empty()) script += series("eval.csv", "task policy (mean +- sd)");
    script += "\n";
    files.push_back(out);
  }
  if (files.empty()) return files;
  const std::string gnuplot = FindInPath("gnuplot");
  if (gnuplot.empty()) return Errorf("gnuplot not found (Debian package gnuplot-nox): no learning-curve PNGs");
  const std::string script_path = (fs::path(dir_) / "curves.gp").string();
  std::ofstream(script_path) << script;
  auto r =
      RunBounded({gnuplot, script_path}, (fs::path(dir_) / "logs" / "gnuplot.log").string(), std::chrono::seconds(30));
  if (!Succeeded(r))
    return Errorf("gnuplot failed ({}); see {}/logs/gnuplot.log",
                  r.ok() ? "exit status " + std::to_string(*r) : r.status().message(), dir_);
  return files;
}

json RunSummary(const StatusView& v, double wall_s, int64_t restarts) {
  json j = {{"wall_s", wall_s}, {"env_steps", v.total_steps()}, {"restarts", restarts}, {"links", json::array()}};
  if (json d = DetectorJson(v.detector()); !d.is_null()) j["detector"] = d;
  if (!v.chain) return j;
  const msg::ChainStatus& c = v.chain->sample;
  j["env_steps"] = std::max(v.total_steps(), c.env_steps());
  j["phase"] = c.phase();
  j["message"] = c.message();
  j["epoch"] = c.epoch();
  for (const auto& l : c.links())
    j["links"].push_back({{"source", l.source()},
                          {"target", l.target()},
                          {"score", l.score()},
                          {"mask", l.mask()},
                          {"goal_kind", l.goal_kind()},
                          {"goal_set", l.goal_set()},
                          {"skill_success", l.skill_success()},
                          {"state", l.state()},
                          {"accepted_at_steps", l.accepted_at_steps()},
                          {"learned_at_steps", l.learned_at_steps()}});
  j["last_scores"] = json::array();
  for (const auto& s : c.last_scores())
    j["last_scores"].push_back({{"source", s.source()},
                                {"target", s.target()},
                                {"score", s.score()},
                                {"interactions", s.interactions()},
                                {"chance_interactions", s.chance_interactions()},
                                {"goal_interactions", s.goal_interactions()},
                                {"eligible", s.eligible()},
                                {"note", s.note()}});
  if (c.eval_env_steps())
    j["eval"] = {{"env_steps", c.eval_env_steps()}, {"mean", c.eval_return_mean()}, {"sd", c.eval_return_sd()}};
  return j;
}

json EvalMilestones(const std::vector<EvalPoint>& evals, const std::vector<double>& targets) {
  if (evals.empty()) return nullptr;
  auto point = [](const EvalPoint& e) {
    return json{{"env_steps", e.env_steps}, {"mean", e.mean}, {"sd", e.sd}, {"wall_s", e.wall_s}};
  };
  const EvalPoint* best = &evals.front();
  for (const EvalPoint& e : evals)
    if (e.mean > best->mean) best = &e;
  json reached = json::array();
  for (double target : targets) {
    auto first = std::find_if(evals.begin(), evals.end(), [&](const EvalPoint& e) { return e.mean >= target; });
    json r = first == evals.end() ? json{{"env_steps", nullptr}} : point(*first);
    r["return"] = target;
    reached.push_back(r);
  }
  return {{"count", evals.size()}, {"best", point(*best)}, {"reached", reached}};
}

json KeptWeightsOf(const std::string& run_dir) {
  json kept = json::object();
  auto dir = FindCheckpoint(run_dir, -1);
  if (!dir.ok()) return kept;
  auto text = ReadFileText(*dir + "/state.json");
  if (!text.ok()) return kept;
  json j = json::parse(*text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return kept;
  if (j.contains("skill_choices")) kept["skill_choices"] = j["skill_choices"];
  if (j.contains("best_task") && j["best_task"].is_object()) kept["kept_task"] = j["best_task"];
  return kept;
}

namespace {
std::string ChoiceLine(const json& c) {
  return fmt::format(
      "    weights of {} env steps kept, the best of {} candidates on {} goals each: hit rate {:.4f}, success "
      "{:.4f} (the final weights': {:.4f}, {:.4f})\n",
      Short(double(c.value("env_steps", uint64_t(0)))), c.value("candidates", uint64_t(0)),
      c.value("goals", uint64_t(0)), c.value("hit_rate", 0.0), c.value("success", 0.0), c.value("final_hit_rate", 0.0),
      c.value("final_success", 0.0));
}
// one scored pair of the newest detect round (rejected pairs too: why the chain stopped there)
std::string ScoreLine(const json& sc) {
  const auto number = [&](const char* k) {
    return sc.contains(k) && sc[k].is_number() ? sc[k].get<double>() : std::numeric_limits<double>::quiet_NaN();
  };
  std::string line =
      fmt::format("    {}->{}: Sc_I {:.2f}", sc.value("source", "?"), sc.value("target", "?"), number("score"));
  if (sc.contains("interactions"))
    line +=
        fmt::format(", {:.0f} detections ({:.1f} by chance)", number("interactions"), number("chance_interactions"));
  if (number("goal_interactions") > 0)
    line += fmt::format(", mask and goal set from {:.0f}", number("goal_interactions"));
  if (!sc.value("eligible", true)) line += ", not eligible";
  const std::string note = sc.value("note", "");
  return line + (note.empty() ? "" : ": " + note) + "\n";
}
// the task's kept weights (the learner's best_task): what scored them, on how many episodes
std::string KeptTaskLine(const json& k) {
  if (k.value("newest", false))
    return "  task weights kept: the newest (the final policy; learner.keep_best_task false)\n";
  const int64_t episodes = k.value("episodes", int64_t(0));  // 0: a checkpoint of an older version
  return fmt::format(
      "  task weights kept: of {} env steps, return {:.2f} +- {:.2f}{} (the final policy, `coins "
      "eval` acts with them{})\n",
      Short(double(k.value("env_steps", uint64_t(0)))), k.value("return_mean", 0.0), k.value("return_sd", 0.0),
      episodes > 0 ? fmt::format(" over {} episodes", episodes) : "",
      k.contains("skill_files") ? ", over the skills' weights of that evaluation: they trained under the task" : "");
}
// the best of a series of evaluations (EvalMilestones; `best_is`: what the best one is, or "") and
// when each reported return was first reached
std::string MilestoneLines(const json& e, const std::string& what, const std::string& best_is,
                           const std::string& name) {
  const json& b = e["best"];
  std::string out =
      fmt::format("  best of {} {}: {:.2f} +- {:.2f} at {} env steps ({:.0f} s){}\n", e["count"].get<uint64_t>(), what,
                  b["mean"].get<double>(), b["sd"].get<double>(), Short(double(b["env_steps"].get<uint64_t>())),
                  b["wall_s"].get<double>(), best_is.empty() ? "" : ": " + best_is);
  for (const json& r : e["reached"])
    out += r["env_steps"].is_null()
               ? fmt::format("  {} >= {:g}: not reached\n", name, r["return"].get<double>())
               : fmt::format("  {} >= {:g}: first at {} env steps ({:.0f} s), {:.2f}\n", name,
                             r["return"].get<double>(), Short(double(r["env_steps"].get<uint64_t>())),
                             r["wall_s"].get<double>(), r["mean"].get<double>());
  return out;
}
}  // namespace

std::string FormatSummary(const json& s) {
  std::string out = fmt::format("coins run summary: phase {} after {:.1f} s, {} env steps, {} restarts\n",
                                s.value("phase", "unknown"), s.value("wall_s", 0.0),
                                Short(double(s.value("env_steps", uint64_t(0)))), s.value("restarts", int64_t(0)));
  if (s.contains("message")) out += "  chain: " + s["message"].get<std::string>() + "\n";
  int level = 0;
  for (const auto& l : s["links"]) {
    auto mask = l["mask"].get<std::vector<float>>();
    out += fmt::format("  level {} {}->{}: Sc_I {:.2f}, accepted at {}, {}, skill success {:.3f}\n", ++level,
                       l["source"].get<std::string>(), l["target"].get<std::string>(), l["score"].get<double>(),
                       Short(double(l["accepted_at_steps"].get<uint64_t>())),
                       l["learned_at_steps"].get<uint64_t>()
                           ? "learned at " + Short(double(l["learned_at_steps"].get<uint64_t>()))
                           : std::string("not learned"),
                       l["skill_success"].get<double>());
    out += fmt::format(
        "    mask {}; goals {}\n", Mask(mask),
        Goals(l["goal_kind"].get<std::string>(), l["goal_set"].get<std::vector<float>>(), MaskedDims(mask)));
    if (s.contains("skill_choices") && s["skill_choices"].is_array())
      for (const json& c : s["skill_choices"])
        if (c.is_object() && c.value("level", 0) == level) out += ChoiceLine(c);
  }
  if (s.contains("last_scores") && s["last_scores"].is_array() && !s["last_scores"].empty()) {
    out += "  newest detect round:\n";
    for (const json& sc : s["last_scores"])
      if (sc.is_object()) out += ScoreLine(sc);
  }
  if (s.contains("detector"))
    out += fmt::format(
        "  detector {} against the env's labels: {:.3g} false positives per state, {:.4f} of {} "
        "interactions missed ({} states)\n",
        s["detector"]["pair"].get<std::string>(), s["detector"]["fp_per_state"].get<double>(),
        s["detector"]["miss_rate"].get<double>(), s["detector"]["labelled"].get<uint64_t>(),
        s["detector"]["states"].get<uint64_t>());
  if (s.contains("eval"))
    out += fmt::format("  newest eval return: {:.2f} +- {:.2f} (evaluated at {} env steps)\n",
                       s["eval"]["mean"].get<double>(), s["eval"]["sd"].get<double>(),
                       Short(double(s["eval"]["env_steps"].get<uint64_t>())));
  else
    out += "  newest eval return: none reported\n";
  if (s.contains("skill_evals") && s["skill_evals"].is_object())
    out += MilestoneLines(s["skill_evals"], "evaluations of the skill in training on random goals playing the task", "",
                          "skill on random goals, return");
  const bool kept = s.contains("kept_task") && s["kept_task"].is_object();
  if (s.contains("evals") && s["evals"].is_object())
    out += MilestoneLines(s["evals"], "task evaluations",
                          kept ? "" : "the final policy, `coins eval` acts with its weights", "eval return");
  if (kept) out += KeptTaskLine(s["kept_task"]);
  return out;
}

std::optional<uint64_t> FinalEpoch(const std::string& run_dir, uint64_t budget_steps) {
  std::error_code ec;
  std::optional<uint64_t> newest;
  for (const auto& e : fs::directory_iterator(fs::path(run_dir) / "chain", ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("chain-epoch-", 0) != 0) continue;
    std::ifstream in(e.path());
    json j = json::parse(in, nullptr, false);
    if (j.is_discarded() || !j.contains("state") || !j["state"].is_object()) continue;
    const json& s = j["state"];
    const bool final =
        s.value("phase", "") == "done" || (budget_steps > 0 && s.value("env_steps", uint64_t(0)) >= budget_steps);
    if (!final || !s.contains("epoch") || !s["epoch"].is_number_unsigned()) continue;
    newest = std::max(newest.value_or(0), s["epoch"].get<uint64_t>());
  }
  return newest;
}

std::string WriteFinalGif(const std::string& coins_path, const std::string& run_dir) {
  const std::string log = (fs::path(run_dir) / "logs" / "eval.log").string();
  auto probe = RunBounded({coins_path, "eval", "--help"}, log, std::chrono::seconds(10));
  if (!Succeeded(probe))
    return "final GIF skipped: this coins has no `eval` subcommand yet (hook: WriteFinalGif in "
           "orchestrator/run_report.cc)";
  const std::string gif = (fs::path(run_dir) / "final.gif").string();
  auto r = RunBounded({coins_path, "eval", run_dir, "--episodes", "1", "--gif", gif}, log, std::chrono::seconds(600));
  if (!Succeeded(r)) return fmt::format("final GIF not written: coins eval failed; see {}", log);
  return "final policy GIF: " + gif;
}

}  // namespace coins
