#include "common/figures.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <nlohmann/json.hpp>

namespace coins {

double Median(std::vector<double> samples) {
  if (samples.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(samples.begin(), samples.end());
  size_t n = samples.size();
  return n % 2 ? samples[n / 2] : 0.5 * (samples[n / 2 - 1] + samples[n / 2]);
}

MeanAndSd MeanSd(const std::vector<double>& samples, bool sample) {
  if (samples.empty()) return {};
  double sum = 0, sq = 0;
  for (double x : samples) sum += x;
  const double mean = sum / double(samples.size());
  for (double x : samples) sq += (x - mean) * (x - mean);
  const size_t n = samples.size();
  if (sample) return {mean, n > 1 ? std::sqrt(sq / double(n - 1)) : 0.0};
  return {mean, std::sqrt(sq / double(n))};
}

void Figures::Add(std::string name, double value, std::string unit) {
  figures_.push_back({std::move(name), value, std::move(unit)});
}

void Figures::AddMedian(std::string name, std::vector<double> samples, std::string unit) {
  Add(std::move(name), Median(std::move(samples)), std::move(unit));
}

double Figures::Get(const std::string& name) const {
  for (const auto& f : figures_)
    if (f.name == name) return f.value;
  return std::numeric_limits<double>::quiet_NaN();
}

void Figures::Print(bool json) const {
  if (json) {
    nlohmann::ordered_json j = nlohmann::ordered_json::object();
    for (const auto& f : figures_) j[f.name] = std::isfinite(f.value) ? nlohmann::ordered_json(f.value) : nullptr;
    std::printf("%s\n", j.dump().c_str());
  } else {
    for (const auto& f : figures_) std::printf("%s %.6g %s\n", f.name.c_str(), f.value, f.unit.c_str());
  }
  std::fflush(stdout);
}

}  // namespace coins
