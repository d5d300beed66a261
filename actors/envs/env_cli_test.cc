// The env CLI: rollout JSON lines (keys, shapes, episodes, labels), actions files and their
// errors, flag validation, and pictures (Breakout raster, MuJoCo EGL render, PNG/GIF files).
#include "actors/envs/env_cli.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "actors/envs/breakout.h"
#include "actors/envs/pushing.h"
#include "actors/envs/render.h"

namespace coins::envs {
namespace {

std::string TempPath(const std::string& name) {
  return (::testing::TempDir().empty() ? std::string("/tmp/") : ::testing::TempDir()) + "coins_envs_" + name;
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::vector<nlohmann::json> ReadLines(const std::string& path) {
  std::ifstream in(path);
  std::vector<nlohmann::json> lines;
  std::string line;
  while (std::getline(in, line)) lines.push_back(nlohmann::json::parse(line));
  return lines;
}

TEST(EnvCli, BreakoutRandomRolloutLines) {
  RolloutOptions o;
  o.env = "breakout";
  o.seed = 3;
  o.policy = "random";
  o.steps = 600;
  o.out = TempPath("breakout.jsonl");
  ASSERT_TRUE(RunRollout(o).ok());
  const auto lines = ReadLines(o.out);
  ASSERT_EQ(lines.size(), 600u);
  int episode = 0;
  for (size_t i = 0; i < lines.size(); ++i) {
    const auto& l = lines[i];
    for (const char* key :
         {"t", "episode", "state", "action", "next_state", "reward", "done", "truncated", "interactions"})
      ASSERT_TRUE(l.contains(key)) << key;
    EXPECT_EQ(l["t"], static_cast<int>(i));
    EXPECT_EQ(l["episode"], episode);
    ASSERT_EQ(l["state"]["Block"].size(), 100u);
    ASSERT_EQ(l["state"]["Block"][0].size(), 5u);
    ASSERT_EQ(l["state"]["Ball"].size(), 5u);
    EXPECT_TRUE(l["action"].is_number_integer());
    // the paddle label matches the paddle's x change
    const bool moved = l["state"]["Paddle"][1] != l["next_state"]["Paddle"][1];
    bool labelled = false;
    for (const auto& s : l["interactions"]) labelled |= s == "Action->Paddle";
    EXPECT_EQ(moved, labelled) << i;
    if (l["done"]) {
      ++episode;
      EXPECT_EQ(l["reward"].get<float>() <= -9.0f, true);
    } else if (i + 1 < lines.size()) {
      EXPECT_EQ(l["next_state"], lines[i + 1]["state"]) << i;
    }
  }
  EXPECT_GT(episode, 3);
  std::remove(o.out.c_str());
}

TEST(EnvCli, PushingActionsFileAndEpisodes) {
  const std::string actions = TempPath("push_actions.txt");
  {
    std::ofstream f(actions);
    for (int i = 0; i < 35; ++i) f << "1, 0.5,-0.25\n";
    f << "\n";
  }
  RolloutOptions o;
  o.env = "pushing-easy";
  o.seed = 1;
  o.actions_file = actions;
  o.out = TempPath("push.jsonl");
  ASSERT_TRUE(RunRollout(o).ok());
  const auto lines = ReadLines(o.out);
  ASSERT_EQ(lines.size(), 35u);
  EXPECT_EQ(lines[0]["action"], (nlohmann::json{1.0, 0.5, -0.25}));
  EXPECT_NEAR(lines[0]["state"]["Gripper"][2].get<double>(), 0.1, 0.002);
  EXPECT_TRUE(lines[29]["truncated"]);
  EXPECT_EQ(lines[29]["episode"], 0);
  EXPECT_EQ(lines[30]["episode"], 1);
  EXPECT_FALSE(lines[30]["state"].contains("Obstacle"));
  // the fingertip moved towards +x, +y, -z in metres, within the joint limits
  const auto g = lines[5]["next_state"]["Gripper"];
  EXPECT_GT(g[0].get<double>(), 0.15);
  EXPECT_LE(g[0].get<double>(), 0.2001);
  EXPECT_GT(g[1].get<double>(), 0.1);
  std::remove(o.out.c_str());
  std::remove(actions.c_str());
}

TEST(EnvCli, ObstaclesAreListsOfLists) {
  RolloutOptions o{"pushing", 2, "", "random", 3, TempPath("push2.jsonl")};
  ASSERT_TRUE(RunRollout(o).ok());
  const auto lines = ReadLines(o.out);
  ASSERT_EQ(lines.size(), 3u);
  ASSERT_EQ(lines[0]["state"]["Obstacle"].size(), 15u);
  ASSERT_EQ(lines[0]["state"]["Obstacle"][0].size(), 3u);
  std::remove(o.out.c_str());
}

TEST(EnvCli, BadActionsFilesNameTheLine) {
  const std::string path = TempPath("bad_actions.txt");
  auto run = [&](const std::string& env, const std::string& text) {
    std::ofstream(path) << text;
    RolloutOptions o{env, 1, path, "", 0, TempPath("bad.jsonl")};
    return RunRollout(o);
  };
  Status s = run("pushing", "0,0,0\n1.5,0\n");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("line 2"), std::string::npos) << s.message();
  s = run("breakout", "1\nabc\n");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("line 2"), std::string::npos) << s.message();
  s = run("breakout", "1\n7\n");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("line 2: action 7 is out of range [0, 3]"), std::string::npos) << s.message();
  s = run("pushing", "0,nan,0\n");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("line 1"), std::string::npos) << s.message();
  // an action the env refuses only when it gets there (step 2): the rollout fails, and neither
  // a partial --out file nor its temporary is left behind
  std::remove(TempPath("bad.jsonl").c_str());
  s = run("pushing", "0,0,0\n0.5,0,0\n5,0,0\n");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("step 2"), std::string::npos) << s.message();
  EXPECT_FALSE(std::filesystem::exists(TempPath("bad.jsonl")));
  EXPECT_FALSE(std::filesystem::exists(TempPath("bad.jsonl") + ".tmp"));
  // an older file of that name stays as it was
  std::ofstream(TempPath("bad.jsonl")) << "old\n";
  ASSERT_FALSE(run("pushing", "0,0,0\n5,0,0\n").ok());
  EXPECT_EQ(ReadText(TempPath("bad.jsonl")), "old\n");
  std::remove(path.c_str());
  std::remove(TempPath("bad.jsonl").c_str());
}

TEST(EnvCli, FlagErrors) {
  auto parse = [](std::vector<std::string> args) {
    CLI::App app{"t"};
    AddEnvCommands(app);
    std::reverse(args.begin(), args.end());
    app.parse(args);
  };
  EXPECT_THROW(parse({"env", "rollout", "--env", "nope", "--seed", "1", "--policy", "random", "--steps", "3", "--out",
                      TempPath("x.jsonl")}),
               CLI::ValidationError);
  EXPECT_THROW(parse({"env", "rollout", "--env", "breakout", "--seed", "1", "--policy", "random", "--steps", "-3",
                      "--out", TempPath("x.jsonl")}),
               CLI::ValidationError);
  // numbers are read whole and never clamped; the messages are one short line
  auto message = [&](std::vector<std::string> args) {
    try {
      parse(args);
    } catch (const CLI::Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string seed64 = "18446744073709551616";  // 2^64
  EXPECT_NE(message({"env", "rollout", "--env", "breakout", "--seed", seed64, "--policy", "random", "--steps", "3",
                     "--out", TempPath("x.jsonl")})
                .find("--seed: must be an integer in [0, 18446744073709551615], got '18446744073709551616'"),
            std::string::npos);
  EXPECT_NE(message({"env", "rollout", "--env", "breakout", "--seed", "1", "--policy", "random", "--steps", seed64,
                     "--out", TempPath("x.jsonl")})
                .find("--steps: must be an integer in [1, 2147483647], got '18446744073709551616'"),
            std::string::npos);
  const std::string neg =
      message({"env", "render", "--env", "breakout", "--seed", "1", "--steps", "-1", "--out", TempPath("x.png")});
  EXPECT_NE(neg.find("--steps: must be an integer in [0, 1000000], got '-1'"), std::string::npos) << neg;
  EXPECT_LT(neg.size(), 100u) << neg;
  EXPECT_NE(message({"env", "rollout", "--env", "breakout", "--seed", "-1", "--policy", "random", "--steps", "3",
                     "--out", TempPath("x.jsonl")})
                .find("--seed"),
            std::string::npos);
  // a run-time failure (no policy and no actions) exits non-zero through RuntimeError
  EXPECT_THROW(parse({"env", "rollout", "--env", "breakout", "--seed", "1", "--out", TempPath("x.jsonl")}),
               CLI::RuntimeError);
  std::remove(TempPath("x.jsonl").c_str());
}

TEST(EnvRender, BreakoutRasterShowsObjects) {
  BreakoutEnv env(BreakoutVariant::kBase);
  std::vector<float> s(env.spec().state_dim());
  env.Reset(4, s);
  const Image img = RenderBreakout(env, 2);
  ASSERT_EQ(img.width, 168);
  auto px = [&](int gy, int gx) { return img.rgb.data() + ((gy * 2) * img.width + gx * 2) * 3; };
  const uint8_t* ball = px(env.ball_y(), env.ball_x());
  EXPECT_EQ(ball[0], 255);
  EXPECT_EQ(ball[1], 255);
  const uint8_t* paddle = px(BreakoutEnv::kPaddleY, env.paddle_x() + 3);
  EXPECT_GT(paddle[2], 200);
  EXPECT_EQ(px(50, 40)[0], 0);  // empty space is black
}

TEST(EnvRender, PushingEglRenderAndFiles) {
  auto env = PushingEnv::Create(false);
  ASSERT_TRUE(env.ok());
  std::vector<float> s((*env)->spec().state_dim());
  (*env)->Reset(1, s);
  auto r = MakeRenderer(**env, 1, 96, 72);
  ASSERT_TRUE(r.ok()) << r.status().message();
  Result<Image> img = (*r)->Render(**env);
  ASSERT_TRUE(img.ok()) << img.status().message();
  int green = 0, red = 0, yellow = 0;
  for (size_t i = 0; i < img->rgb.size(); i += 3) {
    const int R = img->rgb[i], G = img->rgb[i + 1], B = img->rgb[i + 2];
    green += G > 150 && R < 120 && B < 120;
    red += R > 150 && G < 80 && B < 80;
    yellow += R > 180 && G > 150 && B < 80;
  }
  EXPECT_GT(green, 20);    // goal disc
  EXPECT_GT(red, 10);      // cube
  EXPECT_GT(yellow, 200);  // regions
  const std::string png = TempPath("f.png"), gif = TempPath("f.gif");
  ASSERT_TRUE(WritePng(png, *img).ok());
  ASSERT_TRUE(WriteGif(gif, {*img, *img}, 5).ok());
  char magic[4] = {};
  std::ifstream(png, std::ios::binary).read(magic, 4);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
  std::ifstream(gif, std::ios::binary).read(magic, 4);
  EXPECT_EQ(std::string(magic, 3), "GIF");
  std::remove(png.c_str());
  std::remove(gif.c_str());
  EXPECT_FALSE(MakeRenderer(**env, 1, 4000, 72).ok());
}

}  // namespace
}  // namespace coins::envs
