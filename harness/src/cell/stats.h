// Order statistics for timings: the report gives median, p5 and p95 with the sample count, never a
// lone mean.
#pragma once

#include <nlohmann/json.hpp>
#include <vector>

namespace pb::run {

// Linear interpolation between closest ranks (numpy's default), p in [0, 100]; NaN for no samples.
double percentile(std::vector<double> values, double p);

// {"median", "p5", "p95", "mean", "n"}; the values are null when there are no samples.
nlohmann::json describe(const std::vector<double>& values);

}  // namespace pb::run
