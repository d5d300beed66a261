// The hot-path contract: Step (and ResetNext) allocate nothing. Counts calls to the global
// operator new while a window is open.
#include <atomic>
#include <cstdlib>
#include <new>

#include <gtest/gtest.h>

#include "actors/envs/env.h"
#include "actors/envs/rng.h"

namespace {
std::atomic<bool> counting{false};
std::atomic<long> allocations{0};
}  // namespace

void* operator new(std::size_t n) {
  if (counting.load(std::memory_order_relaxed)) allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace coins::envs {
namespace {

TEST(HotPath, StepAndResetNextDoNotAllocate) {
  for (const std::string& name : EnvNames()) {
    auto made = MakeEnv(name);
    ASSERT_TRUE(made.ok()) << name;
    Env& env = **made;
    const EnvSpec& spec = env.spec();
    std::vector<float> state(spec.state_dim()), action(spec.action.dim);
    env.Reset(1, state);
    Rng rng(2);
    const int steps = name.rfind("pushing", 0) == 0 ? 400 : 20000;
    int episodes = 0;
    allocations = 0;
    counting = true;
    for (int t = 0; t < steps; ++t) {
      for (int i = 0; i < spec.action.dim; ++i)
        action[i] = spec.action.discrete ? static_cast<float>(rng.UniformInt(0, spec.action.n - 1))
                                         : static_cast<float>(rng.Uniform(-1.0, 1.0));
      StepResult r;
      if (!env.Step(action, state, &r).ok()) break;
      if (r.done || r.truncated) {
        env.ResetNext(state);
        ++episodes;
      }
    }
    counting = false;
    EXPECT_EQ(allocations.load(), 0) << name;
    EXPECT_GT(episodes, 0) << name;
  }
}

}  // namespace
}  // namespace coins::envs
