#include "cell/stats.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace pb::run {

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  double rank = p / 100.0 * double(values.size() - 1);
  size_t lo = size_t(std::floor(rank)), hi = size_t(std::ceil(rank));
  return values[lo] + (values[hi] - values[lo]) * (rank - double(lo));
}

nlohmann::json describe(const std::vector<double>& values) {
  if (values.empty())
    return {{"median", nullptr}, {"p5", nullptr}, {"p95", nullptr}, {"mean", nullptr}, {"n", 0}};
  double mean = std::accumulate(values.begin(), values.end(), 0.0) / double(values.size());
  return {{"median", percentile(values, 50)},
          {"p5", percentile(values, 5)},
          {"p95", percentile(values, 95)},
          {"mean", mean},
          {"n", values.size()}};
}

}  // namespace pb::run
