#include "config/reference_rules.h"

namespace pb::config {

const std::vector<std::string>& estimator_names() {
  static const std::vector<std::string> names = {"pt", "bdpt", "auto"};
  return names;
}

const std::vector<std::string>& light_sampler_names() {
  static const std::vector<std::string> names = {"power", "bvh"};
  return names;
}

std::optional<StopRuleProblem> stop_rule_problem(double rel_error, double max_seconds,
                                                 uint32_t samples) {
  if (samples == 1) return StopRuleProblem{"samples", "0 (off) or at least 2 iterations"};
  if (!(rel_error > 0) && !(max_seconds > 0) && samples == 0)
    return StopRuleProblem{
        "", "rel_error, max_seconds and samples are all 0: no rule would stop a reference"};
  return std::nullopt;
}

}  // namespace pb::config
