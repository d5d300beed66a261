#include "actors/envs/env.h"

#include <fmt/format.h>

#include "actors/envs/breakout.h"
#include "actors/envs/pushing.h"

namespace coins::envs {

namespace {

constexpr BreakoutVariant kBreakouts[] = {BreakoutVariant::kBase, BreakoutVariant::kSingle, BreakoutVariant::kHard,
                                          BreakoutVariant::kBig,  BreakoutVariant::kNeg,    BreakoutVariant::kCenter,
                                          BreakoutVariant::kProx};

}  // namespace

std::vector<std::string> EnvNames() {
  std::vector<std::string> names;
  for (BreakoutVariant v : kBreakouts) names.push_back(BreakoutName(v));
  names.push_back("pushing");
  names.push_back("pushing-easy");
  return names;
}

Result<std::unique_ptr<Env>> MakeEnv(const std::string& name) {
  for (BreakoutVariant v : kBreakouts)
    if (name == BreakoutName(v)) return std::unique_ptr<Env>(std::make_unique<BreakoutEnv>(v));
  if (name == "pushing" || name == "pushing-easy") {
    Result<std::unique_ptr<PushingEnv>> env = PushingEnv::Create(name == "pushing-easy");
    if (!env.ok()) return env.status();
    return std::unique_ptr<Env>(std::move(env).value());
  }
  return Errorf("unknown env '{}'; known envs: {}", name, fmt::join(EnvNames(), ", "));
}

}  // namespace coins::envs
