// What the config's reference block, `photonbench reference` and the reference renderer
// (trace::ReferenceOptions, reference/options.h) check alike, written once below all three.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace pb::config {

// The reference's unbiased estimators by name, in the order of trace::Estimator
// (reference/estimators.h): "pt", "bdpt", "auto".
const std::vector<std::string>& estimator_names();
// Path tracing's next-event light choices by name, in the order of trace::LightSelection
// (reference/estimators.h): "power", "bvh".
const std::vector<std::string>& light_sampler_names();

// The stop rule at fault, by its key ("samples"; empty: the rules together), and why.
struct StopRuleProblem {
  std::string key, message;
};
// A render stops at the first rule reached, and 0 turns a rule off: samples 1 is refused (one
// iteration has no variance and an empty odd half), and so is every rule off (nothing would stop).
std::optional<StopRuleProblem> stop_rule_problem(double rel_error, double max_seconds,
                                                 uint32_t samples);

}  // namespace pb::config
