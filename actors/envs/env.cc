#include "actors/envs/env.h"

#include <fmt/format.h>

#include "actors/envs/breakout.h"
#include "actors/envs/pushing.h"

namespace coins::envs {

int EnvSpec::state_dim() const {
  int n = 0;
  for (const FactorSpec& f : factors) n += f.size();
  return n;
}

int EnvSpec::factor_index(const std::string& factor_name) const {
  for (int i = 0; i < static_cast<int>(factors.size()); ++i)
    if (factors[i].name == factor_name) return i;
  return -1;
}

int EnvSpec::factor_offset(int i) const {
  int off = 0;
  for (int k = 0; k < i; ++k) off += factors[k].size();
  return off;
}

namespace {

constexpr BreakoutVariant kBreakouts[] = {
    BreakoutVariant::kBase, BreakoutVariant::kSingle, BreakoutVariant::kHard, BreakoutVariant::kBig,
    BreakoutVariant::kNeg,  BreakoutVariant::kCenter, BreakoutVariant::kProx};

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
