#include "reference/options.h"

#include <fmt/format.h>

#include "config/reference_rules.h"
#include "photonbench/error.h"

namespace pb::trace {

void ReferenceOptions::validate() const {
  if (auto problem = config::stop_rule_problem(rel_error, max_seconds, samples))
    throw InputError(fmt::format("reference: {}{}", problem->key.empty() ? "" : problem->key + ": ",
                                 problem->message));
}

}  // namespace pb::trace
