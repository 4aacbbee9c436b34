// The search of one match: the knob value at which a measured quantity (a probe cell's median frame
// time, or its mean error) reaches a target, on measurements alone (no model of the technique).
//
//   probe the start value
//   while the probes do not bracket the target: step the knob toward it (a factor of 2, then 4,
//     8, ... on a log knob; a step that doubles each time on a linear one), up to the end of its
//     range
//   then bisect the bracket (geometrically on a log knob): each new probe replaces the end on its
//     side of the target
//   stop at the first probe within tolerance x target of the target (matched), at the range's end
//     still short of it (unreachable: the range of values reached is said), when the bracket holds
//     no untried value or the probes run out (not converged: the closest probe is kept), or when a
//     probe fails or refuses the target (a quality target below its floor)
//
// A probe is measured once per value: a measured quantity that is noisy and not monotone still
// ends in one of these states, within max_probes.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "plan/match_plan.h"

namespace pb::run {

enum class MatchStatus { matched, unreachable, not_converged, below_floor, failed };
const char* match_status_name(MatchStatus status);

struct SearchTarget {
  double value = 0;      // the target (ms, or the error)
  double tolerance = 0;  // relative
  int direction = 1;     // +1: the measured quantity grows with the knob
  size_t max_probes = 12;
};

// What measuring one probe gave: its value, or why the search stops there (a failed probe, a
// refused target), with that status.
struct Measured {
  std::optional<double> value;
  MatchStatus stop = MatchStatus::failed;  // when value is empty
  std::string reason;
};

struct SearchProbe {
  double knob = 0;
  std::string knob_text;  // as the cell's parameters write it
  Measured measured;
};

struct SearchResult {
  MatchStatus status = MatchStatus::failed;
  std::optional<size_t> best;  // the probe found (matched) or the closest one measured
  std::vector<SearchProbe> probes;
  std::string reason;  // empty when matched
};

// `measure` is called once per probe, with the knob's value as text (knob_text).
SearchResult search_knob(const KnobSpace& space, const SearchTarget& target, double start,
                         const std::function<Measured(const std::string& knob_text)>& measure);

}  // namespace pb::run
