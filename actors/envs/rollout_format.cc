#include "actors/envs/rollout_format.h"

#include <iterator>

#include <fmt/format.h>

namespace coins::envs {

namespace {

void AppendFloat(std::string& out, float v) { fmt::format_to(std::back_inserter(out), "{}", v); }

// {"Factor": [f...], "Class": [[f...], ...], ...}
void AppendState(std::string& out, const EnvSpec& spec, const float* s) {
  out += '{';
  for (size_t i = 0; i < spec.factors.size(); ++i) {
    const FactorSpec& f = spec.factors[i];
    if (i) out += ',';
    fmt::format_to(std::back_inserter(out), "\"{}\":", f.name);
    const bool multi = f.multi_instance || f.instances > 1;
    if (multi) out += '[';
    for (int k = 0; k < f.instances; ++k) {
      if (k) out += ',';
      out += '[';
      for (int j = 0; j < f.features; ++j) {
        if (j) out += ',';
        AppendFloat(out, *s++);
      }
      out += ']';
    }
    if (multi) out += ']';
  }
  out += '}';
}

}  // namespace

void AppendRolloutLine(const EnvSpec& spec, int64_t t, int64_t episode, std::span<const float> state,
                       std::span<const float> action, std::span<const float> next, const StepResult& r,
                       std::string* out) {
  std::string& line = *out;
  fmt::format_to(std::back_inserter(line), "{{\"t\":{},\"episode\":{},\"state\":", t, episode);
  AppendState(line, spec, state.data());
  line += ",\"action\":";
  if (spec.action.discrete) {
    fmt::format_to(std::back_inserter(line), "{}", static_cast<int>(action[0]));
  } else {
    line += '[';
    for (size_t i = 0; i < action.size(); ++i) {
      if (i) line += ',';
      AppendFloat(line, action[i]);
    }
    line += ']';
  }
  line += ",\"next_state\":";
  AppendState(line, spec, next.data());
  line += ",\"reward\":";
  AppendFloat(line, r.reward);
  fmt::format_to(std::back_inserter(line), ",\"done\":{},\"truncated\":{},\"interactions\":[", r.done, r.truncated);
  bool first = true;
  for (size_t i = 0; i < spec.interactions.size(); ++i) {
    if (!(r.interactions >> i & 1u)) continue;
    fmt::format_to(std::back_inserter(line), "{}\"{}\"", first ? "" : ",", spec.interactions[i].label());
    first = false;
  }
  line += "]}\n";
}

}  // namespace coins::envs
