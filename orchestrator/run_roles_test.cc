// `coins run --role/--actor-ids/--shard-ids`: what a host runs, and the errors that name the flag.
#include "orchestrator/run_roles.h"

#include <gtest/gtest.h>

namespace coins {
namespace {

TEST(RunRoles, WithoutARoleAHostRunsEverything) {
  auto r = RunRoles::Parse("", "", "", 3, 2, false);
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_TRUE(r->all);
  EXPECT_EQ(r->roles, (std::set<std::string>{"replay", "learner", "orchestrator", "actors"}));
  EXPECT_EQ(r->actor_ids, (std::vector<int64_t>{0, 1, 2}));
  EXPECT_EQ(r->shard_ids, (std::vector<int64_t>{0, 1}));
  // and its discovery servers when the run discovers through servers
  auto s = RunRoles::Parse("", "", "", 3, 2, true);
  ASSERT_TRUE(s.ok());
  EXPECT_TRUE(s->Has("discovery"));
}

TEST(RunRoles, AHostRunsItsShare) {
  auto r = RunRoles::Parse("actors", "4-7", "", 8, 2, false);
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_FALSE(r->all);
  EXPECT_EQ(r->actor_ids, (std::vector<int64_t>{4, 5, 6, 7}));
  EXPECT_TRUE(r->shard_ids.empty());
  EXPECT_FALSE(r->Has("learner"));
  EXPECT_EQ(r->Describe(), "actors 4-7");
  auto s = RunRoles::Parse("replay,learner", "", "1", 8, 2, false);
  ASSERT_TRUE(s.ok()) << s.status().message();
  EXPECT_EQ(s->shard_ids, (std::vector<int64_t>{1}));
  EXPECT_TRUE(s->actor_ids.empty());
  EXPECT_EQ(s->Describe(), "learner, replay 1");
}

TEST(RunRoles, BadRolesAndIdsAreNamed) {
  auto expect_error = [](const Result<RunRoles>& r, const std::string& text) {
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.status().message().find(text), std::string::npos) << r.status().message();
  };
  expect_error(RunRoles::Parse("actors,shards", "", "", 2, 1, false), "unknown role 'shards'");
  expect_error(RunRoles::Parse("actors", "2", "", 2, 1, false), "the run has 2 (ids 0-1)");
  expect_error(RunRoles::Parse("actors", "3-1", "", 8, 1, false), "expected K or A-B");
  expect_error(RunRoles::Parse("actors", "-1", "", 8, 1, false), "expected K or A-B");
  expect_error(RunRoles::Parse("learner", "0", "", 8, 1, false), "--actor-ids without the actors role");
  expect_error(RunRoles::Parse("learner", "", "0", 8, 1, false), "--shard-ids without the replay role");
  expect_error(RunRoles::Parse("discovery", "", "", 8, 1, false), "needs dds.discovery: server");
}

}  // namespace
}  // namespace coins
