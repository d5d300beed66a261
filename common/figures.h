// Figures: how benchmarks and reports print their numbers.
//
// Every `coins bench NAME` prints one line per figure, "name value unit", in the order added,
// or with --json one JSON object {"name": value, ...} on stdout. A ratio against a baseline
// measured in the same run is its own figure whose name ends in "_ratio".
#pragma once

#include <string>
#include <vector>

namespace coins {

class Figures {
 public:
  void Add(std::string name, double value, std::string unit);
  // median of the samples, recorded as one figure
  void AddMedian(std::string name, std::vector<double> samples, std::string unit);
  // prints to stdout as text lines or as one JSON object
  void Print(bool json) const;
  double Get(const std::string& name) const;  // NaN when absent

 private:
  struct Figure {
    std::string name;
    double value;
    std::string unit;
  };
  std::vector<Figure> figures_;
};

double Median(std::vector<double> samples);

// mean and standard deviation of samples: the population's (divided by n) or, with sample, the
// sample's (divided by n - 1; 0 for one value); both 0 when there are none
struct MeanAndSd {
  double mean = 0.0, sd = 0.0;
};
MeanAndSd MeanSd(const std::vector<double>& samples, bool sample = false);

}  // namespace coins
