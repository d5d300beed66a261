#include "common/actor_stats_json.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "common/files.h"

namespace coins {
namespace {

TEST(ActorStatsJson, AFinalStatsFileReadsBackEveryCounterItCarries) {
  msg::ActorStats s;
  s.actor_id(3);
  s.env("breakout");
  s.shard(1);
  s.steps(30000);
  s.incarnation(0x0123456789abcdefull);
  s.first_step(12000);
  s.episodes(675);
  s.batches(30);
  s.transitions_published(30001);
  s.payload_checksum(0xfedcba9876543210ull);
  s.publish_retries(2);
  s.weights_rejected(4);
  s.env_errors(5);
  s.goals_clipped(6);
  s.detector_pair("Paddle->Ball");
  s.detector_states(1000);
  s.detector_truth(70);
  s.detector_fp(1);
  s.detector_fn(2);
  const std::string file = (std::filesystem::temp_directory_path() / "coins-actor-stats-test.json").string();
  ASSERT_TRUE(WriteFileAtomic(file, ActorStatsJson(s).dump()).ok());
  auto r = ReadActorStatsFile(file);
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_EQ(ActorStatsJson(*r), ActorStatsJson(s));
  EXPECT_EQ(r->payload_checksum(), 0xfedcba9876543210ull);
  EXPECT_EQ(r->incarnation(), 0x0123456789abcdefull);
  EXPECT_EQ(r->first_step(), 12000u);

  // a cut file and a file of something else: errors that name the file
  std::ofstream(file) << ActorStatsJson(s).dump().substr(0, 40);
  auto cut = ReadActorStatsFile(file);
  ASSERT_FALSE(cut.ok());
  EXPECT_NE(cut.status().message().find(file), std::string::npos);
  std::ofstream(file) << R"({"steps": -1, "detector": {}})";
  auto wrong = ReadActorStatsFile(file);
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.status().message().find(file), std::string::npos);
  EXPECT_FALSE(ReadActorStatsFile(file + ".missing").ok());
  std::filesystem::remove(file);
}

}  // namespace
}  // namespace coins
