// Strict number flags. CLI11 2.1 on its own accepts "nan" and "inf" for floating-point flags,
// clamps integers that overflow (18446744073709551616 becomes 2^64 - 1), reads "-1" into an
// unsigned flag as 2^64 - 1, and its range checks print the bounds of double (a 330-character
// number). These checks read the whole text as a number of the expected kind and range before
// CLI11 converts it, and their one-line messages name the bounds and the value:
//   --steps: must be an integer in [1, 100000000], got '1e30'
// The Parse* forms serve hand-written argument loops (the benchmarks).
//
// Fail() is how every `coins` subcommand reports a failure: one line on stderr,
//   coins detect: --source: env 'breakout' has no factor 'Nope' (factors: ...)
// then CLI::RuntimeError(code), which CLI11's App::exit turns into the exit code without
// printing anything more (code 2: bad input or a refused request; 1: a failure while running).
#pragma once

#include <charconv>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <limits>
#include <string>
#include <string_view>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "common/status.h"

namespace coins::cli {

[[noreturn]] inline void Fail(std::string_view command, std::string_view message, int code) {
  std::cerr << "coins " << command << ": " << message << "\n";
  throw CLI::RuntimeError(code);
}
inline void FailIf(std::string_view command, const Status& status, int code) {
  if (!status.ok()) Fail(command, status.message(), code);
}

// a decimal integer (optional '-'), no overflow, within [min, max]
inline Result<int64_t> ParseInteger(std::string_view text, int64_t min, int64_t max) {
  int64_t v = 0;
  auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || v < min || v > max)
    return Errorf("must be an integer in [{}, {}], got '{}'", min, max, text);
  return v;
}

// a non-negative decimal integer that fits 64 bits, at most max
inline Result<uint64_t> ParseUnsigned(std::string_view text, uint64_t max = std::numeric_limits<uint64_t>::max()) {
  uint64_t v = 0;
  auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || v > max)
    return Errorf("must be an integer in [0, {}], got '{}'", max, text);
  return v;
}

// a finite number within [min, max] ((min, max] when min_open)
inline Result<double> ParseFinite(std::string_view text, double min, double max, bool min_open = false) {
  double v = 0;
  auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  bool ok = !text.empty() && ec == std::errc() && end == text.data() + text.size() && std::isfinite(v) &&
            (min_open ? v > min : v >= min) && v <= max;
  if (!ok) return Errorf("must be a finite number in {}{}, {}], got '{}'", min_open ? "(" : "[", min, max, text);
  return v;
}

namespace detail {
template <typename Parse>
CLI::Validator Check(Parse parse, std::string name) {
  return CLI::Validator(
      [parse](std::string& in) -> std::string {
        auto r = parse(in);
        return r.ok() ? std::string() : r.status().message();
      },
      std::move(name));
}
}  // namespace detail

inline CLI::Validator Integer(int64_t min, int64_t max) {
  return detail::Check([=](const std::string& s) { return ParseInteger(s, min, max); },
                       fmt::format("INT in [{}, {}]", min, max));
}
inline CLI::Validator Unsigned(uint64_t max = std::numeric_limits<uint64_t>::max()) {
  return detail::Check([=](const std::string& s) { return ParseUnsigned(s, max); }, fmt::format("UINT <= {}", max));
}
inline CLI::Validator Finite(double min, double max, bool min_open = false) {
  return detail::Check([=](const std::string& s) { return ParseFinite(s, min, max, min_open); },
                       fmt::format("NUMBER in {}{}, {}]", min_open ? "(" : "[", min, max));
}

}  // namespace coins::cli
