// What `coins run` writes about the chain: metrics files, learning curves (real gnuplot), the
// progress line's chain part and the summary, from a scripted StatusView.
#include "orchestrator/run_report.h"

#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace coins {
namespace {

namespace fs = std::filesystem;

fs::path Dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("coins-run-report-" + name + "-" + std::to_string(getpid()));
  fs::remove_all(d);
  fs::create_directories(d / "logs");
  return d;
}

std::vector<std::string> Lines(const fs::path& p) {
  std::ifstream in(p);
  std::vector<std::string> out;
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

msg::ChainLink Link(const std::string& s, const std::string& t, double score, double success,
                    const std::string& state) {
  msg::ChainLink l;
  l.source(s);
  l.target(t);
  l.score(score);
  l.skill_success(success);
  l.state(state);
  l.mask({1, 0, 0});
  l.goal_kind("continuous");
  l.goal_set({-1, 1});
  l.accepted_at_steps(10'000);
  l.learned_at_steps(state == "learned" ? 40'000 : 0);
  return l;
}

StatusView View(uint64_t steps, std::vector<msg::ChainLink> links, uint64_t eval_at, double eval) {
  StatusView v;
  msg::ChainStatus c;
  c.phase(links.size() > 1 ? "training-skill" : "collecting");
  c.source("Action");
  c.env_steps(steps);
  c.links(links);
  c.eval_env_steps(eval_at);
  c.eval_return_mean(eval);
  c.eval_return_sd(2.0);
  c.epoch(3);
  c.message("training Paddle->Ball");
  v.chain = StatusView::Entry<msg::ChainStatus>{c, StatusView::Clock::now()};
  msg::LearnerStatus l;
  l.lag_median(1.5);
  l.updates_per_s(250);
  v.learner = StatusView::Entry<msg::LearnerStatus>{l, StatusView::Clock::now()};
  return v;
}

TEST(RunReport, MetricsRowsAndLearningCurvesAreWritten) {
  fs::path dir = Dir("metrics");
  auto m = RunMetrics::Open(dir.string());
  ASSERT_TRUE(m.ok()) << m.status().message();
  for (int i = 1; i <= 20; ++i) {
    std::vector<msg::ChainLink> links = {Link("Action", "Paddle", 6.2, 0.04 * i, i < 10 ? "training" : "learned")};
    if (i >= 10) links.push_back(Link("Paddle", "Ball", 4.1, 0.03 * (i - 10), "training"));
    uint64_t steps = uint64_t(i) * 5000;
    StatusView v = View(steps, links, i >= 15 ? steps : 0, 10.0 * i);
    if (i >= 10 && i < 15) {  // the ball skill's evaluations, each seen twice, play the task
      v.learner->sample.eval_env_steps(steps - steps % 10'000);
      v.learner->sample.eval_play_return_mean(double(i));
      v.learner->sample.eval_play_return_sd(0.5);
      v.learner->sample.eval_play_episodes(20);
    }
    m->Append(MakeRow(v, double(i), 5000.0, 0));
  }
  auto lines = Lines(dir / "metrics.csv");
  ASSERT_EQ(lines.size(), 21u);
  EXPECT_EQ(lines[0].substr(0, 60), "wall_s,env_steps,phase,steps_per_s,updates_per_s,lag_median,");
  EXPECT_EQ(lines[20],
            "20.00,100000,training-skill,5000.0,250.00,1.500,100000,200.0000,2.0000,3,0,0.8000,0.3000,,,,,,,,,,,,,,");
  EXPECT_EQ(Lines(dir / "eval.csv").size(), 1u + 6u);  // header + evaluations at rows 15..20
  // the skill's evaluations at 50k, 60k and 70k env steps, first seen in rows 10, 12 and 14
  EXPECT_EQ(Lines(dir / "skill_eval.csv"),
            (std::vector<std::string>{"env_steps,eval_return_mean,eval_return_sd,wall_s", "50000,10.0000,0.5000,10.00",
                                      "60000,12.0000,0.5000,12.00", "70000,14.0000,0.5000,14.00"}));
  ASSERT_EQ(m->skill_evals().size(), 3u);
  EXPECT_EQ(m->skill_evals()[2].env_steps, 70'000u);
  auto jsonl = Lines(dir / "metrics.jsonl");
  ASSERT_EQ(jsonl.size(), 20u);
  auto last = nlohmann::json::parse(jsonl.back());
  EXPECT_EQ(last["links"][1]["link"], "Paddle->Ball");
  EXPECT_DOUBLE_EQ(last["eval"]["mean"].get<double>(), 200.0);
  EXPECT_TRUE(nlohmann::json::parse(jsonl.front())["eval"].is_null());
  EXPECT_DOUBLE_EQ(nlohmann::json::parse(jsonl[13])["greedy"]["play"]["mean"].get<double>(), 14.0);
  EXPECT_EQ(nlohmann::json::parse(jsonl[13])["greedy"]["play"]["episodes"], 20u);
  auto plots = m->Plot();
  ASSERT_TRUE(plots.ok()) << plots.status().message();
  ASSERT_EQ(plots->size(), 2u);
  for (const auto& f : *plots) {
    std::ifstream in(f, std::ios::binary);
    char magic[4] = {};
    in.read(magic, 4);
    EXPECT_EQ(std::string(magic + 1, 3), "PNG") << f;
    EXPECT_GT(fs::file_size(f), 2000u) << f;
  }
}

msg::ActorStats Counting(uint64_t seq, const std::string& pair, uint64_t states, uint64_t labelled, uint64_t fp,
                         uint64_t missed) {
  msg::ActorStats a;
  a.command_seq(seq);
  a.detector_pair(pair);
  a.detector_states(states);
  a.detector_truth(labelled);
  a.detector_fp(fp);
  a.detector_fn(missed);
  return a;
}

// rows 1..n of a run whose eval return is 10 x row from row 5 on (an evaluation per row)
void AppendRows(RunMetrics& m, int first, int last) {
  for (int i = first; i <= last; ++i) {
    const uint64_t steps = uint64_t(i) * 5000;
    m.Append(MakeRow(View(steps, {Link("Action", "Paddle", 6.2, 0.5, "training")}, i >= 5 ? steps : 0, 10.0 * i),
                     double(i - first + 1), 5000.0, 0));
  }
}

TEST(RunReport, AResumedRunAppendsToItsMetricsAndTakesItsWallClockOn) {
  fs::path dir = Dir("resume");
  {
    auto m = RunMetrics::Open(dir.string());
    ASSERT_TRUE(m.ok()) << m.status().message();
    AppendRows(*m, 1, 10);  // wall 1..10 s
  }
  std::ofstream(dir / "metrics.csv", std::ios::app) << "11.00,55000,train";  // cut by a crash
  auto m = RunMetrics::Open(dir.string(), /*resume=*/true);
  ASSERT_TRUE(m.ok()) << m.status().message();
  EXPECT_DOUBLE_EQ(m->wall_offset(), 10.0);
  ASSERT_EQ(m->evals().size(), 6u);  // rows 5..10, read back
  EXPECT_EQ(m->evals().back().env_steps, 50'000u);
  EXPECT_DOUBLE_EQ(m->evals().back().mean, 100.0);
  EXPECT_DOUBLE_EQ(m->evals().back().wall_s, 10.0);
  AppendRows(*m, 11, 13);  // this process's wall 1..3 s
  auto rows = Lines(dir / "metrics.csv");
  ASSERT_EQ(rows.size(), 1u + 13u);  // one header, the cut row gone
  EXPECT_EQ(rows[10].substr(0, 12), "10.00,50000,");
  EXPECT_EQ(rows[11].substr(0, 12), "11.00,55000,");
  EXPECT_EQ(rows[13].substr(0, 12), "13.00,65000,");
  auto evals = Lines(dir / "eval.csv");
  ASSERT_EQ(evals.size(), 1u + 9u);
  EXPECT_EQ(evals[0], "env_steps,eval_return_mean,eval_return_sd,wall_s");
  EXPECT_EQ(evals[9], "65000,130.0000,2.0000,13.00");
  EXPECT_EQ(Lines(dir / "metrics.jsonl").size(), 13u);
  ASSERT_EQ(m->evals().size(), 9u);
  EXPECT_DOUBLE_EQ(m->evals()[6].wall_s, 11.0);

  // a run without --resume starts its files anew
  auto fresh = RunMetrics::Open(dir.string());
  ASSERT_TRUE(fresh.ok());
  EXPECT_TRUE(fresh->evals().empty());
  EXPECT_EQ(Lines(dir / "eval.csv").size(), 1u);
}

TEST(RunReport, AResumeKeepsMetricsOfAnotherLayoutAsideInsteadOfMixingThem) {
  fs::path dir = Dir("resume-old");
  std::ofstream(dir / "eval.csv") << "env_steps,eval_return_mean,eval_return_sd\n20000,5.0,1.0\n";
  auto m = RunMetrics::Open(dir.string(), /*resume=*/true);
  ASSERT_TRUE(m.ok()) << m.status().message();
  EXPECT_TRUE(m->evals().empty());
  EXPECT_EQ(Lines(dir / "eval.csv.before-resume").size(), 2u);
  EXPECT_EQ(Lines(dir / "eval.csv"), std::vector<std::string>{"env_steps,eval_return_mean,eval_return_sd,wall_s"});
}

TEST(RunReport, EvalRowsOfThisAndOlderRunsAreReadAndDamagedOnesRefused) {
  const auto now = ParseEvalRow("20000,71.5,30.25,812.5");
  ASSERT_TRUE(now);
  EXPECT_EQ(now->env_steps, 20000u);
  EXPECT_DOUBLE_EQ(now->mean, 71.5);
  EXPECT_DOUBLE_EQ(now->sd, 30.25);
  EXPECT_DOUBLE_EQ(now->wall_s, 812.5);
  const auto older = ParseEvalRow("40000,-3.5,1");  // runs before eval.csv had wall_s
  ASSERT_TRUE(older);
  EXPECT_EQ(older->env_steps, 40000u);
  EXPECT_DOUBLE_EQ(older->mean, -3.5);
  EXPECT_DOUBLE_EQ(older->wall_s, 0.0);
  for (const char* bad : {"env_steps,eval_return_mean,eval_return_sd,wall_s", "60000,80", "60000,nan,1,2",
                          "60000,80,1;2", "60000,80,1,", ""})
    EXPECT_FALSE(ParseEvalRow(bad)) << bad;
}

TEST(RunReport, TheSummarySaysTheBestEvaluationAndWhenEachReturnWasFirstReached) {
  const std::vector<EvalPoint> evals = {{20'000, 40, 9, 100},
                                        {40'000, 91.5, 12, 200},
                                        {60'000, 96, 3, 300},
                                        {80'000, 97.25, 2, 400},
                                        {100'000, 90, 8, 500}};
  const auto m = EvalMilestones(evals, {90, 95, 99});
  EXPECT_EQ(m["count"], 5u);
  EXPECT_EQ(m["best"]["env_steps"], 80'000u);
  EXPECT_EQ(m["reached"][0]["env_steps"], 40'000u);
  EXPECT_EQ(m["reached"][1]["env_steps"], 60'000u);
  EXPECT_DOUBLE_EQ(m["reached"][1]["wall_s"].get<double>(), 300.0);
  EXPECT_TRUE(m["reached"][2]["env_steps"].is_null());
  EXPECT_TRUE(EvalMilestones({}, {95}).is_null());

  auto summary = RunSummary(View(100'000, {}, 100'000, 90), 500, 0);
  summary["evals"] = m;
  summary["skill_evals"] = EvalMilestones({{30'000, 91, 5, 150}, {50'000, 88, 6, 250}}, {90, 95});
  const std::string text = FormatSummary(summary);
  EXPECT_NE(text.find("best of 5 task evaluations: 97.25 +- 2.00 at 80.0k env steps (400 s)"), std::string::npos)
      << text;
  EXPECT_NE(text.find("\n  eval return >= 95: first at 60.0k env steps (300 s), 96.00"), std::string::npos) << text;
  EXPECT_NE(text.find("\n  eval return >= 99: not reached"), std::string::npos) << text;
  EXPECT_NE(text.find("best of 2 evaluations of the skill in training on random goals playing the task: 91.00 +- "
                      "5.00 at 30.0k env steps (150 s)\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("skill on random goals, return >= 90: first at 30.0k env steps (150 s), 91.00"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("skill on random goals, return >= 95: not reached"), std::string::npos) << text;
}

TEST(RunReport, ProgressAndSummaryShowTheChain) {
  StatusView v =
      View(123'456, {Link("Action", "Paddle", 6.2, 0.93, "learned"), Link("Paddle", "Ball", 4.1, 0.4, "training")},
           120'000, 12.3);
  // two actors count the newest command's detector; one still reports an older pair
  v.actors[0] = {Counting(7, "Paddle->Ball", 60'000, 1'000, 3, 20), StatusView::Clock::now()};
  v.actors[1] = {Counting(7, "Paddle->Ball", 40'000, 600, 1, 12), StatusView::Clock::now()};
  v.actors[2] = {Counting(5, "Action->Paddle", 9'000, 900, 50, 50), StatusView::Clock::now()};
  EXPECT_EQ(ChainProgress(v, 2),
            "chain training-skill | Action->Paddle 6.20 0.93 | Paddle->Ball 4.10 0.40* | eval 12.3+-2.0 | lag 1.5 | "
            "250 upd/s | epoch 3 | restarts 2");
  EXPECT_EQ(ChainProgress(StatusView{}, 0), "chain (no status yet) | restarts 0");
  StatusView playing = v;
  playing.learner->sample.eval_play_episodes(20);
  playing.learner->sample.eval_play_return_mean(41.25);
  playing.learner->sample.eval_play_return_sd(9.5);
  EXPECT_NE(ChainProgress(playing, 2).find("| eval 12.3+-2.0 | skill plays 41.2+-9.5 | lag 1.5 |"), std::string::npos)
      << ChainProgress(playing, 2);
  // the newest detect round, a rejected pair among its scores
  msg::InteractionScore block;
  block.source("Ball");
  block.target("Block");
  block.score(0);
  block.interactions(3);
  block.chance_interactions(2.5);
  block.goal_interactions(4);
  block.eligible(false);
  block.note("3 detections are not above 2 x 2.5 by chance");
  v.chain->sample.last_scores({block});
  auto summary = RunSummary(v, 61.5, 2);
  EXPECT_EQ(summary["links"].size(), 2u);
  EXPECT_EQ(summary["last_scores"][0]["chance_interactions"], 2.5);
  EXPECT_EQ(summary["links"][0]["learned_at_steps"], 40'000);
  std::string text = FormatSummary(summary);
  EXPECT_NE(text.find("phase training-skill after 61.5 s, 123.5k env steps, 2 restarts"), std::string::npos) << text;
  EXPECT_NE(text.find("level 1 Action->Paddle: Sc_I 6.20, accepted at 10.0k, learned at 40.0k, skill success 0.930"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("level 2 Paddle->Ball: Sc_I 4.10, accepted at 10.0k, not learned"), std::string::npos) << text;
  EXPECT_NE(text.find("mask [1 0 0]; goals continuous [-1] .. [1]"), std::string::npos) << text;
  EXPECT_NE(text.find("newest detect round:\n    Ball->Block: Sc_I 0.00, 3 detections (2.5 by chance), mask and goal "
                      "set from 4, not eligible: 3 detections are not above 2 x 2.5 by chance\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("newest eval return: 12.30 +- 2.00 (evaluated at 120.0k env steps)"), std::string::npos) << text;
  EXPECT_NE(text.find("detector Paddle->Ball against the env's labels: 4e-05 false positives per state, 0.0200 of 1600 "
                      "interactions missed (100000 states)"),
            std::string::npos)
      << text;
  v.learner->sample.eval_env_steps(118'000);
  v.learner->sample.eval_hit_rate(0.93);
  v.learner->sample.eval_angle_accuracy(0.61);
  MetricsRow row = MakeRow(v, 1.0, 0.0, 0);
  EXPECT_EQ(row.greedy_env_steps, 118'000u);
  EXPECT_DOUBLE_EQ(row.greedy_hit_rate, 0.93);
  EXPECT_DOUBLE_EQ(row.greedy_angle_accuracy, 0.61);
  EXPECT_EQ(row.detector.states, 100'000u);
  EXPECT_EQ(row.detector.missed, 32u);
}

TEST(RunReport, TheFinalEpochIsTheOneCutAfterTheChainWasDone) {
  fs::path dir = Dir("final-epoch");
  EXPECT_FALSE(FinalEpoch(dir.string()).has_value());
  fs::create_directories(dir / "chain");
  auto write = [&](uint64_t epoch, const std::string& phase) {
    nlohmann::json j = {{"format", "coins-chain"}, {"state", {{"phase", phase}, {"epoch", epoch}}}};
    std::ofstream(dir / "chain" / ("chain-epoch-" + std::to_string(epoch) + ".json")) << j.dump();
  };
  write(3, "task");
  EXPECT_FALSE(FinalEpoch(dir.string()).has_value());
  write(5, "done");
  write(4, "done");
  std::ofstream(dir / "chain" / "chain-epoch-9.json") << "{";  // corrupt: ignored
  EXPECT_EQ(FinalEpoch(dir.string()).value_or(0), 5u);
}

// the newest learner checkpoint's record of the skills' kept weights goes under its link, and
// that of the task's kept weights after the task's evaluations
TEST(RunReport, TheSummarySaysWhichWeightsEachSkillAndTheTaskKept) {
  fs::path dir = Dir("choices");
  EXPECT_TRUE(KeptWeightsOf(dir.string()).empty());
  auto checkpoint = [&](uint64_t epoch, uint64_t kept_at) {
    fs::create_directories(dir / "checkpoints" / ("learner-epoch-" + std::to_string(epoch)));
    nlohmann::json state = {{"format", 1},
                            {"skill_choices",
                             {{{"level", 2},
                               {"skill", "skill/Ball"},
                               {"candidates", 9},
                               {"goals", 20000},
                               {"env_steps", kept_at},
                               {"hit_rate", 0.9921},
                               {"success", 0.9311},
                               {"final_env_steps", 866'200},
                               {"final_hit_rate", 0.9802},
                               {"final_success", 0.9105}}}},
                            {"best_task",
                             {{"level", 3},
                              {"env_steps", kept_at + 1000},
                              {"return_mean", 91.25},
                              {"return_sd", 8.5},
                              {"episodes", 50},
                              {"seed", 42},
                              {"file", "task-best.bin"}}}};
    std::ofstream(dir / "checkpoints" / ("learner-epoch-" + std::to_string(epoch)) / "state.json") << state.dump();
  };
  checkpoint(4, 500'000);
  checkpoint(7, 712'345);
  auto summary = RunSummary(
      View(1'000'000, {Link("Action", "Paddle", 4.3, 1, "learned"), Link("Paddle", "Ball", 9000, 0.9, "learned")},
           1'000'000, 90),
      3000, 0);
  summary["evals"] = EvalMilestones({{600'000, 93.0, 5.0, 2000}, {713'345, 92.0, 4.0, 2100}}, {});
  summary.update(KeptWeightsOf(dir.string()));
  const std::string text = FormatSummary(summary);
  const std::string task_line =
      "  task weights kept: of 713.3k env steps, return 91.25 +- 8.50 over 50 episodes (the final policy, `coins eval` "
      "acts with them)\n";
  EXPECT_NE(text.find(task_line), std::string::npos) << text;
  EXPECT_NE(text.find("best of 2 task evaluations: 93.00 +- 5.00 at 600.0k env steps (2000 s)\n"), std::string::npos)
      << "the best evaluation is not called the final policy when the kept weights are another's: " << text;
  summary["kept_task"]["skill_files"] = {"task-best-skill-1.bin"};  // learner.skill_updates_in_task
  EXPECT_NE(FormatSummary(summary).find("acts with them, over the skills' weights of that evaluation: they trained "
                                        "under the task)\n"),
            std::string::npos)
      << FormatSummary(summary);
  summary["kept_task"] = {{"newest", true}};
  const std::string newest = FormatSummary(summary);
  EXPECT_NE(newest.find("  task weights kept: the newest (the final policy; learner.keep_best_task false)\n"),
            std::string::npos)
      << newest;
  EXPECT_EQ(newest.find("acts with its weights"), std::string::npos) << newest;
  const std::string line =
      "    weights of 712.3k env steps kept, the best of 9 candidates on 20000 goals each: hit rate 0.9921, success "
      "0.9311 (the final weights': 0.9802, 0.9105)\n";
  const size_t at = text.find(line);
  ASSERT_NE(at, std::string::npos) << text;
  EXPECT_LT(text.find("level 2 Paddle->Ball"), at);
  EXPECT_EQ(text.find("kept, the best of"), text.rfind("kept, the best of")) << "level 1 made no choice";
  fs::remove_all(dir);
}

}  // namespace
}  // namespace coins
