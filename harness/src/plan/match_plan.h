// The plan of a match run (`match:` in a config): per scene and technique entry (and combination of
// its other swept parameters), the cell at the config's values as the first probe, the budget knob
// the search turns, the part of its range it may probe, and which way the measured quantity (the
// frame time, or the error) moves as the knob grows. Every error here is bad input, found before
// any work (`validate` and `run` alike): a technique without a budget knob, a knob that is not one
// of its budget knobs, a quality target on a knob whose error is not monotone, a matched knob
// swept, a knob_range outside the schema's range.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "plan/plan.h"

namespace pb::run {

// Where the search may probe one knob: [lo, hi] in the knob's units, integer values for an int
// parameter, and whether it brackets by factors (log) or by steps (linear).
struct KnobSpace {
  double lo = 0, hi = 0;
  bool integer = false;
  bool log = false;
};

struct MatchTarget {
  Cell start;        // the first probe: the plan's cell (seed index 0), its knob inside the range
  std::string knob;  // empty when the technique's plugin did not load (the start cell fails)
  KnobSpace space;
  int direction = 1;  // +1: the measured quantity grows with the knob; -1: it falls
};

struct MatchPlan {
  std::vector<MatchTarget> matches;  // in the plan's order
  std::vector<Cell> unmatched;       // the cells of entries with `match: false`, every seed
};

// Throws pb::InputError (file:line:col: key) as above. Empty when the config has no `match`.
MatchPlan plan_matches(const RunPlan& plan);

// The knob's value as the schema writes it: an int rounded, a float as the plan prints numbers.
std::string knob_text(const KnobSpace& space, double value);

// `base` with its knob at `value_text`: the id the plan gives those values (make_cell), then
// "__seed<seed>" on a seed axis (`seeds` > 1), so a probe at the config's value is the plan's cell.
Cell with_knob(const Cell& base, const std::string& knob, const std::string& value_text,
               uint32_t seeds);

}  // namespace pb::run
